//! The guarded move: approach along a direction at a set speed until contact,
//! then regulate the force to the target and hold it; retract and stop above
//! the force limit; stop with a timeout when nothing is touched within the
//! approach distance.
//!
//! ```text
//!  Approach --F >= contact or PDC rise--> Regulate <--band--> Hold
//!     |  \--travelled > max distance (any of the three)--> Stopped(timeout)
//!     \-- F > limit or out of range --> Retract --retracted--> Stopped(reason)
//! ```
//!
//! Sign convention: the task works on the pressing force (the force along
//! minus the approach direction) and returns a speed along the approach
//! direction (positive = towards the object).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::pd::{LoopDelays, PdAxis, PdParams};
use super::task::{translation, Task, TaskEnvelope, TaskInput, TaskLoop, TaskSection};
use super::{Envelope, Phase, StopReason};
use crate::contact::{series_stiffness, BodyParams};
use crate::kinematics::Twist;
use crate::params::{invalid, non_negative, positive, Check, Checked, ParamsError};
use crate::wrench::Axis;

/// Guarded-move settings (`force_controller.guarded` in the scene files).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GuardedParams {
    /// Approach direction in the BioTac frame (normalised on validation);
    /// the pad faces -z.
    pub direction: [f64; 3],
    /// Approach speed (m/s).
    pub approach_speed_mps: f64,
    /// Force to hold (N).
    pub target_force_n: f64,
    /// Estimated force that means contact (N).
    pub contact_force_n: f64,
    /// PDC rise above its tare that means contact (counts).
    pub contact_pdc_counts: f64,
    /// Estimated force above which the move retracts and stops (N).
    pub force_limit_n: f64,
    /// Approach distance after which the move stops with a timeout (m).
    pub max_distance_m: f64,
    /// Retract speed (m/s).
    pub retract_speed_mps: f64,
    /// Distance to retract after the force limit (m).
    pub retract_distance_m: f64,
    /// Force band around the target that counts as settled (N).
    pub settle_band_n: f64,
    /// Time inside the band before the phase is Hold (s).
    pub settle_time_s: f64,
}

/// Normalises the direction.
impl Check for GuardedParams {
    fn check(mut self, key: &str) -> Result<Self, ParamsError> {
        let name = |field: &str| format!("{key}.{field}");
        let d = Vector3::from(self.direction);
        let n = d.norm();
        if !(n.is_finite() && n > 0.0) {
            return Err(invalid(&name("direction"), n, "a finite non-zero vector"));
        }
        self.direction = (d / n).into();
        positive(&name("approach_speed_mps"), self.approach_speed_mps)?;
        positive(&name("contact_force_n"), self.contact_force_n)?;
        positive(&name("contact_pdc_counts"), self.contact_pdc_counts)?;
        if self.target_force_n.is_nan() || self.target_force_n <= self.contact_force_n {
            return Err(invalid(
                &name("target_force_n"),
                self.target_force_n,
                &format!("above {}", name("contact_force_n")),
            ));
        }
        if self.force_limit_n.is_nan() || self.force_limit_n <= self.target_force_n {
            return Err(invalid(
                &name("force_limit_n"),
                self.force_limit_n,
                &format!("above {}", name("target_force_n")),
            ));
        }
        positive(&name("max_distance_m"), self.max_distance_m)?;
        positive(&name("retract_speed_mps"), self.retract_speed_mps)?;
        non_negative(&name("retract_distance_m"), self.retract_distance_m)?;
        positive(&name("settle_band_n"), self.settle_band_n)?;
        non_negative(&name("settle_time_s"), self.settle_time_s)?;
        Ok(self)
    }
}

/// What the guarded move sees each cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuardedInput {
    /// Estimated pressing force (N).
    pub force_n: f64,
    /// PDC rise above its tare (counts).
    pub pdc_rise: f64,
    /// Distance travelled along the approach direction since the start (m).
    pub travelled_m: f64,
    /// True when the input is outside what the estimator knows.
    pub out_of_range: bool,
    /// Time since the previous cycle (s).
    pub dt: f64,
}

/// The guarded-move state machine.
#[derive(Debug, Clone, PartialEq)]
pub struct GuardedMove {
    p: GuardedParams,
    pd: PdAxis,
    phase: Phase,
    reason: Option<StopReason>,
    in_band_s: f64,
    retract_from_m: f64,
}

impl GuardedMove {
    /// A move with checked parameters, its PD law for a contact of effective
    /// stiffness `stiffness` (N/m) at control period `period_s` in a loop
    /// with these delays ([`PdAxis::new`]).
    pub fn new(
        p: Checked<GuardedParams>,
        pd: &Checked<PdParams>,
        stiffness: f64,
        period_s: f64,
        delays: &Checked<LoopDelays>,
    ) -> Self {
        GuardedMove {
            pd: PdAxis::new(pd, stiffness, period_s, 0.0, delays),
            p: *p,
            phase: Phase::Approach,
            reason: None,
            in_band_s: 0.0,
            retract_from_m: 0.0,
        }
    }

    /// Unit approach direction in the BioTac frame.
    pub fn direction(&self) -> Vector3<f64> {
        Vector3::from(self.p.direction)
    }

    /// The force being held (N).
    pub fn target_force_n(&self) -> f64 {
        self.p.target_force_n
    }

    /// The PD law (for its gain).
    pub fn pd(&self) -> &PdAxis {
        &self.pd
    }

    /// One cycle: the speed along the approach direction (m/s).
    pub fn speed(&mut self, i: &GuardedInput) -> f64 {
        let p = self.p;
        let u = self.pd.step(p.target_force_n, i.force_n, i.dt);
        let active = matches!(self.phase, Phase::Approach | Phase::Regulate | Phase::Hold);
        // An estimate outside what the GP knows says nothing about the
        // force, so it is not read as over the limit.
        let abort = if i.out_of_range {
            Some(StopReason::OutOfRange)
        } else {
            (i.force_n > p.force_limit_n).then_some(StopReason::ForceLimit)
        };
        if let (true, Some(reason)) = (active, abort) {
            self.phase = Phase::Retract;
            self.reason = Some(reason);
            self.retract_from_m = i.travelled_m;
        }
        match self.phase {
            Phase::Approach => {
                if i.force_n >= p.contact_force_n || i.pdc_rise >= p.contact_pdc_counts {
                    self.phase = Phase::Regulate;
                    return self.regulate(u, i);
                }
                if i.travelled_m >= p.max_distance_m {
                    self.phase = Phase::Stopped;
                    self.reason = Some(StopReason::Timeout);
                    return 0.0;
                }
                p.approach_speed_mps
            }
            // Never further than the approach distance, even in contact
            // (a PDC rise can mean a touch away from the approach direction).
            Phase::Regulate | Phase::Hold if i.travelled_m >= p.max_distance_m => {
                self.phase = Phase::Stopped;
                self.reason = Some(StopReason::Timeout);
                0.0
            }
            Phase::Regulate | Phase::Hold => self.regulate(u, i),
            Phase::Retract => {
                if i.travelled_m <= self.retract_from_m - p.retract_distance_m {
                    self.phase = Phase::Stopped;
                    return 0.0;
                }
                -p.retract_speed_mps
            }
            Phase::Stopped | Phase::Follow | Phase::Rest | Phase::Tilt | Phase::Shear => 0.0,
        }
    }

    fn regulate(&mut self, u: f64, i: &GuardedInput) -> f64 {
        if (i.force_n - self.p.target_force_n).abs() <= self.p.settle_band_n {
            self.in_band_s += i.dt;
        } else {
            self.in_band_s = 0.0;
        }
        self.phase = if self.in_band_s >= self.p.settle_time_s {
            Phase::Hold
        } else {
            Phase::Regulate
        };
        // Never towards the object faster than the approach.
        u.min(self.p.approach_speed_mps)
    }
}

impl TaskSection for GuardedParams {
    const NAME: &'static str = "guarded";

    fn build(p: Checked<Self>, lp: &TaskLoop, body: &BodyParams) -> Box<dyn Task> {
        let k = series_stiffness(lp.skin, body, p.target_force_n);
        Box::new(GuardedMove::new(p, lp.pd, k, lp.period_s, lp.delays))
    }

    fn envelope(
        p: &Checked<Self>,
        lp: &TaskLoop,
        body: &BodyParams,
        name: &str,
    ) -> Result<TaskEnvelope, ParamsError> {
        Ok(TaskEnvelope {
            envelope: Envelope {
                skin: **lp.skin,
                stiffness_n_per_m: body.stiffness_n_per_m,
                shear: false,
                trigger_n: p.contact_force_n,
                target_n: p.target_force_n,
                limit_n: p.force_limit_n,
                reaction_s: lp.reaction_s(),
            },
            body: name.into(),
            key: "guarded.approach_speed_mps",
            speed_mps: p.approach_speed_mps,
        })
    }
}

/// The guarded move as the controller runs it: along its direction in the
/// BioTac frame at the start, the orientation held.
impl Task for GuardedMove {
    fn step(&mut self, i: &TaskInput) -> Twist {
        let d_tool = self.direction();
        let d_world = i.start.rotation * d_tool;
        let input = GuardedInput {
            force_n: -d_tool.dot(i.force),
            pdc_rise: i.pdc_rise,
            travelled_m: (i.pose.translation.vector - i.start.translation.vector).dot(&d_world),
            out_of_range: i.out_of_range,
            dt: i.dt,
        };
        translation(d_world * self.speed(&input))
    }

    fn phase(&self) -> Phase {
        self.phase
    }

    fn reason(&self) -> Option<StopReason> {
        self.reason
    }

    /// The target on the axis the direction mostly points along.
    fn targets(&self) -> [Option<f64>; 3] {
        let d = self.direction();
        let mut t = [None; 3];
        t[d.iamax()] = Some(self.p.target_force_n * -d[d.iamax()]);
        t
    }

    /// The gain along the direction, on the axis it mostly points along.
    fn gains(&self) -> [Option<f64>; 3] {
        let mut out = [None; 3];
        out[self.direction().iamax()] = Some(self.pd.gain());
        out
    }

    fn directions(&self) -> Vec<(String, Vector3<f64>)> {
        let d = self.direction();
        let name = format!("the approach direction [{}, {}, {}]", d.x, d.y, d.z);
        vec![(name, d)]
    }

    fn force_axes(&self) -> Vec<Axis> {
        let d = self.direction();
        [Axis::Fx, Axis::Fy, Axis::Fz]
            .into_iter()
            .filter(|a| d[a.index()] != 0.0)
            .collect()
    }

    fn pause(&mut self) {
        self.pd.reset();
        self.in_band_s = 0.0;
    }

    fn stop(&mut self) {
        self.phase = Phase::Stopped;
    }

    fn stop_on(&mut self, reason: StopReason) {
        self.phase = Phase::Stopped;
        self.reason = Some(reason);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params() -> GuardedParams {
        GuardedParams {
            direction: [0.0, 0.0, -2.0],
            approach_speed_mps: 0.01,
            target_force_n: 1.0,
            contact_force_n: 0.15,
            contact_pdc_counts: 30.0,
            force_limit_n: 3.0,
            max_distance_m: 0.05,
            retract_speed_mps: 0.01,
            retract_distance_m: 0.005,
            settle_band_n: 0.05,
            settle_time_s: 0.1,
        }
    }

    /// A move with [`params`] against a contact of 1000 N/m.
    fn guarded() -> GuardedMove {
        let pd = PdParams {
            gain_ratio: 0.4,
            derivative_filter_s: 0.02,
            max_speed_mps: 0.05,
        };
        GuardedMove::new(
            params().checked("guarded").unwrap(),
            &pd.checked("pd").unwrap(),
            1000.0,
            0.01,
            &LoopDelays::default().checked("loop_delays").unwrap(),
        )
    }

    fn input(force_n: f64, travelled_m: f64) -> GuardedInput {
        GuardedInput {
            force_n,
            pdc_rise: 0.0,
            travelled_m,
            out_of_range: false,
            dt: 0.01,
        }
    }

    #[test]
    fn approach_contact_regulate_hold_on_a_spring() {
        let mut g = guarded();
        assert_eq!(g.direction(), Vector3::new(0.0, 0.0, -1.0));
        // Object 5 mm away, stiffness 1000 N/m, ideal velocity tracking.
        let mut x: f64 = 0.0;
        let mut phases = vec![];
        for _ in 0..300 {
            let f = (1000.0 * (x - 0.005)).max(0.0);
            let v = g.speed(&input(f, x));
            assert!(v <= 0.01 + 1e-12, "never faster than the approach");
            x += v * 0.01;
            if phases.last() != Some(&g.phase()) {
                phases.push(g.phase());
            }
        }
        assert_eq!(phases, [Phase::Approach, Phase::Regulate, Phase::Hold]);
        assert!((1000.0 * (x - 0.005) - 1.0).abs() < 0.01);
        assert_eq!(g.reason(), None);
    }

    #[test]
    fn pdc_alone_detects_contact() {
        let mut g = guarded();
        g.speed(&GuardedInput {
            pdc_rise: 40.0,
            ..input(0.0, 0.001)
        });
        assert_eq!(g.phase(), Phase::Regulate);
    }

    #[test]
    fn timeout_stops_at_the_distance() {
        let mut g = guarded();
        assert_eq!(g.speed(&input(0.0, 0.049)), 0.01);
        assert_eq!(g.speed(&input(0.0, 0.05)), 0.0);
        assert_eq!(
            (g.phase(), g.reason()),
            (Phase::Stopped, Some(StopReason::Timeout))
        );
        assert_eq!(g.speed(&input(0.0, 0.05)), 0.0, "stays stopped");
    }

    #[test]
    fn a_stopped_move_stays_still() {
        let mut g = guarded();
        assert_eq!(g.speed(&input(0.0, 0.0)), 0.01);
        g.stop();
        assert_eq!(g.speed(&input(0.0, 0.001)), 0.0);
        assert_eq!((g.phase(), g.reason()), (Phase::Stopped, None));
    }

    #[test]
    fn regulating_never_goes_past_the_approach_distance() {
        // A PDC rise from a touch behind the pad: contact, but the force
        // along the approach direction stays below the target.
        let mut g = guarded();
        let touch = |travelled_m| GuardedInput {
            pdc_rise: 100.0,
            ..input(-1.0, travelled_m)
        };
        assert!(g.speed(&touch(0.0)) > 0.0);
        assert_eq!(g.phase(), Phase::Regulate);
        assert!(g.speed(&touch(0.049)) > 0.0);
        assert_eq!(g.speed(&touch(0.05)), 0.0);
        assert_eq!(
            (g.phase(), g.reason()),
            (Phase::Stopped, Some(StopReason::Timeout))
        );
    }

    #[test]
    fn over_force_retracts_in_the_same_cycle_then_stops() {
        for start in [Phase::Approach, Phase::Regulate] {
            let mut g = guarded();
            if start == Phase::Regulate {
                g.speed(&input(0.5, 0.010));
            }
            let v = g.speed(&input(3.5, 0.012));
            assert_eq!((v, g.phase()), (-0.01, Phase::Retract), "from {start:?}");
            assert_eq!(g.speed(&input(0.0, 0.008)), -0.01);
            assert_eq!(g.speed(&input(0.0, 0.007)), 0.0);
            assert_eq!(
                (g.phase(), g.reason()),
                (Phase::Stopped, Some(StopReason::ForceLimit))
            );
        }
    }

    #[test]
    fn out_of_range_input_retracts_like_over_force() {
        // Even over the limit (3 N): the estimate is not trusted.
        for force_n in [1.0, 3.5] {
            let mut g = guarded();
            g.speed(&input(0.5, 0.010));
            let v = g.speed(&GuardedInput {
                out_of_range: true,
                ..input(force_n, 0.011)
            });
            assert_eq!((v, g.phase()), (-0.01, Phase::Retract));
            assert_eq!(g.reason(), Some(StopReason::OutOfRange), "{force_n} N");
        }
    }

    #[test]
    fn bad_parameters_are_named() {
        let mut p = params();
        p.force_limit_n = 0.5;
        let e = p.checked("guarded").unwrap_err().to_string();
        assert!(e.contains("guarded.force_limit_n"), "{e}");
        p = params();
        p.direction = [0.0; 3];
        let e = p.checked("guarded").unwrap_err().to_string();
        assert!(e.contains("guarded.direction"), "{e}");
    }
}
