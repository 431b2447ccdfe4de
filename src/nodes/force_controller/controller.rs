//! The force controller node: each tick it checks its inputs (present and
//! finite, else zero velocity), runs the stability rules, then the task (one
//! of its registry) in the BioTac frame, and turns the BioTac's velocity
//! into joint velocities with the damped least-squares inverse. The
//! BioTac's orientation is held (zero angular velocity). An arm with fewer than six joints runs a task only if
//! it can move the BioTac along each of the task's directions at the start
//! pose; otherwise the task stops at once (`unrealisable_axis`), and
//! [`ForceController::check_start`] names the axis before a run.
//!
//! Update pipeline: inputs -> stability rules (control/rules.rs) -> task ->
//! twist (base frame) -> DLS -> command. A tick allocates nothing: the
//! command is read with [`ForceController::command`].

use nalgebra::{Isometry3, Vector3};

use crate::control::identify::{ArmResponse, LoopMeter};
use crate::control::rules::{RuleInput, Verdict};
use crate::control::task::{missing_axis, TaskInput, TaskRegistry};
use crate::control::{
    Arrivals, ControllerParams, Envelope, Goal, Halt, LoopTiming, OutOfRangeParams, Phase,
    RuleChain, StopReason, Task, Watchdog,
};
use crate::kinematics::{Dls, JointVector, Robot, Twist};
use crate::nodes::{tasks, JointState};
use crate::params::ParamsError;
use crate::wrench::{Axis, AxisSet, WrenchEstimate};
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
    dls: Dls,
    command: JointVector,
    twist: Twist,
    task: Box<dyn Task>,
    axes: AxisSet,
    task_axes: Vec<Axis>,
    out_of_range: OutOfRangeParams,
    /// The stability rules run before the task each cycle.
    rules: RuleChain,
    /// The joint states' age limit.
    watchdog: Watchdog,
    /// Estimates may come this many of their periods late (`stale_periods`).
    stale_periods: f64,
    meter: LoopMeter,
    envelope: Envelope,
    period_s: f64,
    estimate: Option<WrenchEstimate>,
    /// The stamp of the estimate last stepped on.
    stepped_stamp: Option<f64>,
    joints: Option<JointState>,
    start: Option<Isometry3<f64>>,
    last_tick: Option<f64>,
    rejected: u64,
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
    /// the robot description): what a ROS node does at start-up, before a
    /// description arrives. The task is one of the shipped ones.
    pub fn check(p: &ControllerParams) -> Result<(), ParamsError> {
        Self::check_with(p, &tasks::shipped())
    }

    /// [`ForceController::check`] for a task of `tasks`.
    pub fn check_with(p: &ControllerParams, tasks: &TaskRegistry) -> Result<(), ParamsError> {
        CheckedTask::new(p, tasks).map(|_| ())
    }

    /// Checks the parameters and builds the controller for `robot` (built
    /// from the robot description with `p.robot`), its task one of the
    /// shipped ones.
    pub fn new(p: ControllerParams, robot: Robot) -> Result<Self, ParamsError> {
        Self::with_tasks(p, robot, &tasks::shipped())
    }

    /// The controller that runs `goal` applied to `base`, or why the goal
    /// is refused (a value out of range, an unknown surface, a speed beyond
    /// the safety envelope).
    pub fn for_goal(
        goal: &impl Goal,
        base: &ControllerParams,
        robot: Robot,
    ) -> Result<Self, ParamsError> {
        Self::new(goal.apply(base)?, robot)
    }

    /// [`ForceController::new`] for a task of `tasks`.
    pub fn with_tasks(
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
            dls: Dls::new(&robot),
            command: JointVector::zeros(robot.dof()),
            robot,
            task,
            axes: p.axes,
            task_axes: needed,
            out_of_range: p.out_of_range,
            rules: RuleChain::shipped(&p.oscillation),
            // Inputs arrive the transport delay after their stamp.
            watchdog: Watchdog::new(
                p.stale_periods + p.loop_delays.transport_delay_s / p.control_period_s,
                p.control_period_s,
            ),
            stale_periods: p.stale_periods,
            meter: LoopMeter::new(LoopTiming {
                transport_s: p.loop_delays.transport_delay_s,
                latency_s: p.loop_delays.command_latency_s,
                lag_s: p.loop_delays.arm_lag_s,
                period_s: p.control_period_s,
            }),
            envelope,
            period_s: p.control_period_s,
            twist: Twist::zeros(),
            estimate: None,
            stepped_stamp: None,
            joints: None,
            start: None,
            last_tick: None,
            rejected: 0,
            refusal: None,
        })
    }

    /// The controller running the rules of `extra` after the shipped
    /// stability rules.
    pub fn with_rules(mut self, extra: &RuleChain) -> Self {
        self.rules.extend(extra);
        self
    }

    /// A controller for the task `task` with the other parameters of
    /// `base`: a task switch while running, checked as at start-up (the
    /// other task's section, its safety envelope against the scene's
    /// bodies).
    pub fn switched(
        base: &ControllerParams,
        task: &str,
        robot: Robot,
    ) -> Result<Self, ParamsError> {
        ForceController::new(
            ControllerParams {
                task: task.into(),
                ..base.clone()
            },
            robot,
        )
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
        &self.command
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
        &self.twist
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
        realisable(&self.robot, &mut self.dls, self.task.as_ref(), q)
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
        self.rejected
    }

    /// Takes an estimate; a non-finite one is rejected (the previous one
    /// then ages and the watchdog stops the arm).
    pub fn on_estimate(&mut self, e: WrenchEstimate) -> Result<(), Halt> {
        if !e.is_finite() {
            self.rejected += 1;
            return Err(Halt::NonFinite("the wrench estimate"));
        }
        self.estimate = Some(e);
        Ok(())
    }

    /// Takes the joint positions (copied: no heap work after the first);
    /// non-finite ones, or not one per joint, are rejected.
    pub fn on_joint_state(&mut self, js: &JointState) -> Result<(), Halt> {
        if js.q.len() != self.robot.dof() {
            self.rejected += 1;
            return Err(Halt::JointCount {
                expected: self.robot.dof(),
                found: js.q.len(),
            });
        }
        if !(js.stamp_s.is_finite() && js.q.iter().all(|v| v.is_finite())) {
            self.rejected += 1;
            return Err(Halt::NonFinite("the joint state"));
        }
        match &mut self.joints {
            Some(j) => {
                j.stamp_s = js.stamp_s;
                j.q.copy_from(&js.q);
            }
            None => self.joints = Some(js.clone()),
        }
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
        self.estimate.map(|e| now - e.stamp_s)
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
        if let Some(e) = &self.estimate {
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
        let age_s = self.estimate.map_or(f64::INFINITY, |e| now - e.stamp_s);
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
        self.command.fill(0.0);
        self.twist = Twist::zeros();
        self.meter.on_step(now, Vector3::zeros(), None);
        self.output(Vector3::zeros(), 0.0, Some(halt))
    }

    /// One step of the task; the command goes to `self.command`, the
    /// commanded velocity and the damping come back.
    fn step(&mut self, now: f64, dt: f64) -> Result<(Vector3<f64>, f64), Halt> {
        let js = self.joints.as_ref().ok_or(Halt::Missing("joint state"))?;
        self.watchdog.check("joint state", now, Some(js.stamp_s))?;
        let est = self.estimate.ok_or(Halt::Missing("wrench estimate"))?;
        let fresh = self.stepped_stamp != Some(est.stamp_s);
        let rules = RuleInput {
            force: &est.mean.force,
            out_of_range: self.is_out_of_range(&est),
            estimate_age_s: now - est.stamp_s,
            stale_after_s: self.stale_after_s(),
            limit: self.task.force_limit(),
            watch: self.task.watch(),
            dt,
            fresh,
        };
        match self.rules.check(&rules) {
            Some(Verdict::Halt(halt)) => return Err(halt),
            Some(Verdict::Stop(reason)) => self.task.abort(reason),
            Some(Verdict::Oscillating(hz)) => self.task.soften(hz),
            None => {}
        }
        self.stepped_stamp = Some(est.stamp_s);
        let pose = self.robot.chain.forward(&js.q);
        if self.start.is_none() {
            if let Err(e) = realisable(&self.robot, &mut self.dls, self.task.as_ref(), &js.q) {
                self.task.stop_on(StopReason::UNREALISABLE);
                self.refusal = Some(e.to_string());
            }
        }
        let start = *self.start.get_or_insert(pose);
        let timing = *self.meter.timing();
        self.twist = self.task.step(&TaskInput {
            force: &est.mean.force,
            pdc_rise: est.pdc_rise,
            pose: &pose,
            start: &start,
            dt,
            fresh,
            force_position: self.meter.position_at(est.stamp_s),
            force_velocity: self.meter.velocity_at(est.stamp_s),
            timing: &timing,
        });
        let age = fresh.then_some(now - est.stamp_s);
        let v_world: Vector3<f64> = self.twist.fixed_rows::<3>(0).into();
        if self.twist == Twist::zeros() {
            self.command.fill(0.0);
            self.meter.on_step(now, v_world, age);
            return Ok((v_world, 0.0));
        }
        let motion = self.dls.solve(&self.robot, &js.q, &self.twist, None)?;
        self.command.copy_from(self.dls.qdot());
        self.meter.on_step(now, v_world * motion.scale, age);
        // What the arm will do after the speed scaling, in the start frame.
        let velocity = start.rotation.inverse() * v_world * motion.scale;
        Ok((velocity, motion.damping))
    }

    /// True when a controlled axis is too uncertain or PDC nearly saturated.
    fn is_out_of_range(&self, est: &WrenchEstimate) -> bool {
        let limits = &self.out_of_range;
        let uncertain = self
            .task_axes
            .iter()
            .any(|a| est.std.get(*a) > limits.max_std_n);
        uncertain || est.pdc_rise > limits.max_pdc_rise_counts
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

/// Refuses a pose `q` at which an arm with fewer than six joints cannot
/// move the BioTac along a direction of `task` (see
/// [`ForceController::check_start`]).
fn realisable(
    robot: &Robot,
    dls: &mut Dls,
    task: &dyn Task,
    q: &JointVector,
) -> Result<(), ParamsError> {
    let dof = robot.dof();
    if dof >= 6 {
        return Ok(());
    }
    let pose = robot.chain.forward(q);
    for (name, d) in task.directions() {
        let v = pose.rotation * d;
        let unmade = dls.unmade(robot, q, &Twist::new(v.x, v.y, v.z, 0.0, 0.0, 0.0));
        if unmade > REALISABLE_TOLERANCE {
            return Err(ParamsError::Invalid {
                key: "start pose".into(),
                value: format!("{:?} rad", q.as_slice()),
                expected: format!(
                    "a pose where the arm ({dof} joints) can move the BioTac along {name} \
                     while holding its orientation: {:.0} % of that motion cannot be made \
                     (at most {:.0} %); choose another start pose or a task without that axis",
                    unmade * 100.0,
                    REALISABLE_TOLERANCE * 100.0
                ),
            });
        }
    }
    Ok(())
}

mod sections;

#[cfg(test)]
mod tests;
