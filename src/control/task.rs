//! The task seam. A task the force controller runs is a type behind
//! [`Task`] (how it steps), made from its section of the parameters, a
//! type behind [`TaskSection`] (its name, its checks, its gains, the safety
//! envelope of its motion). A controller knows the tasks of a
//! [`TaskRegistry`]; the shipped one is registered in one place
//! ([`crate::nodes::tasks`]). A new task adds its module, its scene file and
//! one line there; nothing else names it.
//!
//! [`TaskKind`] names the shipped tasks' scene files (the demos, the ROS
//! nodes' defaults), not the tasks a controller can run.

mod kind;
pub use kind::TaskKind;

use std::any::Any;
use std::fmt;

use dyn_clone::DynClone;
use nalgebra::{Isometry3, Vector3};
use schemars::JsonSchema;
use serde::de::DeserializeOwned;
use serde::Serialize;

use super::rules::{ForceLimit, Watch};
use super::tuning::LoopTiming;
use super::{
    ControllerParams, Envelope, LoopDelays, OscillationParams, PdParams, Phase, StopReason,
};
use crate::contact::{BodyParams, SkinParams};
use crate::kinematics::Twist;
use crate::params::reference::{params_of, ParamDoc};
use crate::params::{Check, Checked, ParamsError};
use crate::wrench::{Axis, AxisSet};

/// A task the controller runs: each cycle it turns the force on the BioTac
/// into the BioTac's twist. A task is `Clone` (a controller is copied to
/// restart a run from a snapshot).
pub trait Task: fmt::Debug + Send + Any + DynClone {
    /// One cycle: the BioTac's twist (m/s, rad/s, base frame).
    fn step(&mut self, i: &TaskInput) -> Twist;

    /// Where the task is.
    fn phase(&self) -> Phase;

    /// Why the task stopped, if it stopped on its own.
    fn reason(&self) -> Option<StopReason>;

    /// Desired force along x, y, z of the BioTac frame on the controlled
    /// axes (N).
    fn targets(&self) -> [Option<f64>; 3];

    /// Proportional gain of each force axis x, y, z (m/s per N), None where
    /// not controlled.
    fn gains(&self) -> [Option<f64>; 3];

    /// The directions the task moves the BioTac along (BioTac frame), each
    /// with its name for messages.
    fn directions(&self) -> Vec<(String, Vector3<f64>)>;

    /// The force axes the task reads.
    fn force_axes(&self) -> Vec<Axis>;

    /// Forgets the force history after a pause in the inputs.
    fn pause(&mut self);

    /// Stops where it is: no motion any more.
    fn stop(&mut self);

    /// A canceled goal: leaves contact, then stops, so that the next goal
    /// starts out of contact. By default it stops where it is.
    fn withdraw(&mut self) {
        self.stop();
    }

    /// Stops for good with `reason`.
    fn stop_on(&mut self, reason: StopReason);

    /// A stability rule stopped the task (src/control/rules.rs), before it
    /// steps this cycle: it leaves the contact as it must, then stops with
    /// `reason`. By default it stops where it is.
    fn abort(&mut self, reason: StopReason) {
        self.stop_on(reason);
    }

    /// The force the stability rules hold to a limit; none by default (a
    /// task that presses nothing).
    fn force_limit(&self) -> Option<ForceLimit> {
        None
    }

    /// Where the task regulates the force now, for the oscillation
    /// watchdog (src/control/rules.rs); nowhere by default.
    fn watch(&self) -> Watch {
        Watch::Nothing
    }

    /// The force oscillates along the directions of [`Task::watch`] that
    /// have a frequency in `hz` (Hz): the task lowers those gains, or
    /// leaves the contact and stops (`oscillating`) where it cannot. By
    /// default it stops where it is.
    fn soften(&mut self, hz: [Option<f64>; 3]) {
        let _ = hz;
        self.abort(StopReason::OSCILLATING);
    }

    /// What the task measured and chose, for reports; none by default.
    fn figures(&self) -> TaskFigures {
        TaskFigures::default()
    }

    /// Takes the settings of `fresh`, the same task built from changed
    /// parameters, while it runs: it keeps where it started and what it
    /// measured. False: it keeps its own settings until it ends (they
    /// apply from its next start), as by default.
    fn retune(&mut self, fresh: &dyn Task) -> bool {
        let _ = fresh;
        false
    }
}

/// What a task measured of its contact and how it holds, for reports.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TaskFigures {
    /// The contact's stiffness per force axis x, y, z (N/m), as the gains
    /// use it: fitted, or the prior until then.
    pub stiffness_n_per_m: [Option<f64>; 3],
    /// The body behind the skin, fitted in contact (N/m; infinite: rigid).
    pub body_n_per_m: Option<f64>,
    /// The force's standard deviation over the settling window (N), once
    /// full.
    pub settled_sd_n: Option<f64>,
    /// Times the stability watchdog lowered a gain.
    pub softened: u32,
    /// The task's own figures, each with its name (with its unit's
    /// suffix): the report and the diagnostics show them as they are.
    pub own: Vec<(&'static str, f64)>,
}

dyn_clone::clone_trait_object!(Task);

/// A task's section of the `force_controller` parameters (its key is the
/// task's name): the settings, their checks, and the task they make.
pub trait TaskSection: DeserializeOwned + Serialize + JsonSchema + Check + 'static {
    /// The task's name: the value of the parameter `task`, and its
    /// section's key.
    const NAME: &'static str;

    /// The task, its gains set for a contact with `body` in `lp`.
    fn build(p: Checked<Self>, lp: &TaskLoop, body: &BodyParams) -> Box<dyn Task>;

    /// The envelope of the task's motion towards `body` (named `name`) in
    /// `lp`: the speed that the parameters set and the limit it must stay
    /// within.
    fn envelope(
        p: &Checked<Self>,
        lp: &TaskLoop,
        body: &BodyParams,
        name: &str,
    ) -> Result<TaskEnvelope, ParamsError>;

    /// What a run's report reads of the settings: by default no approach,
    /// nothing off-axis.
    fn report(_p: &Checked<Self>) -> TaskReport {
        TaskReport::default()
    }

    /// Outside a goal: the parameters the task is built with, and whether
    /// it then waits, the arm still, for a goal. By default it runs on `p`.
    fn outside_goal(p: ControllerParams) -> Result<OutsideGoal, ParamsError> {
        Ok(OutsideGoal {
            params: p,
            waits: false,
        })
    }
}

/// How a task runs outside a goal (a `task` parameter, not an action).
#[derive(Debug, Clone, PartialEq)]
pub struct OutsideGoal {
    /// The parameters it is built with.
    pub params: ControllerParams,
    /// True: it waits, the arm still, for a goal of its action.
    pub waits: bool,
}

/// What a run's report reads of a task's settings.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TaskReport {
    /// Its speed towards the object (m/s), when it approaches one.
    pub approach_speed_mps: Option<f64>,
    /// What its motion off its axes is measured against.
    pub off_axis: OffAxis,
}

/// What a report measures a task's motion off its axes against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OffAxis {
    /// Nothing: the task slides and turns on purpose.
    #[default]
    Nothing,
    /// The speed across the normal axis, against the approach speed.
    AcrossNormal,
    /// The speed along the axes the finger did not push, against the
    /// finger's speed.
    Unpushed,
}

/// A task section as parameters hold it, before it is read.
pub type RawSection = serde_yaml_ng::Value;

/// Makes a task from its raw section, its gains set for a body.
type BuildFn = fn(&RawSection, &TaskLoop, &BodyParams) -> Result<Box<dyn Task>, ParamsError>;

/// The envelope of a task's motion towards a body (named), from its raw
/// section.
type EnvelopeFn =
    fn(&RawSection, &TaskLoop, &BodyParams, &str) -> Result<TaskEnvelope, ParamsError>;

/// What a report reads of a task's raw section.
type ReportFn = fn(&RawSection) -> Result<TaskReport, ParamsError>;

/// One task a registry knows: its name and how its section is read.
#[derive(Clone, Copy)]
pub struct TaskEntry {
    name: &'static str,
    build: BuildFn,
    envelope: EnvelopeFn,
    report: ReportFn,
    outside_goal: fn(ControllerParams) -> Result<OutsideGoal, ParamsError>,
    params: fn() -> Vec<ParamDoc>,
}

impl fmt::Debug for TaskEntry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name)
    }
}

impl TaskEntry {
    /// The entry of the task whose section is `S`.
    pub fn of<S: TaskSection>() -> Self {
        TaskEntry {
            name: S::NAME,
            build: |raw, lp, body| Ok(S::build(read_section::<S>(raw)?, lp, body)),
            envelope: |raw, lp, body, name| S::envelope(&read_section::<S>(raw)?, lp, body, name),
            report: |raw| Ok(S::report(&read_section::<S>(raw)?)),
            outside_goal: S::outside_goal,
            params: || params_of::<S>(S::NAME),
        }
    }

    /// The task's name.
    pub fn name(&self) -> &'static str {
        self.name
    }

    /// The task of the section `raw`, checked, its gains set for `body`.
    pub fn build(
        &self,
        raw: &RawSection,
        lp: &TaskLoop,
        body: &BodyParams,
    ) -> Result<Box<dyn Task>, ParamsError> {
        (self.build)(raw, lp, body)
    }

    /// The envelope of the task of the section `raw` towards `body`.
    pub fn envelope(
        &self,
        raw: &RawSection,
        lp: &TaskLoop,
        body: &BodyParams,
        name: &str,
    ) -> Result<TaskEnvelope, ParamsError> {
        (self.envelope)(raw, lp, body, name)
    }

    /// What a run's report reads of the section `raw`.
    pub fn report(&self, raw: &RawSection) -> Result<TaskReport, ParamsError> {
        (self.report)(raw)
    }

    /// How the task runs outside a goal on `p` ([`TaskSection::outside_goal`]).
    pub fn outside_goal(&self, p: ControllerParams) -> Result<OutsideGoal, ParamsError> {
        (self.outside_goal)(p)
    }
}

/// Reads and checks the section of `S`.
fn read_section<S: TaskSection>(raw: &RawSection) -> Result<Checked<S>, ParamsError> {
    let section: S = serde_yaml_ng::from_value(raw.clone()).map_err(|error| ParamsError::Yaml {
        node: format!("force_controller, section `{}`", S::NAME),
        error,
    })?;
    section.checked(S::NAME)
}

/// The tasks a controller can run.
#[derive(Debug, Clone, Default)]
pub struct TaskRegistry {
    entries: Vec<TaskEntry>,
}

/// Registries of the same tasks, by name, are equal.
impl PartialEq for TaskRegistry {
    fn eq(&self, other: &Self) -> bool {
        self.names() == other.names()
    }
}

impl TaskRegistry {
    /// A registry with `S`'s task added (replacing one of the same name).
    pub fn with<S: TaskSection>(mut self) -> Self {
        self.entries.retain(|e| e.name != S::NAME);
        self.entries.push(TaskEntry::of::<S>());
        self
    }

    /// The task named `name`, or an error listing the known ones.
    pub fn get(&self, name: &str) -> Result<&TaskEntry, ParamsError> {
        self.entries
            .iter()
            .find(|e| e.name == name)
            .ok_or_else(|| ParamsError::Invalid {
                key: "task".into(),
                value: name.into(),
                expected: self.names(),
            })
    }

    /// True when a task is named `name`.
    pub fn contains(&self, name: &str) -> bool {
        self.entries.iter().any(|e| e.name == name)
    }

    /// Every task's parameters, under its section's key.
    pub fn params(&self) -> Vec<ParamDoc> {
        self.entries.iter().flat_map(|e| (e.params)()).collect()
    }

    /// The tasks' names, for messages ("guarded, guided or calibrate").
    pub fn names(&self) -> String {
        or_list(self.each_name())
    }

    /// Each task's name.
    pub fn each_name(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.entries.iter().map(|e| e.name)
    }
}

/// "a, b or c".
pub(crate) fn or_list<'a>(names: impl Iterator<Item = &'a str>) -> String {
    let names: Vec<&str> = names.collect();
    match names.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => names.join(""),
    }
}

/// The loop a task runs in: what its gains and envelope are computed from
/// besides its own section.
#[derive(Debug, Clone, Copy)]
pub struct TaskLoop<'a> {
    /// The BioTac skin law.
    pub skin: &'a Checked<SkinParams>,
    /// The PD law.
    pub pd: &'a Checked<PdParams>,
    /// The loop's longest delays: the envelope's bounds, the gains' priors.
    pub delays: &'a Checked<LoopDelays>,
    /// The stability watchdog's settings.
    pub oscillation: &'a Checked<OscillationParams>,
    /// The control period (s).
    pub period_s: f64,
    /// The wrench axes the controller controls.
    pub axes: &'a AxisSet,
}

impl TaskLoop<'_> {
    /// Which of the x, y, z forces the controller controls.
    pub fn forces(&self) -> [bool; 3] {
        [Axis::Fx, Axis::Fy, Axis::Fz].map(|a| self.axes.axes().contains(&a))
    }

    /// The time from a force crossing to the arm acting on it (s): the
    /// control period and the loop's delays (src/control/envelope.rs).
    pub fn reaction_s(&self) -> f64 {
        self.period_s + self.delays.total_s()
    }

    /// The envelope of a press along the pad's normal towards `body` in
    /// this loop: advancing until `trigger_n`, regulating to `target_n`,
    /// never past `limit_n` (N).
    pub fn press_envelope(
        &self,
        body: &BodyParams,
        trigger_n: f64,
        target_n: f64,
        limit_n: f64,
    ) -> Envelope {
        Envelope {
            skin: **self.skin,
            stiffness_n_per_m: body.stiffness_n_per_m,
            shear: false,
            trigger_n,
            target_n,
            limit_n,
            reaction_s: self.reaction_s(),
        }
    }

    /// What a task's force loop needs of this loop.
    pub fn law(&self) -> ForceLaw {
        ForceLaw {
            pd: *self.pd,
            skin: **self.skin,
            oscillation: **self.oscillation,
            reaction_s: self.reaction_s(),
            period_s: self.period_s,
        }
    }

    /// The loop's timing the gains assume until it is measured: the delays'
    /// bounds.
    pub fn prior_timing(&self) -> LoopTiming {
        LoopTiming {
            transport_s: self.delays.transport_delay_s,
            latency_s: self.delays.command_latency_s,
            lag_s: self.delays.arm_lag_s,
            period_s: self.period_s,
        }
    }
}

/// What a task's force loop needs of the loop it runs in: the PD law's
/// settings, the skin (the stiffness fit reads through it), the stability
/// watchdog's, the reaction time the safety envelope assumed, the period.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceLaw {
    /// The PD law.
    pub pd: Checked<PdParams>,
    /// The BioTac skin law.
    pub skin: SkinParams,
    /// The stability watchdog.
    pub oscillation: OscillationParams,
    /// The reaction time the safety envelope assumed (s).
    pub reaction_s: f64,
    /// The control period (s).
    pub period_s: f64,
}

/// The error for an axis set that lacks `axis`, which the task reads.
pub fn missing_axis(axes: &AxisSet, axis: Axis) -> ParamsError {
    ParamsError::Invalid {
        key: "axes".into(),
        value: axes.to_string(),
        expected: format!("a set including {axis}, which the task reads"),
    }
}

/// A task's speed towards its bodies and the envelope it must stay in.
#[derive(Debug, Clone, PartialEq)]
pub struct TaskEnvelope {
    /// The envelope against the stiffest body the scene permits.
    pub envelope: Envelope,
    /// That body's name.
    pub body: String,
    /// The parameter that sets the speed.
    pub key: &'static str,
    /// The speed (m/s): the guarded move's approach, the guided move's
    /// largest commanded speed.
    pub speed_mps: f64,
}

impl TaskEnvelope {
    /// Refuses a speed above the envelope's limit, naming it.
    pub fn check(&self) -> Result<(), ParamsError> {
        self.envelope.check(self.key, self.speed_mps, &self.body)
    }
}

/// What a task sees each cycle.
#[derive(Debug, Clone, Copy)]
pub struct TaskInput<'a> {
    /// Estimated force on the BioTac, BioTac frame (N).
    pub force: &'a Vector3<f64>,
    /// PDC rise above its tare (counts).
    pub pdc_rise: f64,
    /// The BioTac's pose now, base frame.
    pub pose: &'a Isometry3<f64>,
    /// The BioTac's pose at the start of the run, base frame.
    pub start: &'a Isometry3<f64>,
    /// Time since the previous cycle (s).
    pub dt: f64,
    /// True when the force is a new estimate, not the last one again.
    pub fresh: bool,
    /// The BioTac's position (base frame) when the force's reading was
    /// taken, when the arm's positions reach back to it.
    pub force_position: Option<Vector3<f64>>,
    /// The BioTac's velocity (base frame) then, likewise.
    pub force_velocity: Option<Vector3<f64>>,
    /// The loop's timing as measured (the bounds until then).
    pub timing: &'a LoopTiming,
}

impl TaskInput<'_> {
    /// The time from a force crossing to the arm acting on it, as measured
    /// (s).
    pub fn reaction_s(&self) -> f64 {
        let t = self.timing;
        t.period_s + t.transport_s + t.latency_s + t.lag_s
    }
}

/// A twist with a linear velocity only (the orientation held).
pub fn translation(v: Vector3<f64>) -> Twist {
    Twist::new(v.x, v.y, v.z, 0.0, 0.0, 0.0)
}

/// What the controller does with the oscillation watchdog `rule` alone
/// before `task` steps on `force` (N, BioTac frame): the task lowers a
/// gain where the force oscillates.
#[cfg(test)]
pub(crate) fn watched_by(
    rule: &mut super::rules::Oscillation,
    task: &mut dyn Task,
    force: &Vector3<f64>,
    dt: f64,
    fresh: bool,
) {
    use super::rules::{Rule, RuleInput, Verdict};
    let seen = RuleInput {
        force,
        out_of_range: false,
        estimate_age_s: 0.0,
        stale_after_s: 1.0,
        limit: None,
        watch: task.watch(),
        dt,
        fresh,
    };
    if let Some(Verdict::Oscillating(hz)) = rule.check(&seen) {
        task.soften(hz);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_registry_finds_its_tasks_by_name_and_lists_them_when_it_cannot() {
        let r = TaskRegistry::default()
            .with::<super::super::GuardedParams>()
            .with::<super::super::GuidedParams>();
        assert_eq!(r.get("guided").unwrap().name(), "guided");
        assert!(r.contains("guarded") && !r.contains("calibrate"));
        let e = r.get("admittance").unwrap_err().to_string();
        assert!(
            e.contains("admittance") && e.contains("guarded or guided"),
            "{e}"
        );
        // Registering a task again replaces it.
        let again = r.with::<super::super::GuardedParams>();
        assert_eq!(again.names(), "guided or guarded");
    }
}
