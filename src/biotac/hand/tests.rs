//! Hand messages: definitions read for their arrays, both encodings
//! decoded, and the one place a reading is made.

use super::*;

const SHADOW: &str = "Header header\nBiotac[5] tactiles\n\
    ================================================================================\n\
    MSG: std_msgs/Header\n# seq\nuint32 seq\ntime stamp\nstring frame_id\n\
    ================================================================================\n\
    MSG: sr_robot_msgs/Biotac\nint16 pac0\nint16 pac1\nint16 pdc\n\nint16 tac\nint16 tdc\n\
    int16[] electrodes # impedances\n";

const PENN_ROS2: &str = "std_msgs/Header header\nstring hand_id\n\
    biotac_sensors/BioTacData[] bt_data\nbiotac_sensors/BioTacTime bt_time\n\
    ================================================================================\n\
    MSG: biotac_sensors/BioTacData\nstring bt_serial\nuint16 bt_position\nuint16 tdc_data\n\
    uint16 tac_data\nuint16 pdc_data\nuint16[22] pac_data\nuint16[19] electrode_data\n";

#[test]
fn definitions_give_fixed_and_stated_arrays() {
    let shadow = HandLayout::from_definition(HandKind::BiotacAll, SHADOW).unwrap();
    assert_eq!(shadow.sensors, Len::Fixed(5));
    assert_eq!(shadow.electrodes, Len::Stated);
    let penn = HandLayout::from_definition(HandKind::BioTacHand, PENN_ROS2).unwrap();
    assert_eq!(
        (penn.sensors, penn.pac, penn.electrodes),
        (Len::Stated, Len::Fixed(22), Len::Fixed(19))
    );
    let bounded = SHADOW.replace("Biotac[5]", "Biotac[<=8]");
    let bounded = HandLayout::from_definition(HandKind::BiotacAll, &bounded).unwrap();
    assert_eq!(bounded.sensors, Len::Stated);
    assert_eq!(
        (shadow.fixed_sensors(), bounded.fixed_sensors()),
        (Some(5), None)
    );
}

#[test]
fn live_hand_messages_have_the_layout_of_the_ros2_definition() {
    // What a ROS 2 bag of a Shadow hand stores: live messages carry none.
    let ros2 = SHADOW.replace("Header header", "std_msgs/Header header");
    let from_bag = HandLayout::from_definition(HandKind::BiotacAll, &ros2).unwrap();
    assert_eq!(from_bag, SHADOW_HAND);
}

#[test]
fn a_definition_that_differs_is_refused_naming_its_fields() {
    let swapped = SHADOW.replace("int16 pdc\n\nint16 tac", "int16 tac\n\nint16 pdc");
    let err = HandLayout::from_definition(HandKind::BiotacAll, &swapped).unwrap_err();
    assert!(err.contains("int16 tac, int16 pdc"), "{err}");
    assert!(
        err.contains("expected (int16 pac0, int16 pac1, int16 pdc, int16 tac"),
        "{err}"
    );
    let err = HandLayout::from_definition(HandKind::BioTacHand, SHADOW).unwrap_err();
    assert!(err.contains("the message"), "{err}");
    let no_sensor = PENN_ROS2.split("=====").next().unwrap();
    let err = HandLayout::from_definition(HandKind::BioTacHand, no_sensor).unwrap_err();
    assert!(err.contains("no MSG: BioTacData section"), "{err}");
    assert_eq!(
        HandKind::of("sr_robot_msgs/msg/BiotacAll"),
        Some(HandKind::BiotacAll)
    );
    assert_eq!(
        HandKind::of("biotac_sensors/BioTacHand"),
        Some(HandKind::BioTacHand)
    );
    assert_eq!(HandKind::of("sr_robot_msgs/Biotac"), None);
}

/// A BioTacHand in CDR (little or big endian) with `sensors` sensors,
/// sensor k's electrodes 1000 + 10 k + e, PAC 2000 + j.
fn penn_cdr(sensors: u32, little: bool) -> Vec<u8> {
    let mut b = vec![0, u8::from(little), 0, 0];
    let put = |b: &mut Vec<u8>, bytes: &[u8], align: usize| {
        while !(b.len() - 4).is_multiple_of(align) {
            b.push(0);
        }
        let mut bytes = bytes.to_vec();
        if !little {
            bytes.reverse();
        }
        b.extend(bytes);
    };
    let string = |b: &mut Vec<u8>, s: &str| {
        put(b, &(s.len() as u32 + 1).to_le_bytes(), 4);
        b.extend(s.as_bytes());
        b.push(0);
    };
    put(&mut b, &7i32.to_le_bytes(), 4);
    put(&mut b, &500_000_000u32.to_le_bytes(), 4);
    string(&mut b, "hand");
    string(&mut b, "left");
    put(&mut b, &sensors.to_le_bytes(), 4);
    for k in 0..sensors as u16 {
        string(&mut b, "B0001");
        for v in [k, 2300 + k, 2001, 1900 + k] {
            put(&mut b, &v.to_le_bytes(), 2);
        }
        for j in 0..22u16 {
            put(&mut b, &(2000 + j).to_le_bytes(), 2);
        }
        for e in 0..19u16 {
            put(&mut b, &(1000 + 10 * k + e).to_le_bytes(), 2);
        }
    }
    b
}

#[test]
fn cdr_messages_of_either_byte_order_give_the_finger_asked_for() {
    let penn = HandLayout::from_definition(HandKind::BioTacHand, PENN_ROS2).unwrap();
    for little in [true, false] {
        let bytes = penn_cdr(3, little);
        let (stamp_s, r) = penn.decode(&bytes, Encoding::Cdr, 2).unwrap();
        assert_eq!(stamp_s, 7.5);
        assert_eq!(
            r.electrodes,
            std::array::from_fn::<u16, 19, _>(|e| 1020 + e as u16).into()
        );
        assert_eq!((r.tdc, r.tac, r.pdc), (2302, 2001, 1902));
        assert_eq!(
            r.pac,
            std::array::from_fn::<u16, 22, _>(|j| 2000 + j as u16).into()
        );
        let err = penn.decode(&bytes, Encoding::Cdr, 3).unwrap_err();
        assert_eq!(
            err,
            DecodeError::Finger {
                finger: 3,
                sensors: 3
            }
        );
        let cut = penn
            .decode(&bytes[..bytes.len() - 1], Encoding::Cdr, 2)
            .unwrap_err();
        assert!(
            matches!(&cut, DecodeError::Bad(s) if s.contains("the message ends")),
            "{cut:?}"
        );
    }
    // A stated count beyond the bytes is refused before any reading.
    let mut huge = penn_cdr(1, true);
    huge.truncate(36); // the stamp, "hand", "left", up to the sensor count
    huge.extend(u32::MAX.to_le_bytes());
    let err = penn.decode(&huge, Encoding::Cdr, 0).unwrap_err();
    assert!(
        matches!(&err, DecodeError::Bad(s) if s.contains("stated length")),
        "{err:?}"
    );
}

#[test]
fn a_reading_takes_19_electrodes_and_keeps_the_pac_samples_it_is_given() {
    let electrodes: Vec<i32> = (0..19).map(|e| 3000 + e).collect();
    let c = Channels {
        electrodes: &electrodes,
        pac: &[2040, 2051],
        pdc: 1970,
        tdc: 2360,
        tac: 2001,
    };
    let r = reading_from(&c, 9, 1.25).unwrap();
    assert_eq!(r.electrodes[18], 3018);
    assert_eq!(r.pac_mean(), 2045.5);
    assert_eq!(&r.pac[..], [2040, 2051]);
    assert_eq!(
        (r.seq, r.stamp_s, r.pdc, r.tdc, r.tac),
        (9, 1.25, 1970, 2360, 2001)
    );

    let sp: Vec<i32> = vec![3000; 24];
    let with = |electrodes: &[i32]| reading_from(&Channels { electrodes, ..c }, 0, 0.0);
    assert_eq!(with(&sp).unwrap().electrodes.len(), 24, "a BioTac SP's");
    let err = with(&sp[..20]).unwrap_err();
    assert_eq!(
        err,
        "the message has 20 electrodes: a BioTac has 19, a BioTac SP 24"
    );
    let err = reading_from(&Channels { pac: &[1; 28], ..c }, 0, 0.0).unwrap_err();
    assert!(err.contains("28 PAC samples"), "{err}");
    let none = reading_from(&Channels { pac: &[], ..c }, 0, 0.0).unwrap_err();
    assert!(none.contains("0 PAC samples"), "{none}");
    let err = reading_from(&Channels { pdc: -4, ..c }, 0, 0.0).unwrap_err();
    assert_eq!(err, "pdc is -4, not a count");
}

#[test]
fn a_ros1_wrench_reads_its_stamp_and_refuses_non_finite_values() {
    let mut b = Vec::new();
    for v in [3u32, 12, 250_000_000, 2] {
        b.extend(v.to_le_bytes());
    }
    b.extend(b"ft");
    for v in [1.0, -2.0, 3.5, 0.1, 0.2, 0.3f64] {
        b.extend(v.to_le_bytes());
    }
    let (stamp_s, w) = ros1_wrench(&b).unwrap();
    assert_eq!(stamp_s, 12.25);
    assert_eq!((w.force.z, w.torque.x), (3.5, 0.1));
    let n = b.len();
    b[n - 8..].copy_from_slice(&f64::NAN.to_le_bytes());
    assert!(ros1_wrench(&b).unwrap_err().contains("not finite"));
    assert!(ros1_wrench(&b[..n - 1])
        .unwrap_err()
        .contains("ends at byte"));
}
