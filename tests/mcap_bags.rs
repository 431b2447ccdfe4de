//! `learn::data::bag` against MCAP files from an independent writer (Python's
//! mcap-ros2-support, serialising from the .msg definitions). The bags and
//! the CSV they were made from come from `tests/bag/run.sh`, which runs
//! these tests with `--ignored`.

use std::path::PathBuf;

use tactile_force::learn::data::bag::{read_bag, Bag, BagError, BagTopics};
use tactile_force::learn::data::{electrode_columns, Counts, Dataset};
use tactile_force::wrench::{Axis, AxisSet};

/// The directory of the bags; fails when unset, so that run.sh's
/// `--ignored` run cannot pass without them.
fn bags() -> PathBuf {
    match std::env::var_os("TACTILE_FORCE_TEST_BAGS") {
        Some(dir) => PathBuf::from(dir),
        None => panic!(
            "TACTILE_FORCE_TEST_BAGS is not set: run tests/bag/run.sh, which writes the bags \
             (Python mcap writer) and runs these tests"
        ),
    }
}

fn read(name: &str) -> Result<Bag, BagError> {
    read_bag(&bags().join(name), &BagTopics::default())
}

#[test]
#[ignore = "needs tests/bag/run.sh (Python mcap writer)"]
fn the_good_bag_gives_every_csv_row_with_its_values() {
    let mut features = electrode_columns(tactile_force::biotac::ElectrodeLayout::Biotac);
    features.extend(["pdc", "tdc", "tac", "pac_mean"].map(String::from));
    let axes = AxisSet::new(Axis::ALL.to_vec()).unwrap();
    let csv =
        Dataset::read_csv(&bags().join("session.csv"), &features, &axes, Counts::Raw).unwrap();
    let bag = read("good.mcap").unwrap();
    assert_eq!(bag.records.len(), csv.len());
    assert_eq!((bag.unpaired_readings, bag.unpaired_wrenches), (0, 0));
    for (i, r) in bag.records.iter().enumerate() {
        let x = csv.x.row(i);
        let counts: Vec<f64> = (r.reading.electrodes.iter())
            .chain([&r.reading.pdc, &r.reading.tdc, &r.reading.tac])
            .map(|&v| f64::from(v))
            .collect();
        assert_eq!(counts, x.as_slice().unwrap()[..counts.len()], "row {i}");
        let pac_mean = x[features.len() - 1];
        assert!(r
            .reading
            .pac
            .iter()
            .all(|&p| (f64::from(p) - pac_mean).abs() <= 0.5));
        for (j, &axis) in Axis::ALL.iter().enumerate() {
            let (got, want) = (r.wrench.get(axis), csv.y[[i, j]]);
            assert!((got - want).abs() < 1e-6, "row {i} {axis}: {got} vs {want}");
        }
        assert!((r.t - 0.01 * i as f64).abs() < 1e-6, "row {i}: t = {}", r.t);
        assert_eq!((r.set, r.trial), (1, 1));
    }
}

#[test]
#[ignore = "needs tests/bag/run.sh (Python mcap writer)"]
fn each_bad_bag_gives_its_error_naming_the_topic() {
    // Cut in half: its whole chunks read, the first rows of the good bag,
    // said to be cut.
    let cut = read("truncated.mcap").unwrap();
    let good = read("good.mcap").unwrap();
    let n = cut.records.len();
    assert!(n > 0 && n < good.records.len(), "{n} records");
    assert!(
        cut.cut_after.is_some_and(|m| m >= 2 * n),
        "{:?}",
        cut.cut_after
    );
    assert_eq!(cut.records[..], good.records[..n]);

    let err = read("wrong_type.mcap").unwrap_err();
    assert!(
        matches!(&err, BagError::WrongType { topic, expected, .. }
            if topic == "/ft_sensor/wrench" && *expected == "geometry_msgs/msg/WrenchStamped"),
        "{err}"
    );
    assert!(
        err.to_string().contains("geometry_msgs/msg/Wrench in cdr"),
        "{err}"
    );

    let err = read("no_ft.mcap").unwrap_err();
    assert!(
        matches!(&err, BagError::MissingTopic { topic, .. } if topic == "/ft_sensor/wrench"),
        "{err}"
    );
    assert!(err.to_string().contains("/biotac/readings"), "{err}");

    let err = read("clock_jump.mcap").unwrap_err();
    assert!(
        matches!(&err, BagError::ClockJump { topic, stamp_s, previous_s, .. }
            if topic == "/biotac/readings" && (previous_s - stamp_s - 4.99).abs() < 1e-6),
        "{err}"
    );
}

#[test]
#[ignore = "needs tests/bag/run.sh (Python mcap writer)"]
fn the_cli_trains_on_a_bag_and_names_what_is_wrong_with_a_bad_one() {
    let tf = env!("CARGO_BIN_EXE_tactile_force");
    let path = |name: &str| bags().join(name).display().to_string();
    let o = std::process::Command::new(tf)
        .args([
            "eval",
            "--train",
            &path("good.mcap"),
            "--test",
            &path("session.csv"),
        ])
        .args(["--axes", "fz", "--max-train", "500", "--no-nn", "--json"])
        .output()
        .unwrap();
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(
            "8000 readings of tactile_force_msgs/msg/BioTac paired with a wrench; unpaired: 0 \
             readings, 0 wrenches; trials: 1"
        ),
        "{err}"
    );
    let j: serde_json::Value = serde_json::from_str(out.lines().last().unwrap()).unwrap();
    let rmse = j["gp"]["rmse"]["fz"].as_f64().unwrap();
    assert!(
        rmse < 0.3,
        "trained on the bag, tested on its CSV: fz RMSE {rmse}"
    );
    let o = std::process::Command::new(tf)
        .args([
            "train",
            "--data",
            &path("no_ft.mcap"),
            "--out",
            &path("m.json"),
        ])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("/ft_sensor/wrench") && err.contains("no_ft.mcap"),
        "{err}"
    );
}

#[test]
#[ignore = "needs tests/bag/run.sh (a killed calibration read by Python's mcap)"]
fn python_reads_a_killed_calibration_s_session_as_far_as_we_do() {
    // cut.mcap: `demo calibrate --realtime` killed (SIGKILL) at 40 % of its
    // motion; cut.json: what Python's mcap (NonSeekingReader, mcap-ros2
    // decoder) read of it before the end of the file.
    let bag = read("cut.mcap").unwrap();
    let text = std::fs::read_to_string(bags().join("cut.json")).unwrap();
    let py: serde_json::Value = serde_json::from_str(&text).unwrap();
    let n = bag.records.len();
    assert!(n > 2000, "{n} records");
    assert_eq!(
        py["messages"].as_u64(),
        bag.cut_after.map(|m| m as u64),
        "{py}"
    );
    assert_eq!(py["readings"].as_u64(), Some(n as u64), "{py}");
    assert_eq!(py["wrenches"].as_u64(), Some(n as u64), "{py}");
    assert_eq!(py["error"].as_str(), Some("EndOfFile"), "{py}");
    let last = bag.records.last().unwrap();
    let py_last = py["last_reading_stamp_s"].as_f64().unwrap();
    assert!(
        (py_last - last.reading.stamp_s).abs() < 1e-6,
        "{py_last} vs {}",
        last.reading.stamp_s
    );
    let py_fz = py["last_wrench_fz"].as_f64().unwrap();
    assert!(
        (py_fz - last.wrench.force.z).abs() < 1e-9,
        "{py_fz} vs {}",
        last.wrench.force.z
    );
}
