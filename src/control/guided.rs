//! The guided move (joystick): keep a set force against a person's fingertip
//! along each controlled axis (1 N along z, 0 N along x and y by default), so
//! that the arm follows the finger's pushes. A deadband (0.2 N in the thesis)
//! ignores small forces. Above the force limit the arm stops.
//!
//! Per axis the PD law gives `u` ("raise the force"); the BioTac moves by
//! `v = -u`: along -z to press harder on a finger under the pad, along +x to
//! give way to a finger pushing the skin towards +x.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::pd::{LoopDelays, PdAxis, PdParams};
use super::task::{
    missing_axis, translation, Task, TaskEnvelope, TaskInput, TaskLoop, TaskSection,
};
use super::{Envelope, Phase, StopReason};
use crate::contact::{series_stiffness, shear_stiffness, BodyParams};
use crate::kinematics::Twist;
use crate::params::{invalid, non_negative, Check, Checked, ParamsError};
use crate::wrench::Axis;

/// Guided-move settings (`force_controller.guided` in the scene files).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GuidedParams {
    /// Force to hold along x, y, z of the BioTac frame (N).
    pub target_force_n: [f64; 3],
    /// Deadband on the force error (N).
    pub deadband_n: f64,
    /// Force magnitude above which the arm stops (N).
    pub force_limit_n: f64,
}

impl Check for GuidedParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        let t = Vector3::from(self.target_force_n);
        if !t.iter().all(|v| v.is_finite()) {
            let key = format!("{key}.target_force_n");
            return Err(invalid(&key, t.norm(), "finite values"));
        }
        non_negative(&format!("{key}.deadband_n"), self.deadband_n)?;
        if self.force_limit_n.is_nan() || self.force_limit_n <= t.norm() {
            return Err(invalid(
                &format!("{key}.force_limit_n"),
                self.force_limit_n,
                "above the target force's magnitude",
            ));
        }
        Ok(self)
    }
}

/// The guided-move controller.
#[derive(Debug, Clone, PartialEq)]
pub struct GuidedMove {
    p: GuidedParams,
    pd: [Option<PdAxis>; 3],
    phase: Phase,
    reason: Option<StopReason>,
}

impl GuidedMove {
    /// A guided move controlling the axes with `Some(stiffness)` (N/m,
    /// effective contact stiffness along x, y, z) at control period
    /// `period_s` in a loop with these delays ([`PdAxis::new`]).
    pub fn new(
        p: Checked<GuidedParams>,
        pd: &Checked<PdParams>,
        stiffness: [Option<f64>; 3],
        period_s: f64,
        delays: &Checked<LoopDelays>,
    ) -> Self {
        let axis = |k| PdAxis::new(pd, k, period_s, p.deadband_n, delays);
        GuidedMove {
            pd: stiffness.map(|k| k.map(axis)),
            p: *p,
            phase: Phase::Follow,
            reason: None,
        }
    }

    /// One cycle: estimated force (N, BioTac frame) -> BioTac velocity (m/s,
    /// BioTac frame). Over the force limit, or with the input out of the
    /// estimator's range, the arm stops for good.
    pub fn velocity(&mut self, force: &Vector3<f64>, out_of_range: bool, dt: f64) -> Vector3<f64> {
        // An estimate outside what the GP knows says nothing about the
        // force, so it is not read as over the limit.
        let stop = if out_of_range {
            Some(StopReason::OutOfRange)
        } else {
            (force.norm() > self.p.force_limit_n).then_some(StopReason::ForceLimit)
        };
        if let (Phase::Follow, Some(reason)) = (self.phase, stop) {
            self.phase = Phase::Stopped;
            self.reason = Some(reason);
        }
        let mut v = Vector3::zeros();
        for (i, pd) in self.pd.iter_mut().enumerate() {
            if let Some(pd) = pd {
                v[i] = -pd.step(self.p.target_force_n[i], force[i], dt);
            }
        }
        if self.phase == Phase::Stopped {
            return Vector3::zeros();
        }
        v
    }
}

impl TaskSection for GuidedParams {
    const NAME: &'static str = "guided";

    /// Gains per controlled axis: the skin in series with `body` across
    /// the pad (x, y) and along its normal (z).
    fn build(p: Checked<Self>, lp: &TaskLoop, body: &BodyParams) -> Box<dyn Task> {
        let normal = series_stiffness(lp.skin, body, p.target_force_n[2]);
        let shear = shear_stiffness(lp.skin, body);
        let k = [shear, shear, normal];
        let forces = lp.forces();
        let k = std::array::from_fn(|i| forces[i].then_some(k[i]));
        Box::new(GuidedMove::new(p, lp.pd, k, lp.period_s, lp.delays))
    }

    /// The controlled axis that allows the slowest motion towards `body`.
    /// On each axis the PD stops advancing past the target plus the
    /// deadband, and the axis may take what the force limit leaves beside
    /// the other axes' targets.
    fn envelope(
        p: &Checked<Self>,
        lp: &TaskLoop,
        body: &BodyParams,
        name: &str,
    ) -> Result<TaskEnvelope, ParamsError> {
        let forces = lp.forces();
        let t = p.target_force_n;
        let total: f64 = t.iter().map(|v| v * v).sum();
        let envelope = (0..3)
            .filter(|&i| forces[i])
            .map(|i| Envelope {
                skin: **lp.skin,
                stiffness_n_per_m: if i == 2 {
                    body.stiffness_n_per_m
                } else {
                    shear_stiffness(lp.skin, body)
                },
                shear: i != 2,
                trigger_n: t[i].abs() + p.deadband_n,
                target_n: t[i].abs(),
                limit_n: (p.force_limit_n.powi(2) - (total - t[i] * t[i])).sqrt(),
                reaction_s: lp.reaction_s(),
            })
            .min_by(|a, b| a.max_speed_mps().total_cmp(&b.max_speed_mps()))
            .ok_or_else(|| missing_axis(lp.axes, Axis::Fz))?;
        Ok(TaskEnvelope {
            envelope,
            body: name.into(),
            key: "pd.max_speed_mps",
            speed_mps: lp.pd.max_speed_mps,
        })
    }
}

/// The guided move as the controller runs it: in the BioTac's frame as it
/// turns, the orientation held.
impl Task for GuidedMove {
    fn step(&mut self, i: &TaskInput) -> Twist {
        translation(i.pose.rotation * self.velocity(i.force, i.out_of_range, i.dt))
    }

    /// Follow, or Stopped after the force limit.
    fn phase(&self) -> Phase {
        self.phase
    }

    fn reason(&self) -> Option<StopReason> {
        self.reason
    }

    fn targets(&self) -> [Option<f64>; 3] {
        std::array::from_fn(|i| self.pd[i].as_ref().map(|_| self.p.target_force_n[i]))
    }

    fn gains(&self) -> [Option<f64>; 3] {
        self.pd.each_ref().map(|p| p.as_ref().map(PdAxis::gain))
    }

    fn directions(&self) -> Vec<(String, Vector3<f64>)> {
        ["x", "y", "z"]
            .iter()
            .enumerate()
            .filter(|(i, _)| self.pd[*i].is_some())
            .map(|(i, name)| (format!("{name} of the BioTac frame"), Vector3::ith(i, 1.0)))
            .collect()
    }

    fn force_axes(&self) -> Vec<Axis> {
        [Axis::Fx, Axis::Fy, Axis::Fz]
            .into_iter()
            .enumerate()
            .filter_map(|(i, a)| self.pd[i].as_ref().map(|_| a))
            .collect()
    }

    fn pause(&mut self) {
        self.pd.iter_mut().flatten().for_each(PdAxis::reset);
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

    fn guided() -> GuidedMove {
        let p = GuidedParams {
            target_force_n: [0.0, 0.0, 1.0],
            deadband_n: 0.2,
            force_limit_n: 5.0,
        };
        let pd = PdParams {
            gain_ratio: 0.4,
            derivative_filter_s: 0.02,
            max_speed_mps: 0.1,
        };
        GuidedMove::new(
            p.checked("guided").unwrap(),
            &pd.checked("pd").unwrap(),
            [Some(500.0), Some(500.0), Some(300.0)],
            0.01,
            &LoopDelays::default().checked("loop_delays").unwrap(),
        )
    }

    #[test]
    fn gives_way_to_pushes_and_presses_when_too_light() {
        let mut g = guided();
        let v = g.velocity(&Vector3::new(0.5, -0.5, 1.0), false, 0.01);
        assert!(v.x > 0.0 && v.y < 0.0 && v.z == 0.0, "{v}");
        let v = g.velocity(&Vector3::new(0.1, 0.0, 0.5), false, 0.01);
        assert!(v.x == 0.0 && v.z < 0.0, "deadband on x, press on z: {v}");
        assert_eq!(g.targets(), [Some(0.0), Some(0.0), Some(1.0)]);
    }

    #[test]
    fn out_of_range_input_stops() {
        for force in [Vector3::new(0.5, 0.0, 1.0), Vector3::new(0.0, 0.0, 8.0)] {
            let mut g = guided();
            assert_eq!(g.velocity(&force, true, 0.01), Vector3::zeros());
            // Even over the limit: the estimate is not trusted.
            assert_eq!(g.reason(), Some(StopReason::OutOfRange), "{force}");
        }
    }

    #[test]
    fn force_limit_stops_for_good() {
        let mut g = guided();
        assert_eq!(
            g.velocity(&Vector3::new(0.0, 0.0, 6.0), false, 0.01),
            Vector3::zeros()
        );
        assert_eq!(
            g.velocity(&Vector3::new(0.0, 0.0, 0.0), false, 0.01),
            Vector3::zeros()
        );
        assert_eq!(
            (g.phase(), g.reason()),
            (Phase::Stopped, Some(StopReason::ForceLimit))
        );
    }
}
