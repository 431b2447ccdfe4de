//! The serial driver's soak run against the bridge emulator (what
//! `biotac-emulator --pty --fault-rate` runs) on the two ends of a real
//! pseudo-terminal pair: 100 frames a second for `--minutes` (default 30),
//! with faults injected at `--fault-rate` (default 0.001): per SPI word a
//! parity error at the source, per byte on the wire a bit flip or a dropped
//! byte. Each frame the driver decodes is checked bit for bit against the
//! one the bridge meant to send.
//!
//! Prints a table a minute: frames sent, those hit by a wire fault and by a
//! source parity fault, readings out of the driver, readings lost (sent and
//! never out: a frame dropped by the decoder, or a reading dropped by the
//! invalid-sample policy), readings lost from frames no fault hit, and
//! corrupt frames accepted; then the totals and the driver's counters
//! (docs/results.md, "Soak"). Exits 1 if a corrupt frame was accepted.
//!
//! ```text
//! cargo run --release --example serial_soak -- --minutes 30 --fault-rate 0.001
//! ```

use std::collections::VecDeque;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};
use tactile_force::biotac::driver::{Driver, DriverConfig, DriverEvent};
use tactile_force::biotac::emulator::{Emulator, EmulatorConfig};
use tactile_force::biotac::wire::{decode_frame, DecodedFrame};
use tactile_force::biotac::{BioTacSimConfig, FRAME_PERIOD_S};
use tactile_force::sim::collect::unit_seed;

/// A frame as the bridge sent it.
struct Sent {
    minute: usize,
    seq: u16,
    wire_fault: bool,
    parity_fault: bool,
    /// Its write timed out: the port did not drain (the driver fell behind).
    blocked: bool,
    /// What the driver must decode from it.
    want: Option<DecodedFrame>,
    at: Instant,
}

/// One minute's counts, by the minute the frames were sent in.
#[derive(Default, Clone, Copy)]
struct Counts {
    sent: u64,
    wire_faults: u64,
    parity_faults: u64,
    blocked: u64,
    readings: u64,
    lost: u64,
    lost_clean: u64,
    corrupt_accepted: u64,
}

fn arg(args: &[String], name: &str, default: f64) -> f64 {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// How long after its bytes went out a frame is given up as lost.
const LATE: Duration = Duration::from_secs(5);

/// Frames a minute (100 Hz).
const PER_MINUTE: u64 = 6000;

/// The bridge: `frames` frames, one every 10 ms, into the master, each
/// announced on `tx` once its bytes went out, or did not (a write that
/// times out drops the frame, as the emulator's `stream` does); gives the
/// master back, so that the port stays open until the driver has read
/// everything.
fn bridge(
    mut master: TTYPort,
    fault_rate: f64,
    frames: u64,
    tx: mpsc::Sender<Sent>,
) -> std::thread::JoinHandle<TTYPort> {
    std::thread::spawn(move || {
        let config = EmulatorConfig {
            fault_rate,
            ..EmulatorConfig::default()
        };
        let mut emu = Emulator::new(config, &BioTacSimConfig::default(), unit_seed(1));
        let period = Duration::from_secs_f64(FRAME_PERIOD_S);
        let start = Instant::now();
        for n in 1..=frames {
            let f = emu.next_frame();
            let want = decode_frame(&f.intended).ok();
            let written = std::io::Write::write_all(&mut master, &f.bytes);
            let blocked = matches!(&written, Err(e) if e.kind() == std::io::ErrorKind::TimedOut);
            if let (Err(e), false) = (&written, blocked) {
                eprintln!("bridge: {e}");
                break;
            }
            let sent = Sent {
                minute: ((n - 1) / PER_MINUTE) as usize,
                seq: f.seq,
                wire_fault: f.corrupted,
                parity_fault: want.is_some_and(|w| !w.invalid.is_empty()),
                blocked,
                want,
                at: Instant::now(),
            };
            if tx.send(sent).is_err() {
                break;
            }
            let due = start + period.mul_f64(n as f64);
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
        }
        master
    })
}

fn main() -> std::process::ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let minutes = arg(&args, "--minutes", 30.0);
    let fault_rate = arg(&args, "--fault-rate", 0.001);
    let (mut master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
    master
        .set_timeout(Duration::from_millis(100))
        .expect("timeout");
    let path = slave.name().expect("the slave has a path");
    let mut driver = Driver::new(DriverConfig::new(&path));
    // The driver opens the port before the bridge writes.
    let opened = Instant::now();
    let mut connected = false;
    while !connected && opened.elapsed() < Duration::from_secs(5) {
        driver.poll(&mut |e| connected |= matches!(e, DriverEvent::Connected { .. }));
    }
    let (tx, rx) = mpsc::channel();
    let frames = (minutes * PER_MINUTE as f64).round() as u64;
    let bridge = bridge(master, fault_rate, frames, tx);
    println!("serial driver <- emulator on {path}, fault rate {fault_rate}, {minutes} min");
    println!(
        "| min | frames sent | wire-faulted | parity-faulted | write timed out | readings out \
         | readings lost | lost without a fault | corrupt accepted |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");

    let mut counts: Vec<Counts> = Vec::new();
    let mut pending: VecDeque<Sent> = VecDeque::new();
    let (mut stale, mut reasons) = (0u64, Vec::<String>::new());
    let mut out: VecDeque<(DecodedFrame, bool, Instant)> = VecDeque::new();
    let mut late = 0u64;
    let mut printed = 0;
    let start = Instant::now();
    let lose = |s: &Sent, counts: &mut Vec<Counts>| {
        let c = &mut counts[s.minute];
        c.lost += 1;
        c.lost_clean += u64::from(!s.wire_fault && !s.parity_fault && !s.blocked);
    };
    loop {
        // Once finished, the bridge has announced every frame it sent.
        let finished = bridge.is_finished();
        driver.poll(&mut |e| match e {
            DriverEvent::Frame { frame, reading } => {
                out.push_back((frame, reading.is_some(), Instant::now()))
            }
            DriverEvent::Stale { .. } => stale += 1,
            DriverEvent::Disconnected { reason, .. } => reasons.push(reason),
            _ => {}
        });
        for s in rx.try_iter() {
            if counts.len() <= s.minute {
                counts.resize(s.minute + 1, Counts::default());
            }
            let c = &mut counts[s.minute];
            c.sent += 1;
            c.wire_faults += u64::from(s.wire_fault);
            c.parity_faults += u64::from(s.parity_fault);
            c.blocked += u64::from(s.blocked);
            pending.push_back(s);
        }
        // Frames arrive in order: those sent before one are lost. A frame
        // whose announcement has not come yet waits, with those after it.
        let announced = out
            .iter()
            .take_while(|(f, ..)| pending.iter().any(|s| s.seq == f.seq))
            .count();
        for (frame, reading, _) in out.drain(..announced) {
            while let Some(s) = pending.pop_front() {
                if s.seq == frame.seq {
                    let c = &mut counts[s.minute];
                    if s.want != Some(frame) {
                        c.corrupt_accepted += 1;
                    }
                    if reading {
                        c.readings += 1;
                    } else {
                        lose(&s, &mut counts);
                    }
                    break;
                }
                lose(&s, &mut counts);
            }
        }
        // An announcement comes microseconds after its bytes: a frame still
        // unannounced after 50 ms came after it was given up as lost (LATE).
        if out
            .front()
            .is_some_and(|(.., at)| finished || at.elapsed() > Duration::from_millis(50))
        {
            out.pop_front();
            late += 1;
        }
        // A frame not out LATE after it was sent is lost.
        while pending.front().is_some_and(|s| s.at.elapsed() > LATE) {
            let s = pending.pop_front().unwrap();
            lose(&s, &mut counts);
        }
        let done = finished && pending.is_empty() && out.is_empty();
        // A minute is complete once its frames are settled.
        let settled = if done {
            counts.len()
        } else {
            pending.front().map_or(0, |s| s.minute)
        };
        for (k, c) in counts.iter().enumerate().take(settled).skip(printed) {
            println!(
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                k + 1,
                c.sent,
                c.wire_faults,
                c.parity_faults,
                c.blocked,
                c.readings,
                c.lost,
                c.lost_clean,
                c.corrupt_accepted
            );
            printed = k + 1;
        }
        if done {
            break;
        }
    }
    let total = counts.iter().fold(Counts::default(), |a, c| Counts {
        sent: a.sent + c.sent,
        wire_faults: a.wire_faults + c.wire_faults,
        parity_faults: a.parity_faults + c.parity_faults,
        blocked: a.blocked + c.blocked,
        readings: a.readings + c.readings,
        lost: a.lost + c.lost,
        lost_clean: a.lost_clean + c.lost_clean,
        corrupt_accepted: a.corrupt_accepted + c.corrupt_accepted,
    });
    let stats = driver.stats();
    let d = stats.decoder;
    let elapsed = start.elapsed().as_secs_f64();
    println!(
        "total over {elapsed:.0} s: {} frames sent, {} with a wire fault ({:.2} %), {} with a \
         source parity fault ({:.2} %), {} whose write timed out; {} readings out, {} lost \
         ({:.2} %; {} of them from frames no fault hit), {} corrupt frames accepted",
        total.sent,
        total.wire_faults,
        100.0 * total.wire_faults as f64 / total.sent.max(1) as f64,
        total.parity_faults,
        100.0 * total.parity_faults as f64 / total.sent.max(1) as f64,
        total.blocked,
        total.readings,
        total.lost,
        100.0 * total.lost as f64 / total.sent.max(1) as f64,
        total.lost_clean,
        total.corrupt_accepted
    );
    println!(
        "driver: {} frames decoded, {} CRC errors, {} invalid words, {} frames lost by sequence \
         gaps, {} readings dropped by the invalid-sample policy, {} bytes skipped; {} stale \
         events, {} disconnects {:?}; {} frames out more than {} s after they were sent \
         (counted lost)",
        d.frames,
        d.crc_errors,
        d.parity_errors,
        d.lost.iter().sum::<u64>(),
        stats.dropped,
        d.bytes_skipped,
        stale,
        reasons.len(),
        reasons.iter().take(3).collect::<Vec<_>>(),
        late,
        LATE.as_secs()
    );
    drop((bridge.join(), slave));
    if total.corrupt_accepted > 0 {
        return std::process::ExitCode::FAILURE;
    }
    std::process::ExitCode::SUCCESS
}
