//! The force controller's parameters (`force_controller` in the parameter
//! files: the world, the robot's file, a task's scene), and the goals of its
//! actions, which are applied to them.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use super::task::{RawSection, TaskRegistry, TaskSection};
use super::{LoopDelays, OscillationParams, PdParams, SafetyParams};
use crate::contact::{BodyParams, SkinParams};
use crate::kinematics::RobotParams;
use crate::params::ParamsError;
use crate::wrench::AxisSet;

/// The `force_controller` parameters. Every key but the task sections is
/// a field; a task's section is the key of its name (`guarded:`, ...),
/// read by the task's own type ([`TaskSection`]) when the task is built.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
pub struct ControllerParams {
    /// Sensing and control period (s).
    #[schemars(range(min = 0.0001, max = 1.0))]
    pub control_period_s: f64,
    /// The BioTac skin law.
    pub skin: SkinParams,
    /// Objects the arm may touch, by name.
    pub objects: BTreeMap<String, BodyParams>,
    /// The object of this run, for the simulator: one of `safety.objects`
    /// (checked; the gains do not depend on it).
    pub object: String,
    /// The arm: the links of its robot description, the BioTac's mount,
    /// limits and inverse-kinematics settings.
    pub robot: RobotParams,
    /// An estimate this many of its stream's measured periods later than
    /// usual (at least 2, plus the arrival's jitter: src/control/window.rs),
    /// or a joint state this many control periods old, stops the arm.
    #[schemars(range(min = 2.0, max = 10.0))]
    pub stale_periods: f64,
    /// When the estimate cannot be trusted.
    pub out_of_range: OutOfRangeParams,
    /// What the safety envelope assumes: delays, the bodies the scene may touch.
    pub safety: SafetyParams,
    /// Wrench axes the task controls (and the estimator must provide).
    pub axes: AxisSet,
    /// The task: the name of a registered task.
    pub task: String,
    /// Start the task as soon as inputs arrive (a simulation); false: the
    /// ROS node commands zero until a goal or a `task` set asks for motion.
    /// The embedded runtime is asked when it is run.
    pub autostart: bool,
    /// PD law.
    pub pd: PdParams,
    /// The longest delays of the loop: the safety envelope's reaction time,
    /// and the gains' priors until the controller has measured them.
    pub loop_delays: LoopDelays,
    /// The stability watchdog.
    pub oscillation: OscillationParams,
    /// Every other key: the tasks' sections, by task name (checked against
    /// the registry: [`ControllerParams::check_sections`]).
    #[serde(flatten)]
    #[schemars(skip)]
    pub sections: BTreeMap<String, RawSection>,
}

/// Limits beyond which the BioTac input is outside what the estimator
/// knows. Far from its training data a GP's mean falls back to the prior
/// (zero force) while its standard deviation grows, and PDC saturates with
/// force (architecture page): either means the force may be larger than
/// estimated, so the task stops (guarded: retracts).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct OutOfRangeParams {
    /// Largest trusted standard deviation on a controlled axis (N).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_std_n: f64,
    /// Largest trusted PDC rise above the tare (counts).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_pdc_rise_counts: f64,
}

impl ControllerParams {
    /// Refuses a key that is neither a field nor the section of a task of
    /// `tasks` (what `deny_unknown_fields` does for the fields).
    pub fn check_sections(&self, tasks: &TaskRegistry) -> Result<(), ParamsError> {
        match self.sections.keys().find(|k| !tasks.contains(k)) {
            None => Ok(()),
            Some(k) => Err(ParamsError::Invalid {
                key: k.clone(),
                value: "an unknown parameter".into(),
                expected: format!(
                    "a field of force_controller, or the section of a task ({})",
                    tasks.names()
                ),
            }),
        }
    }

    /// The raw section of the task `name`, or an error naming it.
    pub fn raw_section(&self, name: &str) -> Result<&RawSection, ParamsError> {
        self.sections.get(name).ok_or_else(|| ParamsError::Invalid {
            key: name.into(),
            value: "absent".into(),
            expected: format!("a `{name}` section for the task {name}"),
        })
    }

    /// The section of the task `S`, not yet checked.
    pub fn section<S: TaskSection>(&self) -> Result<S, ParamsError> {
        serde_yaml_ng::from_value(self.raw_section(S::NAME)?.clone()).map_err(|error| {
            ParamsError::Yaml {
                node: format!("force_controller, section `{}`", S::NAME),
                error,
            }
        })
    }

    /// Replaces the section of the task `S`.
    pub fn set_section<S: TaskSection>(&mut self, s: &S) {
        let raw = serde_yaml_ng::to_value(s).expect("a task section serialises");
        self.sections.insert(S::NAME.into(), raw);
    }

    /// Changes the section of the task `S` (which must be there) with `f`.
    pub fn edit_section<S: TaskSection>(
        &mut self,
        f: impl FnOnce(&mut S),
    ) -> Result<(), ParamsError> {
        let mut s = self.section::<S>()?;
        f(&mut s);
        self.set_section(&s);
        Ok(())
    }
}

/// A goal of the controller's actions: the start-up parameters with the
/// goal applied, checked like any scene when the controller is built.
pub trait Goal {
    /// The start-up parameters with this goal applied.
    fn apply(&self, base: &ControllerParams) -> Result<ControllerParams, ParamsError>;
}
