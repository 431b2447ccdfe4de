//! The guided move (joystick): keep a set force against a person's fingertip
//! along each controlled axis (1 N along z, 0 N along x and y by default), so
//! that the arm follows the finger's pushes. A deadband (0.2 N in the thesis)
//! ignores small forces. Above the force limit the arm stops.
//!
//! Per axis the PD law gives `u` ("raise the force"); the BioTac moves by
//! `v = -u`: along -z to press harder on a finger under the pad, along +x to
//! give way to a finger pushing the skin towards +x.

use nalgebra::Vector3;
use serde::Deserialize;

use super::pd::{LoopDelays, PdAxis, PdParams};
use super::{Phase, StopReason};
use crate::params::{invalid, non_negative, Check, Checked, ParamsError};

/// Guided-move settings (`force_controller.guided` in the scene files).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
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

    /// Current phase: Follow, or Stopped after the force limit.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// Why the move stopped, if it did.
    pub fn reason(&self) -> Option<StopReason> {
        self.reason
    }

    /// Target force of each controlled axis (N), None for the others.
    pub fn targets(&self) -> [Option<f64>; 3] {
        let mut t = [None; 3];
        for (i, pd) in self.pd.iter().enumerate() {
            t[i] = pd.as_ref().map(|_| self.p.target_force_n[i]);
        }
        t
    }

    /// Proportional gain of each controlled axis (m/s per N).
    pub fn gains(&self) -> [Option<f64>; 3] {
        self.pd.each_ref().map(|p| p.as_ref().map(PdAxis::gain))
    }

    /// Forgets the force history after a pause in the estimates.
    pub fn pause(&mut self) {
        self.pd.iter_mut().flatten().for_each(PdAxis::reset);
    }

    /// Stops where it is: no motion any more.
    pub fn stop(&mut self) {
        self.phase = Phase::Stopped;
    }

    /// Stops for good, with `reason`, before any motion.
    pub fn stop_on(&mut self, reason: StopReason) {
        self.phase = Phase::Stopped;
        self.reason = Some(reason);
    }

    /// One cycle: estimated force (N, BioTac frame) -> BioTac velocity (m/s,
    /// BioTac frame). Over the force limit, or with the input out of the
    /// estimator's range, the arm stops for good.
    pub fn step(&mut self, force: &Vector3<f64>, out_of_range: bool, dt: f64) -> Vector3<f64> {
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
        let v = g.step(&Vector3::new(0.5, -0.5, 1.0), false, 0.01);
        assert!(v.x > 0.0 && v.y < 0.0 && v.z == 0.0, "{v}");
        let v = g.step(&Vector3::new(0.1, 0.0, 0.5), false, 0.01);
        assert!(v.x == 0.0 && v.z < 0.0, "deadband on x, press on z: {v}");
        assert_eq!(g.targets(), [Some(0.0), Some(0.0), Some(1.0)]);
    }

    #[test]
    fn out_of_range_input_stops() {
        for force in [Vector3::new(0.5, 0.0, 1.0), Vector3::new(0.0, 0.0, 8.0)] {
            let mut g = guided();
            assert_eq!(g.step(&force, true, 0.01), Vector3::zeros());
            // Even over the limit: the estimate is not trusted.
            assert_eq!(g.reason(), Some(StopReason::OutOfRange), "{force}");
        }
    }

    #[test]
    fn force_limit_stops_for_good() {
        let mut g = guided();
        assert_eq!(
            g.step(&Vector3::new(0.0, 0.0, 6.0), false, 0.01),
            Vector3::zeros()
        );
        assert_eq!(
            g.step(&Vector3::new(0.0, 0.0, 0.0), false, 0.01),
            Vector3::zeros()
        );
        assert_eq!(
            (g.phase(), g.reason()),
            (Phase::Stopped, Some(StopReason::ForceLimit))
        );
    }
}
