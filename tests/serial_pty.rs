//! The serial driver against the bridge emulator on the two ends of a real
//! pseudo-terminal pair (openpty through `serialport::TTYPort::pair`): the
//! driver opens the slave by path, the emulator writes to the master.
//! Run with `-- --nocapture` to see the figures these tests measure.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};
use tactile_force::biotac::driver::{Driver, DriverConfig, DriverEvent};
use tactile_force::biotac::emulator::{stream, Emulator, EmulatorConfig, SentFrame};
use tactile_force::biotac::wire::{decode_frame, DecodedFrame};
use tactile_force::biotac::BioTacSimConfig;
use tactile_force::sim::collect::unit_seed;

/// A pseudo-terminal: the master (the bridge's end) and the slave's path.
/// The slave handle is kept so the pair lives until the master is dropped.
struct Pty {
    master: TTYPort,
    _slave: TTYPort,
    path: String,
}

fn pty() -> Pty {
    let (mut master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
    master
        .set_timeout(Duration::from_millis(100))
        .expect("timeout");
    let path = slave.name().expect("the slave has a path");
    Pty {
        master,
        _slave: slave,
        path,
    }
}

fn emulator(fault_rate: f64, press_peak_n: f64) -> Emulator {
    let config = EmulatorConfig {
        fault_rate,
        press_peak_n,
        ..EmulatorConfig::default()
    };
    Emulator::new(config, &BioTacSimConfig::default(), unit_seed(1))
}

/// The driver on its own thread, sending (time, event) until `stop`.
fn spawn_driver(
    path: &str,
    stop: Arc<AtomicBool>,
) -> (mpsc::Receiver<(Instant, DriverEvent)>, JoinHandle<Driver>) {
    let (tx, rx) = mpsc::channel();
    let mut driver = Driver::new(DriverConfig::new(path));
    let handle = std::thread::spawn(move || {
        while !stop.load(Ordering::Relaxed) {
            driver.poll(&mut |e| {
                let _ = tx.send((Instant::now(), e));
            });
        }
        driver
    });
    (rx, handle)
}

/// A bridge streaming at 100 Hz into the master until `stop`; gives the pty
/// back so the caller decides when its end closes.
fn spawn_bridge(mut p: Pty, press_peak_n: f64, stop: Arc<AtomicBool>) -> JoinHandle<Pty> {
    std::thread::spawn(move || {
        let mut emu = emulator(0.0, press_peak_n);
        let _ = stream(
            &mut emu,
            &mut p.master,
            Duration::from_millis(10),
            None,
            &stop,
        );
        p
    })
}

/// Frames the driver decoded among `events`.
fn frames(events: &[(Instant, DriverEvent)]) -> Vec<DecodedFrame> {
    events
        .iter()
        .filter_map(|(_, e)| match e {
            DriverEvent::Frame { frame, .. } => Some(*frame),
            _ => None,
        })
        .collect()
}

/// Writes `n` frames from `emu` into the master, `period` apart.
fn send(emu: &mut Emulator, master: &mut TTYPort, n: usize, period: Duration) -> Vec<SentFrame> {
    (0..n)
        .map(|_| {
            let f = emu.next_frame();
            std::io::Write::write_all(master, &f.bytes).expect("the pty takes the bytes");
            std::thread::sleep(period);
            f
        })
        .collect()
}

fn wait_for(
    rx: &mpsc::Receiver<(Instant, DriverEvent)>,
    what: impl Fn(&DriverEvent) -> bool,
) -> Instant {
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match rx.recv_timeout(left) {
            Ok((t, e)) if what(&e) => return t,
            Ok(_) => {}
            Err(e) => panic!("event not seen within 5 s: {e}"),
        }
    }
}

#[test]
fn every_frame_sent_is_received_bit_exact_without_faults() {
    let mut p = pty();
    let stop = Arc::new(AtomicBool::new(false));
    let (rx, driver) = spawn_driver(&p.path, stop.clone());
    wait_for(&rx, |e| matches!(e, DriverEvent::Connected { .. }));
    let mut emu = emulator(0.0, 3.0);
    let sent = send(&mut emu, &mut p.master, 300, Duration::from_millis(1));
    std::thread::sleep(Duration::from_millis(200));
    stop.store(true, Ordering::Relaxed);
    let driver = driver.join().unwrap();
    let events: Vec<_> = rx.try_iter().collect();
    let got = frames(&events);
    let want: Vec<DecodedFrame> = sent
        .iter()
        .map(|f| decode_frame(&f.intended).unwrap())
        .collect();
    assert_eq!(got.len(), 300);
    assert!(got == want, "frames differ from those sent");
    let stats = driver.stats().decoder;
    assert_eq!(
        (stats.crc_errors, stats.parity_errors, stats.lost[0]),
        (0, 0, 0)
    );
    // Every reading passed the invalid-sample policy, stamped by the host.
    let readings: Vec<f64> = events
        .iter()
        .filter_map(|(_, e)| match e {
            DriverEvent::Frame { reading, .. } => reading.map(|r| r.stamp_s),
            _ => None,
        })
        .collect();
    assert_eq!(readings.len(), 300);
    assert!(readings.windows(2).all(|w| w[1] >= w[0]));
}

#[test]
fn with_1_percent_corrupt_bytes_no_corrupt_frame_is_accepted() {
    let mut p = pty();
    let stop = Arc::new(AtomicBool::new(false));
    let (rx, driver) = spawn_driver(&p.path, stop.clone());
    wait_for(&rx, |e| matches!(e, DriverEvent::Connected { .. }));
    let mut emu = emulator(0.01, 3.0);
    let n = 2000;
    let sent = send(&mut emu, &mut p.master, n, Duration::from_micros(500));
    let corrupted = sent.iter().filter(|f| f.corrupted).count();
    std::thread::sleep(Duration::from_millis(200));
    stop.store(true, Ordering::Relaxed);
    let driver = driver.join().unwrap();
    let got = frames(&rx.try_iter().collect::<Vec<_>>());
    // Each accepted frame is exactly one the bridge meant to send.
    for f in &got {
        let want = decode_frame(&sent[usize::from(f.seq)].intended).unwrap();
        assert_eq!(*f, want, "seq {}", f.seq);
    }
    let clean = n - corrupted;
    // Only wire-corrupted frames may be missing (a bit flip in a frame's
    // tail can also tear the next one's sync: allow a few more).
    assert!(
        got.len() <= n && got.len() + 20 >= clean,
        "{} of {clean}",
        got.len()
    );
    let invalid = got.iter().filter(|f| !f.invalid.is_empty()).count();
    let stats = driver.stats();
    eprintln!(
        "fault test: {n} frames sent, {corrupted} corrupted on the wire, {} accepted \
         (all bit-exact, {invalid} with parity-invalid channels), {} CRC errors, \
         {} invalid samples, {} lost, {} readings dropped by the hold policy",
        got.len(),
        stats.decoder.crc_errors,
        stats.decoder.parity_errors,
        stats.decoder.lost[0],
        stats.dropped
    );
    assert!(invalid > 0 && stats.decoder.parity_errors > 0);
}

/// Points `link` at `target`.
fn relink(link: &Path, target: &str) {
    let _ = std::fs::remove_file(link);
    std::os::unix::fs::symlink(target, link).expect("symlink");
}

#[test]
fn a_lost_port_goes_stale_and_the_stream_resumes_when_it_returns() {
    let dir = tempfile::tempdir().unwrap();
    let link: PathBuf = dir.path().join("biotac");
    let first = pty();
    relink(&link, &first.path);
    let stop = Arc::new(AtomicBool::new(false));
    let (rx, driver) = spawn_driver(link.to_str().unwrap(), stop.clone());

    let bridge_stop = Arc::new(AtomicBool::new(false));
    let bridge = spawn_bridge(first, 3.0, bridge_stop.clone());
    wait_for(&rx, |e| matches!(e, DriverEvent::Frame { .. }));
    std::thread::sleep(Duration::from_millis(300));

    // Unplug: stop and close the bridge's end.
    bridge_stop.store(true, Ordering::Relaxed);
    drop(bridge.join().unwrap());
    let unplugged = Instant::now();
    let stale_at = wait_for(&rx, |e| matches!(e, DriverEvent::Stale { .. }));
    let lost_at = wait_for(&rx, |e| matches!(e, DriverEvent::Disconnected { .. }));

    // Plug back in after 0.3 s: a new pty behind the same path.
    std::thread::sleep(Duration::from_millis(300));
    let second = pty();
    relink(&link, &second.path);
    let replugged = Instant::now();
    let bridge_stop = Arc::new(AtomicBool::new(false));
    let bridge = spawn_bridge(second, 3.0, bridge_stop.clone());
    let resumed_at = wait_for(&rx, |e| matches!(e, DriverEvent::Frame { .. }));
    bridge_stop.store(true, Ordering::Relaxed);
    drop(bridge.join().unwrap());
    stop.store(true, Ordering::Relaxed);
    let driver = driver.join().unwrap();

    let ms = |a: Instant, b: Instant| b.saturating_duration_since(a).as_secs_f64() * 1e3;
    eprintln!(
        "reconnect test: port loss -> stale {:.1} ms, -> disconnected {:.1} ms; \
         port return -> first reading {:.1} ms",
        ms(unplugged, stale_at),
        ms(unplugged, lost_at),
        ms(replugged, resumed_at)
    );
    assert!(driver.stats().disconnects >= 1);
    // Generous bounds: this machine is shared; the figures are printed.
    assert!(ms(unplugged, stale_at) < 500.0);
    assert!(ms(replugged, resumed_at) < 3000.0);
}

#[test]
fn when_the_sensor_goes_stale_the_controller_stops_the_arm() {
    use tactile_force::control::{ForceController, JointState, TaskKind};
    use tactile_force::learn::default_model;
    use tactile_force::nodes::EstimatorNode;
    use tactile_force::runtime::Scene;

    let scene = Scene::builtin(TaskKind::Guarded).unwrap();
    let robot = tactile_force::kinematics::Robot::pa10();
    let q0 = scene.sim.start_joints_deg.clone().unwrap();
    let q = robot.positions_from_deg_mm("start", &q0).unwrap();
    let mut controller =
        ForceController::new(scene.controller.clone(), robot, &scene.tasks).unwrap();
    let recipe = scene.estimator.clone().default_model;
    let model = default_model::train(&recipe).unwrap();
    let mut estimator: EstimatorNode = EstimatorNode::new(Box::new(model), false).unwrap();

    let p = pty();
    let mut driver = Driver::new(DriverConfig::new(p.path.clone()));
    let bridge_stop = Arc::new(AtomicBool::new(false));
    // No press: the guarded move approaches, which needs fresh estimates.
    let bridge = spawn_bridge(p, 0.0, bridge_stop.clone());

    // The embedded loop by hand: driver -> estimator -> controller, 100 Hz.
    let mut last_stamp = None;
    // (age of the newest reading, moving, the controller's stale limit)
    let mut ticks = Vec::new();
    let mut next_tick = driver.now_s();
    let unplug_at = 1.5;
    while driver.now_s() < unplug_at + 0.5 {
        driver.poll(&mut |e| {
            if let DriverEvent::Frame {
                reading: Some(r), ..
            } = e
            {
                if let Ok(Some(est)) = estimator.on_reading(&r) {
                    let _ = controller.on_estimate(est);
                }
                last_stamp = Some(r.stamp_s);
            }
        });
        let now = driver.now_s();
        if now >= unplug_at {
            bridge_stop.store(true, Ordering::Relaxed);
        }
        if now >= next_tick {
            next_tick += 0.01;
            let js = JointState {
                stamp_s: now,
                q: q.clone(),
            };
            let _ = controller.on_joint_state(&js);
            controller.tick(now);
            if let Some(s) = last_stamp {
                ticks.push((
                    now - s,
                    controller.command().norm() > 0.0,
                    controller.stale_after_s(),
                ));
            }
        }
    }
    drop(bridge.join().unwrap());
    // After the tare: moving while the newest reading is at most 3 periods
    // old, halted once it is older than the limit the controller derives
    // from the ages it has seen (it grows when the host is loaded).
    let start = ticks.iter().position(|t| t.1).expect("it moved");
    let after = &ticks[start..];
    let fresh: Vec<bool> = after
        .iter()
        .filter(|t| t.0 <= 0.03_f64.min(t.2) - 1e-9)
        .map(|t| t.1)
        .collect();
    let stale: Vec<bool> = after
        .iter()
        .filter(|t| t.0 > t.2 + 1e-9)
        .map(|t| t.1)
        .collect();
    assert!(
        fresh.len() > 50 && fresh.iter().all(|&m| m),
        "moving while fresh"
    );
    assert!(
        stale.len() > 10 && stale.iter().all(|&m| !m),
        "halted once stale"
    );
}

#[test]
fn a_tare_is_taken_at_rest_and_refused_while_pressed() {
    for (press_peak_n, refused) in [(0.0, false), (3.0, true)] {
        let p = pty();
        let mut driver = Driver::new(DriverConfig::new(p.path.clone()));
        let stop = Arc::new(AtomicBool::new(false));
        let bridge = spawn_bridge(p, press_peak_n, stop.clone());
        // Skip the first second: the press cycle is then well under way.
        let deadline = Instant::now() + Duration::from_secs(5);
        let mut outcome = None;
        let mut asked = false;
        while outcome.is_none() && Instant::now() < deadline {
            if !asked && driver.now_s() > 1.0 {
                driver.request_tare(50);
                asked = true;
            }
            driver.poll(&mut |e| match e {
                DriverEvent::Tared(t) => outcome = Some(Ok(t)),
                DriverEvent::TareRefused(e) => outcome = Some(Err(e)),
                _ => {}
            });
        }
        stop.store(true, Ordering::Relaxed);
        drop(bridge.join().unwrap());
        match outcome.expect("the tare finished") {
            Ok(t) => assert!(!refused && t.pdc() > 1000.0),
            Err(e) => assert!(refused && e.to_string().contains("PDC varied"), "{e}"),
        }
    }
}
