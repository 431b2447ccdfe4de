//! The message against msg/msg/BioTac.msg: fields, CDR both ways, refusals, older layouts.

use super::*;

/// (name, type, array length) of every field in msg/msg/BioTac.msg.
fn msg_fields() -> Vec<(String, String, Option<usize>)> {
    let text = include_str!("../../../msg/msg/BioTac.msg");
    text.lines()
        .map(|l| l.split('#').next().unwrap_or("").trim())
        .filter(|l| !l.is_empty())
        .map(|l| {
            let mut it = l.split_whitespace();
            let ty = it.next().unwrap().to_string();
            let name = it.next().unwrap().to_string();
            match ty.split_once('[') {
                Some((base, rest)) => {
                    let n = rest.trim_end_matches(']');
                    (name, format!("{base}[]"), n.parse().ok())
                }
                None => (name, ty, None),
            }
        })
        .collect()
}

fn reading() -> BioTacReading {
    BioTacReading {
        seq: 65535,
        stamp_s: 12.25,
        electrodes: std::array::from_fn::<u16, 19, _>(|i| 100 * i as u16 + 7).into(),
        pdc: 2000,
        pac: std::array::from_fn::<u16, N_PAC, _>(|i| 2048 + i as u16).into(),
        tdc: 1800,
        tac: 4095,
    }
}

#[test]
fn every_field_of_the_msg_file_is_written_with_its_type_and_length() {
    let meta = BioTacMeta {
        frame_id: "biotac".into(),
        serial: "BT-1".into(),
        sensor_index: 2,
        invalid_channels: vec!["e3".into(), "pac7".into()],
    };
    let r = reading();
    let v = to_json(&r, &meta);
    let obj = v.as_object().unwrap();
    let fields = msg_fields();
    assert_eq!(obj.len(), fields.len(), "{obj:?} vs {fields:?}");
    for (name, ty, len) in &fields {
        let x = obj
            .get(name)
            .unwrap_or_else(|| panic!("{name} not written"));
        match ty.as_str() {
            "std_msgs/Header" => {
                assert!(x["stamp"]["sec"].is_u64() && x["stamp"]["nanosec"].is_u64());
                assert!(x["frame_id"].is_string());
            }
            "string" => assert!(x.is_string(), "{name}"),
            "uint8" => assert!(x.as_u64().unwrap() <= u8::MAX as u64, "{name}"),
            "uint16" => assert!(x.as_u64().unwrap() <= u16::MAX as u64, "{name}"),
            "uint16[]" => {
                let a = x.as_array().unwrap();
                let n = [("electrodes", r.electrodes.len()), ("pac", r.pac.len())];
                let n = n.iter().find(|f| f.0 == name).map(|f| f.1);
                assert_eq!(len.or(n), Some(a.len()), "{name}");
                assert!(a.iter().all(|e| e.as_u64().unwrap() <= 4095), "{name}");
            }
            "string[]" => assert!(x.as_array().unwrap().iter().all(Value::is_string)),
            other => panic!("field {name}: type {other} not handled"),
        }
    }
    // Sequences: 19 electrodes and 22 PAC samples, or 24 and 27 from a
    // BioTac SP.
    assert_eq!(fields.iter().find(|f| f.0 == "electrodes").unwrap().2, None);
    assert_eq!(fields.iter().find(|f| f.0 == "pac").unwrap().2, None);
}

#[test]
fn stamps_split_and_join() {
    assert_eq!(split_stamp(12.25), (12, 250_000_000));
    assert_eq!(split_stamp(f64::NAN), (0, 0));
    assert_eq!(split_stamp(-1.0), (0, 0));
    assert!((join_stamp(12, 250_000_000) - 12.25).abs() < 1e-12);
}

#[test]
fn cdr_bytes_decode_and_short_or_out_of_range_ones_are_refused() {
    let r = reading();
    let meta = BioTacMeta {
        frame_id: "biotac".into(),
        serial: "BT-1".into(),
        sensor_index: 1,
        invalid_channels: vec!["e3".into()],
    };
    let mut m = CdrBioTac::new(&r, &meta);
    let bytes = to_cdr(&r, &meta);
    let (back, meta) = from_cdr(&bytes).unwrap();
    assert_eq!(back, r);
    assert_eq!(
        (meta.serial.as_str(), meta.invalid_channels.len()),
        ("BT-1", 1)
    );
    // A message cut short (an electrode array of 10 values, say).
    let err = from_cdr(&bytes[..40]).unwrap_err();
    assert!(matches!(err, BioTacMsgError::Cdr(_)), "{err}");
    // Big-endian CDR decodes too.
    let be = cdr::serialize::<_, _, cdr::CdrBe>(&m, cdr::Infinite).unwrap();
    assert_eq!(from_cdr(&be).unwrap().0, r);
    // 24 electrodes and 27 PAC samples: a BioTac SP's; 20 are no
    // sensor's, nor are 28 PAC samples.
    let mut sp = r;
    sp.electrodes = Electrodes::from_slice(&[3000; MAX_ELECTRODES]).unwrap();
    sp.pac = Pac::from_slice(&[2047; MAX_PAC]).unwrap();
    assert_eq!(from_cdr(&to_cdr(&sp, &meta)).unwrap().0, sp);
    let mut long = CdrBioTac::new(&r, &meta);
    long.pac = vec![2047; MAX_PAC + 1];
    let bytes = cdr::serialize::<_, _, cdr::CdrLe>(&long, cdr::Infinite).unwrap();
    let err = from_cdr(&bytes).unwrap_err().to_string();
    assert!(err.contains("more PAC samples than a BioTac SP's"), "{err}");
    long.pac = vec![];
    let bytes = cdr::serialize::<_, _, cdr::CdrLe>(&long, cdr::Infinite).unwrap();
    let err = from_cdr(&bytes).unwrap_err().to_string();
    assert!(err.contains("0 PAC samples"), "{err}");
    let mut odd = CdrBioTac::new(&r, &meta);
    odd.electrodes = vec![3000; 20];
    let bytes = cdr::serialize::<_, _, cdr::CdrLe>(&odd, cdr::Infinite).unwrap();
    let err = from_cdr(&bytes).unwrap_err().to_string();
    assert!(err.contains("20 electrodes"), "{err}");
    m.pac[3] = 5000;
    let bytes = cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).unwrap();
    let err = from_cdr(&bytes).unwrap_err().to_string();
    assert!(err.contains("pac") && err.contains("5000"), "{err}");
    m.pac[3] = 0;
    m.nanosec = 1_000_000_000;
    let bytes = cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).unwrap();
    assert!(matches!(
        from_cdr(&bytes),
        Err(BioTacMsgError::Stamp { .. })
    ));
}

#[test]
fn a_stated_length_beyond_the_bytes_is_refused_before_anything_is_reserved() {
    // Header, stamp, then a frame_id claiming 0xF000_0000 bytes.
    let mut bytes = vec![0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0];
    bytes.extend(0xF000_0000u32.to_le_bytes());
    let err = from_cdr(&bytes).unwrap_err().to_string();
    assert!(err.contains("longer than the message"), "{err}");
    // So many invalid channels that their lengths alone cannot fit.
    let m = CdrBioTac {
        sec: 1,
        nanosec: 0,
        frame_id: String::new(),
        serial: String::new(),
        sensor_index: 0,
        seq: 0,
        electrodes: vec![0u16; N_ELECTRODES],
        pdc: 0,
        pac: vec![0u16; N_PAC],
        tdc: 0,
        tac: 0,
        invalid_channels: vec![],
    };
    let mut bytes = cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).unwrap();
    let n = bytes.len();
    bytes[n - 4..].copy_from_slice(&u32::MAX.to_le_bytes());
    let err = from_cdr(&bytes).unwrap_err().to_string();
    assert!(err.contains("more invalid channels"), "{err}");
    assert!(from_cdr(&[1, 2, 3]).is_err() && from_cdr(&[]).is_err());
    // An electrode sequence claiming more values than a BioTac SP has.
    let mut bytes = cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).unwrap();
    // Header 4, stamp 8, two empty strings (length and NUL) 5 + 3 + 5,
    // index 1, seq 2 (aligned): the sequence length at 4 + 24.
    let at = 28;
    assert_eq!(bytes[at..at + 4], 19u32.to_le_bytes());
    bytes[at..at + 4].copy_from_slice(&0x7000_0000u32.to_le_bytes());
    let err = from_cdr(&bytes).unwrap_err().to_string();
    assert!(err.contains("more electrodes than a BioTac SP"), "{err}");
}

#[test]
fn messages_recorded_with_the_older_fixed_arrays_decode() {
    use ArrayField::{Fixed, Sequence};
    let today = include_str!("../../../msg/msg/BioTac.msg");
    assert_eq!(MsgLayout::of_definition(today), MsgLayout::CURRENT);
    let r = reading();
    let m = CdrBioTac::new(&r, &BioTacMeta::default());
    let electrodes = <[u16; N_ELECTRODES]>::try_from(&r.electrodes[..]).unwrap();
    let pac = <[u16; N_PAC]>::try_from(&r.pac[..]).unwrap();
    // Before the BioTac SP: both fixed. Then a sequence of electrodes
    // with the fixed 22 PAC samples.
    let before_sp = "uint16 seq\nuint16[19] electrodes  # E1..E19\nuint16 pdc\nuint16[22] pac\n";
    let before_27 = "uint16 seq\nuint16[] electrodes\nuint16 pdc\nuint16[22] pac # 2200 Hz\n";
    let fixed = m.with_arrays(electrodes, pac);
    let bytes = cdr::serialize::<_, _, cdr::CdrLe>(&fixed, cdr::Infinite).unwrap();
    let layout = MsgLayout::of_definition(before_sp);
    assert_eq!((layout.electrodes, layout.pac), (Fixed, Fixed));
    assert_eq!(from_cdr_as(&bytes, layout).unwrap().0, r);
    assert!(from_cdr(&bytes).is_err(), "not sequences");
    let m = CdrBioTac::new(&r, &BioTacMeta::default());
    let fixed_pac = m.with_arrays(r.electrodes.to_vec(), pac);
    let bytes = cdr::serialize::<_, _, cdr::CdrLe>(&fixed_pac, cdr::Infinite).unwrap();
    let layout = MsgLayout::of_definition(before_27);
    assert_eq!((layout.electrodes, layout.pac), (Sequence, Fixed));
    assert_eq!(from_cdr_as(&bytes, layout).unwrap().0, r);
    assert!(from_cdr(&bytes).is_err(), "no PAC sequence");
}
