//! `biotac-emulator` and `biotac-monitor`: a bridge emulator that writes
//! frames to a serial port, and a live view of what a serial port or a
//! Cheetah SPI adapter (`--cheetah`) receives.

use std::io::Write;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use serialport::{SerialPort, TTYPort};

use tactile_force::biotac::cheetah::{CheetahConfig, CheetahSource};
use tactile_force::biotac::driver::{Driver, DriverConfig, DriverEvent, LinkStats};
use tactile_force::biotac::emulator::{stream, Emulator, EmulatorConfig};
use tactile_force::biotac::wire::{DecodedFrame, DEFAULT_BAUD};
use tactile_force::biotac::BioTacSimConfig;
use tactile_force::sim::collect::unit_seed;

use super::{BadArgument, Context, Failure, Result};

#[derive(Args)]
pub struct EmulatorArgs {
    /// Serial port to write to (e.g. one end of `socat -d -d pty,raw,echo=0 pty,raw,echo=0`).
    #[arg(long, required_unless_present = "pty", conflicts_with = "pty")]
    port: Option<String>,
    /// Create a pseudo-terminal and print the path a driver should open.
    #[arg(long)]
    pty: bool,
    /// Baud rate.
    #[arg(long, default_value_t = DEFAULT_BAUD)]
    baud: u32,
    /// Fault probability per SPI word (parity error) and per byte (bit flip or drop).
    #[arg(long, default_value_t = 0.0)]
    fault_rate: f64,
    /// The simulated sensor unit, numbered as `collect --unit` numbers them.
    #[arg(long, default_value_t = 1)]
    unit: u64,
    /// Seed of the noise and of the faults.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Sensor index written in the frames (0..=2).
    #[arg(long, default_value_t = 0)]
    sensor: u8,
    /// Peak force of the simulated press cycle (N; 0: never touched).
    #[arg(long, default_value_t = 3.0)]
    press_peak_n: f64,
    /// Stop after this many frames (default: run until interrupted).
    #[arg(long)]
    frames: Option<u64>,
}

#[derive(Args)]
pub struct MonitorArgs {
    /// Serial port of the BioTac bridge.
    #[arg(long, required_unless_present = "cheetah", conflicts_with = "cheetah")]
    port: Option<String>,
    /// Read a multi-BioTac board through a Total Phase Cheetah adapter: its
    /// port number (0, 1, ...) or serial number (1364-123456).
    #[arg(long, value_name = "ADAPTER")]
    cheetah: Option<String>,
    /// Total Phase's Cheetah library (cheetah.so), or its directory
    /// (default: searched in LD_LIBRARY_PATH, next to the executable, in
    /// the current directory).
    #[arg(long, value_name = "PATH", requires = "cheetah")]
    cheetah_lib: Option<std::path::PathBuf>,
    /// Board positions to sample, e.g. 0,2 (default: every BioTac that
    /// answers).
    #[arg(long, value_delimiter = ',', requires = "cheetah")]
    sensors: Option<Vec<u8>>,
    /// Electrodes of the BioTacs on the board: 19 (BioTac) or 24 (BioTac SP).
    #[arg(long, default_value_t = 19, requires = "cheetah")]
    electrodes: usize,
    /// Baud rate.
    #[arg(long, default_value_t = DEFAULT_BAUD)]
    baud: u32,
    /// Stop after this many decoded frames (default: run until interrupted).
    #[arg(long)]
    frames: Option<u64>,
    /// Print each decoded frame as a JSON line, then the link statistics.
    #[arg(long, requires = "frames")]
    jsonl: bool,
    /// Give up when no frame arrives for this long (s).
    #[arg(long, default_value_t = 10.0)]
    timeout_s: f64,
}

pub fn run_emulator(a: EmulatorArgs) -> Result<()> {
    if !(0.0..=1.0).contains(&a.fault_rate) {
        let msg = format!(
            "--fault-rate {}: expected a probability in 0..=1",
            a.fault_rate
        );
        return Err(BadArgument(msg).into());
    }
    if a.sensor > 2 {
        let msg = format!(
            "--sensor {}: the wire format carries sensors 0..=2",
            a.sensor
        );
        return Err(BadArgument(msg).into());
    }
    let config = EmulatorConfig {
        sensor: a.sensor,
        fault_rate: a.fault_rate,
        seed: a.seed,
        press_peak_n: a.press_peak_n,
        ..EmulatorConfig::default()
    };
    let mut emulator = Emulator::new(config, &BioTacSimConfig::default(), unit_seed(a.unit));
    // The slave end of a created pty stays open so the pair lives.
    let (mut port, _slave): (Box<dyn SerialPort>, Option<TTYPort>) = match &a.port {
        Some(path) => {
            let port = serialport::new(path, a.baud)
                .timeout(Duration::from_millis(100))
                .open()
                .with_context(|| format!("opening {path}"))?;
            (port, None)
        }
        None => {
            let (mut master, slave) = TTYPort::pair().context("creating a pseudo-terminal")?;
            master.set_timeout(Duration::from_millis(100))?;
            let path = slave.name().unwrap_or_default();
            println!("emulating a BioTac bridge on {path}");
            std::io::stdout().flush()?;
            (Box::new(master), Some(slave))
        }
    };
    let period = Duration::from_secs_f64(tactile_force::biotac::FRAME_PERIOD_S);
    let sent = stream(
        &mut emulator,
        &mut port,
        period,
        a.frames,
        &AtomicBool::new(false),
    )
    .context("writing to the port")?;
    eprintln!("sent {sent} frames");
    Ok(())
}

/// The driver the arguments ask for, and what it reads.
fn monitor_driver(a: &MonitorArgs) -> Result<(Driver, String)> {
    let Some(adapter) = &a.cheetah else {
        let port = a.port.clone().unwrap_or_default();
        let mut config = DriverConfig::new(port.clone());
        config.baud = a.baud;
        return Ok((Driver::new(config), port));
    };
    let library = a.cheetah_lib.as_deref().unwrap_or(std::path::Path::new(""));
    let config = CheetahConfig::from_settings(
        adapter,
        &library.to_string_lossy(),
        a.sensors.as_deref().unwrap_or_default(),
        a.electrodes,
    )?;
    let adapter = config.adapter;
    let source = CheetahSource::new(config);
    let name = format!("the Cheetah adapter at {adapter}");
    Ok((source.into_driver(), name))
}

pub fn run_monitor(a: MonitorArgs) -> Result<()> {
    let (mut driver, link) = monitor_driver(&a)?;
    let view = (!a.jsonl).then(live_view);
    let mut shown = 0u64;
    let mut last_frame = Instant::now();
    let mut last_problem = String::from("no frame yet");
    let mut stats = driver.stats();
    let mut out = std::io::stdout().lock();
    while a.frames.is_none_or(|n| shown < n) {
        let mut error = None;
        let mut fatal = None;
        driver.poll(&mut |e| match e {
            DriverEvent::Frame { frame, .. } => {
                shown += 1;
                last_frame = Instant::now();
                match &view {
                    Some(bar) => show_frame(bar, &frame, &stats),
                    None => {
                        if a.frames.is_some_and(|n| shown <= n) {
                            error = writeln!(out, "{}", frame_json(&frame)).err();
                        }
                    }
                }
            }
            DriverEvent::Stats(s) => stats = s,
            DriverEvent::Disconnected { reason, .. } => last_problem = reason,
            DriverEvent::Stale { silent_s } => {
                last_problem = format!("no frame for {silent_s:.3} s (stale)");
            }
            DriverEvent::Failed { reason } => fatal = Some(reason),
            _ => {}
        });
        if let Some(e) = error {
            return Err(e.into());
        }
        if let Some(reason) = fatal {
            return Err(BadArgument(reason).into());
        }
        if last_frame.elapsed().as_secs_f64() > a.timeout_s {
            return Err(Failure::failed(format!(
                "no frame from {link} for {} s: {last_problem}",
                a.timeout_s
            )));
        }
    }
    let s = driver.stats().decoder;
    let json = serde_json::json!({"stats": {
        "frames": s.frames,
        "crc_errors": s.crc_errors,
        "parity_errors": s.parity_errors,
        "lost": s.lost.iter().sum::<u64>(),
        "dropped": driver.stats().dropped,
        "disconnects": driver.stats().disconnects,
    }});
    writeln!(out, "{json}")?;
    Ok(())
}

fn frame_json(f: &DecodedFrame) -> serde_json::Value {
    let r = &f.reading;
    serde_json::json!({
        "sensor": f.sensor,
        "seq": f.seq,
        "electrodes": r.electrodes,
        "pdc": r.pdc,
        "pac": r.pac,
        "tdc": r.tdc,
        "tac": r.tac,
        "invalid": f.invalid_names().collect::<Vec<_>>(),
    })
}

fn live_view() -> ProgressBar {
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{msg}").unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar
}

fn show_frame(bar: &ProgressBar, f: &DecodedFrame, s: &LinkStats) {
    // Ten refreshes per second of frames are enough to read.
    if !f.seq.is_multiple_of(10) {
        return;
    }
    let r = &f.reading;
    // Every electrode, ten to a row (E1-E10, E11-E19 or E11-E20, E21-E24).
    let n = r.electrodes.len();
    let electrodes: String = r
        .electrodes
        .chunks(10)
        .enumerate()
        .map(|(i, row)| {
            let span = format!("E{}-E{}", 10 * i + 1, (10 * i + 10).min(n));
            let values: String = row.iter().map(|v| format!("{v:5}")).collect();
            format!("{span:7}{values}\n")
        })
        .collect();
    let invalid: Vec<String> = f.invalid_names().collect();
    bar.set_message(format!(
        "sensor {} seq {:5}\n{electrodes}PDC {:5}  TDC {:5}  TAC {:5}  PAC mean {:6.1} ({} samples)  \
         invalid: {}\n\
         link: {:.0} frames/s, {} CRC errors, {} invalid samples, {} lost, {} dropped",
        f.sensor,
        f.seq,
        r.pdc,
        r.tdc,
        r.tac,
        r.pac_mean(),
        r.pac.len(),
        if invalid.is_empty() {
            "none".into()
        } else {
            invalid.join(",")
        },
        s.frames_per_s,
        s.decoder.crc_errors,
        s.decoder.parity_errors,
        s.decoder.lost.iter().sum::<u64>(),
        s.dropped,
    ));
}
