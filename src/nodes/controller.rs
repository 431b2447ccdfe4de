//! The force controller node: each tick it checks its inputs (fresh and
//! finite, else zero velocity), runs the task (guarded or guided move) in the
//! BioTac frame, and turns the BioTac's velocity into joint velocities with
//! the damped least-squares inverse. The BioTac's orientation is held (zero
//! angular velocity).
//!
//! Update pipeline: inputs -> watchdog -> task -> twist (base frame) -> DLS -> command.

use std::collections::BTreeMap;

use nalgebra::{Isometry3, Vector3};
use serde::Deserialize;

use super::{JointState, WrenchEstimate};
use crate::control::guarded::GuardedInput;
use crate::control::{
    GuardedMove, GuardedParams, GuidedMove, GuidedParams, Halt, PdParams, Phase, StopReason,
    Watchdog,
};
use crate::kinematics::{joint_velocities, JointVector, Robot, RobotParams, Twist};
use crate::params::ParamsError;
use crate::sim::contact::{object_body, positive, series_stiffness, BodyParams, SkinParams};
use crate::wrench::{Axis, AxisSet};

/// Which task the controller runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TaskKind {
    /// Approach, touch, hold a force.
    Guarded,
    /// Follow a person's finger.
    Guided,
}

/// The `force_controller` parameters (robot file + scene file).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerParams {
    /// Sensing and control period (s).
    pub control_period_s: f64,
    /// The BioTac skin law.
    pub skin: SkinParams,
    /// Objects the arm may touch, by name.
    pub objects: BTreeMap<String, BodyParams>,
    /// The object of this run: its stiffness sets the gains.
    pub object: String,
    /// The arm.
    pub robot: RobotParams,
    /// Estimates older than this many periods stop the arm.
    pub stale_periods: f64,
    /// When the estimate cannot be trusted.
    pub out_of_range: OutOfRangeParams,
    /// Wrench axes the task controls (and the estimator must provide).
    pub axes: AxisSet,
    /// The task.
    pub task: TaskKind,
    /// PD law.
    pub pd: PdParams,
    /// Guarded-move settings (needed when `task` is guarded).
    pub guarded: Option<GuardedParams>,
    /// Guided-move settings (needed when `task` is guided).
    pub guided: Option<GuidedParams>,
}

/// Limits beyond which the BioTac input is outside what the estimator
/// knows. Far from its training data a GP's mean falls back to the prior
/// (zero force) while its standard deviation grows, and PDC saturates with
/// force (architecture page): either means the force may be larger than
/// estimated, so the task stops (guarded: retracts).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct OutOfRangeParams {
    /// Largest trusted standard deviation on a controlled axis (N).
    pub max_std_n: f64,
    /// Largest trusted PDC rise above the tare (counts).
    pub max_pdc_rise_counts: f64,
}

/// The running task.
#[derive(Debug, Clone, PartialEq)]
enum Task {
    Guarded(GuardedMove),
    Guided(GuidedMove),
}

/// What the controller commands this tick.
#[derive(Debug, Clone, PartialEq)]
pub struct ControlOutput {
    /// Joint velocities (rad/s); zero when halted.
    pub qdot: JointVector,
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
}

/// The force controller.
#[derive(Debug, Clone)]
pub struct ForceController {
    robot: Robot,
    task: Task,
    axes: AxisSet,
    task_axes: Vec<Axis>,
    out_of_range: OutOfRangeParams,
    watchdog: Watchdog,
    period_s: f64,
    estimate: Option<WrenchEstimate>,
    joints: Option<JointState>,
    start: Option<Isometry3<f64>>,
    last_tick: Option<f64>,
    rejected: u64,
}

impl ForceController {
    /// Checks the parameters and builds the controller.
    pub fn new(p: ControllerParams) -> Result<Self, ParamsError> {
        positive("control_period_s", p.control_period_s)?;
        positive("stale_periods", p.stale_periods)?;
        positive("out_of_range.max_std_n", p.out_of_range.max_std_n)?;
        positive(
            "out_of_range.max_pdc_rise_counts",
            p.out_of_range.max_pdc_rise_counts,
        )?;
        p.skin.validate("skin")?;
        p.pd.validate()?;
        let body = object_body(&p.objects, &p.object)?;
        let robot = p.robot.validate()?;
        let missing = |what: &str| ParamsError::Invalid {
            key: what.into(),
            value: "absent".into(),
            expected: format!("a `{what}` section for this task"),
        };
        let task = match p.task {
            TaskKind::Guarded => {
                let g = p.guarded.ok_or_else(|| missing("guarded"))?.validate()?;
                let k = series_stiffness(&p.skin, &body, g.target_force_n);
                Task::Guarded(GuardedMove::new(g, &p.pd, k, p.control_period_s))
            }
            TaskKind::Guided => {
                let g = p.guided.ok_or_else(|| missing("guided"))?.validate()?;
                let normal = series_stiffness(&p.skin, &body, g.target_force_n[2]);
                let shear =
                    1.0 / (1.0 / p.skin.shear_stiffness_n_per_m + 1.0 / body.stiffness_n_per_m);
                let on = |axis| p.axes.axes().contains(&axis);
                let k = [
                    on(Axis::Fx).then_some(shear),
                    on(Axis::Fy).then_some(shear),
                    on(Axis::Fz).then_some(normal),
                ];
                Task::Guided(GuidedMove::new(g, &p.pd, k, p.control_period_s))
            }
        };
        let needed = needed_axes(&task);
        if let Some(axis) = needed.iter().find(|a| !p.axes.axes().contains(a)) {
            return Err(invalid_axes(&p.axes, *axis));
        }
        Ok(ForceController {
            robot,
            task,
            axes: p.axes,
            task_axes: needed,
            out_of_range: p.out_of_range,
            watchdog: Watchdog::new(p.stale_periods, p.control_period_s),
            period_s: p.control_period_s,
            estimate: None,
            joints: None,
            start: None,
            last_tick: None,
            rejected: 0,
        })
    }

    /// The axes the task controls.
    pub fn axes(&self) -> &AxisSet {
        &self.axes
    }

    /// The robot.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// Proportional gain of each force axis x, y, z (m/s per N), None where
    /// not controlled. For the guarded move, the gain along its direction is
    /// reported on the axis it mostly points along.
    pub fn gains(&self) -> [Option<f64>; 3] {
        match &self.task {
            Task::Guarded(g) => {
                let d = g.direction();
                let mut out = [None; 3];
                out[d.iamax()] = Some(g.pd().gain());
                out
            }
            Task::Guided(g) => g.gains(),
        }
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

    /// Takes the joint positions; non-finite ones are rejected.
    pub fn on_joint_state(&mut self, js: JointState) -> Result<(), Halt> {
        if !(js.stamp_s.is_finite() && js.q.iter().all(|v| v.is_finite())) {
            self.rejected += 1;
            return Err(Halt::NonFinite("the joint state"));
        }
        self.joints = Some(js);
        Ok(())
    }

    /// One control cycle at time `now` (s).
    pub fn tick(&mut self, now: f64) -> ControlOutput {
        let dt = self.last_tick.map_or(self.period_s, |t| now - t);
        self.last_tick = Some(now);
        match self.step(now, dt) {
            Ok((qdot, velocity)) => self.output(qdot, velocity, None),
            Err(halt) => {
                match &mut self.task {
                    Task::Guarded(g) => g.pause(),
                    Task::Guided(g) => g.pause(),
                }
                self.output(JointVector::zeros(), Vector3::zeros(), Some(halt))
            }
        }
    }

    fn step(&mut self, now: f64, dt: f64) -> Result<(JointVector, Vector3<f64>), Halt> {
        let w = self.watchdog;
        let js = self.joints.ok_or(Halt::Missing("joint state"))?;
        w.check("joint state", now, Some(js.stamp_s))?;
        let est = self.estimate.ok_or(Halt::Missing("wrench estimate"))?;
        w.check("wrench estimate", now, Some(est.stamp_s))?;
        let out_of_range = self.is_out_of_range(&est);
        let pose = self.robot.chain.forward(&js.q);
        let start = *self.start.get_or_insert(pose);
        let v_world = match &mut self.task {
            Task::Guarded(g) => {
                let d_tool = g.direction();
                let d_world = start.rotation * d_tool;
                let input = GuardedInput {
                    force_n: -d_tool.dot(&est.mean.force),
                    pdc_rise: est.pdc_rise,
                    travelled_m: (pose.translation.vector - start.translation.vector).dot(&d_world),
                    out_of_range,
                    dt,
                };
                d_world * g.step(&input)
            }
            Task::Guided(g) => pose.rotation * g.step(&est.mean.force, out_of_range, dt),
        };
        if v_world == Vector3::zeros() {
            return Ok((JointVector::zeros(), v_world));
        }
        let twist = Twist::new(v_world.x, v_world.y, v_world.z, 0.0, 0.0, 0.0);
        let motion = joint_velocities(&self.robot, &js.q, &twist, None)
            .map_err(|e| Halt::Kinematics(e.to_string()))?;
        // What the arm will do after the speed scaling, in the start frame.
        let velocity = start.rotation.inverse() * v_world * motion.scale;
        Ok((motion.qdot, velocity))
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

    fn output(
        &self,
        qdot: JointVector,
        velocity: Vector3<f64>,
        halt: Option<Halt>,
    ) -> ControlOutput {
        let (phase, reason, targets) = match &self.task {
            Task::Guarded(g) => {
                let d = g.direction();
                let mut t = [None; 3];
                t[d.iamax()] = Some(g.target_force_n() * -d[d.iamax()]);
                (g.phase(), g.reason(), t)
            }
            Task::Guided(g) => (g.phase(), g.reason(), g.targets()),
        };
        ControlOutput {
            qdot,
            velocity,
            phase,
            reason,
            halt,
            targets,
        }
    }
}

/// Force axes a task reads.
fn needed_axes(task: &Task) -> Vec<Axis> {
    let forces = [Axis::Fx, Axis::Fy, Axis::Fz];
    match task {
        Task::Guarded(g) => {
            let d = g.direction();
            forces.into_iter().filter(|a| d[a.index()] != 0.0).collect()
        }
        Task::Guided(g) => forces
            .into_iter()
            .zip(g.targets())
            .filter_map(|(a, t)| t.map(|_| a))
            .collect(),
    }
}

fn invalid_axes(axes: &AxisSet, axis: Axis) -> ParamsError {
    ParamsError::Invalid {
        key: "axes".into(),
        value: axes.to_string(),
        expected: format!("a set including {axis}, which the task reads"),
    }
}
