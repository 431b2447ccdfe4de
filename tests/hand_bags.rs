//! Hands' BioTac bags from an independent writer (Python's rosbags,
//! serialising from the message definitions registered in its type
//! system): `sr_robot_msgs/BiotacAll` and `biotac_sensors/BioTacHand` with
//! `geometry_msgs/WrenchStamped`, as ROS 1 bags (uncompressed, bz2, lz4) and
//! as rosbag2 MCAP (CDR),
//! read back value for value by learn::data::ros1 and learn::data::bag.
//! The bags and `expected.json` (what was written) come from
//! `tests/bag/run.sh`, which runs these tests with `--ignored`.

use std::path::PathBuf;

use tactile_force::learn::data::bag::{read_bag, Bag, BagError, BagTopics};
use tactile_force::learn::data::ros1::read_ros1_bag;
use tactile_force::learn::data::trials::{split_trials, TrialSplit};

/// The directory of the bags; fails when unset, so that run.sh's
/// `--ignored` run cannot pass without them.
fn bags() -> PathBuf {
    match std::env::var_os("TACTILE_FORCE_TEST_BAGS") {
        Some(dir) => PathBuf::from(dir),
        None => panic!(
            "TACTILE_FORCE_TEST_BAGS is not set: run tests/bag/run.sh, which writes the bags \
             (Python rosbags) and runs these tests"
        ),
    }
}

#[derive(serde::Deserialize)]
struct Sensor {
    electrodes: Vec<u16>,
    pdc: u16,
    tdc: u16,
    tac: u16,
    pac: Vec<u16>,
}

#[derive(serde::Deserialize)]
struct Expected {
    stamp_ns: u64,
    sensors: Vec<Sensor>,
    force: [f64; 3],
    torque: [f64; 3],
}

fn expected() -> Vec<Expected> {
    let text = std::fs::read_to_string(bags().join("expected.json")).unwrap();
    serde_json::from_str(&text).unwrap()
}

fn read(name: &str, topic: &str, finger: usize) -> Result<Bag, BagError> {
    let topics = BagTopics {
        biotac: topic.into(),
        ft: "/ft".into(),
        tolerance_s: 0.005,
        finger,
    };
    let path = bags().join(name);
    match name.ends_with(".mcap") {
        true => read_bag(&path, &topics),
        false => read_ros1_bag(&path, &topics),
    }
}

/// (file, readings topic, message type, sensors per message)
const BAGS: [(&str, &str, &str, usize); 6] = [
    ("shadow.bag", "/rh/tactile", "sr_robot_msgs/BiotacAll", 5),
    (
        "shadow_bz2.bag",
        "/rh/tactile",
        "sr_robot_msgs/BiotacAll",
        5,
    ),
    (
        "shadow_lz4.bag",
        "/rh/tactile",
        "sr_robot_msgs/BiotacAll",
        5,
    ),
    (
        "shadow_mcap/shadow_mcap.mcap",
        "/rh/tactile",
        "sr_robot_msgs/msg/BiotacAll",
        5,
    ),
    ("penn.bag", "/biotac_pub", "biotac_sensors/BioTacHand", 3),
    (
        "penn_mcap/penn_mcap.mcap",
        "/biotac_pub",
        "biotac_sensors/msg/BioTacHand",
        3,
    ),
];

#[test]
#[ignore = "needs tests/bag/run.sh (Python rosbags writer)"]
fn every_hand_bag_gives_each_finger_exactly_as_written() {
    let want = expected();
    for (name, topic, msg_type, sensors) in BAGS {
        for finger in [0, sensors - 1] {
            let mut bag = read(name, topic, finger).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(bag.reading_type, msg_type);
            assert_eq!(bag.records.len(), want.len(), "{name}");
            assert_eq!(
                (bag.unpaired_readings, bag.unpaired_wrenches),
                (0, 0),
                "{name}"
            );
            for (i, (r, w)) in bag.records.iter().zip(&want).enumerate() {
                let s = &w.sensors[finger];
                let at = format!("{name} finger {finger} message {i}");
                assert_eq!(r.reading.electrodes.to_vec(), s.electrodes, "{at}");
                let got = (r.reading.pdc, r.reading.tdc, r.reading.tac);
                assert_eq!(got, (s.pdc, s.tdc, s.tac), "{at}");
                if msg_type.starts_with("sr_robot_msgs") {
                    // pac0 and pac1: the reading keeps the two.
                    assert_eq!(r.reading.pac[..], s.pac[..2], "{at}");
                } else {
                    assert_eq!(r.reading.pac.to_vec(), s.pac, "{at}");
                }
                let (sec, ns) = (w.stamp_ns / 1_000_000_000, w.stamp_ns % 1_000_000_000);
                assert_eq!(r.reading.stamp_s, sec as f64 + ns as f64 * 1e-9, "{at}");
                assert_eq!(<[f64; 3]>::from(r.wrench.force), w.force, "{at}");
                assert_eq!(<[f64; 3]>::from(r.wrench.torque), w.torque, "{at}");
            }
            let rests = TrialSplit::Rests {
                force_n: 0.1,
                min_rest_s: 0.5,
                rest_samples: 50,
            };
            assert_eq!(split_trials(&mut bag.records, &rests), 3, "{name}");
            // Presses 1.5..3 s, 4.5..6 s, 7..8.5 s: cut at 3.75 s and 6.5 s.
            let first = |k| bag.records.iter().position(|r| r.trial == k).unwrap();
            assert!((first(2) as i64 - 375).abs() <= 1, "{name}: {}", first(2));
            assert!((first(3) as i64 - 650).abs() <= 1, "{name}: {}", first(3));
        }
        let err = read(name, topic, sensors).unwrap_err();
        assert!(
            matches!(&err, BagError::FingerOutOfRange { finger, sensors: n, .. }
                if *finger == sensors && *n == sensors),
            "{name}: {err}"
        );
    }
}

#[test]
#[ignore = "needs tests/bag/run.sh (Python rosbags writer)"]
fn the_cli_evaluates_a_hand_bag_and_refuses_an_unknown_type() {
    let tf = env!("CARGO_BIN_EXE_tactile_force");
    let path = |name: &str| bags().join(name).display().to_string();
    let o = std::process::Command::new(tf)
        .args([
            "eval",
            "--data",
            &path("penn.bag"),
            "--biotac-topic",
            "/biotac_pub",
        ])
        .args([
            "--ft-topic",
            "/ft",
            "--finger",
            "2",
            "--folds",
            "3",
            "--axes",
            "fz",
        ])
        .args(["--max-train", "300", "--no-nn", "--json"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(
            "900 readings of biotac_sensors/BioTacHand paired with a wrench; unpaired: 0 \
             readings, 0 wrenches; trials: 3"
        ),
        "{err}"
    );
    let o = std::process::Command::new(tf)
        .args([
            "train",
            "--data",
            &path("unknown_type.bag"),
            "--biotac-topic",
            "/rh/tactile",
        ])
        .args(["--out", &path("m.json")])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("topic /rh/tactile carries std_msgs/String")
            && err.contains("/rh/tactile (std_msgs/String, 10 messages)"),
        "{err}"
    );
}
