//! The BioTac driver: reads frames from a link (the serial bridge's byte
//! stream, wire format v1, [`super::wire`]; or a Cheetah SPI adapter,
//! [`super::cheetah`]), applies the invalid-sample policy and reports what
//! happens on the link. The policies below are the driver's, whatever the
//! link: a link is a [`FrameSource`] that only opens, reads frames and
//! closes.
//!
//! - **Readings** are stamped with the host's monotonic clock (seconds since
//!   the driver started).
//! - **Invalid samples.** The source sets the channels whose words are
//!   invalid to 0 and lists them ([`super::wire`], "Invalid samples");
//!   [`HoldLastGood`] then applies the policy before a reading reaches the
//!   estimator: an invalid channel takes its value from the previous frame
//!   (consecutive sequence number, channel valid there), which holds a value
//!   for at most one frame. If a channel is invalid two frames in a row, or
//!   the previous frame is missing, the reading is dropped, so the estimator
//!   never uses an invalid value as if it were good; the controller's watchdog
//!   stops the arm when readings stop. Nothing is held across a reconnect.
//! - **Link loss.** A read error (a pulled USB adapter, a closed
//!   pseudo-terminal) closes the link at once; the driver logs it and tries
//!   to reopen it with exponential back-off (`retry_initial_s`, doubling up
//!   to `retry_max_s`), then resumes.
//! - **Fatal errors** (a missing adapter library, a sensor the reading type
//!   cannot hold): one [`DriverEvent::Failed`]; the driver then stops.
//! - **Stale.** No frame for `stale_after_s` (3 sensor periods): one
//!   [`DriverEvent::Stale`], again after each recovery.
//! - **Statistics** every `stats_every_s`: frames/s and the source's counts.
//! - **Tare** on request: the next `samples` readings, refused when PDC shows
//!   contact ([`Tare::from_readings_out_of_contact`]).
//!
//! [`Driver::poll`] does one bounded step (it blocks at most ~`read_timeout_s`,
//! or one Cheetah batch, or until the next retry), so a thread or an
//! executor can own the loop.

use std::time::{Duration, Instant};

use super::tare::{Tare, TareError};
use super::wire::{
    slot, to_frame_order, ChannelMask, DecodedFrame, DecoderStats, DEFAULT_BAUD, MAX_WORDS,
    N_SENSORS,
};
use super::{BioTacReading, FRAME_PERIOD_S};

mod serial;
pub use serial::SerialSource;

/// Why a link read or open failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum LinkError {
    /// The link is gone or could not be opened: retried with back-off.
    Lost(String),
    /// Retrying cannot help (configuration, a missing library): the driver
    /// stops.
    Fatal(String),
}

/// A link that delivers decoded frames: it only moves bytes and decodes
/// them; every policy is the [`Driver`]'s.
pub trait FrameSource: Send {
    /// What the link reads from, for logs ("/dev/ttyACM0", "Cheetah port 0").
    fn name(&self) -> String;
    /// Opens the link; says what was opened.
    fn open(&mut self) -> Result<String, LinkError>;
    /// Reads what arrives within about `timeout_s` (a Cheetah: one batch)
    /// and appends the decoded frames. An error means the link is closed.
    fn read(&mut self, timeout_s: f64, frames: &mut Vec<DecodedFrame>) -> Result<(), LinkError>;
    /// Closes the link (nothing if it is not open).
    fn close(&mut self);
    /// What the link has seen since it was made.
    fn stats(&self) -> DecoderStats;
}

/// Driver settings.
#[derive(Debug, Clone, PartialEq)]
pub struct DriverConfig {
    /// Serial device path.
    pub port: String,
    /// Baud rate (default 230400: two sensors, docs/serial-protocol.md).
    pub baud: u32,
    /// Longest wait in one read (s).
    pub read_timeout_s: f64,
    /// Silence after which the sensor is stale (s): 3 frame periods.
    pub stale_after_s: f64,
    /// First wait before reopening a lost port (s).
    pub retry_initial_s: f64,
    /// Longest wait between reopening attempts (s).
    pub retry_max_s: f64,
    /// Period of the statistics events (s).
    pub stats_every_s: f64,
    /// PDC change that refuses a tare (counts): ~0.1 N at light touch
    /// (config/guarded_move.yaml, contact_pdc_counts).
    pub tare_pdc_limit: f64,
}

impl DriverConfig {
    /// Defaults for the device at `port`.
    pub fn new(port: impl Into<String>) -> Self {
        DriverConfig {
            port: port.into(),
            baud: DEFAULT_BAUD,
            read_timeout_s: 0.002,
            stale_after_s: 3.0 * FRAME_PERIOD_S,
            retry_initial_s: 0.05,
            retry_max_s: 0.25,
            stats_every_s: 1.0,
            tare_pdc_limit: 30.0,
        }
    }
}

/// Link statistics since the driver started.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkStats {
    /// Frames per second over the last statistics period.
    pub frames_per_s: f64,
    /// The source's counters (the serial decoder's; a Cheetah's frames,
    /// invalid words and lost batches).
    pub decoder: DecoderStats,
    /// Readings dropped by the invalid-sample policy.
    pub dropped: u64,
    /// Times the link was lost.
    pub disconnects: u64,
}

/// What the driver reports.
#[derive(Debug, Clone, PartialEq)]
pub enum DriverEvent {
    /// The link is open.
    Connected {
        /// What was opened (the device path; the Cheetah adapter and its
        /// BioTacs).
        port: String,
    },
    /// The link was lost or could not be opened; the driver retries.
    Disconnected {
        /// The error.
        reason: String,
        /// Seconds until the next attempt.
        retry_in_s: f64,
    },
    /// A frame decoded.
    Frame {
        /// The frame as decoded (invalid channels zeroed and listed).
        frame: DecodedFrame,
        /// The reading after the invalid-sample policy, stamped; None when
        /// it was dropped.
        reading: Option<BioTacReading>,
    },
    /// No frame for `stale_after_s`.
    Stale {
        /// Seconds since the last frame.
        silent_s: f64,
    },
    /// Periodic link statistics.
    Stats(LinkStats),
    /// A requested tare was taken.
    Tared(Tare),
    /// A requested tare was refused.
    TareRefused(TareError),
    /// A fatal error: the driver stopped.
    Failed {
        /// The error.
        reason: String,
    },
}

/// A tare being collected.
#[derive(Debug, Clone)]
struct TareRequest {
    samples: usize,
    readings: Vec<BioTacReading>,
}

/// The driver: a link's frames through the policies (module documentation).
pub struct Driver {
    config: DriverConfig,
    source: Box<dyn FrameSource>,
    open: bool,
    failed: bool,
    hold: HoldLastGood,
    start: Instant,
    last_frame: Option<Instant>,
    stale: bool,
    retry_at: Instant,
    backoff_s: f64,
    stats_at: Instant,
    frames_at_stats: u64,
    dropped: u64,
    disconnects: u64,
    tare: Option<TareRequest>,
    last_tare: Option<Tare>,
    frames: Vec<DecodedFrame>,
}

impl Driver {
    /// A driver of the serial bridge at `config.port`; the port opens on the
    /// first [`Driver::poll`].
    pub fn new(config: DriverConfig) -> Self {
        let source = SerialSource::new(&config);
        Driver::with_source(config, Box::new(source))
    }

    /// A driver of any link (`config.port` and `config.baud` unused); the
    /// link opens on the first [`Driver::poll`].
    pub fn with_source(config: DriverConfig, source: Box<dyn FrameSource>) -> Self {
        let now = Instant::now();
        Driver {
            backoff_s: config.retry_initial_s,
            stats_at: now + secs(config.stats_every_s),
            config,
            source,
            open: false,
            failed: false,
            hold: HoldLastGood::new(),
            start: now,
            last_frame: None,
            stale: false,
            retry_at: now,
            frames_at_stats: 0,
            dropped: 0,
            disconnects: 0,
            tare: None,
            last_tare: None,
            frames: Vec::with_capacity(64),
        }
    }

    /// Seconds since the driver started: the clock of the readings' stamps.
    pub fn now_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// Whether a fatal error stopped the driver.
    pub fn failed(&self) -> bool {
        self.failed
    }

    /// The link statistics so far (frames/s not measured: 0).
    pub fn stats(&self) -> LinkStats {
        LinkStats {
            frames_per_s: 0.0,
            decoder: self.source.stats(),
            dropped: self.dropped,
            disconnects: self.disconnects,
        }
    }

    /// Asks for a tare from the next `samples` readings (at least 1).
    pub fn request_tare(&mut self, samples: usize) {
        let samples = samples.max(1);
        self.tare = Some(TareRequest {
            samples,
            readings: Vec::with_capacity(samples),
        });
    }

    /// One step: open the link if due, read what arrives within the read
    /// timeout, apply the policies, and report.
    pub fn poll(&mut self, on_event: &mut dyn FnMut(DriverEvent)) {
        let now = Instant::now();
        if self.failed {
            std::thread::sleep(secs(self.config.read_timeout_s));
            return;
        }
        match self.open {
            false if now >= self.retry_at => self.open(now, on_event),
            false => {
                std::thread::sleep((self.retry_at - now).min(secs(self.config.read_timeout_s)))
            }
            true => self.read(on_event),
        }
        let now = Instant::now();
        if let Some(last) = self.last_frame {
            let silent = now - last;
            if !self.stale && silent.as_secs_f64() > self.config.stale_after_s {
                self.stale = true;
                on_event(DriverEvent::Stale {
                    silent_s: silent.as_secs_f64(),
                });
            }
        }
        if now >= self.stats_at {
            let frames = self.source.stats().frames;
            let period = self.config.stats_every_s;
            on_event(DriverEvent::Stats(LinkStats {
                frames_per_s: frames.saturating_sub(self.frames_at_stats) as f64 / period,
                ..self.stats()
            }));
            self.frames_at_stats = frames;
            self.stats_at = now + secs(period);
        }
    }

    fn open(&mut self, now: Instant, on_event: &mut dyn FnMut(DriverEvent)) {
        let name = self.source.name();
        match self.source.open() {
            Ok(port) => {
                tracing::info!(link = %name, opened = %port, "BioTac link open");
                self.open = true;
                self.hold = HoldLastGood::new();
                self.backoff_s = self.config.retry_initial_s;
                on_event(DriverEvent::Connected { port });
            }
            Err(LinkError::Lost(e)) => {
                let retry_in_s = self.backoff_s;
                tracing::warn!(link = %name, error = %e, retry_in_s, "cannot open the BioTac link");
                self.retry_at = now + secs(retry_in_s);
                self.backoff_s = (self.backoff_s * 2.0).min(self.config.retry_max_s);
                on_event(DriverEvent::Disconnected {
                    reason: format!("{name}: {e}"),
                    retry_in_s,
                });
            }
            Err(LinkError::Fatal(e)) => self.fail(e, on_event),
        }
    }

    fn fail(&mut self, reason: String, on_event: &mut dyn FnMut(DriverEvent)) {
        tracing::error!(link = %self.source.name(), error = %reason, "BioTac driver stopped");
        self.source.close();
        self.open = false;
        self.failed = true;
        on_event(DriverEvent::Failed { reason });
    }

    fn read(&mut self, on_event: &mut dyn FnMut(DriverEvent)) {
        let mut decoded = std::mem::take(&mut self.frames);
        let result = self.source.read(self.config.read_timeout_s, &mut decoded);
        let stamp_s = self.start.elapsed().as_secs_f64();
        for frame in decoded.drain(..) {
            self.last_frame = Some(Instant::now());
            self.stale = false;
            let reading = self.hold.apply(&frame).map(|mut r| {
                r.stamp_s = stamp_s;
                r
            });
            match &reading {
                Some(r) => self.collect_tare(r, on_event),
                None => self.dropped += 1,
            }
            on_event(DriverEvent::Frame { frame, reading });
        }
        self.frames = decoded;
        match result {
            Ok(()) => {}
            Err(LinkError::Lost(e)) => {
                self.source.close();
                self.open = false;
                self.disconnects += 1;
                let retry_in_s = self.config.retry_initial_s;
                let name = self.source.name();
                tracing::warn!(link = %name, error = %e, "BioTac link lost");
                self.retry_at = Instant::now() + secs(retry_in_s);
                self.backoff_s = (retry_in_s * 2.0).min(self.config.retry_max_s);
                on_event(DriverEvent::Disconnected {
                    reason: format!("{name}: {e}"),
                    retry_in_s,
                });
            }
            Err(LinkError::Fatal(e)) => self.fail(e, on_event),
        }
    }

    fn collect_tare(&mut self, r: &BioTacReading, on_event: &mut dyn FnMut(DriverEvent)) {
        let Some(req) = &mut self.tare else {
            return;
        };
        req.readings.push(*r);
        if req.readings.len() < req.samples {
            return;
        }
        let limit = self.config.tare_pdc_limit;
        match Tare::from_readings_out_of_contact(&req.readings, limit, self.last_tare.as_ref()) {
            Ok(t) => {
                self.last_tare = Some(t.clone());
                on_event(DriverEvent::Tared(t));
            }
            Err(e) => on_event(DriverEvent::TareRefused(e)),
        }
        self.tare = None;
    }
}

fn secs(s: f64) -> Duration {
    Duration::from_secs_f64(s.max(0.0))
}

/// The invalid-sample policy (module documentation, "Invalid samples"): an
/// invalid channel takes the value of the sensor's previous frame for at
/// most one frame, otherwise the reading is dropped. One instance serves all
/// sensors of a bridge.
#[derive(Debug, Clone, Default)]
pub struct HoldLastGood {
    /// The previous frame per sensor, its held values filled in.
    previous: [Option<Previous>; N_SENSORS],
}

/// What [`HoldLastGood`] keeps of a frame.
#[derive(Debug, Clone, Copy)]
struct Previous {
    seq: u16,
    /// Values in frame order (invalid channels as received: 0).
    values: [u16; MAX_WORDS],
    invalid: ChannelMask,
}

impl HoldLastGood {
    /// A policy that has seen no frame.
    pub fn new() -> Self {
        HoldLastGood::default()
    }

    /// The frame's reading with invalid channels held from the previous
    /// frame, or `None` if a channel cannot be held (invalid in the previous
    /// frame too, no previous frame, a sequence gap, or a sensor index past
    /// the bridge's sensors).
    pub fn apply(&mut self, frame: &DecodedFrame) -> Option<BioTacReading> {
        let stored = self.previous.get_mut(usize::from(frame.sensor))?;
        let previous = stored.filter(|p| p.seq.wrapping_add(1) == frame.seq);
        let usable = frame.invalid.is_empty()
            || previous.is_some_and(|p| p.invalid.intersection(frame.invalid).is_empty());
        let mut reading = frame.reading;
        if let (true, Some(p)) = (usable, previous) {
            for position in frame.invalid.positions() {
                if let (Some(dst), Some(&value)) =
                    (slot(&mut reading, position), p.values.get(position))
                {
                    *dst = value;
                }
            }
        }
        *stored = Some(Previous {
            seq: frame.seq,
            values: to_frame_order(&reading),
            invalid: frame.invalid,
        });
        usable.then_some(reading)
    }
}

#[cfg(test)]
mod tests;
