//! The guarded move's section of the parameters: its settings, their
//! checks, and the task, safety envelope and report they make.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::GuardedMove;
use crate::contact::BodyParams;
use crate::control::task::{OffAxis, Task, TaskEnvelope, TaskLoop, TaskReport, TaskSection};
use crate::params::reference::check_ranges;
use crate::params::{invalid, Check, Checked, ParamsError};

/// Guarded-move settings (`force_controller.guarded` in the scene files).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GuardedParams {
    /// Approach direction in the BioTac frame (normalised on validation);
    /// the pad faces -z.
    pub direction: [f64; 3],
    /// Approach speed (m/s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub approach_speed_mps: f64,
    /// Force to hold (N).
    pub target_force_n: f64,
    /// Estimated force that means contact (N).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub contact_force_n: f64,
    /// PDC rise above its tare that means contact (counts).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub contact_pdc_counts: f64,
    /// Estimated force above which the move retracts and stops (N).
    pub force_limit_n: f64,
    /// Travel along the direction after which the move stops (m).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_distance_m: f64,
    /// Time of approach without contact after which the move stops (s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_approach_s: f64,
    /// Retract speed (m/s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub retract_speed_mps: f64,
    /// Distance to retract after the force limit (m).
    #[schemars(range(min = 0.0))]
    pub retract_distance_m: f64,
    /// Force band around the target that counts as settled (N).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub settle_band_n: f64,
    /// Estimates within the band, over this time, before the phase is
    /// Hold (s; at most a minute: the window's estimates are held in memory).
    #[schemars(range(min = 0.0, max = 60.0))]
    pub settle_time_s: f64,
    /// Largest standard deviation of the force over that time (N).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub settle_sd_n: f64,
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
        check_ranges(&self, key)?;
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
        Ok(self)
    }
}

impl TaskSection for GuardedParams {
    const NAME: &'static str = "guarded";

    /// The gains for `body` (the stiffest the scene permits) until the
    /// contact is measured.
    fn build(p: Checked<Self>, lp: &TaskLoop, body: &BodyParams) -> Box<dyn Task> {
        Box::new(GuardedMove::new(p, &lp.law(), body.stiffness_n_per_m))
    }

    fn envelope(
        p: &Checked<Self>,
        lp: &TaskLoop,
        body: &BodyParams,
        name: &str,
    ) -> Result<TaskEnvelope, ParamsError> {
        Ok(TaskEnvelope {
            envelope: lp.press_envelope(body, p.contact_force_n, p.target_force_n, p.force_limit_n),
            body: name.into(),
            key: "guarded.approach_speed_mps",
            speed_mps: p.approach_speed_mps,
        })
    }

    fn report(p: &Checked<Self>) -> TaskReport {
        TaskReport {
            approach_speed_mps: Some(p.approach_speed_mps),
            off_axis: OffAxis::AcrossNormal,
        }
    }
}
