//! Bags: written and read back, pairing, and the errors that name their place.

use super::*;
use crate::biotac::msg::{split_stamp, to_cdr, BioTacMeta, CdrBioTac};
use crate::biotac::{N_ELECTRODES, N_PAC};
use crate::exit::{Classify, ExitClass};
use std::io::{Cursor, Write};

#[derive(serde::Serialize)]
struct WrenchMsg {
    sec: i32,
    nanosec: u32,
    frame_id: String,
    force: [f64; 3],
    torque: [f64; 3],
}

fn wrench_cdr(stamp_s: f64, fx: f64) -> Vec<u8> {
    let (sec, nanosec) = split_stamp(stamp_s);
    let m = WrenchMsg {
        sec,
        nanosec,
        frame_id: "ft_sensor".into(),
        force: [fx, -2.0, 3.5],
        torque: [0.01, -0.02, 0.03],
    };
    cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).unwrap()
}

fn reading_cdr(stamp_s: f64, e1: u16) -> Vec<u8> {
    let mut electrodes = [3000; N_ELECTRODES];
    electrodes[0] = e1;
    let r = BioTacReading {
        seq: e1,
        stamp_s,
        electrodes: electrodes.into(),
        pdc: 2100,
        pac: [2048; N_PAC].into(),
        tdc: 1800,
        tac: 2000,
    };
    to_cdr(&r, &BioTacMeta::default())
}

/// A bag written with the mcap crate: channels by (topic, schema name,
/// message encoding), messages as (channel, log time in s, bytes).
fn bag(channels: &[(&str, &str, &str)], messages: &[(usize, f64, Vec<u8>)]) -> Vec<u8> {
    let with_text: Vec<_> = channels
        .iter()
        .map(|&(t, s, e)| (t, s, e, "# test"))
        .collect();
    bag_with_schemas(&with_text, messages)
}

/// [`bag`] with each channel's schema text (its message definition).
fn bag_with_schemas(
    channels: &[(&str, &str, &str, &str)],
    messages: &[(usize, f64, Vec<u8>)],
) -> Vec<u8> {
    let mut w = mcap::Writer::new(Cursor::new(Vec::new())).unwrap();
    let ids: Vec<u16> = channels
        .iter()
        .map(|(topic, schema, encoding, text)| {
            let schema = w.add_schema(schema, "ros2msg", text.as_bytes()).unwrap();
            w.add_channel(schema, topic, encoding, &BTreeMap::new())
                .unwrap()
        })
        .collect();
    for (seq, (channel, log_time_s, data)) in messages.iter().enumerate() {
        let header = mcap::records::MessageHeader {
            channel_id: ids[*channel],
            sequence: seq as u32,
            log_time: (log_time_s * 1e9).round() as u64,
            publish_time: (log_time_s * 1e9).round() as u64,
        };
        w.write_to_known_channel(&header, data).unwrap();
    }
    w.finish().unwrap();
    w.into_inner().into_inner()
}

const BIOTAC: (&str, &str, &str) = ("/biotac/readings", BIOTAC_MSG_TYPE, "cdr");
const FT: (&str, &str, &str) = ("/ft_sensor/wrench", WRENCH_STAMPED_TYPE, "cdr");

/// Readings at 100 Hz from 10 s (e1 = row), wrenches 2 ms after them
/// (fx = row), each on channel 0 and 1.
fn session(rows: usize) -> Vec<(usize, f64, Vec<u8>)> {
    let mut m = Vec::new();
    for i in 0..rows {
        let t = 10.0 + 0.01 * i as f64;
        m.push((0, t + 0.001, reading_cdr(t, i as u16)));
        m.push((1, t + 0.003, wrench_cdr(t + 0.002, i as f64)));
    }
    m
}

fn read(bytes: &[u8]) -> Result<Bag, BagError> {
    let mut f = tempfile::NamedTempFile::new().unwrap();
    f.write_all(bytes).unwrap();
    read_bag(f.path(), &BagTopics::default())
}

#[test]
fn readings_pair_with_the_nearest_wrench_within_the_tolerance() {
    let mut m = session(10);
    // No wrench near readings 0 and 1: they are left out.
    m.retain(|(c, _, data)| *c == 0 || wrench_from_cdr(data).unwrap().1.force.x >= 2.0);
    // A second wrench 4 ms after reading 5: farther than the one at 2 ms.
    let fx = |m: &(usize, f64, Vec<u8>)| wrench_from_cdr(&m.2).map(|w| w.1.force.x);
    let at = m.iter().position(|m| m.0 == 1 && fx(m) == Ok(5.0)).unwrap();
    m.insert(at + 1, (1, 10.056, wrench_cdr(10.054, 99.0)));
    // A wrench 25 ms after the last reading; another topic.
    m.push((1, 10.12, wrench_cdr(10.115, 98.0)));
    m.push((2, 10.12, b"not CDR".to_vec()));
    let other = ("/rosout", "rcl_interfaces/msg/Log", "cdr");
    let b = read(&bag(&[BIOTAC, FT, other], &m)).unwrap();
    assert_eq!((b.unpaired_readings, b.unpaired_wrenches), (2, 2));
    assert_eq!(b.records.len(), 8);
    for (k, r) in b.records.iter().enumerate() {
        let row = k + 2;
        assert!((r.t - 0.01 * k as f64).abs() < 1e-9, "{}", r.t);
        assert_eq!((r.set, r.trial), (1, 1));
        assert_eq!(r.reading.electrodes[0], row as u16);
        assert_eq!(r.wrench.force, Vector3::new(row as f64, -2.0, 3.5));
        assert_eq!(r.wrench.torque, Vector3::new(0.01, -0.02, 0.03));
    }
}

#[test]
fn a_written_session_reads_back_record_for_record() {
    let records: Vec<Record> = (0..50)
        .map(|i| Record {
            t: 0.01 * f64::from(i),
            set: 3,
            trial: 1 + i / 20,
            reading: reading_with(i as u16, 3),
            wrench: Wrench::new(
                Vector3::new(0.1, -0.2, 0.05 * f64::from(i)),
                Vector3::new(0.0, 0.001, 0.0),
            ),
        })
        .collect();
    let f = tempfile::NamedTempFile::new().unwrap();
    write_bag(f.path(), &records, &BagTopics::default(), "biotac", 1e6).unwrap();
    let back = read_bag(f.path(), &BagTopics::default()).unwrap();
    assert_eq!(back.records.len(), 50);
    assert_eq!((back.unpaired_readings, back.unpaired_wrenches), (0, 0));
    for (a, b) in records.iter().zip(&back.records) {
        assert!((a.t - b.t).abs() < 1e-6, "{} {}", a.t, b.t);
        assert_eq!(a.reading.electrodes, b.reading.electrodes);
        assert_eq!(a.wrench, b.wrench);
    }
}

#[test]
fn a_bag_without_a_topic_names_it_and_lists_the_topics_found() {
    let readings_only: Vec<_> = session(5).into_iter().filter(|m| m.0 == 0).collect();
    let err = read(&bag(&[BIOTAC, FT], &readings_only)).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, BagError::MissingTopic { .. }), "{text}");
    assert!(
        text.contains("no message on topic /ft_sensor/wrench")
            && text.contains("/biotac/readings (tactile_force_msgs/msg/BioTac, 5 messages)"),
        "{text}"
    );
}

#[test]
fn a_topic_of_another_type_or_encoding_is_refused() {
    for ft in [
        ("/ft_sensor/wrench", "geometry_msgs/msg/Wrench", "cdr"),
        ("/ft_sensor/wrench", WRENCH_STAMPED_TYPE, "json"),
    ] {
        let err = read(&bag(&[BIOTAC, ft], &session(3))).unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, BagError::WrongType { .. }), "{text}");
        assert!(
            text.contains("topic /ft_sensor/wrench carries")
                && text.contains(&format!("{} in {}", ft.1, ft.2))
                && text.contains("expected geometry_msgs/msg/WrenchStamped in cdr"),
            "{text}"
        );
    }
}

#[test]
fn a_message_that_does_not_decode_is_named_by_topic_number_and_log_time() {
    let mut m = session(5);
    // The third reading: cut short.
    m[4].2.truncate(30);
    let err = read(&bag(&[BIOTAC, FT], &m)).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, BagError::Decode { index: 3, .. }), "{text}");
    assert!(
        text.contains("topic /biotac/readings, message 3 (log time 10.021")
            && text.contains("not decodable as CDR"),
        "{text}"
    );
    // A wrench whose frame_id claims 4 GB.
    let mut m = session(5);
    m[3].2[12..16].copy_from_slice(&u32::MAX.to_le_bytes());
    let err = read(&bag(&[BIOTAC, FT], &m)).unwrap_err().to_string();
    assert!(
        err.contains("topic /ft_sensor/wrench, message 2")
            && err.contains("a string longer than the message"),
        "{err}"
    );
}

#[test]
fn stamps_that_jump_back_or_leave_a_gap_are_refused() {
    let mut m = session(8);
    // Reading 6 (message 6 of the topic) stamped 0.1 s before reading 5.
    m[10].2 = reading_cdr(9.95, 5);
    let err = read(&bag(&[BIOTAC, FT], &m)).unwrap_err();
    let text = err.to_string();
    assert!(
        matches!(err, BagError::ClockJump { index: 6, .. }),
        "{text}"
    );
    assert!(
        text.contains("topic /biotac/readings, message 6")
            && text.contains("9.950000 s follows 10.040000 s"),
        "{text}"
    );
    // A step back within the tolerance is taken (and sorted).
    let mut m = session(8);
    m[10].2 = reading_cdr(10.046, 5);
    assert_eq!(read(&bag(&[BIOTAC, FT], &m)).unwrap().records.len(), 8);
    // A wrench 1.5 s after the one before.
    let mut m = session(8);
    m[7].2 = wrench_cdr(11.532, 3.0);
    let err = read(&bag(&[BIOTAC, FT], &m)).unwrap_err().to_string();
    assert!(
        err.contains("topic /ft_sensor/wrench, message 4") && err.contains("(+1.510000 s)"),
        "{err}"
    );
}

#[test]
fn no_pair_within_the_tolerance_says_the_tolerance_and_both_spans() {
    let m: Vec<_> = session(5)
        .into_iter()
        .map(|(c, t, data)| match c {
            1 => (c, t, wrench_cdr(t + 0.5, 0.0)),
            _ => (c, t, data),
        })
        .collect();
    let err = read(&bag(&[BIOTAC, FT], &m)).unwrap_err();
    let text = err.to_string();
    assert!(matches!(err, BagError::NoPairs { .. }), "{text}");
    assert!(
        text.contains("within 0.005 s")
            && text.contains("readings stamped 10.000000..10.040000 s")
            && text.contains("wrenches 10.503000..10.543000 s"),
        "{text}"
    );
}

#[test]
fn a_file_that_is_not_mcap_or_cut_short_gives_an_error_not_a_panic() {
    let err = read(b"t,set,trial\n").unwrap_err();
    assert!(matches!(err, BagError::NotMcap { .. }), "{err}");
    assert!(matches!(read(b"").unwrap_err(), BagError::NotMcap { .. }));
    let missing = read_bag(Path::new("/nonexistent/x.mcap"), &BagTopics::default());
    assert!(matches!(missing, Err(BagError::Open { .. })));

    let good = bag(&[BIOTAC, FT], &session(40));
    let whole = read(&good).unwrap();
    assert_eq!((whole.records.len(), whole.cut_after), (40, None));
    // A cut inside the one chunk fails; one after it reads every message,
    // said to be cut; none panics.
    let (mut failed, mut cut_read) = (0, 0);
    for cut in (8..good.len()).step_by(13) {
        match read(&good[..cut]) {
            Ok(b) => {
                assert_eq!(
                    (b.records.len(), b.cut_after),
                    (40, Some(80)),
                    "cut at {cut}"
                );
                cut_read += 1;
            }
            Err(e) => {
                assert!(matches!(e, BagError::Corrupt { messages: 0, .. }), "{e}");
                assert!(e.to_string().contains("truncated or corrupt"), "{e}");
                failed += 1;
            }
        }
    }
    assert!(
        failed > 0 && cut_read > 0,
        "{failed} failed, {cut_read} read"
    );
    for at in (0..good.len()).step_by(7) {
        let mut bad = good.clone();
        bad[at] ^= 0xA5;
        let _ = read(&bad);
    }
}

/// `n` records of push `trial`, from `t0` at 100 Hz; e1 = 2000 + row.
fn records(t0: f64, n: usize, trial: u32) -> Vec<Record> {
    (0..n)
        .map(|i| Record {
            t: t0 + 0.01 * i as f64,
            set: 1,
            trial,
            reading: reading_with(i as u16, 0),
            wrench: Wrench::new(Vector3::new(0.0, 0.0, 0.01 * i as f64), Vector3::zeros()),
        })
        .collect()
}

/// Reading `seq`: electrode `e` (0-based) at 2000 + seq, the others 3000.
fn reading_with(seq: u16, e: usize) -> BioTacReading {
    let mut electrodes = [3000; N_ELECTRODES];
    electrodes[e] = 2000 + seq;
    BioTacReading {
        seq,
        stamp_s: 0.0,
        electrodes: electrodes.into(),
        pdc: 2100,
        pac: [2048; N_PAC].into(),
        tdc: 1800,
        tac: 2000,
    }
}

#[test]
fn a_session_abandoned_part_way_reads_up_to_its_last_flush_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.mcap");
    let mut w = SessionWriter::create(&path, &BagTopics::default(), "biotac", 0.0).unwrap();
    // Three pushes of 120 rows, each flushed; a fourth half written, not.
    for push in 0..3u32 {
        for r in records(f64::from(push) * 1.2, 120, push + 1) {
            w.write(&r).unwrap();
        }
        w.flush().unwrap();
    }
    for r in records(3.6, 60, 4) {
        w.write(&r).unwrap();
    }
    assert_eq!(w.counts(), (420, 360));
    // As a kill leaves it: neither the last chunk nor the footer written.
    std::mem::forget(w);
    let b = read_bag(&path, &BagTopics::default()).unwrap();
    assert_eq!((b.records.len(), b.cut_after), (360, Some(720)));
    assert!(
        (b.records[359].t - 3.59).abs() < 1e-6,
        "{}",
        b.records[359].t
    );
    assert_eq!(b.records[359].reading.electrodes[0], 2119);
    let warning = b.cut_warning(&path).unwrap();
    assert!(
        warning.contains("the file was cut") && warning.contains("720 messages"),
        "{warning}"
    );

    // Finished, the same session reads whole and uncut.
    let mut w = SessionWriter::create(&path, &BagTopics::default(), "biotac", 0.0).unwrap();
    for r in records(0.0, 50, 1) {
        w.write(&r).unwrap();
    }
    assert_eq!(w.finish().unwrap(), 50);
    let b = read_bag(&path, &BagTopics::default()).unwrap();
    assert_eq!(
        (b.records.len(), b.cut_after, b.cut_warning(&path)),
        (50, None, None)
    );
    // A folder that does not exist: a write error, a failure, naming the session.
    let e = SessionWriter::create(
        Path::new("/nonexistent-dir/s.mcap"),
        &BagTopics::default(),
        "biotac",
        0.0,
    )
    .unwrap_err();
    assert_eq!(e.class(), ExitClass::Failure);
    assert!(
        e.to_string()
            .starts_with("session /nonexistent-dir/s.mcap: cannot write"),
        "{e}"
    );
}

/// Property tests: whatever the bytes, the reader answers without a panic,
/// and an error names the file.
mod props {
    use proptest::prelude::*;

    use super::*;

    /// A session of 60 records written as the calibration writes one: a
    /// chunk flushed every 10 records.
    fn chunked() -> &'static Vec<u8> {
        static BYTES: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
        BYTES.get_or_init(|| {
            let f = tempfile::NamedTempFile::new().unwrap();
            let mut w =
                SessionWriter::create(f.path(), &BagTopics::default(), "biotac", 1e6).unwrap();
            for (i, r) in records(0.0, 60, 1).iter().enumerate() {
                w.write(r).unwrap();
                if i % 10 == 9 {
                    w.flush().unwrap();
                }
            }
            w.finish().unwrap();
            std::fs::read(f.path()).unwrap()
        })
    }

    /// Reads `bytes` as a bag: the result and the file's path.
    fn read_file(bytes: &[u8]) -> (Result<Bag, BagError>, String) {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        f.write_all(bytes).unwrap();
        let path = f.path().display().to_string();
        (read_bag(f.path(), &BagTopics::default()), path)
    }

    /// A bag read from damaged bytes: no more records than were written,
    /// each one of them; or an error that names the file, once.
    fn answered(got: (Result<Bag, BagError>, String)) -> Result<(), TestCaseError> {
        match got {
            (Ok(bag), _) => {
                prop_assert!(bag.records.len() <= 60);
                for r in &bag.records {
                    let row = usize::from(r.reading.seq);
                    prop_assert!(row < 60 && r.reading.electrodes[0] == 2000 + r.reading.seq);
                }
            }
            (Err(e), path) => {
                let msg = e.to_string();
                prop_assert_eq!(msg.matches(&path).count(), 1, "{}", msg);
                prop_assert!(msg.len() > path.len() + 10, "{}", msg);
            }
        }
        Ok(())
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        #[test]
        fn arbitrary_bytes_behind_the_magic_are_refused(bytes in proptest::collection::vec(any::<u8>(), 0..600),
                                                        magic in any::<bool>()) {
            let mut data = if magic { mcap::MAGIC.to_vec() } else { Vec::new() };
            data.extend(bytes);
            let got = read_file(&data);
            prop_assert!(got.0.is_err());
            answered(got)?;
        }

        #[test]
        fn a_cut_session_reads_its_whole_chunks_or_is_refused(cut in 0.0..1.0f64) {
            let good = chunked();
            let at = (cut * good.len() as f64) as usize;
            let got = read_file(&good[..at]);
            if let Ok(bag) = &got.0 {
                // What a cut file gives is said to be cut.
                prop_assert!(bag.cut_after.is_some(), "cut at {} of {}", at, good.len());
            }
            answered(got)?;
        }

        #[test]
        fn damaged_bytes_read_true_records_or_are_refused(at in proptest::collection::vec(0.0..1.0f64, 1..4),
                                                          value in any::<u8>(),
                                                          cut in proptest::option::of(0.0..1.0f64)) {
            let mut bad = chunked().clone();
            for a in at {
                let i = (a * bad.len() as f64) as usize;
                bad[i] = value;
            }
            if let Some(c) = cut {
                bad.truncate((c * bad.len() as f64) as usize);
            }
            answered(read_file(&bad))?;
        }
    }
}

/// Reading `i` at `t` (PAC 2000 + k + i) as bags recorded before PAC
/// became a sequence hold it: `uint16[22] pac`, electrodes as `E`
/// (`uint16[19]` before the BioTac SP, then `uint16[]`).
fn old_cdr<E: serde::Serialize>(t: f64, i: u16, electrodes: E) -> Vec<u8> {
    let pac: [u16; N_PAC] = std::array::from_fn(|k| 2000 + k as u16 + i);
    let r = BioTacReading {
        seq: i,
        stamp_s: t,
        electrodes: [3000; N_ELECTRODES].into(),
        pdc: 2100,
        pac: pac.into(),
        tdc: 1800,
        tac: 2000,
    };
    let m = CdrBioTac::new(&r, &BioTacMeta::default()).with_arrays(electrodes, pac);
    cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).unwrap()
}

#[test]
fn bags_recorded_with_the_fixed_pac_array_read_by_their_schema() {
    let definition = |electrodes: &str| {
        format!(
            "std_msgs/Header header\nstring serial\nuint8 sensor_index\nuint16 seq\n\
             {electrodes} electrodes\nuint16 pdc\nuint16[22] pac\nuint16 tdc\nuint16 tac\n\
             string[] invalid_channels\n"
        )
    };
    let old = |t: f64, i: u16, fixed: bool| {
        let mut e = [3000; N_ELECTRODES];
        e[0] = i;
        match fixed {
            true => old_cdr(t, i, e),
            false => old_cdr(t, i, e.to_vec()),
        }
    };
    let ft = ("/ft_sensor/wrench", WRENCH_STAMPED_TYPE, "cdr", "# test");
    for (fixed, electrodes) in [(true, "uint16[19]"), (false, "uint16[]")] {
        let text = definition(electrodes);
        let biotac = ("/biotac/readings", BIOTAC_MSG_TYPE, "cdr", text.as_str());
        let mut m = Vec::new();
        for i in 0..20u16 {
            let t = 10.0 + 0.01 * f64::from(i);
            m.push((0, t + 0.001, old(t, i, fixed)));
            m.push((1, t + 0.003, wrench_cdr(t + 0.002, f64::from(i))));
        }
        let mut f = tempfile::NamedTempFile::new().unwrap();
        f.write_all(&bag_with_schemas(&[biotac, ft], &m)).unwrap();
        let back = read_bag(f.path(), &BagTopics::default()).unwrap();
        assert_eq!(back.records.len(), 20, "{electrodes}");
        for (i, r) in back.records.iter().enumerate() {
            let want: Vec<u16> = (0..N_PAC).map(|k| (2000 + k + i) as u16).collect();
            assert_eq!(&r.reading.pac[..], &want[..], "{electrodes}");
            assert_eq!(r.reading.electrodes[0], i as u16);
            assert_eq!(r.reading.electrodes.len(), N_ELECTRODES);
        }
        // Under today's definition the same bytes do not decode.
        let today = include_str!("../../../../msg/msg/BioTac.msg");
        let biotac = ("/biotac/readings", BIOTAC_MSG_TYPE, "cdr", today);
        let mut f = tempfile::NamedTempFile::new().unwrap();
        f.write_all(&bag_with_schemas(&[biotac, ft], &m)).unwrap();
        let err = read_bag(f.path(), &BagTopics::default()).unwrap_err();
        assert_eq!(err.class(), ExitClass::Refused, "{err}");
    }
}
