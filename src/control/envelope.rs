//! The safety envelope: the fastest motion towards a body from which a task
//! still stops within its force limit, so that no speed can crush what the
//! BioTac touches.
//!
//! Model (SI units). Pressing a body of stiffness `k` through the BioTac
//! skin (`F = A (exp(x / x0) - 1)`, [`SkinParams`]) compresses the two in
//! series by
//!
//! ```text
//! x(F) = x0 ln(1 + F / A) + F / k.
//! ```
//!
//! The controller reacts once the force passes a trigger `F_t`: the guarded
//! move's contact threshold (from then on it commands at most the PD's
//! regulating speed, which falls to zero at the target), the guided move's
//! target plus deadband (beyond it the PD moves away). Until the arm acts on
//! that, it keeps moving at `v` for the reaction time
//!
//! ```text
//! R = T + D + L + tau
//! ```
//!
//! - `T`, the control period: the reading that shows the crossing is taken
//!   up to one period after it;
//! - `D`, the transport delay from the reading to the controller (0 in one
//!   process; over ROS the estimator, DDS and the controller's timer);
//! - `L`, the arm's command latency;
//! - `tau`, the time constant of the arm's velocity servo: a first-order
//!   servo stopping from `v` travels `v tau` more.
//!
//! `D`, `L` and `tau` are the [`crate::control::LoopDelays`] (`force_controller.loop_delays`).
//!
//! So the force peaks at `F_peak(v)`, the root of `x(F) = x(F_t) + v R`
//! (at least the target force, which the task regulates to), and the task
//! stays within its force limit `F_lim` for
//!
//! ```text
//! v <= v_max = (x(F_lim) - x(F_t)) / R.
//! ```
//!
//! This is an upper bound: the guarded move's derivative term brakes
//! before the trigger force, and a retracting command stops the arm faster
//! than a zero one. `demo guarded --sweep-speed` prints the predicted peak
//! beside the measured one (docs/demos.md, "Safety envelope"). "Peak force on first
//! contact ~ latency x approach speed x stiffness" (architecture page,
//! "Force control facts").

use serde::{Deserialize, Serialize};

use crate::contact::SkinParams;
use crate::params::reference::check_ranges;
use crate::params::{Check, ParamsError};

/// What the envelope assumes of the bodies (`force_controller.safety` in
/// the scene files); the loop's delays are [`crate::control::LoopDelays`].
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SafetyParams {
    /// The bodies this scene may touch (names of `objects`, or
    /// [`UNKNOWN_OBJECT`]); the stiffest one sets the speed limit.
    pub objects: Vec<String>,
    /// Stiffness assumed for [`UNKNOWN_OBJECT`] (N/m).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub worst_case_stiffness_n_per_m: f64,
}

/// The object name of a body whose stiffness is not known (a real robot
/// touching whatever is there): `safety.worst_case_stiffness_n_per_m`.
pub const UNKNOWN_OBJECT: &str = "unknown";

impl Check for SafetyParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        check_ranges(&self, key)?;
        if self.objects.is_empty() {
            return Err(ParamsError::Invalid {
                key: format!("{key}.objects"),
                value: "[]".into(),
                expected: "the bodies this scene may touch".into(),
            });
        }
        Ok(self)
    }
}

/// The envelope of one direction of motion against one body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Envelope {
    /// The skin law.
    pub skin: SkinParams,
    /// Stiffness of the body (N/m); for shear, the skin's shear stiffness in
    /// series with it (and `skin` then plays no part).
    pub stiffness_n_per_m: f64,
    /// True for a tangential direction (a linear spring, no skin law).
    pub shear: bool,
    /// Force after which the controller stops advancing (N).
    pub trigger_n: f64,
    /// Force the task regulates to (N).
    pub target_n: f64,
    /// Force the task must never pass (N).
    pub limit_n: f64,
    /// Reaction time `R` (s).
    pub reaction_s: f64,
}

impl Envelope {
    /// Compression of skin and body in series at force `f` (m).
    pub fn compression(&self, f: f64) -> f64 {
        let body = f / self.stiffness_n_per_m;
        if self.shear {
            return body;
        }
        self.skin.length_scale_mm * 1e-3 * (f / self.skin.force_scale_n).ln_1p() + body
    }

    /// The fastest speed towards the body that peaks within the limit (m/s).
    pub fn max_speed_mps(&self) -> f64 {
        (self.compression(self.limit_n) - self.compression(self.trigger_n)) / self.reaction_s
    }

    /// The predicted peak force at speed `v` (N): the root of
    /// `x(F) = x(F_t) + v R`, at least the target.
    pub fn peak_force_n(&self, v: f64) -> f64 {
        let travel = self.compression(self.trigger_n) + v.max(0.0) * self.reaction_s;
        // x(F) is increasing: bisect on [0, hi] with hi doubled until past.
        let mut hi = self.limit_n.max(1.0);
        while self.compression(hi) < travel && hi < 1e9 {
            hi *= 2.0;
        }
        let mut lo = 0.0;
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if self.compression(mid) < travel {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        hi.max(self.target_n)
    }

    /// Refuses a speed `v` (m/s, parameter `key`) above [`Self::max_speed_mps`],
    /// naming the limit and why; `body` names what is touched.
    pub fn check(&self, key: &str, v: f64, body: &str) -> Result<(), ParamsError> {
        let max = self.max_speed_mps();
        if v.is_finite() && v >= 0.0 && v <= max {
            return Ok(());
        }
        let hint = if v > 1.0 {
            format!(" (the unit is m/s: {v} mm/s would be {} m/s)", v * 1e-3)
        } else {
            String::new()
        };
        Err(ParamsError::Invalid {
            key: key.into(),
            value: format!("{v} m/s{hint}"),
            expected: format!(
                "a speed >= 0 and at most {max:.4} m/s, the safety envelope: against {body} \
                 ({:.1e} N/m), the stiffest body the scene permits, the BioTac moves on for \
                 {:.0} ms (control period + transport delay + command latency + arm lag, \
                 loop_delays.*) after the force passes {:.2} N, so faster it would press past the \
                 {:.2} N force limit (at {v} m/s: ~{:.1} N)",
                self.stiffness_n_per_m,
                self.reaction_s * 1e3,
                self.trigger_n,
                self.limit_n,
                self.peak_force_n(v),
            ),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn skin() -> SkinParams {
        SkinParams {
            force_scale_n: 0.5,
            length_scale_mm: 1.2,
            shear_stiffness_n_per_m: 1500.0,
        }
    }

    fn envelope(k: f64) -> Envelope {
        Envelope {
            skin: skin(),
            stiffness_n_per_m: k,
            shear: false,
            trigger_n: 0.15,
            target_n: 1.0,
            limit_n: 3.0,
            reaction_s: 0.04,
        }
    }

    #[test]
    fn compression_inverts_the_skin_law_in_series_with_the_body() {
        let e = envelope(1e4);
        for f in [0.1, 1.0, 3.0, 10.0] {
            let x = e.compression(f);
            let x_body = f / 1e4;
            assert!((skin().force(x - x_body) - f).abs() < 1e-9, "{f} N");
        }
    }

    #[test]
    fn the_limit_speed_peaks_exactly_at_the_force_limit() {
        for k in [1e2, 1e4, 1e5, 1e6] {
            let e = envelope(k);
            let v = e.max_speed_mps();
            assert!((e.peak_force_n(v) - 3.0).abs() < 1e-6, "k {k}");
            assert!(e.peak_force_n(0.9 * v) < 3.0 && e.peak_force_n(1.1 * v) > 3.0);
            // Slow: the target, which the task regulates to.
            assert_eq!(e.peak_force_n(1e-4), 1.0);
        }
    }

    #[test]
    fn stiffer_bodies_and_longer_delays_allow_slower_approaches() {
        // Wooden box (1e5 N/m): (x(3 N) - x(0.15 N)) / 40 ms = 2.05 mm / 40 ms.
        let wood = envelope(1e5).max_speed_mps();
        assert!((wood - 0.0512).abs() < 5e-4, "{wood}");
        assert!(envelope(1e4).max_speed_mps() > wood);
        assert!(envelope(1e2).max_speed_mps() > 10.0 * wood);
        let slow = Envelope {
            reaction_s: 0.08,
            ..envelope(1e5)
        };
        assert!((slow.max_speed_mps() - wood / 2.0).abs() < 1e-12);
    }

    #[test]
    fn shear_is_a_linear_spring() {
        let e = Envelope {
            shear: true,
            stiffness_n_per_m: 250.0,
            trigger_n: 0.2,
            target_n: 0.0,
            limit_n: 5.0,
            ..envelope(1.0)
        };
        assert!((e.max_speed_mps() - 4.8 / 250.0 / 0.04).abs() < 1e-12);
    }

    #[test]
    fn speeds_beyond_the_limit_are_refused_with_the_limit_named() {
        let e = envelope(1e5);
        e.check("guarded.approach_speed_mps", 0.05, "wooden_box")
            .unwrap();
        // No motion towards the body is within any envelope.
        e.check("hold_still", 0.0, "wooden_box").unwrap();
        for v in [0.2, 5.0, f64::NAN, -0.01, f64::INFINITY] {
            let msg = e
                .check("guarded.approach_speed_mps", v, "wooden_box")
                .unwrap_err()
                .to_string();
            assert!(msg.contains("guarded.approach_speed_mps"), "{msg}");
            assert!(msg.contains("at most 0.0512 m/s"), "{msg}");
            assert!(
                msg.contains("wooden_box") && msg.contains("3.00 N"),
                "{msg}"
            );
        }
        let msg = e.check("k", 5.0, "wooden_box").unwrap_err().to_string();
        assert!(msg.contains("5 mm/s would be 0.005 m/s"), "{msg}");
    }

    #[test]
    fn bad_safety_parameters_are_named() {
        let p = SafetyParams {
            objects: vec!["wooden_box".into()],
            worst_case_stiffness_n_per_m: -1.0,
        };
        let e = p.checked("safety").unwrap_err().to_string();
        assert!(e.contains("safety.worst_case_stiffness_n_per_m"), "{e}");
        let e = SafetyParams {
            objects: vec![],
            worst_case_stiffness_n_per_m: 1e6,
        }
        .checked("safety")
        .unwrap_err()
        .to_string();
        assert!(e.contains("safety.objects"), "{e}");
    }
}
