//! A BioTac bridge emulator: frames from the simulator in wire format v1,
//! with optional injected faults, for users without hardware and for tests.
//!
//! The simulated finger is pressed on the pad with a raised-cosine force
//! (0 to `press_peak_n` and back every `press_period_s`), so a monitor shows
//! electrodes and PDC moving. Faults, each with probability `fault_rate`:
//! - per SPI word, a parity error at the source (one bit of the word flips
//!   before the bridge computes the CRC): the frame arrives with an invalid
//!   channel;
//! - per byte on the wire, a bit flip, or (one time in three) a dropped
//!   byte: the CRC or the framing fails and the decoder drops the frame.

use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::sim::{BioTacSim, BioTacSimConfig, Contact};
use super::wire::{crc16_ccitt_false, encode_frame, FRAME_LEN};
use super::{BioTacReading, FRAME_PERIOD_S};

/// Emulator settings.
#[derive(Debug, Clone, PartialEq)]
pub struct EmulatorConfig {
    /// Sensor index written in the frames (0..=2).
    pub sensor: u8,
    /// Probability of a fault per word (source) and per byte (wire).
    pub fault_rate: f64,
    /// Seed of the simulated unit's noise and of the faults.
    pub seed: u64,
    /// Peak force of the press cycle (N).
    pub press_peak_n: f64,
    /// Period of the press cycle (s).
    pub press_period_s: f64,
}

impl Default for EmulatorConfig {
    fn default() -> Self {
        EmulatorConfig {
            sensor: 0,
            fault_rate: 0.0,
            seed: 1,
            press_peak_n: 3.0,
            press_period_s: 4.0,
        }
    }
}

/// One frame as sent.
#[derive(Debug, Clone, PartialEq)]
pub struct SentFrame {
    /// The bytes on the wire (after wire faults; 99..=100 bytes).
    pub bytes: Vec<u8>,
    /// The frame the bridge meant to send (after source faults only).
    pub intended: [u8; FRAME_LEN],
    /// Its sequence number.
    pub seq: u16,
    /// True when a wire fault hit it.
    pub corrupted: bool,
}

/// The emulator.
#[derive(Debug, Clone)]
pub struct Emulator {
    config: EmulatorConfig,
    sim: BioTacSim,
    rng: ChaCha8Rng,
    seq: u16,
    t: f64,
}

impl Emulator {
    /// An emulator of the simulated unit `unit_seed` of `sensor` config.
    pub fn new(config: EmulatorConfig, sensor: &BioTacSimConfig, unit_seed: u64) -> Self {
        let mut sim = BioTacSim::new(sensor, unit_seed);
        sim.reseed_noise(config.seed);
        Emulator {
            rng: ChaCha8Rng::seed_from_u64(config.seed ^ 0xfa17),
            config,
            sim,
            seq: 0,
            t: 0.0,
        }
    }

    /// The next frame, 10 ms of simulated time after the previous one.
    pub fn next_frame(&mut self) -> SentFrame {
        let reading = self.reading();
        let bridge_us = (self.t * 1e6) as u64 as u32;
        let mut intended = encode_frame(self.config.sensor, self.seq, bridge_us, &reading);
        self.source_faults(&mut intended);
        let (bytes, corrupted) = self.wire_faults(&intended);
        let seq = self.seq;
        self.seq = self.seq.wrapping_add(1);
        self.t += FRAME_PERIOD_S;
        SentFrame {
            bytes,
            intended,
            seq,
            corrupted,
        }
    }

    fn reading(&mut self) -> BioTacReading {
        let c = &self.config;
        let phase = 2.0 * std::f64::consts::PI * self.t / c.press_period_s;
        let force = 0.5 * c.press_peak_n * (1.0 - phase.cos());
        let contact = (force > 0.0).then_some(Contact {
            x_mm: -4.0,
            angle_rad: 0.0,
            force: Vector3::new(0.0, 0.0, force),
        });
        self.sim.step(contact.as_ref(), FRAME_PERIOD_S)
    }

    /// Parity errors at the source: a flipped bit in a word, CRC recomputed.
    fn source_faults(&mut self, frame: &mut [u8; FRAME_LEN]) {
        let mut hit = false;
        for word in 0..44 {
            if self.rng.random::<f64>() < self.config.fault_rate {
                let bit = self.rng.random_range(0..16);
                let at = 10 + 2 * word + bit / 8;
                frame[at] ^= 1 << (bit % 8);
                hit = true;
            }
        }
        if hit {
            let crc = crc16_ccitt_false(&frame[2..98]);
            frame[98..100].copy_from_slice(&crc.to_le_bytes());
        }
    }

    /// Bit flips and dropped bytes on the wire.
    fn wire_faults(&mut self, frame: &[u8; FRAME_LEN]) -> (Vec<u8>, bool) {
        let mut bytes = Vec::with_capacity(FRAME_LEN);
        let mut corrupted = false;
        for &b in frame {
            if self.rng.random::<f64>() >= self.config.fault_rate {
                bytes.push(b);
                continue;
            }
            corrupted = true;
            if self.rng.random_range(0..3) > 0 {
                bytes.push(b ^ (1 << self.rng.random_range(0..8)));
            }
        }
        (bytes, corrupted)
    }
}

/// Writes a frame to `port` every `period` until `frames` frames went out
/// (None: no limit) or `stop` is set; returns the frames written. A write
/// that times out (nobody reading, buffer full) drops that frame, as a
/// bridge would; any other write error ends the run.
pub fn stream(
    emulator: &mut Emulator,
    port: &mut dyn Write,
    period: Duration,
    frames: Option<u64>,
    stop: &AtomicBool,
) -> std::io::Result<u64> {
    let start = Instant::now();
    let mut sent = 0u64;
    while frames.is_none_or(|n| sent < n) && !stop.load(Ordering::Relaxed) {
        let f = emulator.next_frame();
        match port.write_all(&f.bytes) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {
                tracing::debug!(seq = f.seq, "frame dropped: the port does not drain");
            }
            Err(e) => return Err(e),
        }
        sent += 1;
        let due = start + period.mul_f64(sent as f64);
        std::thread::sleep(due.saturating_duration_since(Instant::now()));
    }
    Ok(sent)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::biotac::wire::{decode_frame, Decoder};

    #[test]
    fn without_faults_every_frame_decodes_to_the_simulated_reading() {
        let mut e = Emulator::new(EmulatorConfig::default(), &BioTacSimConfig::default(), 3);
        let mut d = Decoder::new();
        let mut got = Vec::new();
        let mut sent = Vec::new();
        for _ in 0..300 {
            let f = e.next_frame();
            assert!(!f.corrupted && f.bytes == f.intended);
            d.push(&f.bytes, |x| got.push(x));
            sent.push(decode_frame(&f.intended).unwrap());
        }
        assert_eq!(got, sent);
        // The press cycle moves PDC.
        let pdc: Vec<u16> = got.iter().map(|f| f.reading.pdc).collect();
        assert!(pdc.iter().max().unwrap() - pdc.iter().min().unwrap() > 300);
    }

    #[test]
    fn faults_hit_at_about_the_rate_asked() {
        let config = EmulatorConfig {
            fault_rate: 0.01,
            ..EmulatorConfig::default()
        };
        let mut e = Emulator::new(config, &BioTacSimConfig::default(), 3);
        let frames: Vec<SentFrame> = (0..2000).map(|_| e.next_frame()).collect();
        let corrupted = frames.iter().filter(|f| f.corrupted).count() as f64 / 2000.0;
        // 1 - 0.99^100 = 63 % of frames take a wire fault.
        assert!((corrupted - 0.634).abs() < 0.05, "{corrupted}");
        let invalid = frames
            .iter()
            .filter(|f| decode_frame(&f.intended).is_ok_and(|d| !d.invalid.is_empty()))
            .count() as f64
            / 2000.0;
        // 1 - 0.99^44 = 36 % carry a source parity error (a few flips are
        // bits 2..1 or make an error word: still invalid).
        assert!((invalid - 0.357).abs() < 0.05, "{invalid}");
    }
}
