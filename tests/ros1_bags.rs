//! ROS 1 bags (learn::data::ros1) of a Shadow hand's BiotacAll messages:
//! bags made byte by byte here (the format's records, so that each fault
//! can be placed), read back exactly; each bad bag refused by the CLI with
//! exit 2 and a message naming what the bag holds; arbitrary bytes never
//! panic the reader. And the real recording `../shared/data/rf_foam_bar.bag`
//! (see the README there), when present: the same rows as its CSV and the
//! same accuracy.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use proptest::prelude::*;
use tactile_force::learn::data::bag::BagTopics;
use tactile_force::learn::data::ros1::read_ros1_bag;
use tactile_force::learn::data::trials::{split_trials, TrialSplit};
use tactile_force::learn::data::{electrode_columns, Counts, Dataset};
use tactile_force::wrench::AxisSet;

/// BiotacAll's definition as the Shadow driver records it (comments
/// dropped), with `Biotac[5] tactiles`.
const BIOTAC_ALL_DEF: &str = "Header header\nBiotac[5] tactiles\n\
    ================================================================================\n\
    MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n\
    ================================================================================\n\
    MSG: sr_robot_msgs/Biotac\nint16 pac0\nint16 pac1\nint16 pdc\n\nint16 tac\nint16 tdc\n\n\
    int16[] electrodes\n";
const WRENCH_DEF: &str = "Header header\nWrench wrench\n\
    ================================================================================\n\
    MSG: std_msgs/Header\nuint32 seq\ntime stamp\nstring frame_id\n\
    ================================================================================\n\
    MSG: geometry_msgs/Wrench\nVector3  force\nVector3  torque\n\
    ================================================================================\n\
    MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n";

const T0_S: u32 = 1_500_000_000;

fn field(name: &str, value: &[u8]) -> Vec<u8> {
    let mut f = ((name.len() + 1 + value.len()) as u32)
        .to_le_bytes()
        .to_vec();
    f.extend(name.as_bytes());
    f.push(b'=');
    f.extend(value);
    f
}

fn record(header: &[Vec<u8>], data: &[u8]) -> Vec<u8> {
    let header = header.concat();
    let mut r = (header.len() as u32).to_le_bytes().to_vec();
    r.extend(&header);
    r.extend((data.len() as u32).to_le_bytes());
    r.extend(data);
    r
}

fn ros1_header(seq: u32, sec: u32, nsec: u32) -> Vec<u8> {
    let mut b = Vec::new();
    for v in [seq, sec, nsec, 4] {
        b.extend(v.to_le_bytes());
    }
    b.extend(b"hand");
    b
}

/// Sensor k's channels in message i: (pac0, pac1, pdc, tac, tdc, electrodes).
fn channels(i: usize, k: usize, n_electrodes: usize) -> (i16, i16, i16, i16, i16, Vec<i16>) {
    let press = press_n(i);
    let electrodes = (0..n_electrodes)
        .map(|e| (3000 - 100 * k - 7 * e) as i16 - (200.0 * press) as i16 * (e % 3) as i16)
        .collect();
    let pdc = 1970 + 10 * k as i16 + (100.0 * press) as i16;
    (
        2040 + k as i16,
        2050 + (i % 5) as i16,
        pdc,
        2000,
        2360 + k as i16,
        electrodes,
    )
}

/// Two presses: 0.5..1.5 s and 2.5..3.5 s, 1 N (at 100 Hz).
fn press_n(i: usize) -> f64 {
    let t = i as f64 / 100.0;
    if (0.5..1.5).contains(&t) || (2.5..3.5).contains(&t) {
        1.0
    } else {
        0.0
    }
}

fn biotac_all(i: usize, stamp: (u32, u32), sensors: usize, n_electrodes: usize) -> Vec<u8> {
    let mut b = ros1_header(i as u32, stamp.0, stamp.1);
    for k in 0..sensors {
        let (pac0, pac1, pdc, tac, tdc, electrodes) = channels(i, k, n_electrodes);
        for v in [pac0, pac1, pdc, tac, tdc] {
            b.extend(v.to_le_bytes());
        }
        b.extend((electrodes.len() as u32).to_le_bytes());
        for e in electrodes {
            b.extend(e.to_le_bytes());
        }
    }
    b
}

fn wrench_stamped(i: usize, stamp: (u32, u32)) -> Vec<u8> {
    let mut b = ros1_header(i as u32, stamp.0, stamp.1);
    for v in [0.1, -0.2, -0.3 - press_n(i), 0.01, 0.02, i as f64 * 1e-3] {
        b.extend(f64::to_le_bytes(v));
    }
    b
}

/// What to put in a test bag.
struct Spec {
    messages: usize,
    /// The readings' type and definition.
    reading_type: &'static str,
    /// Sensors per message (the definition says 5).
    sensors: usize,
    n_electrodes: usize,
    /// Header stamps zero (the record time stands in).
    zero_stamps: bool,
    /// The header's index position; None: where the index starts.
    index_pos: Option<u64>,
}

impl Default for Spec {
    fn default() -> Self {
        Spec {
            messages: 400,
            reading_type: "sr_robot_msgs/BiotacAll",
            sensors: 5,
            n_electrodes: 19,
            zero_stamps: false,
            index_pos: None,
        }
    }
}

fn connection(id: u32, topic: &str, tp: &str, def: &str) -> Vec<u8> {
    let data = [
        field("topic", topic.as_bytes()),
        field("type", tp.as_bytes()),
        field("md5sum", &[b'0'; 32]),
        field("message_definition", def.as_bytes()),
    ]
    .concat();
    let header = [
        field("op", &[7]),
        field("conn", &id.to_le_bytes()),
        field("topic", topic.as_bytes()),
    ];
    record(&header, &data)
}

/// A ROS 1 bag (format 2.0): the header record, one uncompressed chunk
/// with both connections and every message (/rh/tactile, /ft), then the
/// connections again as the index section starts.
fn bag_bytes(spec: &Spec) -> Vec<u8> {
    bag_and_index(spec).0
}

/// The bag's bytes and where its index section starts.
fn bag_and_index(spec: &Spec) -> (Vec<u8>, usize) {
    let conns = [
        connection(0, "/rh/tactile", spec.reading_type, BIOTAC_ALL_DEF),
        connection(1, "/ft", "geometry_msgs/WrenchStamped", WRENCH_DEF),
    ];
    let mut chunk = conns.concat();
    for i in 0..spec.messages {
        let ns = 10_000_000 * i as u64;
        let time = (
            T0_S + (ns / 1_000_000_000) as u32,
            (ns % 1_000_000_000) as u32,
        );
        let stamp = if spec.zero_stamps { (0, 0) } else { time };
        let mut t = time.0.to_le_bytes().to_vec();
        t.extend(time.1.to_le_bytes());
        let msgs = [
            (0u32, biotac_all(i, stamp, spec.sensors, spec.n_electrodes)),
            (1, wrench_stamped(i, stamp)),
        ];
        for (conn, data) in msgs {
            let header = [
                field("op", &[2]),
                field("conn", &conn.to_le_bytes()),
                field("time", &t),
            ];
            chunk.extend(record(&header, &data));
        }
    }
    let chunk_header = [
        field("op", &[5]),
        field("compression", b"none"),
        field("size", &(chunk.len() as u32).to_le_bytes()),
    ];
    let chunk = record(&chunk_header, &chunk);
    let header_len = 13 + 4096;
    let index_pos = spec.index_pos.unwrap_or((header_len + chunk.len()) as u64);
    let mut fields = vec![
        field("op", &[3]),
        field("index_pos", &index_pos.to_le_bytes()),
        field("conn_count", &2u32.to_le_bytes()),
        field("chunk_count", &1u32.to_le_bytes()),
    ];
    let used = fields.iter().map(Vec::len).sum::<usize>() + 8;
    let mut out = b"#ROSBAG V2.0\n".to_vec();
    fields.push(Vec::new());
    out.extend(record(&fields, &vec![b' '; 4096 - used]));
    assert_eq!(out.len(), header_len);
    out.extend(chunk);
    let index_at = out.len();
    out.extend(conns.concat());
    (out, index_at)
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn topics(finger: usize) -> BagTopics {
    BagTopics {
        biotac: "/rh/tactile".into(),
        ft: "/ft".into(),
        tolerance_s: 0.005,
        finger,
    }
}

#[test]
fn a_bag_reads_back_exactly_and_splits_at_its_rests() {
    let dir = tempfile::tempdir().unwrap();
    for zero_stamps in [false, true] {
        let spec = Spec {
            zero_stamps,
            ..Spec::default()
        };
        let path = write(dir.path(), "hand.bag", &bag_bytes(&spec));
        for finger in [0, 3] {
            let mut bag = read_ros1_bag(&path, &topics(finger)).unwrap();
            assert_eq!(bag.records.len(), 400);
            assert_eq!((bag.unpaired_readings, bag.unpaired_wrenches), (0, 0));
            assert_eq!(bag.reading_type, "sr_robot_msgs/BiotacAll");
            for (i, r) in bag.records.iter().enumerate() {
                let (pac0, pac1, pdc, tac, tdc, e) = channels(i, finger, 19);
                let e: Vec<u16> = e.iter().map(|&v| v as u16).collect();
                assert_eq!(r.reading.electrodes.to_vec(), e, "message {i}");
                let got = (r.reading.pdc, r.reading.tac, r.reading.tdc);
                assert_eq!(got, (pdc as u16, tac as u16, tdc as u16));
                assert_eq!(r.reading.pac[..], [pac0 as u16, pac1 as u16]);
                assert_eq!(
                    r.reading.pac_mean(),
                    (f64::from(pac0) + f64::from(pac1)) / 2.0
                );
                assert_eq!(r.reading.seq, i as u16);
                assert!((r.reading.stamp_s - (f64::from(T0_S) + i as f64 * 0.01)).abs() < 1e-6);
                assert!((r.t - i as f64 * 0.01).abs() < 1e-6);
                let w = r.wrench;
                assert_eq!([w.force.x, w.force.y], [0.1, -0.2]);
                assert_eq!(w.force.z, -0.3 - press_n(i));
                assert_eq!(w.torque.z, i as f64 * 1e-3);
            }
            let rests = TrialSplit::Rests {
                force_n: 0.1,
                min_rest_s: 0.5,
                rest_samples: 50,
            };
            assert_eq!(split_trials(&mut bag.records, &rests), 2);
            // Contact ends at 1.49 s and starts again at 2.50 s: cut at 1.995 s.
            let first_of_2 = bag.records.iter().position(|r| r.trial == 2).unwrap();
            assert_eq!(first_of_2, 200);
        }
    }
}

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_tactile_force"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// `eval` on `path` with the test bag's topics and `extra` options.
fn eval(path: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["eval", "--data", path.to_str().unwrap(), "--folds", "2"];
    args.extend(["--biotac-topic", "/rh/tactile", "--no-nn"]);
    if !extra.contains(&"--ft-topic") {
        args.extend(["--ft-topic", "/ft"]);
    }
    args.extend(extra);
    run(&args)
}

fn refused_saying(o: &Output, says: &[&str]) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for s in says {
        assert!(err.contains(s), "{s:?} not in {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn each_bad_bag_is_refused_with_exit_2_naming_what_it_holds() {
    let dir = tempfile::tempdir().unwrap();
    let good = bag_bytes(&Spec::default());
    let path = write(dir.path(), "good.bag", &good);
    let o = eval(&path, &["--axes", "fz"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("400 readings of sr_robot_msgs/BiotacAll"),
        "{err}"
    );
    assert!(err.contains("trials: 2"), "{err}");

    // Cut short: the index lies beyond the end.
    let cut = write(dir.path(), "cut.bag", &good[..good.len() / 2]);
    refused_saying(
        &eval(&cut, &[]),
        &["truncated or corrupt ROS 1 bag", "cut short"],
    );

    // A message record's header length overwritten: the chunk no longer parses.
    let mut bad = good.clone();
    let at = 13 + 4096 + 200;
    bad[at..at + 64].fill(0xff);
    let corrupt = write(dir.path(), "corrupt.bag", &bad);
    refused_saying(&eval(&corrupt, &[]), &["truncated or corrupt ROS 1 bag"]);

    // Not closed: no index.
    let open = bag_bytes(&Spec {
        index_pos: Some(0),
        ..Spec::default()
    });
    let open = write(dir.path(), "open.bag", &open);
    refused_saying(&eval(&open, &[]), &["rosbag reindex"]);

    // Not a bag at all.
    let text = write(dir.path(), "text.bag", b"#ROSBAG V1.2\nhello");
    refused_saying(
        &eval(&text, &[]),
        &["not a ROS 1 bag (format 2.0)", "#ROSBAG V1.2"],
    );

    let unknown = bag_bytes(&Spec {
        reading_type: "sensor_msgs/JointState",
        ..Spec::default()
    });
    let unknown = write(dir.path(), "unknown.bag", &unknown);
    refused_saying(
        &eval(&unknown, &[]),
        &[
            "topic /rh/tactile carries sensor_msgs/JointState",
            "sr_robot_msgs/BiotacAll or biotac_sensors/BioTacHand",
            "/rh/tactile (sensor_msgs/JointState, 400 messages)",
            "/ft (geometry_msgs/WrenchStamped, 400 messages)",
        ],
    );

    refused_saying(
        &eval(&path, &["--finger", "5"]),
        &["topic /rh/tactile (sr_robot_msgs/BiotacAll) holds 5 sensors (fingers 0..4), finger 5"],
    );

    refused_saying(
        &eval(&path, &["--ft-topic", "/wrench"]),
        &[
            "no message on topic /wrench",
            "/ft (geometry_msgs/WrenchStamped, 400 messages), /rh/tactile \
             (sr_robot_msgs/BiotacAll, 400 messages)",
        ],
    );

    // 20 electrodes: no BioTac's (a BioTac SP has 24).
    let odd = bag_bytes(&Spec {
        n_electrodes: 20,
        ..Spec::default()
    });
    let odd = write(dir.path(), "odd.bag", &odd);
    refused_saying(
        &eval(&odd, &[]),
        &["the message has 20 electrodes: a BioTac has 19, a BioTac SP 24"],
    );

    // The definition says Biotac[5]: a message with 4 runs out of bytes.
    let four = bag_bytes(&Spec {
        sensors: 4,
        ..Spec::default()
    });
    let four = write(dir.path(), "four.bag", &four);
    refused_saying(
        &eval(&four, &["--finger", "4"]),
        &[
            "topic /rh/tactile, message 1",
            "does not decode: the message ends at byte",
        ],
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..3000),
                                   magic in any::<bool>()) {
        let dir = tempfile::tempdir().unwrap();
        let mut data = if magic { b"#ROSBAG V2.0\n".to_vec() } else { Vec::new() };
        data.extend(bytes);
        let path = write(dir.path(), "any.bag", &data);
        prop_assert!(read_ros1_bag(&path, &topics(0)).is_err());
    }

    #[test]
    fn truncated_or_damaged_bags_never_panic(cut in 0usize..20_000, at in 0usize..20_000,
                                             value in any::<u8>()) {
        let (good, index_at) = bag_and_index(&Spec { messages: 20, ..Spec::default() });
        let dir = tempfile::tempdir().unwrap();
        let cut_path = write(dir.path(), "cut.bag", &good[..cut.min(good.len())]);
        let cut_result = read_ros1_bag(&cut_path, &topics(0));
        // Cut within the header or the chunks: refused (the index is not read).
        prop_assert!(cut >= index_at || cut_result.is_err());
        let mut bad = good.clone();
        let at = at % bad.len();
        bad[at] = value;
        let bad_path = write(dir.path(), "bad.bag", &bad);
        if let Ok(bag) = read_ros1_bag(&bad_path, &topics(0)) {
            prop_assert!(bag.records.len() <= 20);
        }
    }
}

/// The real recording and its CSV, or None (with a message) without them.
fn real_data() -> Option<(PathBuf, PathBuf)> {
    let dir = std::env::var_os("TACTILE_FORCE_REAL_BAG_DIR").map_or_else(
        || PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shared/data"),
        PathBuf::from,
    );
    let (bag, csv) = (
        dir.join("rf_foam_bar.bag"),
        dir.join("biotac_foam_bar_real.csv"),
    );
    if bag.exists() && csv.exists() {
        Some((bag, csv))
    } else {
        eprintln!(
            "skipped: {} and its CSV are missing (set TACTILE_FORCE_REAL_BAG_DIR)",
            bag.display()
        );
        None
    }
}

#[test]
fn the_real_bag_gives_the_rows_and_presses_of_its_csv() {
    let Some((bag_path, csv_path)) = real_data() else {
        return;
    };
    let topics = BagTopics {
        biotac: "/rh/tactile".into(),
        ft: "/sensor_readings".into(),
        tolerance_s: 0.02,
        finger: 2,
    };
    let mut bag = read_ros1_bag(&bag_path, &topics).unwrap();
    let rests = TrialSplit::Rests {
        force_n: 0.1,
        min_rest_s: 0.5,
        rest_samples: 50,
    };
    assert_eq!(split_trials(&mut bag.records, &rests), 3);
    let mut features = electrode_columns(tactile_force::biotac::ElectrodeLayout::Biotac);
    features.extend(["pdc", "tdc", "tac"].map(String::from));
    let axes: AxisSet = "fx,fy,fz".parse().unwrap();
    let csv = Dataset::read_csv(&csv_path, &features, &axes, Counts::Raw).unwrap();
    assert_eq!(bag.records.len(), csv.len());
    for (i, r) in bag.records.iter().enumerate() {
        let counts: Vec<f64> = (r.reading.electrodes.iter())
            .chain([&r.reading.pdc, &r.reading.tdc, &r.reading.tac])
            .map(|&v| f64::from(v))
            .collect();
        assert_eq!(counts, csv.x.row(i).to_vec(), "row {i}");
        for j in 0..3 {
            let (got, want) = (r.wrench.force[j], csv.y[[i, j]]);
            assert!((got - want).abs() <= 5e-6, "row {i}: {got} vs {want}");
        }
        assert_eq!(r.trial, csv.trial[i], "row {i}");
    }
    let per_trial: Vec<usize> = (1..=3)
        .map(|k| bag.records.iter().filter(|r| r.trial == k).count())
        .collect();
    assert_eq!(per_trial, [965, 576, 752]);
}

#[test]
fn the_real_bag_is_as_accurate_as_its_csv() {
    let Some((bag, csv)) = real_data() else {
        return;
    };
    let r2 = |data: &Path, extra: &[&str]| -> f64 {
        let mut args = vec!["eval", "--data", data.to_str().unwrap(), "--folds", "3"];
        args.extend(["--axes", "fz", "--ft-to-biotac", "180,0,0,0,0,0", "--no-nn"]);
        args.extend(["--json"]);
        args.extend(extra);
        let o = run(&args);
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let json: serde_json::Value = serde_json::from_str(out.lines().last().unwrap()).unwrap();
        json["gp"]["r2"]["fz"].as_f64().unwrap()
    };
    let from_bag = r2(
        &bag,
        &[
            "--biotac-topic",
            "/rh/tactile",
            "--finger",
            "2",
            "--ft-topic",
            "/sensor_readings",
            "--pair-tolerance-s",
            "0.02",
        ],
    );
    let from_csv = r2(&csv, &[]);
    assert!(from_bag >= 0.95, "{from_bag}");
    assert!(
        (from_bag - from_csv).abs() <= 0.02,
        "{from_bag} vs {from_csv}"
    );
}
