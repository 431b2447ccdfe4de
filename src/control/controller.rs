//! The force controller: each cycle runs named stages, a halt ending it
//! with zero velocity:
//!
//! 1. estimate in (controller/inputs.rs): the newest wrench estimate and
//!    joint state, present, finite and fresh;
//! 2. checks: the stability rules ([`RuleChain`], src/control/rules.rs,
//!    each a [`crate::control::Rule`]): halt, stop the task, or soften it;
//! 3. task (a [`Task`] of the controller's [`TaskRegistry`]): the BioTac's
//!    velocity from the force, in the BioTac frame, its orientation held;
//! 4. inverse kinematics -> command (controller/joint_command.rs): the joint
//!    velocities by an [`InverseKinematics`], the damped least-squares
//!    inverse unless [`ForceController::with_inverse`] gives another.
//!
//! There is no filter stage: the estimate's own std is what the rules and
//! the tasks read. An arm with fewer than six joints runs a task only if it
//! can move the BioTac along each of the task's directions at the start
//! pose; otherwise the task stops at once (`unrealisable_axis`), and
//! [`ForceController::check_start`] names the axis before a run. A cycle
//! allocates nothing: the command is read with [`ForceController::command`].

use nalgebra::{Isometry3, Vector3};

use super::identify::{ArmResponse, LoopMeter};
use super::rules::{RuleInput, Verdict};
use super::task::{missing_axis, TaskInput, TaskRegistry};
use super::{
    Arrivals, ControllerParams, Envelope, Goal, Halt, LoopTiming, Phase, RuleChain, StopReason,
    Task,
};
use crate::kinematics::{Dls, JointVector, Robot, Twist};
use crate::params::ParamsError;
use crate::wrench::{Axis, AxisSet, WrenchEstimate};
use inputs::{Inputs, Reading};
use joint_command::JointCommand;
pub use joint_command::{InverseKinematics, Made};
pub use sections::task_envelope;
use sections::{stiffest_permitted, Sections};

/// The controller's own stop reason, whatever the task.
impl StopReason {
    /// The arm (fewer than six joints) cannot move the BioTac along an
    /// axis of the task at its start pose.
    pub const UNREALISABLE: StopReason = StopReason::named("unrealisable_axis");
}

/// A motion an arm with fewer than six joints may leave undone, as a
/// fraction of the commanded motion, for a task direction to count as
/// realisable at the start pose.
pub const REALISABLE_TOLERANCE: f64 = 0.01;

/// Joint positions at a time (the `joint_states` topic).
#[derive(Debug, Clone, PartialEq)]
pub struct JointState {
    /// Time of the measurement (s).
    pub stamp_s: f64,
    /// Joint positions (rad or m), one per joint in chain order.
    pub q: JointVector,
}

/// What the controller commands this tick (the joint velocities are
/// [`ForceController::command`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ControlOutput {
    /// Commanded BioTac velocity (m/s, BioTac frame at the start of the run).
    pub velocity: Vector3<f64>,
    /// Task phase.
    pub phase: Phase,
    /// Why the task stopped, if it did.
    pub reason: Option<StopReason>,
    /// Why the arm is halted this tick, if it is.
    pub halt: Option<Halt>,
    /// Desired force along x, y, z of the BioTac frame, on controlled axes (N).
    pub targets: [Option<f64>; 3],
    /// Damping factor of the inverse kinematics (0: away from singularity).
    pub damping: f64,
}

/// The force controller.
#[derive(Debug, Clone)]
pub struct ForceController {
    robot: Robot,
    /// Estimate in.
    inputs: Inputs,
    /// Checks: the stability rules, run before the task each cycle.
    rules: RuleChain,
    task: Box<dyn Task>,
    /// Inverse kinematics -> command.
    out: JointCommand,
    axes: AxisSet,
    /// Estimates may come this many of their periods late (`stale_periods`).
    stale_periods: f64,
    meter: LoopMeter,
    envelope: Envelope,
    period_s: f64,
    start: Option<Isometry3<f64>>,
    last_tick: Option<f64>,
    refusal: Option<String>,
}

/// The task of checked parameters, its envelope and the force axes it reads.
struct CheckedTask {
    task: Box<dyn Task>,
    envelope: Envelope,
    needed: Vec<Axis>,
}

impl CheckedTask {
    /// Checks every parameter but the robot's and builds the task of
    /// `tasks`.
    fn new(p: &ControllerParams, tasks: &TaskRegistry) -> Result<Self, ParamsError> {
        let sections = Sections::check(p, tasks)?;
        let speed = sections.envelope(p)?;
        speed.check()?;
        // The gains' prior until the contact is measured: the stiffest body
        // the scene permits (the object of the run does not set them).
        let (body, _) = stiffest_permitted(p, &sections.safety)?;
        let task = sections.build(p, &body)?;
        let needed = task.force_axes();
        if let Some(axis) = needed.iter().find(|a| !p.axes.axes().contains(a)) {
            return Err(missing_axis(&p.axes, *axis));
        }
        Ok(CheckedTask {
            task,
            envelope: speed.envelope,
            needed,
        })
    }
}

impl ForceController {
    /// Checks every parameter but the robot's (`robot.*` is checked with
    /// the robot description), the task one of `tasks`: what a ROS node
    /// does at start-up, before a description arrives.
    pub fn check(p: &ControllerParams, tasks: &TaskRegistry) -> Result<(), ParamsError> {
        CheckedTask::new(p, tasks).map(|_| ())
    }

    /// The controller that runs `goal` applied to `base`, or why the goal
    /// is refused (a value out of range, an unknown surface, a speed beyond
    /// the safety envelope).
    pub fn for_goal(
        goal: &impl Goal,
        base: &ControllerParams,
        robot: Robot,
        tasks: &TaskRegistry,
    ) -> Result<Self, ParamsError> {
        Self::new(goal.apply(base)?, robot, tasks)
    }

    /// Checks the parameters and builds the controller for `robot` (built
    /// from the robot description with `p.robot`), its task one of `tasks`.
    pub fn new(
        p: ControllerParams,
        robot: Robot,
        tasks: &TaskRegistry,
    ) -> Result<Self, ParamsError> {
        let CheckedTask {
            task,
            envelope,
            needed,
        } = CheckedTask::new(&p, tasks)?;
        Ok(ForceController {
            inputs: Inputs::new(&p, needed),
            rules: RuleChain::shipped(&p.oscillation),
            task,
            out: JointCommand::new(&robot, Box::new(Dls::new(&robot))),
            robot,
            axes: p.axes,
            stale_periods: p.stale_periods,
            meter: LoopMeter::new(LoopTiming {
                transport_s: p.loop_delays.transport_delay_s,
                latency_s: p.loop_delays.command_latency_s,
                lag_s: p.loop_delays.arm_lag_s,
                period_s: p.control_period_s,
            }),
            envelope,
            period_s: p.control_period_s,
            start: None,
            last_tick: None,
            refusal: None,
        })
    }

    /// The controller running the rules of `extra` after the shipped
    /// stability rules.
    pub fn with_rules(mut self, extra: &RuleChain) -> Self {
        self.rules.extend(extra);
        self
    }

    /// The controller with `inverse` as its inverse kinematics instead of
    /// the damped least-squares inverse.
    pub fn with_inverse(mut self, inverse: impl InverseKinematics + 'static) -> Self {
        self.out = JointCommand::new(&self.robot, Box::new(inverse));
        self
    }

    /// The axes the task controls.
    pub fn axes(&self) -> &AxisSet {
        &self.axes
    }

    /// The robot.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// The joint velocities of the last tick (rad/s or m/s, one per joint in
    /// chain order); zero when halted or stopped.
    pub fn command(&self) -> &JointVector {
        self.out.command()
    }

    /// Takes changed parameters `p` (the task's and the stability rules'
    /// settings; checked as at start-up, the task the one running) while
    /// the task runs, if the task can take them at once
    /// ([`Task::retune`]): Ok(true). Ok(false): the task keeps its own
    /// settings, and `p` applies from its next start. Err: `p` is refused.
    pub fn retune(
        &mut self,
        p: &ControllerParams,
        tasks: &TaskRegistry,
    ) -> Result<bool, ParamsError> {
        let fresh = CheckedTask::new(p, tasks)?;
        if !self.task.retune(fresh.task.as_ref()) {
            return Ok(false);
        }
        self.envelope = fresh.envelope;
        self.rules.retune(&p.oscillation);
        self.inputs.retune(p.out_of_range);
        Ok(true)
    }

    /// Goes on from what `before` measured of the loop (same arm and link).
    pub fn measured_from(&mut self, before: &ForceController) {
        self.meter.carry_on(&before.meter);
    }

    /// The task running.
    pub fn task(&self) -> &dyn Task {
        self.task.as_ref()
    }

    /// The BioTac's twist of the last tick (base frame, m/s and rad/s: zero
    /// angular velocity, the orientation held); zero when halted or stopped.
    /// What an arm driven by a Cartesian controller is sent instead of
    /// [`ForceController::command`].
    pub fn twist(&self) -> &Twist {
        self.out.twist()
    }

    /// True once the task has begun (a first tick with fresh inputs).
    pub fn started(&self) -> bool {
        self.start.is_some()
    }

    /// Why the task was refused at its start pose, if it was
    /// ([`StopReason::UNREALISABLE`]).
    pub fn refusal(&self) -> Option<&str> {
        self.refusal.as_deref()
    }

    /// Refuses a start pose `q` at which an arm with fewer than six joints
    /// cannot move the BioTac along a direction of the task while holding
    /// its orientation, naming the direction. Arms with six joints or more
    /// pass (near a singularity the damping slows them instead).
    pub fn check_start(&mut self, q: &JointVector) -> Result<(), ParamsError> {
        self.out.realisable(&self.robot, self.task.as_ref(), q)
    }

    /// Proportional gain of each force axis x, y, z (m/s per N), None where
    /// not controlled. For the guarded move, the gain along its direction is
    /// reported on the axis it mostly points along.
    pub fn gains(&self) -> [Option<f64>; 3] {
        self.task.gains()
    }

    /// The safety envelope the task's speed was checked against: the
    /// guarded move's approach, or the guided move's tightest axis.
    pub fn envelope(&self) -> &Envelope {
        &self.envelope
    }

    /// Inputs rejected for NaN or infinity so far.
    pub fn rejected(&self) -> u64 {
        self.inputs.rejected()
    }

    /// Takes an estimate; a non-finite one is rejected (the previous one
    /// then ages and the watchdog stops the arm).
    pub fn on_estimate(&mut self, e: WrenchEstimate) -> Result<(), Halt> {
        self.inputs.on_estimate(e)
    }

    /// Takes the joint positions (copied: no heap work after the first);
    /// non-finite ones, or not one per joint, are rejected.
    pub fn on_joint_state(&mut self, js: &JointState) -> Result<(), Halt> {
        self.inputs.on_joint_state(js, self.robot.dof())?;
        let p = self.robot.chain.forward(&js.q).translation.vector;
        self.meter.on_position(js.stamp_s, p);
        Ok(())
    }

    /// The loop's timing as measured so far (the delays' bounds until then).
    pub fn timing(&self) -> &LoopTiming {
        self.meter.timing()
    }

    /// The arm's latency and lag, once fitted from its motion.
    pub fn arm_response(&self) -> Option<ArmResponse> {
        self.meter.arm()
    }

    /// The newest estimate's age at `now` (s), once one has come.
    pub fn estimate_age_s(&self, now: f64) -> Option<f64> {
        self.inputs.estimate().map(|e| now - e.stamp_s)
    }

    /// How old the newest estimate may be before the arm halts (s): its usual
    /// age, `stale_periods` of its stream's periods, jitter (control/window.rs).
    pub fn stale_after_s(&self) -> f64 {
        self.meter.stale_after_s(self.stale_periods)
    }

    /// How the estimates arrive.
    pub fn arrivals(&self) -> &Arrivals {
        self.meter.arrivals()
    }

    /// Stops the task where it is: every later tick commands zero velocity.
    pub fn stop(&mut self) {
        self.task.stop();
    }

    /// A canceled goal: the task leaves contact, then stops
    /// ([`Task::withdraw`]).
    pub fn withdraw(&mut self) {
        self.task.withdraw();
    }

    /// One control cycle at time `now` (s).
    pub fn tick(&mut self, now: f64) -> ControlOutput {
        let dt = self.last_tick.map_or(self.period_s, |t| now - t);
        self.last_tick = Some(now);
        if let Some(e) = self.inputs.estimate() {
            self.meter.on_arrival(now, e.stamp_s);
        }
        match self.step(now, dt) {
            Ok((velocity, damping)) => self.output(velocity, damping, None),
            Err(halt) => self.halt(now, halt),
        }
    }

    /// A cycle in which no estimate came for longer than
    /// [`ForceController::stale_after_s`] allows (a controller that steps on
    /// each estimate): zero velocity, the task paused, until one comes.
    pub fn estimate_late(&mut self, now: f64) -> ControlOutput {
        self.last_tick = Some(now);
        let age_s = self.estimate_age_s(now).unwrap_or(f64::INFINITY);
        self.halt(
            now,
            Halt::Stale {
                what: "wrench estimate",
                age_s,
                max_age_s: self.stale_after_s(),
            },
        )
    }

    fn halt(&mut self, now: f64, halt: Halt) -> ControlOutput {
        self.task.pause();
        self.rules.pause();
        self.out.zero();
        self.meter.on_step(now, Vector3::zeros(), None);
        self.output(Vector3::zeros(), 0.0, Some(halt))
    }

    /// One cycle's stages: estimate in -> checks -> task -> inverse
    /// kinematics -> command. The commanded velocity (start frame) and the
    /// damping come back; a halt stops the cycle where it is raised.
    fn step(&mut self, now: f64, dt: f64) -> Result<(Vector3<f64>, f64), Halt> {
        let r = self.inputs.read(now)?;
        self.run_rules(&r, now, dt)?;
        let js = self.inputs.step_on(&r)?;
        // The task, in the BioTac frame; at its first step, refused if the
        // arm cannot make its directions.
        let pose = self.robot.chain.forward(&js.q);
        if self.start.is_none() {
            if let Err(e) = self.out.realisable(&self.robot, self.task.as_ref(), &js.q) {
                self.task.stop_on(StopReason::UNREALISABLE);
                self.refusal = Some(e.to_string());
            }
        }
        let start = *self.start.get_or_insert(pose);
        let timing = *self.meter.timing();
        let twist = self.task.step(&TaskInput {
            force: &r.est.mean.force,
            pdc_rise: r.est.pdc_rise,
            pose: &pose,
            start: &start,
            dt,
            fresh: r.fresh,
            force_position: self.meter.position_at(r.est.stamp_s),
            force_velocity: self.meter.velocity_at(r.est.stamp_s),
            timing: &timing,
        });
        let made = self.out.solve(&self.robot, &js.q, twist)?;
        let v_world = Vector3::new(twist[0], twist[1], twist[2]) * made.scale;
        self.meter
            .on_step(now, v_world, r.fresh.then_some(now - r.est.stamp_s));
        // What the arm will do after the speed scaling, in the start frame.
        Ok((start.rotation.inverse() * v_world, made.damping))
    }

    /// The stability rules on the reading `r`: a halt ends the cycle; a
    /// stop or an oscillation goes to the task.
    fn run_rules(&mut self, r: &Reading, now: f64, dt: f64) -> Result<(), Halt> {
        let input = RuleInput {
            force: &r.est.mean.force,
            out_of_range: r.out_of_range,
            estimate_age_s: now - r.est.stamp_s,
            stale_after_s: self.stale_after_s(),
            limit: self.task.force_limit(),
            watch: self.task.watch(),
            dt,
            fresh: r.fresh,
        };
        match self.rules.check(&input) {
            Some(Verdict::Halt(halt)) => return Err(halt),
            Some(Verdict::Stop(reason)) => self.task.abort(reason),
            Some(Verdict::Oscillating(hz)) => self.task.soften(hz),
            None => {}
        }
        Ok(())
    }

    fn output(&self, velocity: Vector3<f64>, damping: f64, halt: Option<Halt>) -> ControlOutput {
        ControlOutput {
            velocity,
            damping,
            phase: self.task.phase(),
            reason: self.task.reason(),
            halt,
            targets: self.task.targets(),
        }
    }
}

mod inputs;
mod joint_command;
mod sections;

#[cfg(test)]
mod tests;
