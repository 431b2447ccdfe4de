//! The serial driver: reads a BioTac bridge's byte stream (wire format v1,
//! [`super::wire`]), decodes it, applies the invalid-sample policy and
//! reports what happens on the link.
//!
//! - **Readings** are stamped with the host's monotonic clock (seconds since
//!   the driver started).
//! - **Invalid samples.** The decoder sets the channels whose words are
//!   invalid to 0 and lists them ([`super::wire`], "Invalid samples");
//!   [`HoldLastGood`] then applies the policy before a reading reaches the
//!   estimator: an invalid channel takes its value from the previous frame
//!   (consecutive sequence number, channel valid there), which holds a value
//!   for at most one frame. If a channel is invalid two frames in a row, or
//!   the previous frame is missing, the reading is dropped, so the estimator
//!   never uses an invalid value as if it were good; the controller's watchdog
//!   stops the arm when readings stop.
//! - **Port loss.** A read error (a pulled USB adapter, a closed
//!   pseudo-terminal) closes the port at once; the driver logs it and tries
//!   to reopen the same path with exponential back-off
//!   (`retry_initial_s`, doubling up to `retry_max_s`), then resumes.
//! - **Stale.** No frame for `stale_after_s` (3 sensor periods): one
//!   [`DriverEvent::Stale`], again after each recovery.
//! - **Statistics** every `stats_every_s`: frames/s and the decoder's counts.
//! - **Tare** on request: the next `samples` readings, refused when PDC shows
//!   contact ([`Tare::from_readings_out_of_contact`]).
//!
//! [`Driver::poll`] does one bounded step (it blocks at most ~`read_timeout_s`
//! or until the next retry), so a thread or an executor can own the loop.

use std::io::Read;
use std::time::{Duration, Instant};

use serialport::SerialPort;

use super::tare::{Tare, TareError};
use super::wire::{
    slot, to_frame_order, ChannelMask, DecodedFrame, Decoder, DecoderStats, DEFAULT_BAUD,
    N_SENSORS, N_WORDS,
};
use super::{BioTacReading, FRAME_PERIOD_S};

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
    /// The decoder's counters.
    pub decoder: DecoderStats,
    /// Readings dropped by the invalid-sample policy.
    pub dropped: u64,
    /// Times the port was lost.
    pub disconnects: u64,
}

/// What the driver reports.
#[derive(Debug, Clone, PartialEq)]
pub enum DriverEvent {
    /// The port is open.
    Connected {
        /// Device path.
        port: String,
    },
    /// The port was lost or could not be opened; the driver retries.
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
}

/// A tare being collected.
#[derive(Debug, Clone)]
struct TareRequest {
    samples: usize,
    readings: Vec<BioTacReading>,
}

/// The serial driver.
pub struct Driver {
    config: DriverConfig,
    port: Option<Box<dyn SerialPort>>,
    decoder: Decoder,
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
    buf: Vec<u8>,
    frames: Vec<DecodedFrame>,
}

impl Driver {
    /// A driver for `config`; the port opens on the first [`Driver::poll`].
    pub fn new(config: DriverConfig) -> Self {
        let now = Instant::now();
        Driver {
            backoff_s: config.retry_initial_s,
            stats_at: now + secs(config.stats_every_s),
            config,
            port: None,
            decoder: Decoder::new(),
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
            buf: vec![0; 4096],
            frames: Vec::with_capacity(64),
        }
    }

    /// Seconds since the driver started: the clock of the readings' stamps.
    pub fn now_s(&self) -> f64 {
        self.start.elapsed().as_secs_f64()
    }

    /// The link statistics so far (frames/s not measured: 0).
    pub fn stats(&self) -> LinkStats {
        LinkStats {
            frames_per_s: 0.0,
            decoder: self.decoder.stats(),
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

    /// One step: open the port if due, read what arrives within the read
    /// timeout, decode it, and report.
    pub fn poll(&mut self, on_event: &mut dyn FnMut(DriverEvent)) {
        let now = Instant::now();
        match self.port.take() {
            None if now >= self.retry_at => self.open(now, on_event),
            None => std::thread::sleep((self.retry_at - now).min(secs(self.config.read_timeout_s))),
            Some(port) => self.read(port, on_event),
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
            let frames = self.decoder.stats().frames;
            let period = self.config.stats_every_s;
            on_event(DriverEvent::Stats(LinkStats {
                frames_per_s: (frames - self.frames_at_stats) as f64 / period,
                ..self.stats()
            }));
            self.frames_at_stats = frames;
            self.stats_at = now + secs(period);
        }
    }

    fn open(&mut self, now: Instant, on_event: &mut dyn FnMut(DriverEvent)) {
        let c = &self.config;
        match serialport::new(c.port.as_str(), c.baud)
            .timeout(secs(c.read_timeout_s))
            .open()
        {
            Ok(port) => {
                tracing::info!(port = %c.port, baud = c.baud, "BioTac port open");
                self.port = Some(port);
                self.backoff_s = c.retry_initial_s;
                on_event(DriverEvent::Connected {
                    port: c.port.clone(),
                });
            }
            Err(e) => {
                let retry_in_s = self.backoff_s;
                tracing::warn!(port = %c.port, error = %e, retry_in_s, "cannot open the BioTac port");
                self.retry_at = now + secs(retry_in_s);
                self.backoff_s = (self.backoff_s * 2.0).min(c.retry_max_s);
                on_event(DriverEvent::Disconnected {
                    reason: format!("{}: {e}", c.port),
                    retry_in_s,
                });
            }
        }
    }

    fn read(&mut self, mut port: Box<dyn SerialPort>, on_event: &mut dyn FnMut(DriverEvent)) {
        let n = match port.read(&mut self.buf) {
            Ok(0) => Err(std::io::Error::new(
                std::io::ErrorKind::UnexpectedEof,
                "end of stream",
            )),
            Ok(n) => Ok(n),
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => Ok(0),
            Err(e) => Err(e),
        };
        let n = match n {
            Ok(n) => n,
            Err(e) => {
                self.disconnects += 1;
                let retry_in_s = self.config.retry_initial_s;
                tracing::warn!(port = %self.config.port, error = %e, "BioTac port lost");
                self.retry_at = Instant::now() + secs(retry_in_s);
                self.backoff_s = (retry_in_s * 2.0).min(self.config.retry_max_s);
                on_event(DriverEvent::Disconnected {
                    reason: format!("{}: {e}", self.config.port),
                    retry_in_s,
                });
                return;
            }
        };
        self.port = Some(port);
        let stamp_s = self.start.elapsed().as_secs_f64();
        let frames = &mut self.frames;
        self.decoder.push(&self.buf[..n], |f| frames.push(f));
        let mut decoded = std::mem::take(&mut self.frames);
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
    values: [u16; N_WORDS],
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
mod tests {
    use super::*;
    use crate::biotac::wire::tests::reading;

    /// A decoded frame of `reading(offset)` with the given invalid channels
    /// (zeroed, as the decoder leaves them).
    fn frame_with_invalid(sensor: u8, seq: u16, offset: u16, invalid: &[usize]) -> DecodedFrame {
        let mut frame = DecodedFrame {
            sensor,
            seq,
            bridge_us: 0,
            reading: BioTacReading {
                seq,
                ..reading(offset)
            },
            invalid: ChannelMask::default(),
        };
        for &position in invalid {
            frame.invalid.insert(position);
            if let Some(v) = slot(&mut frame.reading, position) {
                *v = 0;
            }
        }
        frame
    }

    #[test]
    fn hold_passes_valid_readings_through() {
        let mut hold = HoldLastGood::new();
        let frame = frame_with_invalid(0, 1, 0, &[]);
        assert_eq!(hold.apply(&frame), Some(frame.reading));
    }

    #[test]
    fn hold_fills_one_invalid_frame_from_the_previous_one() {
        let mut hold = HoldLastGood::new();
        hold.apply(&frame_with_invalid(0, 1, 0, &[]));
        let held = hold.apply(&frame_with_invalid(0, 2, 5, &[12, 38])).unwrap();
        assert_eq!(held.electrodes[6], reading(0).electrodes[6]);
        assert_eq!(held.pdc, reading(0).pdc);
        assert_eq!(held.electrodes[5], reading(5).electrodes[5]);
        assert_eq!(held.seq, 2);
    }

    #[test]
    fn hold_drops_a_channel_invalid_twice_in_a_row() {
        let mut hold = HoldLastGood::new();
        hold.apply(&frame_with_invalid(0, 1, 0, &[]));
        assert!(hold.apply(&frame_with_invalid(0, 2, 0, &[12])).is_some());
        assert_eq!(hold.apply(&frame_with_invalid(0, 3, 0, &[12, 5])), None);
        assert_eq!(hold.apply(&frame_with_invalid(0, 4, 0, &[5])), None);
        assert!(hold.apply(&frame_with_invalid(0, 5, 0, &[12])).is_some());
    }

    #[test]
    fn hold_drops_without_a_previous_frame() {
        let mut hold = HoldLastGood::new();
        assert_eq!(hold.apply(&frame_with_invalid(0, 1, 0, &[3])), None);
        hold.apply(&frame_with_invalid(0, 2, 0, &[]));
        assert_eq!(hold.apply(&frame_with_invalid(0, 4, 0, &[3])), None, "gap");
        hold.apply(&frame_with_invalid(0, 5, 0, &[]));
        assert_eq!(
            hold.apply(&frame_with_invalid(1, 6, 0, &[3])),
            None,
            "other sensor"
        );
        assert_eq!(
            hold.apply(&frame_with_invalid(3, 6, 0, &[])),
            None,
            "no sensor 3"
        );
    }

    #[test]
    fn hold_allows_different_channels_in_consecutive_frames() {
        let mut hold = HoldLastGood::new();
        hold.apply(&frame_with_invalid(2, 65535, 0, &[]));
        let a = hold.apply(&frame_with_invalid(2, 0, 1, &[7])).unwrap();
        let b = hold.apply(&frame_with_invalid(2, 1, 2, &[8])).unwrap();
        assert_eq!(a.pac[3], reading(0).pac[3]);
        assert_eq!(b.electrodes[4], reading(1).electrodes[4]);
    }
}
