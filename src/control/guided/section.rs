//! The guided move's section of the parameters: its settings, their
//! checks, and the task, safety envelope and report they make.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::GuidedMove;
use crate::contact::{shear_stiffness, BodyParams};
use crate::control::task::{
    missing_axis, OffAxis, Task, TaskEnvelope, TaskLoop, TaskReport, TaskSection,
};
use crate::control::tuning::Margins;
use crate::control::Envelope;
use crate::params::reference::check_ranges;
use crate::params::{invalid, Check, Checked, ParamsError};
use crate::wrench::Axis;

/// Guided-move settings (`force_controller.guided` in the scene files).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GuidedParams {
    /// Force to hold along x, y, z of the BioTac frame (N).
    pub target_force_n: [f64; 3],
    /// Deadband on the force error (N).
    #[schemars(range(min = 0.0))]
    pub deadband_n: f64,
    /// Force magnitude above which the arm stops (N).
    pub force_limit_n: f64,
    /// Force magnitude that means a finger is there (N).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub contact_force_n: f64,
    /// Time without a finger after which the move stops (s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub contact_timeout_s: f64,
    /// Distance from the start after which the move stops (m).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_travel_m: f64,
    /// Speed of the retract after an oscillation (m/s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub retract_speed_mps: f64,
    /// Distance of that retract along the pad's normal (m).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub retract_distance_m: f64,
    /// The margins the gains keep: following a finger trades some of the
    /// hold's damping (`pd.margins`) for a smaller lag behind it.
    pub margins: Margins,
}

impl Check for GuidedParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        let t = Vector3::from(self.target_force_n);
        if !t.iter().all(|v| v.is_finite()) {
            let key = format!("{key}.target_force_n");
            return Err(invalid(&key, t.norm(), "finite values"));
        }
        check_ranges(&self, key)?;
        if self.force_limit_n.is_nan() || self.force_limit_n <= t.norm() {
            return Err(invalid(
                &format!("{key}.force_limit_n"),
                self.force_limit_n,
                "above the target force's magnitude",
            ));
        }
        self.margins.check(&format!("{key}.margins"))?;
        Ok(self)
    }
}

impl TaskSection for GuidedParams {
    const NAME: &'static str = "guided";

    /// The gains for `body` (the stiffest the scene permits) until the
    /// finger is measured, on the controlled force axes.
    fn build(p: Checked<Self>, lp: &TaskLoop, body: &BodyParams) -> Box<dyn Task> {
        Box::new(GuidedMove::new(
            p,
            &lp.law(),
            lp.forces(),
            body.stiffness_n_per_m,
        ))
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
            .map(|i| {
                let limit_n = (p.force_limit_n.powi(2) - (total - t[i] * t[i])).sqrt();
                let normal =
                    lp.press_envelope(body, t[i].abs() + p.deadband_n, t[i].abs(), limit_n);
                match i {
                    2 => normal,
                    _ => Envelope {
                        stiffness_n_per_m: shear_stiffness(lp.skin, body),
                        shear: true,
                        ..normal
                    },
                }
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

    fn report(_: &Checked<Self>) -> TaskReport {
        TaskReport {
            approach_speed_mps: None,
            off_axis: OffAxis::Unpushed,
        }
    }
}
