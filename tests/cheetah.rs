//! The Cheetah backend against a test double of Total Phase's library
//! (tests/cheetah_double): three BioTacs at 100 Hz read bit-exactly,
//! parity faults held or dropped and counted, a BioTac missing from the
//! board, the adapter unplugged and plugged back, one to three BioTac SPs
//! (24 electrodes, 27 PAC samples a frame) read bit-exactly with their
//! parity faults, a missing library. A few seconds in all; the 10-minute
//! run is examples/cheetah_soak.rs.

#[path = "cheetah_double/mod.rs"]
mod cheetah_double;

use std::path::PathBuf;
use std::process::Command;
use std::time::{Duration, Instant};

use cheetah_double::{Checker, Double};
use tactile_force::biotac::cheetah::{AdapterId, CheetahConfig, CheetahSource};
use tactile_force::biotac::driver::{Driver, DriverConfig, DriverEvent, LinkStats};
use tactile_force::biotac::spi::SensorModel;
use tactile_force::biotac::ElectrodeLayout;

fn dir(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR"))
        .join("cheetah")
        .join(name)
}

fn driver(double: &Double, sensors: Option<Vec<u8>>, model: SensorModel) -> Driver {
    let config = CheetahConfig {
        library: Some(double.path().to_path_buf()),
        sensors,
        model,
        ..CheetahConfig::new(AdapterId::Port(0))
    };
    CheetahSource::new(config).into_driver()
}

/// What a run saw.
#[derive(Default)]
struct Run {
    checker: Checker,
    connected: Vec<String>,
    disconnects: usize,
    stale: usize,
    failed: Vec<String>,
    stats: Option<LinkStats>,
}

/// Polls `driver` for `seconds`, checking every frame; `at` is called on
/// every poll with the seconds elapsed.
fn run(driver: &mut Driver, run: &mut Run, seconds: f64, mut at: impl FnMut(f64)) {
    let start = Instant::now();
    while start.elapsed().as_secs_f64() < seconds && !driver.failed() {
        at(start.elapsed().as_secs_f64());
        driver.poll(&mut |e| match e {
            DriverEvent::Frame { frame, reading } => run.checker.check(&frame, reading.as_ref()),
            DriverEvent::Connected { port } => {
                run.checker.reconnected();
                run.connected.push(port);
            }
            DriverEvent::Disconnected { .. } => run.disconnects += 1,
            DriverEvent::Stale { .. } => run.stale += 1,
            DriverEvent::Failed { reason } => run.failed.push(reason),
            DriverEvent::Stats(s) => run.stats = Some(s),
            _ => {}
        });
    }
}

#[test]
fn three_biotacs_read_bit_exactly_at_100_hz() {
    let double = Double::build(&dir("three")).unwrap();
    let mut d = driver(&double, None, SensorModel::BioTac);
    let mut r = Run::default();
    run(&mut d, &mut r, 3.0, |_| {});
    assert_eq!(r.connected.len(), 1, "{:?}", r.failed);
    for s in 0..3 {
        assert!(
            r.connected[0].contains(&format!("{s}: BTSIM0000000000{s}")),
            "{}",
            r.connected[0]
        );
    }
    let stats = r.stats.unwrap();
    assert!(
        (95.0..=105.0).contains(&(stats.frames_per_s / 3.0)),
        "{} frames/s",
        stats.frames_per_s
    );
    for (s, t) in r.checker.sensors.iter().enumerate() {
        // ~3 s less the 100 ms power-on wait and the first batch.
        assert!((270..=310).contains(&t.frames), "sensor {s}: {t:?}");
        assert_eq!(t.readings, t.frames, "sensor {s}: {t:?}");
        assert_eq!(
            (t.mismatches, t.invalid, t.gaps),
            (0, 0, 0),
            "sensor {s}: {t:?}"
        );
    }
    assert_eq!(d.stats().decoder.parity_errors, 0);
}

#[test]
fn parity_faults_are_held_or_dropped_and_counted() {
    let double = Double::build(&dir("parity")).unwrap();
    let mut d = driver(&double, None, SensorModel::BioTac);
    let mut r = Run::default();
    // Every 97th word: scattered faults, each held for one frame.
    double.control("parity_every", 97);
    run(&mut d, &mut r, 1.5, |_| {});
    let phase1 = r.checker.sensors;
    // Every 132nd word (3 x 44): the same channel of one sensor every frame.
    double.control("parity_every", 132);
    run(&mut d, &mut r, 1.0, |_| {});
    double.control("parity_every", 0);
    run(&mut d, &mut r, 0.3, |_| {});
    let injected = double.stat("parity_injected") as u64;
    let counted = d.stats().decoder.parity_errors;
    let seen: u64 = r.checker.sensors.iter().map(|t| t.invalid).sum();
    assert!(injected > 100, "{injected}");
    assert_eq!(counted, injected);
    assert_eq!(seen, injected);
    let held: u64 = phase1.iter().map(|t| t.held).sum();
    assert!(held > 50, "{phase1:?}");
    let dropped: u64 = r.checker.sensors.iter().map(|t| t.dropped).sum();
    assert_eq!(d.stats().dropped, dropped);
    assert!(dropped >= 90, "{:?}", r.checker.sensors);
    for t in &r.checker.sensors {
        assert_eq!(t.mismatches, 0, "{t:?}");
        assert_eq!(t.readings + t.dropped, t.frames, "{t:?}");
    }
}

#[test]
fn a_biotac_missing_from_the_board() {
    let double = Double::build(&dir("missing")).unwrap();
    // Position 1 empty at start: only 0 and 2 answer and are sampled.
    double.control("missing", 0b010);
    let mut d = driver(&double, None, SensorModel::BioTac);
    let mut r = Run::default();
    run(&mut d, &mut r, 1.0, |_| {});
    assert!(r.connected[0].contains("BioTacs 0: BTSIM00000000000, 2: BTSIM00000000002"));
    assert_eq!(r.checker.sensors[1].frames, 0);
    assert!(r.checker.sensors[0].readings > 80);
    drop(d); // closes the adapter
             // Asked for all three: position 1's frames are all invalid, dropped and
             // counted; the others are unaffected. Then position 2 is pulled too.
    let mut d = driver(&double, Some(vec![0, 1, 2]), SensorModel::BioTac);
    let mut r = Run::default();
    run(&mut d, &mut r, 2.0, |t| {
        if t > 1.0 {
            double.control("missing", 0b110);
        }
    });
    assert!(
        r.connected[0].contains("1: no answer"),
        "{}",
        r.connected[0]
    );
    let [zero, one, two] = r.checker.sensors;
    assert!(one.frames > 150 && one.readings == 0, "{one:?}");
    assert_eq!(one.invalid, 44 * one.frames);
    assert!(
        zero.readings == zero.frames && zero.mismatches == 0,
        "{zero:?}"
    );
    assert!(two.readings > 80 && two.dropped > 80, "{two:?}");
    assert_eq!(two.mismatches, 0);
    assert_eq!(d.stats().dropped, one.dropped + two.dropped);
}

#[test]
fn an_unplugged_adapter_reconnects_within_a_second_of_replugging() {
    let double = Double::build(&dir("unplug")).unwrap();
    let mut d = driver(&double, None, SensorModel::BioTac);
    let mut r = Run::default();
    run(&mut d, &mut r, 1.0, |_| {});
    double.control("plugged", 0);
    run(&mut d, &mut r, 0.5, |_| {});
    assert!(
        r.disconnects >= 1 && r.stale == 1,
        "{} {}",
        r.disconnects,
        r.stale
    );
    let frames_unplugged = r.checker.sensors[0].frames;
    double.control("plugged", 1);
    let replugged = Instant::now();
    let mut first_reading = None;
    let start = Instant::now();
    while start.elapsed() < Duration::from_secs(2) && first_reading.is_none() {
        d.poll(&mut |e| {
            if let DriverEvent::Frame {
                frame,
                reading: Some(reading),
            } = e
            {
                first_reading.get_or_insert(replugged.elapsed());
                r.checker.check(&frame, Some(&reading));
            }
        });
    }
    let after = first_reading.expect("no reading after replugging");
    assert!(after < Duration::from_secs(1), "{after:?}");
    r.checker.reconnected();
    run(&mut d, &mut r, 0.5, |_| {});
    assert!(r.checker.sensors[0].frames > frames_unplugged + 40);
    assert_eq!(d.stats().disconnects, 1);
    for t in &r.checker.sensors {
        assert_eq!(t.mismatches, 0, "{t:?}");
    }
}

#[test]
fn biotac_sps_read_bit_exactly_with_parity_faults_dropped_and_counted() {
    let double = Double::build(&dir("sp")).unwrap();
    double.control("electrodes", 24);
    // Three SPs: clean, then every 97th word and every 162nd (3 x 54: the
    // same channel of one SP every frame, so its readings are dropped).
    let mut d = driver(&double, None, SensorModel::BioTacSp);
    let mut r = Run::default();
    run(&mut d, &mut r, 1.2, |_| {});
    let clean = r.checker.sensors;
    double.control("parity_every", 97);
    run(&mut d, &mut r, 0.8, |_| {});
    double.control("parity_every", 162);
    run(&mut d, &mut r, 0.6, |_| {});
    double.control("parity_every", 0);
    run(&mut d, &mut r, 0.2, |_| {});
    assert!(r.failed.is_empty(), "{:?}", r.failed);
    let stats = r.stats.unwrap();
    // 4400 words/s over 54-word frames: 81.5 frames/s per SP.
    let per_sp = stats.frames_per_s / 3.0;
    assert!((70.0..=88.0).contains(&per_sp), "{per_sp} frames/s");
    for (s, t) in clean.iter().enumerate() {
        assert!(t.frames >= 40, "sensor {s}: {t:?}");
        assert_eq!((t.readings, t.invalid), (t.frames, 0), "sensor {s}: {t:?}");
    }
    let injected = double.stat("parity_injected") as u64;
    let seen: u64 = r.checker.sensors.iter().map(|t| t.invalid).sum();
    assert!(injected > 100, "{injected}");
    assert_eq!(
        (d.stats().decoder.parity_errors, seen),
        (injected, injected)
    );
    let dropped: u64 = r.checker.sensors.iter().map(|t| t.dropped).sum();
    assert!(dropped >= 30, "{:?}", r.checker.sensors);
    assert_eq!(d.stats().dropped, dropped);
    for t in &r.checker.sensors {
        assert_eq!((t.mismatches, t.gaps, t.unverified), (0, 0, 0), "{t:?}");
        assert_eq!(t.readings + t.dropped, t.frames, "{t:?}");
    }
    assert_eq!(double.stat("out_of_order"), 0, "the SP's sampling order");
    drop(d);

    // One SP, at board position 1; its readings hold 24 electrodes and 27
    // PAC samples.
    let mut d = driver(&double, Some(vec![1]), SensorModel::BioTacSp);
    let mut layouts = Vec::new();
    let start = Instant::now();
    let mut checker = Checker::default();
    while start.elapsed() < Duration::from_secs_f64(0.6) {
        d.poll(&mut |e| {
            if let DriverEvent::Frame { frame, reading } = e {
                checker.check(&frame, reading.as_ref());
                let r = reading.unwrap();
                layouts.push((r.electrodes.layout(), r.pac.len()));
            }
        });
    }
    assert!(layouts.len() > 30, "{}", layouts.len());
    assert!(layouts
        .iter()
        .all(|l| *l == (ElectrodeLayout::BiotacSp, 27)));
    let [zero, one, two] = checker.sensors;
    assert_eq!((zero.frames, two.frames, one.mismatches), (0, 0, 0));
    assert_eq!(one.readings, one.frames);
    drop(d);

    // BioTacs read as SPs: their E20..E24 answer SynTouch's error word, so
    // no frame makes a reading, and every one is counted.
    double.control("electrodes", 19);
    let mut d = driver(&double, Some(vec![0]), SensorModel::BioTacSp);
    let mut r = Run::default();
    run(&mut d, &mut r, 0.5, |_| {});
    let t = r.checker.sensors[0];
    assert!(t.frames > 20 && t.readings == 0, "{t:?}");
    assert_eq!(t.invalid, 5 * t.frames);
    assert_eq!(d.stats().dropped, t.frames);
}

#[test]
fn a_missing_library_stops_the_driver_with_where_to_put_it() {
    let config = CheetahConfig {
        library: Some(dir("nothing-here")),
        ..CheetahConfig::new(AdapterId::Port(0))
    };
    std::fs::create_dir_all(dir("nothing-here")).unwrap();
    let mut d = Driver::with_source(
        DriverConfig::new("cheetah"),
        Box::new(CheetahSource::new(config)),
    );
    let mut r = Run::default();
    run(&mut d, &mut r, 0.2, |_| {});
    assert_eq!(r.failed.len(), 1);
    assert!(r.failed[0].contains("cheetah.so"), "{}", r.failed[0]);
}

#[test]
fn biotac_monitor_reads_the_cheetah() {
    let double = Double::build(&dir("cli")).unwrap();
    let exe = env!("CARGO_BIN_EXE_tactile_force");
    let out = Command::new(exe)
        .args(["biotac-monitor", "--cheetah", "0", "--cheetah-lib"])
        .arg(double.path())
        .args(["--frames", "30", "--jsonl"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 31);
    let first = &lines[0];
    let sensor = first["sensor"].as_u64().unwrap() as u8;
    let k = first["tdc"].as_u64().unwrap() as u32;
    let want = cheetah_double::frame_values(sensor, k, 19);
    let electrodes: Vec<u16> = serde_json::from_value(first["electrodes"].clone()).unwrap();
    let got: Vec<u16> = (0..19).map(|i| want[2 * i]).collect();
    assert_eq!(electrodes, got);
    assert_eq!(first["pac"].as_array().unwrap().len(), 22);
    assert!(lines[30]["stats"]["frames"].as_u64().unwrap() >= 30);

    // A board of BioTac SPs: every electrode and PAC sample printed.
    let sp = Command::new(exe)
        .env("CHEETAH_DOUBLE_ELECTRODES", "24")
        .args(["biotac-monitor", "--cheetah", "0", "--electrodes", "24"])
        .arg("--cheetah-lib")
        .arg(double.path())
        .args(["--frames", "3", "--jsonl"])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&sp.stdout);
    assert!(sp.status.success(), "{text}");
    let first: serde_json::Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
    let (sensor, k) = (
        first["sensor"].as_u64().unwrap() as u8,
        first["tdc"].as_u64().unwrap(),
    );
    let want = cheetah_double::frame_values(sensor, k as u32, 24);
    let pac: Vec<u16> = serde_json::from_value(first["pac"].clone()).unwrap();
    let got: Vec<u16> = (0..27).map(|i| want[2 * i + 1]).collect();
    assert_eq!(pac, got);
    assert_eq!(first["electrodes"].as_array().unwrap().len(), 24);

    let missing = Command::new(exe)
        .args(["biotac-monitor", "--cheetah", "0", "--cheetah-lib"])
        .arg(dir("nothing-here-either"))
        .args(["--frames", "3"])
        .output()
        .unwrap();
    assert_eq!(missing.status.code(), Some(2));
    let err = String::from_utf8_lossy(&missing.stderr);
    assert!(err.contains("cheetah.so"), "{err}");
}
