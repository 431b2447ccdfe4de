//! The Cheetah backend's soak run against the test double of Total Phase's
//! library (tests/cheetah_double, built here with `cc`): three BioTacs at
//! 100 Hz (or, with `--electrodes 24`, three BioTac SPs at 81.5 Hz) for
//! `--duration-s` seconds (default 600), every reading checked bit for bit
//! against what the double sent, with faults injected on a fixed schedule:
//!
//! - a parity error in every 997th response word, all along;
//! - each minute at 20 s: the adapter unplugged for 2 s, then plugged back
//!   (the time from replugging to the next reading is measured);
//! - each minute at 40 s: the BioTac at board position 1 gone for 3 s.
//!
//! Prints the figures (docs/results.md quotes them) and exits 1 if a value
//! differed from what the double sent, a fault went uncounted or a
//! reconnect took 1 s or more.
//!
//! ```text
//! cargo run --release --example cheetah_soak -- --duration-s 600 [--electrodes 24]
//! ```

#[path = "../tests/cheetah_double/mod.rs"]
mod cheetah_double;

use std::time::{Duration, Instant};

use cheetah_double::{Checker, Double};
use tactile_force::biotac::cheetah::{AdapterId, CheetahConfig, CheetahSource};
use tactile_force::biotac::driver::DriverEvent;
use tactile_force::biotac::spi::SensorModel;

const PARITY_EVERY: i64 = 997;
const UNPLUG_AT_S: f64 = 20.0;
const UNPLUG_FOR_S: f64 = 2.0;
const MISSING_AT_S: f64 = 40.0;
const MISSING_FOR_S: f64 = 3.0;

fn main() -> std::process::ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| {
        let at = args.iter().position(|a| a == name)?;
        args.get(at + 1)?.parse::<f64>().ok()
    };
    let duration_s = arg("--duration-s").unwrap_or(600.0);
    let electrodes = arg("--electrodes").unwrap_or(19.0) as usize;
    let Some(model) = SensorModel::from_electrodes(electrodes) else {
        eprintln!("--electrodes {electrodes}: a BioTac has 19, a BioTac SP 24");
        return std::process::ExitCode::from(2);
    };
    let dir = std::env::temp_dir().join(format!("cheetah-soak-{}", std::process::id()));
    let double = match Double::build(&dir) {
        Ok(d) => d,
        Err(e) => {
            eprintln!("cannot build the Cheetah double: {e}");
            return std::process::ExitCode::FAILURE;
        }
    };
    let config = CheetahConfig {
        library: Some(double.path().to_path_buf()),
        model,
        ..CheetahConfig::new(AdapterId::Port(0))
    };
    let mut driver = CheetahSource::new(config).into_driver();
    double.control("electrodes", electrodes as i64);
    double.control("parity_every", PARITY_EVERY);

    let mut checker = Checker::default();
    let mut reconnects: Vec<Duration> = Vec::new();
    let mut replugged_at: Option<Instant> = None;
    let (mut unplugged, mut missing) = (false, false);
    let (mut disconnect_events, mut stale_events, mut failed) = (0u64, 0u64, None);
    let mut connected_s = 0.0;
    let mut connected_since: Option<Instant> = None;
    let start = Instant::now();
    while start.elapsed().as_secs_f64() < duration_s && failed.is_none() {
        let t = start.elapsed().as_secs_f64();
        let in_minute = t % 60.0;
        let want_unplugged = (UNPLUG_AT_S..UNPLUG_AT_S + UNPLUG_FOR_S).contains(&in_minute);
        if want_unplugged != unplugged {
            unplugged = want_unplugged;
            double.control("plugged", i64::from(!unplugged));
            if !unplugged {
                replugged_at = Some(Instant::now());
            }
        }
        let want_missing = (MISSING_AT_S..MISSING_AT_S + MISSING_FOR_S).contains(&in_minute);
        if want_missing != missing {
            missing = want_missing;
            double.control("missing", if missing { 0b010 } else { 0 });
        }
        driver.poll(&mut |e| match e {
            DriverEvent::Frame { frame, reading } => {
                if reading.is_some() {
                    if let Some(at) = replugged_at.take() {
                        reconnects.push(at.elapsed());
                    }
                }
                checker.check(&frame, reading.as_ref());
            }
            DriverEvent::Connected { .. } => {
                checker.reconnected();
                connected_since = Some(Instant::now());
            }
            DriverEvent::Disconnected { .. } => {
                disconnect_events += 1;
                if let Some(since) = connected_since.take() {
                    connected_s += since.elapsed().as_secs_f64();
                }
            }
            DriverEvent::Stale { .. } => stale_events += 1,
            DriverEvent::Failed { reason } => failed = Some(reason),
            _ => {}
        });
    }
    if let Some(since) = connected_since {
        connected_s += since.elapsed().as_secs_f64();
    }
    let elapsed = start.elapsed().as_secs_f64();
    let stats = driver.stats();
    let injected = double.stat("parity_injected") as u64;
    let sensors = checker.sensors;
    let mismatches: u64 = sensors.iter().map(|t| t.mismatches).sum();
    let invalid: u64 = sensors.iter().map(|t| t.invalid).sum();
    let dropped: u64 = sensors.iter().map(|t| t.dropped).sum();
    let max_reconnect = reconnects.iter().max().copied().unwrap_or_default();
    let mean_reconnect =
        reconnects.iter().map(Duration::as_secs_f64).sum::<f64>() / reconnects.len().max(1) as f64;

    let sensor = match model {
        SensorModel::BioTac => "BioTacs",
        SensorModel::BioTacSp => "BioTac SPs",
    };
    println!("Cheetah double, 3 {sensor}, {elapsed:.1} s ({connected_s:.1} s connected)");
    for (s, t) in sensors.iter().enumerate() {
        println!(
            "  sensor {s}: {} frames ({:.2} per connected second), {} readings, {} dropped, \
             {} invalid words, {} values held, {} values differing, {} frame-number gaps",
            t.frames,
            t.frames as f64 / connected_s.max(1e-9),
            t.readings,
            t.dropped,
            t.invalid,
            t.held,
            t.mismatches,
            t.gaps
        );
    }
    println!(
        "  parity faults: {injected} injected, {} counted by the driver, {invalid} seen in frames",
        stats.decoder.parity_errors
    );
    println!(
        "  invalid words beyond the injected parity faults: {} (sensor 1's {} per frame while \
         it was gone)",
        invalid.saturating_sub(injected),
        model.frame_words()
    );
    println!(
        "  readings dropped: {dropped} (driver's count {})",
        stats.dropped
    );
    println!(
        "  unplugs: {} link losses counted, {disconnect_events} disconnect events, \
         {stale_events} stale events; reconnects {}, replug -> next reading mean {:.3} s, max {:.3} s",
        stats.disconnects,
        reconnects.len(),
        mean_reconnect,
        max_reconnect.as_secs_f64()
    );
    let out_of_order = double.stat("out_of_order");
    println!("  sampling commands out of the sensor's default order: {out_of_order}");
    let ok = failed.is_none()
        && mismatches == 0
        && out_of_order == 0
        && stats.decoder.parity_errors == invalid
        && dropped == stats.dropped
        && max_reconnect < Duration::from_secs(1);
    println!(
        "{}",
        serde_json::json!({
            "electrodes": electrodes,
            "duration_s": elapsed,
            "connected_s": connected_s,
            "frames": sensors.iter().map(|t| t.frames).collect::<Vec<_>>(),
            "readings": sensors.iter().map(|t| t.readings).collect::<Vec<_>>(),
            "dropped": dropped,
            "held": sensors.iter().map(|t| t.held).sum::<u64>(),
            "mismatches": mismatches,
            "parity_injected": injected,
            "invalid_counted": stats.decoder.parity_errors,
            "disconnects": stats.disconnects,
            "reconnect_max_s": max_reconnect.as_secs_f64(),
            "reconnect_mean_s": mean_reconnect,
            "failed": failed,
            "ok": ok,
        })
    );
    let _ = std::fs::remove_dir_all(&dir);
    if ok {
        std::process::ExitCode::SUCCESS
    } else {
        std::process::ExitCode::FAILURE
    }
}
