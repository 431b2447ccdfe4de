//! The `force_controller` node's logic around the controller, whatever
//! moves its messages (the ROS 2 adapter, `ros/force_controller.rs`, only
//! converts them and calls these methods):
//!
//! - the arm: the robot description it commands (none: nothing is
//!   commanded), a new one taken while no task runs and refused while one
//!   does; the joints' names on `joint_states`; the BioTac frame on its
//!   tip ([`tool_frame`]);
//! - the task: the parameter `task`, switched while running, checked as at
//!   start-up; a task that waits for its goal (the calibration) waits, the arm
//!   still ([`crate::control::TaskSection::outside_goal`]);
//! - the goals of its actions and their life cycle ([`goals`]);
//! - the force: the estimate (one message: mean, std, the PDC rise), or
//!   while a calibration records, the F/T wrench (moved to the BioTac
//!   frame), each paired with its BioTac reading;
//! - stepping: on each complete estimate, or, with none for a while, a
//!   halt ([`ForceController::estimate_late`]);
//! - what changed (logged) and its status (`/diagnostics`), with what its
//!   [`InputGuard`] refused: messages over their size, goals and parameter
//!   sets over their rates;
//! - the parameters set while it runs ([`live`]): checked as at start-up,
//!   taken at once by a running guided move, by the others from their next
//!   start;
//! - the frames its wrenches come in ([`frames`]), its lifecycle state, and
//!   the stop from outside the task ([`stop`]).

pub mod frames;
pub mod goals;
pub mod live;
pub mod stop;
pub mod tool_frame;

mod diagnostics;

use nalgebra::Vector3;

use std::sync::Arc;

use super::bounds::InputGuard;
use super::joint_names;
use super::loop_delay::LoopDelayMonitor;
use crate::biotac::BioTacReading;
use crate::calibration::CalibrationRecorder;
use crate::control::{
    task_envelope, ControlOutput, ControllerParams, ForceController, Halt, JointState, OutsideGoal,
    Phase, TaskKind, TaskRegistry,
};
use crate::kinematics::{Robot, RobotError};
use crate::nodes::lifecycle::State;
use crate::params::{layered_flat_params, FlatParams, ParamsError, WORLD_YAML};
use crate::wrench::{FrameTransform, Wrench, WrenchEstimate};
use frames::Frames;

/// What the node publishes (the parameter `command_interface`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommandInterface {
    /// Joint velocities on `velocity_controller/commands`.
    JointVelocities,
    /// The BioTac's twist on `twist_commands`.
    Twist,
}

impl std::str::FromStr for CommandInterface {
    type Err = ParamsError;

    fn from_str(s: &str) -> Result<Self, ParamsError> {
        match s {
            "joint_velocities" => Ok(CommandInterface::JointVelocities),
            "twist" => Ok(CommandInterface::Twist),
            other => Err(ParamsError::Invalid {
                key: "command_interface".into(),
                value: other.into(),
                expected: "joint_velocities or twist".into(),
            }),
        }
    }
}

/// The parameter `ft_to_biotac`: where the F/T sensor sits in the BioTac
/// frame (roll,pitch,yaw,x,y,z); empty: its wrenches are in it already.
pub fn ft_to_biotac(text: &str) -> Result<Option<FrameTransform>, ParamsError> {
    if text.is_empty() {
        return Ok(None);
    }
    text.parse().map(Some).map_err(|e| ParamsError::Invalid {
        key: "ft_to_biotac".into(),
        value: text.into(),
        expected: e,
    })
}

/// A wrench and the stamp of its reading (s).
pub type Stamped = (f64, Wrench);

/// Which topic of the force a message came on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ForcePart {
    /// The estimate (`biotac/wrench_estimate`).
    Estimate,
    /// The F/T sensor's wrench (`ft_sensor/wrench`), in its own frame.
    Ft,
}

impl ForcePart {
    /// The topic it comes on.
    pub fn topic(self) -> &'static str {
        match self {
            ForcePart::Estimate => "biotac/wrench_estimate",
            ForcePart::Ft => "ft_sensor/wrench",
        }
    }
}

/// A force message as the node takes it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Force {
    /// An estimate, in the BioTac frame.
    Estimate(WrenchEstimate),
    /// The F/T sensor's wrench and its stamp (s).
    Ft(Stamped),
}

/// Why a robot description is refused.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DescriptionError {
    /// A task runs on the arm in use.
    #[error(
        "a task is running (a new description is taken once it has stopped, or with no goal \
         active)"
    )]
    Running,
    /// Not a chain between the configured links.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// The joint names, or the task on this arm.
    #[error(transparent)]
    Params(#[from] ParamsError),
}

/// The robot in use: its description, the chain, the joints' names.
#[derive(Debug, Clone)]
struct Arm {
    robot: Robot,
    description: String,
    names: Vec<String>,
}

/// The node's state between messages.
#[derive(Debug)]
pub struct ForceControllerNode {
    base: ControllerParams,
    tasks: TaskRegistry,
    /// The `joint_names` parameter (empty: the URDF's).
    remap: Vec<String>,
    /// Where the F/T sensor sits in the BioTac frame (None: its wrenches
    /// are in the BioTac frame already).
    ft_to_biotac: Option<FrameTransform>,
    arm: Option<Arm>,
    /// None until a robot description arrives.
    controller: Option<ForceController>,
    /// The task running: the parameter's, or a goal's.
    task: String,
    /// False until a goal or a `task` set asks for motion (true from the
    /// start with `autostart`): until then the controller commands zero.
    asked: bool,
    /// True while a goal runs (from its start until it ends).
    goal: bool,
    /// When the goal running was canceled: its pad withdraws.
    withdrawing_since: Option<f64>,
    /// While a calibration runs, its recording: the F/T wrench, not the
    /// estimate, is then the force.
    calibration: Option<CalibrationRecorder>,
    /// The latest force, BioTac frame (N): the goals' feedback.
    force: Vector3<f64>,
    last: Option<ControlOutput>,
    /// Messages refused: not finite, or not matching the arm.
    rejected: u64,
    /// Halts for a stale estimate, each counted once however long.
    stale_halts: u64,
    delays: LoopDelayMonitor,
    delay_warned: bool,
    /// The bounds of its input, shared with the adapter that asks them.
    guard: Arc<InputGuard>,
    /// Where it is in its lifecycle: it commands only while active.
    state: State,
    /// Why the goal running must end: the arm was stopped from outside
    /// its task ([`stop`]), or a wrench it uses came in the wrong frame.
    goal_end: Option<String>,
    frames: Frames,
    /// The last parameter set while it ran, and when it took effect.
    live_set: Option<live::LiveSet>,
}

/// The shipped defaults of the `force_controller` parameters: the guarded
/// scene on the world's robot defaults (the links empty: the URDF's root
/// and leaf), with every shipped task's section from its own scene, so
/// that `task` can switch while running.
pub fn shipped_defaults() -> Result<FlatParams, ParamsError> {
    let name = "force_controller";
    let mut d = layered_flat_params(&[WORLD_YAML, TaskKind::Guarded.scene_yaml()], name)?;
    for task in TaskKind::ALL {
        let section = format!("{}.", task.name());
        let own = layered_flat_params(&[task.scene_yaml()], name)?;
        for (key, value) in own.into_iter().filter(|(k, _)| k.starts_with(&section)) {
            if !d.iter().any(|(k, _)| *k == key) {
                d.push((key, value));
            }
        }
    }
    Ok(d)
}

impl ForceControllerNode {
    /// The node with its start-up parameters, checked (the robot's with the
    /// description), running a task of `tasks`.
    pub fn new(
        base: ControllerParams,
        tasks: TaskRegistry,
        remap: Vec<String>,
        ft_to_biotac: Option<FrameTransform>,
    ) -> Result<Self, ParamsError> {
        ForceController::check(&base, &tasks)?;
        Ok(ForceControllerNode {
            task: base.task.clone(),
            asked: base.autostart,
            delays: LoopDelayMonitor::new(base.loop_delays.transport_delay_s),
            base,
            tasks,
            remap,
            ft_to_biotac,
            arm: None,
            controller: None,
            goal: false,
            withdrawing_since: None,
            calibration: None,
            force: Vector3::zeros(),
            last: None,
            rejected: 0,
            stale_halts: 0,
            delay_warned: false,
            guard: Arc::new(InputGuard::with_goals()),
            state: State::Active,
            goal_end: None,
            // Until `with_frames`: every wrench in the BioTac frame.
            frames: Frames::new(tool_frame::BIOTAC_FRAME, "", false)?,
            live_set: None,
        })
    }

    /// The node with the frames its wrenches must come in ([`frames`]).
    pub fn with_frames(self, frames: Frames) -> Self {
        ForceControllerNode { frames, ..self }
    }

    /// The node sharing the input bounds of `guard` (those a transport
    /// made its subscriptions with).
    pub fn with_guard(self, guard: Arc<InputGuard>) -> Self {
        ForceControllerNode { guard, ..self }
    }

    /// The parameters: the start-up ones with the live sets since.
    pub fn params(&self) -> &ControllerParams {
        &self.base
    }

    /// The tasks it can run.
    pub fn tasks(&self) -> &TaskRegistry {
        &self.tasks
    }

    /// The bounds of its input: what a transport asks before it hands the
    /// node a message, a goal or a parameter set.
    pub fn guard(&self) -> &Arc<InputGuard> {
        &self.guard
    }

    /// The controller, once a robot description has come.
    pub fn controller(&self) -> Option<&ForceController> {
        self.controller.as_ref()
    }

    /// The arm's joints on `joint_states`, in chain order (none before a
    /// description).
    pub fn joint_names(&self) -> &[String] {
        self.arm.as_ref().map_or(&[], |a| &a.names)
    }

    /// True while a task runs: a goal, or a task that has begun and not
    /// stopped.
    pub fn running(&self) -> bool {
        let begun = self
            .controller
            .as_ref()
            .is_some_and(ForceController::started);
        let stopped = self
            .last
            .as_ref()
            .is_some_and(|o| o.phase == Phase::STOPPED);
        self.goal || (begun && !stopped)
    }

    /// Takes a robot description: the controller is built for its arm with
    /// the task that runs now. The one in use is taken again without a
    /// word (Ok(false)); while a task runs, or for a description that is
    /// refused, the arm in use stays and the reason comes back.
    pub fn take_description(&mut self, text: &str) -> Result<bool, DescriptionError> {
        if self.arm.as_ref().is_some_and(|a| a.description == text) {
            return Ok(false);
        }
        if self.running() {
            return Err(DescriptionError::Running);
        }
        let robot = Robot::from_urdf(text, &self.base.robot)?;
        let names = joint_names(&robot, &self.remap)?;
        let c = self.built(&self.task, robot.clone())?;
        tracing::info!(
            "robot {}: {} -> {}, {} joints {names:?}; commanding it",
            robot.name,
            robot.links.0,
            robot.links.1,
            robot.dof()
        );
        self.controller = Some(c);
        self.arm = Some(Arm {
            robot,
            description: text.into(),
            names,
        });
        self.last = None;
        Ok(true)
    }

    /// How `task` runs outside a goal, on the parameters `base`.
    fn outside_goal(
        &self,
        task: &str,
        base: &ControllerParams,
    ) -> Result<OutsideGoal, ParamsError> {
        let p = ControllerParams {
            task: task.into(),
            ..base.clone()
        };
        self.tasks.get(task)?.outside_goal(p)
    }

    /// The controller of `task` outside a goal: still until asked, or,
    /// for a task that waits for its goal, until that goal.
    fn built(&self, task: &str, robot: Robot) -> Result<ForceController, ParamsError> {
        let OutsideGoal { params, waits } = self.outside_goal(task, &self.base)?;
        let mut c = ForceController::new(params, robot, &self.tasks)?;
        if waits {
            c.stop();
            tracing::info!("task {task}: the arm waits for a goal of its action");
        } else if !self.asked {
            c.stop();
            tracing::info!(
                "task {task}: commanding zero velocity until asked (a goal, or the parameter \
                 task set; autostart: false)"
            );
        }
        Ok(c)
    }

    /// Checks (`apply` false) or applies a value of the parameter `task`:
    /// the task starts (again, after it stopped), or Err says why it
    /// cannot. Without a robot description it is checked, and starts when
    /// one arrives.
    pub fn set_task(&mut self, name: &str, apply: bool) -> Result<(), String> {
        self.tasks.get(name).map_err(|e| e.to_string())?;
        self.not_acting()?;
        if self.goal {
            return Err("a goal is running (guarded_move or calibrate): cancel it first".into());
        }
        if name == self.task && self.running() {
            return Err(format!(
                "the task {name} is running: set another task to switch, or wait until it stops"
            ));
        }
        let asked = std::mem::replace(&mut self.asked, true);
        let c = match &self.arm {
            Some(arm) => Some(
                self.built(name, arm.robot.clone())
                    .map_err(|e| e.to_string())?,
            ),
            // Checked now, built when a description arrives.
            None => {
                self.outside_goal(name, &self.base)
                    .and_then(|o| ForceController::check(&o.params, &self.tasks))
                    .map_err(|e| e.to_string())?;
                None
            }
        };
        if !apply {
            self.asked = asked;
            return Ok(());
        }
        self.controller = c;
        self.task = name.into();
        self.last = None;
        match &self.arm {
            Some(_) => tracing::info!("task {name} started"),
            None => tracing::info!("task {name}: starts when the robot description arrives"),
        }
        Ok(())
    }

    /// Counts a message refused before it reached the node (`why`).
    pub fn reject(&mut self, why: &str) {
        self.rejected += 1;
        tracing::debug!("refused: {why}");
    }

    /// Takes the arm's joint positions.
    pub fn on_joint_state(&mut self, js: &JointState) {
        let Some(c) = self.controller.as_mut() else {
            return;
        };
        if let Err(e) = c.on_joint_state(js) {
            self.reject(&format!("joint_states: {e}"));
        }
    }

    /// True while BioTac readings are wanted: a calibration records them.
    pub fn wants_readings(&self) -> bool {
        self.calibration.is_some()
    }

    /// Takes a BioTac reading for the calibration's recording.
    pub fn on_reading(&mut self, r: BioTacReading) {
        if let Some(rec) = self.calibration.as_mut() {
            rec.on_reading(r);
        }
    }

    /// [`ForceControllerNode::on_force`] for a message as it came in
    /// `frame`: one that could not be read (`Err`, why) is counted (its
    /// frame unknown); one in another frame than its topic's is refused
    /// ([`frames`]). True when it stepped.
    pub fn on_force_msg(
        &mut self,
        part: ForcePart,
        frame: &str,
        msg: Result<Force, String>,
        now: f64,
    ) -> bool {
        let force = match msg {
            Ok(force) => force,
            Err(why) => {
                self.reject(&why);
                return false;
            }
        };
        if let Err((m, new)) = self.frames.check(part, frame) {
            return self.refuse_frame(part, m.to_string(), new, now);
        }
        self.on_force(force, now).is_some()
    }

    /// A wrench of `part` in the wrong frame (`why`): counted, said once
    /// (`new`); if the task running uses it, the task stops at `now` and
    /// the goal running ends with the reason: true, its zero command due.
    fn refuse_frame(&mut self, part: ForcePart, why: String, new: bool, now: f64) -> bool {
        self.reject(&why);
        if new {
            tracing::error!("{why}: refused, not used");
        }
        let used = (part == ForcePart::Ft) == self.calibration.is_some();
        if !(used && self.running() && self.not_acting().is_ok()) {
            return false;
        }
        self.stop_for(format!("refused: {why}"));
        let Some(c) = self.controller.as_mut() else {
            return false;
        };
        let out = c.tick(now);
        self.keep(out);
        true
    }

    /// Takes one message of the force (stamped with its reading, BioTac
    /// frame for the estimate) and steps at `now` when that makes a force:
    /// the estimate; while a calibration runs, the F/T wrench instead
    /// (moved to the BioTac frame, recorded with the push running), the
    /// estimates waiting.
    pub fn on_force(&mut self, force: Force, now: f64) -> Option<&ControlOutput> {
        let calibrating = self.calibration.is_some();
        let e = match force {
            Force::Estimate(e) if !calibrating => e,
            Force::Ft((stamp_s, w)) if calibrating => {
                let w = self.ft_to_biotac.map_or(w, |t| t.apply(&w));
                let task = self.controller.as_ref()?.task();
                let recorder = self.calibration.as_mut()?;
                recorder.on_ft_while(stamp_s, w, task)
            }
            _ => return None,
        };
        self.step_on(e, now)
    }

    /// Hands `e` to the controller and steps it; a refused estimate is
    /// counted and not stepped on (if none follows, the late-estimate halt
    /// stops the arm).
    fn step_on(&mut self, e: WrenchEstimate, now: f64) -> Option<&ControlOutput> {
        self.not_acting().ok()?;
        let c = self.controller.as_mut()?;
        if let Err(why) = c.on_estimate(e) {
            self.reject(&format!("estimate: {why}"));
            return None;
        }
        self.force = e.mean.force;
        self.delays.record(e.stamp_s, now);
        let out = c.tick(now);
        Some(self.keep(out))
    }

    /// Seconds from `now` until the newest estimate goes stale
    /// ([`ForceController::stale_after_s`]), at least a period: when to
    /// look again if none comes.
    pub fn until_stale_s(&self, now: f64) -> f64 {
        let period = self.base.control_period_s;
        let Some(c) = &self.controller else {
            return period;
        };
        let age = c.estimate_age_s(now).unwrap_or(f64::INFINITY);
        (c.stale_after_s() - age).max(period)
    }

    /// Called when no estimate came in time: once the newest is stale, zero
    /// velocity, the task paused, until estimates return (logged with the
    /// figures); None while it is not stale yet.
    pub fn on_late(&mut self, now: f64) -> Option<&ControlOutput> {
        self.not_acting().ok()?;
        let c = self.controller.as_mut()?;
        let age = c.estimate_age_s(now).unwrap_or(f64::INFINITY);
        if age < c.stale_after_s() {
            return None;
        }
        let out = c.estimate_late(now);
        Some(self.keep(out))
    }

    /// Logs what changed, counts a new stale-estimate halt (estimates that
    /// stopped coming; not the wait for the first) and keeps `out` as the
    /// last output.
    fn keep(&mut self, out: ControlOutput) -> &ControlOutput {
        let stale = |o: &ControlOutput| {
            matches!(o.halt, Some(Halt::Stale { what, age_s, .. })
                if what == "wrench estimate" && age_s.is_finite())
        };
        if stale(&out) && !self.last.as_ref().is_some_and(stale) {
            self.stale_halts += 1;
        }
        let refusal = self.controller.as_ref().and_then(|c| c.refusal());
        log_change(self.last.as_ref(), &out, refusal);
        self.last.insert(out)
    }

    /// What the node runs, for its start-up log line.
    pub fn summary(&self) -> Result<String, ParamsError> {
        let p = &self.base;
        let envelope = task_envelope(p, &self.tasks)?.envelope;
        Ok(format!(
            "task {} on {}, loop delays {:?}, speed limit {:.1} mm/s (safety envelope for the \
             stiffest permitted body, {:.1e} N/m)",
            p.task,
            p.object,
            p.loop_delays,
            envelope.max_speed_mps() * 1e3,
            envelope.stiffness_n_per_m,
        ))
    }
}

/// Logs a new phase (with the stop reason, and why a task was refused at
/// its start pose), a halt and the end of a halt.
fn log_change(before: Option<&ControlOutput>, now: &ControlOutput, refusal: Option<&str>) {
    let Some(before) = before else {
        if let Some(why) = refusal {
            tracing::error!("task refused at its start pose: {why}");
        }
        return;
    };
    if before.phase != now.phase {
        match now.reason {
            Some(r) => tracing::info!("phase {}: {}", now.phase.name(), r.name()),
            None => tracing::info!("phase {}", now.phase.name()),
        }
    }
    match (&before.halt, &now.halt) {
        (None, Some(h)) => tracing::warn!("halted, zero velocity: {h}"),
        (Some(_), None) => tracing::info!("inputs back: the task goes on"),
        _ => {}
    }
}

#[cfg(test)]
mod tests;
