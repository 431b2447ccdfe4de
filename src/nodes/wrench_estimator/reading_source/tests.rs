//! The estimator's sources: parameters checked, each message type decoded
//! (a Shadow hand's finger by finger), unusable messages said why.

use super::*;
use crate::biotac::msg::{to_cdr, BioTacMeta};
use crate::biotac::ElectrodeLayout;

/// A BiotacAll in little-endian CDR, as a hand publishes it: stamp 12.25 s,
/// sensor k with pac0 100 + k, pac1 200 + k, pdc 2000 + k, tac 2100 + k,
/// tdc 2200 + k, and `electrodes` electrodes 1000 + 10 k + e.
fn shadow_cdr(electrodes: u32) -> Vec<u8> {
    let mut b = vec![0, 1, 0, 0];
    let align = |b: &mut Vec<u8>, n: usize| {
        while !(b.len() - 4).is_multiple_of(n) {
            b.push(0);
        }
    };
    b.extend(12i32.to_le_bytes());
    b.extend(250_000_000u32.to_le_bytes());
    b.extend(6u32.to_le_bytes());
    b.extend(b"rh_ff\0");
    for k in 0..5i16 {
        align(&mut b, 2);
        for v in [100, 200, 2000, 2100, 2200] {
            b.extend((v + k).to_le_bytes());
        }
        align(&mut b, 4);
        b.extend(electrodes.to_le_bytes());
        for e in 0..electrodes as i16 {
            b.extend((1000 + 10 * k + e).to_le_bytes());
        }
    }
    b
}

#[test]
fn the_parameters_name_a_source_or_are_refused_with_what_they_take() {
    assert_eq!(
        ReadingSource::from_params("biotac", 7.0),
        Ok(ReadingSource::BioTac)
    );
    let hand = ReadingSource::from_params("biotac_all", 4.0).unwrap();
    assert_eq!(hand, ReadingSource::ShadowHand { finger: 4 });
    assert_eq!(
        (hand.topic(), hand.type_name()),
        ("/rh/tactile", "sr_robot_msgs/msg/BiotacAll")
    );
    for finger in [5.0, -1.0, 1.5, f64::NAN] {
        let e = ReadingSource::from_params("biotac_all", finger).unwrap_err();
        assert!(
            e.to_string()
                .contains("holds 5 BioTacs, 0 (first finger) to 4 (thumb)"),
            "{e}"
        );
        assert_eq!(e.class(), ExitClass::Refused);
    }
    let e = ReadingSource::from_params("shadow", 0.0).unwrap_err();
    assert!(
        e.to_string()
            .starts_with("input = \"shadow\": expected biotac"),
        "{e}"
    );
}

#[test]
fn a_hand_message_gives_the_chosen_fingers_reading_with_its_stamp() {
    let bytes = shadow_cdr(19);
    for finger in 0..5u16 {
        let source = ReadingSource::ShadowHand {
            finger: finger as usize,
        };
        let (r, serial) = source.decode(&bytes).unwrap();
        assert_eq!(serial, format!("sr_robot_msgs/BiotacAll finger {finger}"));
        assert_eq!(r.stamp_s, 12.25);
        assert_eq!(r.electrodes.layout(), ElectrodeLayout::Biotac);
        let want: Vec<u16> = (0..19).map(|e| 1000 + 10 * finger + e).collect();
        assert_eq!(r.electrodes.to_vec(), want);
        assert_eq!(
            (r.pdc, r.tac, r.tdc),
            (2000 + finger, 2100 + finger, 2200 + finger)
        );
        // pac0 and pac1: the finger's two PAC samples.
        assert_eq!(&r.pac[..], [100 + finger, 200 + finger]);
    }
}

#[test]
fn a_hand_of_biotac_sps_gives_24_electrode_readings() {
    let source = ReadingSource::ShadowHand { finger: 3 };
    let (r, _) = source.decode(&shadow_cdr(24)).unwrap();
    assert_eq!(r.electrodes.layout(), ElectrodeLayout::BiotacSp);
    assert_eq!(r.electrodes.to_vec()[23], 1000 + 30 + 23);
}

#[test]
fn unusable_messages_say_why() {
    let hand = ReadingSource::ShadowHand { finger: 4 };
    let bytes = shadow_cdr(19);
    let Err(Unusable::Undecodable(why)) = hand.decode(&bytes[..bytes.len() - 1]) else {
        panic!("a cut message decoded");
    };
    // The thumb's 19 electrodes stated, 37 bytes left for them.
    assert!(
        why.contains("a stated length of 19 with 37 bytes left"),
        "{why}"
    );
    let Err(Unusable::Undecodable(why)) = hand.decode(&shadow_cdr(20)) else {
        panic!("20 electrodes decoded");
    };
    assert!(why.contains("20 electrodes"), "{why}");
    // Our own message (with the thumb's reading) is not a hand's, and the
    // other way round.
    let (reading, _) = hand.decode(&bytes).unwrap();
    let mut meta = BioTacMeta {
        serial: "B1".into(),
        ..BioTacMeta::default()
    };
    let ours = to_cdr(&reading, &meta);
    assert_eq!(
        ReadingSource::BioTac.decode(&ours),
        Ok((reading, "B1".to_string()))
    );
    assert!(matches!(hand.decode(&ours), Err(Unusable::Undecodable(_))));
    assert!(matches!(
        ReadingSource::BioTac.decode(&bytes),
        Err(Unusable::Undecodable(_))
    ));
    meta.invalid_channels = vec!["e3".into()];
    assert_eq!(
        ReadingSource::BioTac.decode(&to_cdr(&reading, &meta)),
        Err(Unusable::InvalidChannels)
    );
}
