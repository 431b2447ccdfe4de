//! A stability watchdog: sustained oscillation of the force.
//!
//! The force, less its slow part (a first-order low-pass at
//! `SLOW_HZ`), swings about zero. A swing is counted when it passes
//! `+threshold` after `-threshold`, or the reverse (hysteresis: noise
//! smaller than the threshold crosses nothing). Consecutive swings whose
//! half periods lie in the 3-30 Hz band build a count; a half period
//! outside the band restarts it. Six in a row, three cycles, is an
//! oscillation.
//!
//! The threshold (`force_controller.oscillation.threshold_n`, 0.02 N by
//! default): a sine of amplitude `A` has a standard deviation of
//! `A / sqrt(2)`, so the hold's bound of 0.02 N on the standard deviation
//! is broken from `A = 0.028 N` on; swings through +-0.02 N (`A >= 0.02 N`)
//! are caught before that. The GP's estimate noise at a hold is a few mN
//! (docs/results.md), well under it; a noisier model's is not (the network
//! ensemble's, 12-16 mN on the simulated unit, crossed +-0.02 N at random
//! and was taken for an oscillation at 7-8 Hz while the force held). So
//! the watchdog may be told the estimate at rest, out of contact
//! ([`OscillationDetector::rest`]): the threshold is then at least
//! `NOISE_SIGMAS` standard deviations of that noise.

use serde::{Deserialize, Serialize};

use crate::params::reference::check_ranges;
use crate::params::{Check, ParamsError};

/// The lowest frequency counted (Hz).
pub const LOW_HZ: f64 = 3.0;
/// The highest frequency counted (Hz).
pub const HIGH_HZ: f64 = 30.0;
/// Corner of the low-pass that takes out the force's slow part (Hz).
const SLOW_HZ: f64 = 1.5;
/// Half periods in a row that make an oscillation (three cycles).
const HALF_PERIODS: u32 = 6;
/// The threshold is at least this many standard deviations of the noise
/// at rest: white noise passes 3 sigma one way, then the other, six times
/// in a row within the band's half periods far too rarely to count.
const NOISE_SIGMAS: f64 = 3.0;
/// Estimates at rest before their noise raises the threshold.
const REST_SAMPLES: u32 = 50;

/// The watchdog's settings (`force_controller.oscillation`).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OscillationParams {
    /// The swing that counts, either side of the slow force (N).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub threshold_n: f64,
    /// The gain is multiplied by this at the first oscillation.
    #[schemars(extend("exclusiveMinimum" = 0.0, "exclusiveMaximum" = 1.0))]
    pub gain_factor: f64,
}

impl Check for OscillationParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        check_ranges(&self, key)?;
        Ok(self)
    }
}

/// The watchdog of one force.
#[derive(Debug, Clone, PartialEq)]
pub struct OscillationDetector {
    threshold_n: f64,
    slow: Option<f64>,
    /// Side of the last swing (+1, -1; 0 before the first).
    side: f64,
    /// Time since the last swing (s).
    since_s: f64,
    swings: u32,
    /// Half period of the last swing counted (s).
    last_half_s: f64,
    /// The estimate at rest: its slow part, and the sum of squares and
    /// count of what is left.
    rest: (Option<f64>, f64, u32),
}

impl OscillationDetector {
    /// A watchdog counting swings beyond `threshold_n`.
    pub fn new(threshold_n: f64) -> Self {
        OscillationDetector {
            threshold_n,
            slow: None,
            side: 0.0,
            since_s: 0.0,
            swings: 0,
            last_half_s: 0.0,
            rest: (None, 0.0, 0),
        }
    }

    /// Takes the force `f` (N) estimated at rest, out of contact, `dt` (s)
    /// after the previous one: its noise sets the threshold's floor.
    pub fn rest(&mut self, f: f64, dt: f64) {
        let (slow, sum_sq, n) = &mut self.rest;
        let s = low_pass(*slow, f, dt);
        *slow = Some(s);
        *sum_sq += (f - s).powi(2);
        *n += 1;
    }

    /// Sets the swing that counts (N), keeping the force's history.
    pub fn set_threshold_n(&mut self, threshold_n: f64) {
        self.threshold_n = threshold_n;
    }

    /// The swing that counts (N): the setting, or `NOISE_SIGMAS` times the
    /// noise at rest if that is more.
    pub fn threshold_n(&self) -> f64 {
        match self.rest {
            (_, sum_sq, n) if n >= REST_SAMPLES => {
                let sd = (sum_sq / f64::from(n)).sqrt();
                self.threshold_n.max(NOISE_SIGMAS * sd)
            }
            _ => self.threshold_n,
        }
    }

    /// Takes the force `f` (N) measured `dt` (s) after the previous one;
    /// true when the last three cycles were an oscillation in the band
    /// (the count then starts over).
    pub fn step(&mut self, f: f64, dt: f64) -> bool {
        let slow = low_pass(self.slow, f, dt);
        self.slow = Some(slow);
        self.since_s += dt;
        let r = f - slow;
        let threshold = self.threshold_n();
        let side = if r > threshold {
            1.0
        } else if r < -threshold {
            -1.0
        } else {
            0.0
        };
        let (shortest, longest) = (0.5 / HIGH_HZ, 0.5 / LOW_HZ);
        if self.since_s > longest {
            self.swings = 0;
        }
        if side != 0.0 && side != self.side {
            let half = self.since_s;
            let in_band = self.side != 0.0 && (shortest..=longest).contains(&half);
            self.swings = if in_band { self.swings + 1 } else { 0 };
            self.last_half_s = half;
            self.side = side;
            self.since_s = 0.0;
        }
        if self.swings >= HALF_PERIODS {
            self.swings = 0;
            return true;
        }
        false
    }

    /// The frequency of the last swings counted (Hz).
    pub fn frequency_hz(&self) -> f64 {
        0.5 / self.last_half_s.max(f64::MIN_POSITIVE)
    }

    /// Forgets the history (a pause in the inputs), not the noise at rest.
    pub fn reset(&mut self) {
        *self = OscillationDetector {
            rest: self.rest,
            ..OscillationDetector::new(self.threshold_n)
        };
    }
}

/// The slow part `slow` of a force (None: none yet) after `f` (N), `dt`
/// (s) later: a first-order low-pass at `SLOW_HZ`.
fn low_pass(slow: Option<f64>, f: f64, dt: f64) -> f64 {
    match slow {
        Some(s) => s + (f - s) * (1.0 - (-2.0 * std::f64::consts::PI * SLOW_HZ * dt).exp()),
        None => f,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// Steps `d` through 1 N plus a sine of `amp` at `hz` and noise of
    /// `sd` for `seconds` at 100 Hz; when it first fires (s).
    fn fires(hz: f64, amp: f64, sd: f64, seconds: f64) -> Option<f64> {
        let mut d = OscillationDetector::new(0.02);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let noise = Normal::new(0.0, sd.max(1e-12)).unwrap();
        (0..(seconds * 100.0) as usize).find_map(|k| {
            let t = k as f64 * 0.01;
            let f =
                1.0 + amp * (2.0 * std::f64::consts::PI * hz * t).sin() + noise.sample(&mut rng);
            d.step(f, 0.01).then_some(t)
        })
    }

    #[test]
    fn three_cycles_in_the_band_are_an_oscillation() {
        for hz in [4.0, 12.0, 25.0] {
            let t = fires(hz, 0.05, 0.0, 5.0).unwrap_or_else(|| panic!("{hz} Hz"));
            // Three cycles, plus the low-pass settling for the slowest.
            assert!(t <= 3.5 / hz + 0.3, "{hz} Hz at {t} s");
        }
    }

    #[test]
    fn a_new_threshold_counts_from_the_next_swing() {
        let mut d = OscillationDetector::new(0.02);
        d.set_threshold_n(0.1);
        let swing =
            |k: usize| 1.0 + 0.05 * (2.0 * std::f64::consts::PI * 12.0 * k as f64 * 0.01).sin();
        assert!(
            !(0..500).any(|k| d.step(swing(k), 0.01)),
            "0.05 N under 0.1 N"
        );
        d.set_threshold_n(0.02);
        assert!(
            (500..600).any(|k| d.step(swing(k), 0.01)),
            "0.05 N over 0.02 N"
        );
    }

    #[test]
    fn noise_slow_drifts_and_small_swings_are_not() {
        assert_eq!(fires(12.0, 0.0, 0.005, 60.0), None, "noise of 5 mN");
        assert_eq!(fires(12.0, 0.015, 0.0, 60.0), None, "under the threshold");
        assert_eq!(fires(1.0, 0.3, 0.0, 60.0), None, "a slow swing");
        assert_eq!(fires(45.0, 0.05, 0.0, 60.0), None, "above the band");
    }

    #[test]
    fn noise_at_rest_raises_the_threshold_and_a_real_swing_still_counts() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let noise = Normal::new(0.0, 0.014).unwrap();
        let mut at_rest = OscillationDetector::new(0.02);
        (0..200).for_each(|_| at_rest.rest(noise.sample(&mut rng), 0.01));
        assert!(
            (0.035..0.05).contains(&at_rest.threshold_n()),
            "{}",
            at_rest.threshold_n()
        );
        let run = |d: &mut OscillationDetector, amp: f64, rng: &mut ChaCha8Rng| {
            (0..6000).any(|k| {
                let t = k as f64 * 0.01;
                let swing = amp * (2.0 * std::f64::consts::PI * 8.0 * t).sin();
                d.step(1.0 + swing + noise.sample(rng), 0.01)
            })
        };
        // 60 s of 14 mN noise: taken for an oscillation without the rest,
        // not with it (after a reset too, which keeps the rest).
        assert!(run(&mut OscillationDetector::new(0.02), 0.0, &mut rng));
        let mut d = at_rest.clone();
        d.reset();
        assert!(!run(&mut d, 0.0, &mut rng));
        assert!(
            run(&mut at_rest, 0.08, &mut rng),
            "a swing of 0.08 N at 8 Hz"
        );
        // Too few estimates at rest say nothing.
        let mut short = OscillationDetector::new(0.02);
        (0..10).for_each(|_| short.rest(0.5 * noise.sample(&mut rng), 0.01));
        assert_eq!(short.threshold_n(), 0.02);
    }

    #[test]
    fn the_frequency_is_reported_and_bad_settings_named() {
        let mut d = OscillationDetector::new(0.02);
        let fired = (0..300).any(|k| {
            let f = 1.0 + 0.1 * (2.0 * std::f64::consts::PI * 10.0 * k as f64 * 0.01).sin();
            d.step(f, 0.01)
        });
        assert!(
            fired && (d.frequency_hz() - 10.0).abs() < 1.0,
            "{}",
            d.frequency_hz()
        );
        let e = OscillationParams {
            threshold_n: 0.02,
            gain_factor: 1.5,
        }
        .checked("oscillation")
        .unwrap_err();
        assert!(e.to_string().contains("oscillation.gain_factor"), "{e}");
    }
}
