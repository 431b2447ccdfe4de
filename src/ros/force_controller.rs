//! `force_controller`: `joint_states` (sensor_msgs/JointState),
//! `biotac/wrench`, `biotac/wrench_stddev` and `biotac/pdc_rise` in -> [`ForceController`] ->
//! `velocity_controller/commands` (std_msgs/Float64MultiArray, one velocity
//! per joint in chain order: the ros2_control JointGroupVelocityController
//! convention), or with `command_interface: twist`, `twist_commands`
//! (geometry_msgs/TwistStamped: the BioTac's twist in the base link's
//! frame, for MoveIt Servo or a Cartesian controller).
//!
//! The arm is the chain between `robot.base_link` and `robot.tip_link` of
//! the robot description: the `robot_description` parameter, or else the
//! `/robot_description` topic ([`super::description`]). Until one arrives
//! the node commands nothing and says so; a new one is taken while no task
//! runs, and refused, with the reason, while one does. `joint_names` (one
//! per joint of the chain) renames the joints as `joint_states` lists them;
//! by default they are the URDF's.
//!
//! The controller steps on each new estimate (the mean and the std of one
//! reading both in), so an estimate acts as soon as it arrives rather than
//! up to a period later on a timer of its own. With no estimate for 1.5
//! periods it commands zero velocity, every period, until estimates return
//! ([`ForceController::estimate_late`]). The age of each estimate's reading
//! when stepped on is measured from its stamp ([`LoopDelayMonitor`]) and
//! reported on `/diagnostics` once a second, with a warning when it exceeds
//! what the gains assume.
//!
//! The parameter `task` (`guarded`, `guided` or `calibrate`) may be set
//! while running: the controller is rebuilt for it and checked as at
//! start-up, or the set is refused with the reason (`calibrate` waits, the
//! arm still, for a calibration goal). Every other parameter is read at
//! start-up.
//!
//! The calibration is an action, `~/calibrate`
//! (tactile_force_msgs/action/Calibrate): while it runs, the force is the
//! F/T sensor's (`ft_sensor/wrench`, moved to the BioTac frame by
//! `ft_to_biotac`), not the estimate, and each wrench is recorded with the
//! BioTac reading of its stamp (`biotac/readings`); see
//! `force_controller/calibrate_action.rs`.
//! The guarded move is also an action, `~/guarded_move`
//! (tactile_force_msgs/action/GuardedMove): see
//! [`crate::nodes::guarded_goal`]. A goal the
//! controller refuses (a value out of range, a speed beyond the safety
//! envelope, no robot description yet) is accepted and aborted at once with
//! `reason` "refused: ..." naming the limit, so that a client can read why.
//! r2r has no untyped action server and, under its `doc-only` build, no
//! types for our interface package, so the action server is compiled only
//! in a real ROS build (`cfg(not(feature = "ros2-doc-only"))`).

#[cfg(not(feature = "ros2-doc-only"))]
mod calibrate_action;
mod estimates;
#[cfg(not(feature = "ros2-doc-only"))]
mod guarded_move_action;
mod status;

use std::sync::{Arc, Mutex};
use std::time::Duration;

use futures::StreamExt;
use r2r::diagnostic_msgs::msg::DiagnosticArray;
use r2r::geometry_msgs::msg::{TwistStamped, WrenchStamped};
use r2r::sensor_msgs::msg::{FluidPressure, JointState as JointStateMsg};
use r2r::std_msgs::msg::Float64MultiArray;
use r2r::QosProfile;

use super::description::{joint_names, joint_names_param, robot_description, Description};
use super::params::RuntimeParams;
use super::{convert, RosError};
use crate::control::{Phase, TaskKind};
use crate::kinematics::Robot;
use crate::nodes::calibration::{CalibrateGoal, CalibrationRecorder};
use crate::nodes::loop_delay::LoopDelayMonitor;
use crate::nodes::{ControlOutput, ControllerParams, ForceController, Goal};
use crate::params::{layered_flat_params, FlatParams, ParamsError, WORLD_YAML};
use crate::wrench::FrameTransform;
use estimates::{take_estimate, EstimatePart};
use status::{diagnostics_msg, keep};

fn lock(s: &Mutex<Shared>) -> std::sync::MutexGuard<'_, Shared> {
    s.lock().unwrap_or_else(|e| e.into_inner())
}

/// What the node publishes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum CommandInterface {
    /// Joint velocities on `velocity_controller/commands`.
    JointVelocities,
    /// The BioTac's twist on `twist_commands`.
    Twist,
}

impl CommandInterface {
    fn parse(s: &str) -> Result<Self, ParamsError> {
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

/// What the loop, the subscriptions and the action share.
struct Shared {
    /// None until a robot description arrives.
    controller: Option<ForceController>,
    /// The robot of the description in use.
    robot: Option<Robot>,
    /// The description in use.
    description: Option<String>,
    /// The arm's joints on joint_states, in chain order.
    names: Vec<String>,
    /// The `joint_names` parameter (empty: the URDF's).
    remap: Vec<String>,
    base: ControllerParams,
    /// The task running: the parameter's, or guarded after a goal.
    task: TaskKind,
    /// A guarded_move or calibrate goal is running (a task switch then is
    /// refused).
    goal_active: bool,
    /// While a calibration runs, its recording: the F/T wrench, not the
    /// estimate, is then the force.
    calibration: Option<CalibrationRecorder>,
    /// Where the F/T sensor sits in the BioTac frame (None: its wrenches
    /// are in the BioTac frame already).
    ft_to_biotac: Option<FrameTransform>,
    pdc: Option<FluidPressure>,
    /// The newest mean and std not yet stepped on.
    mean: Option<WrenchStamped>,
    stddev: Option<WrenchStamped>,
    /// The latest estimated force, BioTac frame (N): the action's feedback.
    force: nalgebra::Vector3<f64>,
    last: Option<ControlOutput>,
    /// Messages refused: not finite, or not matching the arm.
    rejected: u64,
    delays: LoopDelayMonitor,
}

/// The shipped defaults of the guarded scene on the world's robot defaults
/// (the links empty: the URDF's root and leaf), with every task's section
/// from its own scene, so that `task` can switch while running.
fn defaults() -> Result<FlatParams, ParamsError> {
    let name = "force_controller";
    let scene = TaskKind::Guarded.scene_yaml();
    let mut d = layered_flat_params(&[WORLD_YAML, scene], name)?;
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

impl Shared {
    /// True while a task runs: a goal, or a task that has begun and not
    /// stopped.
    fn running(&self) -> bool {
        let begun = self
            .controller
            .as_ref()
            .is_some_and(ForceController::started);
        let stopped = self
            .last
            .as_ref()
            .is_some_and(|o| o.phase == Phase::Stopped);
        self.goal_active || (begun && !stopped)
    }

    /// Takes the robot of a description: the controller is built for it
    /// with the task that runs now.
    fn install(&mut self, robot: Robot, text: String) -> Result<(), ParamsError> {
        let names = joint_names(&robot, &self.remap)?;
        let c = built(&self.base, self.task, robot.clone())?;
        tracing::info!(
            "robot {}: {} -> {}, {} joints {names:?}; commanding it",
            robot.name,
            robot.links.0,
            robot.links.1,
            robot.dof()
        );
        self.controller = Some(c);
        self.robot = Some(robot);
        self.names = names;
        self.description = Some(text);
        self.last = None;
        Ok(())
    }

    /// A description from the topic: taken unless it is the one in use, or
    /// a task runs, or it is refused (the reason is logged; the robot in use,
    /// if any, stays).
    fn take_description(&mut self, text: String) {
        if self.description.as_deref() == Some(text.as_str()) {
            return;
        }
        if self.running() {
            tracing::warn!(
                "robot description refused: a task is running (a new description is taken \
                 once it has stopped, or with no goal active)"
            );
            return;
        }
        let taken = Robot::from_urdf(&text, &self.base.robot)
            .map_err(|e| e.to_string())
            .and_then(|robot| self.install(robot, text).map_err(|e| e.to_string()));
        if let Err(e) = taken {
            tracing::error!("robot description refused: {e}");
        }
    }
}

/// The controller of `task` outside a goal; the calibration's waits, the
/// arm still, for a calibrate goal.
fn built(
    base: &ControllerParams,
    task: TaskKind,
    robot: Robot,
) -> Result<ForceController, ParamsError> {
    if task != TaskKind::Calibrate {
        return ForceController::switched(base, task, robot);
    }
    let mut c = CalibrateGoal::default().start(base, robot)?;
    c.stop();
    tracing::info!("task calibrate: the arm waits for a ~/calibrate goal");
    Ok(c)
}

/// Applies (or, `apply` false, checks) a new value of `task`.
fn switch_task(s: &Mutex<Shared>, value: &r2r::ParameterValue, apply: bool) -> Result<(), String> {
    let r2r::ParameterValue::String(name) = value else {
        return Err(format!(
            "{value:?}: expected the string {}",
            TaskKind::names()
        ));
    };
    let task: TaskKind = name.parse().map_err(|e: ParamsError| e.to_string())?;
    let mut g = lock(s);
    if g.goal_active {
        return Err("a goal is running (guarded_move or calibrate): cancel it first".into());
    }
    if task == g.task {
        return Ok(()); // nothing to change (a stopped task stays stopped)
    }
    let switched = ControllerParams {
        task,
        ..g.base.clone()
    };
    let c = match g.robot.clone() {
        Some(robot) => Some(built(&g.base, task, robot).map_err(|e| e.to_string())?),
        // Checked now, built when a description arrives.
        None => {
            let checked = match task {
                TaskKind::Calibrate => CalibrateGoal::default().apply(&switched),
                _ => Ok(switched),
            };
            checked
                .and_then(|p| ForceController::check(&p))
                .map_err(|e| e.to_string())?;
            None
        }
    };
    if apply {
        g.controller = c;
        g.task = task;
        g.last = None;
        tracing::info!("task switched to {task}");
    }
    Ok(())
}

/// What the loop publishes: joint velocities or a twist.
enum Command {
    Joints(Float64MultiArray),
    Twist(TwistStamped),
}

/// The command of the last step, in the node's interface.
fn command(g: &Shared, interface: CommandInterface, now: f64) -> Option<Command> {
    let c = g.controller.as_ref()?;
    Some(match interface {
        CommandInterface::JointVelocities => Command::Joints(convert::commands_msg(c.command())),
        CommandInterface::Twist => {
            let frame = &c.robot().links.0;
            Command::Twist(convert::twist_msg(now, frame, c.twist()))
        }
    })
}

/// Runs the node until the process ends.
pub async fn run() -> Result<(), RosError> {
    let mut node = super::create_node("force_controller")?;
    let remap = joint_names_param(&node)?;
    let interface = CommandInterface::parse(&super::own_string(
        &node,
        "command_interface",
        "joint_velocities",
        "joint_velocities (velocity_controller/commands) or twist (twist_commands).",
    )?)?;
    let ft_to_biotac = match super::own_string(
        &node,
        "ft_to_biotac",
        "",
        "Where the F/T sensor sits in the BioTac frame, roll,pitch,yaw,x,y,z (deg, fixed-axis x-y-z; m): its wrenches are moved to the BioTac frame for the calibration; empty: they are in it already.",
    )?
    .as_str()
    {
        "" => None,
        t => Some(t.parse::<FrameTransform>().map_err(|e| ParamsError::Invalid {
            key: "ft_to_biotac".into(),
            value: t.into(),
            expected: e,
        })?),
    };
    let estimator = super::own_string(
        &node,
        "estimator_node",
        "wrench_estimator",
        "The estimator whose model the calibration adapts and then sets (its model_file parameter).",
    )?;
    let skip = [
        "joint_names",
        "robot_description",
        "command_interface",
        "ft_to_biotac",
        "estimator_node",
    ];
    let base: ControllerParams = super::node_params(
        &node,
        "force_controller",
        defaults()?,
        &skip,
        super::describe_shared,
    )?;
    ForceController::check(&base)?;
    let period = Duration::from_secs_f64(base.control_period_s);
    let envelope = crate::nodes::controller::task_envelope(&base)?.envelope;
    tracing::info!(
        "task {:?} on {}, loop delays {:?}, speed limit {:.1} mm/s (safety envelope for the \
         stiffest permitted body, {:.1e} N/m), commands: {interface:?}",
        base.task,
        base.object,
        base.loop_delays,
        envelope.max_speed_mps() * 1e3,
        envelope.stiffness_n_per_m,
    );
    let description = robot_description(&mut node)?;
    let mut shared = Shared {
        controller: None,
        robot: None,
        description: None,
        names: Vec::new(),
        remap,
        task: base.task,
        goal_active: false,
        calibration: None,
        ft_to_biotac,
        delays: LoopDelayMonitor::new(base.loop_delays.transport_delay_s),
        base,
        pdc: None,
        mean: None,
        stddev: None,
        force: nalgebra::Vector3::zeros(),
        last: None,
        rejected: 0,
    };
    let mut topic = None;
    match description {
        Description::Given(text) => {
            let robot = Robot::from_urdf(&text, &shared.base.robot)?;
            shared.install(robot, text)?;
        }
        Description::Topic(stream) => {
            tracing::info!(
                "waiting for the robot description on {}: commanding nothing until it comes \
                 (or set the robot_description parameter)",
                super::description::DESCRIPTION_TOPIC
            );
            topic = Some(stream);
        }
    }
    let shared = Arc::new(Mutex::new(shared));

    let mut joints = node.subscribe::<JointStateMsg>("joint_states", QosProfile::default())?;
    let wrench = node.subscribe::<WrenchStamped>("biotac/wrench", QosProfile::default())?;
    let mut pdc = node.subscribe::<FluidPressure>("biotac/pdc_rise", QosProfile::default())?;
    let stddev = node.subscribe::<WrenchStamped>("biotac/wrench_stddev", QosProfile::default())?;
    let ft = node.subscribe::<WrenchStamped>("ft_sensor/wrench", QosProfile::default())?;
    let mut readings = node.subscribe_raw(
        "biotac/readings",
        crate::biotac::msg::BIOTAC_MSG_TYPE,
        QosProfile::sensor_data(),
    )?;
    let commands = node.create_publisher::<Float64MultiArray>(
        "velocity_controller/commands",
        QosProfile::default(),
    )?;
    let twists = node.create_publisher::<TwistStamped>("twist_commands", QosProfile::default())?;
    let diagnostics =
        node.create_publisher::<DiagnosticArray>("/diagnostics", QosProfile::default())?;
    #[cfg(not(feature = "ros2-doc-only"))]
    let goals = node.create_action_server::<r2r::tactile_force_msgs::action::GuardedMove::Action>(
        "~/guarded_move",
    )?;
    #[cfg(not(feature = "ros2-doc-only"))]
    let calibrations = node
        .create_action_server::<r2r::tactile_force_msgs::action::Calibrate::Action>(
            "~/calibrate",
        )?;
    #[cfg(not(feature = "ros2-doc-only"))]
    let link = calibrate_action::EstimatorLink::new(&mut node, &estimator)?;
    let s = shared.clone();
    let live = RuntimeParams::new(
        &["task"],
        Box::new(move |_, value, apply| {
            switch_task(&s, value, apply).inspect_err(|e| tracing::warn!("task refused: {e}"))
        }),
    );
    let clock = super::serve_parameters(&mut node, live)?;
    super::spin_with_action_server(node);

    // Callbacks only check and store (STYLE 3); the loop below runs the pipeline.
    if let Some(mut topic) = topic {
        let s = shared.clone();
        tokio::spawn(async move {
            while let Some(text) = topic.next().await {
                lock(&s).take_description(text);
            }
        });
    }
    let s = shared.clone();
    tokio::spawn(async move {
        while let Some(m) = joints.next().await {
            let mut g = lock(&s);
            let g = &mut *g;
            let Some(c) = g.controller.as_mut() else {
                continue;
            };
            let ok = convert::joint_state_from_msg(&m, &g.names)
                .map_err(|e| e.to_string())
                .and_then(|js| c.on_joint_state(&js).map_err(|e| e.to_string()));
            if let Err(e) = ok {
                g.rejected += 1;
                tracing::debug!("joint_states refused: {e}");
            }
        }
    });
    let s = shared.clone();
    tokio::spawn(async move {
        while let Some(m) = pdc.next().await {
            if m.fluid_pressure.is_finite() {
                lock(&s).pdc = Some(m);
            } else {
                lock(&s).rejected += 1;
            }
        }
    });
    // BioTac readings are decoded only while a calibration records them.
    let s = shared.clone();
    tokio::spawn(async move {
        while let Some(bytes) = readings.next().await {
            if lock(&s).calibration.is_none() {
                continue;
            }
            match crate::biotac::msg::from_cdr(&bytes) {
                Ok((r, meta)) if meta.invalid_channels.is_empty() => {
                    if let Some(rec) = lock(&s).calibration.as_mut() {
                        rec.on_reading(r);
                    }
                }
                _ => lock(&s).rejected += 1,
            }
        }
    });
    #[cfg(not(feature = "ros2-doc-only"))]
    tokio::spawn(guarded_move_action::serve(goals, shared.clone(), period));
    #[cfg(not(feature = "ros2-doc-only"))]
    tokio::spawn(calibrate_action::serve(
        calibrations,
        shared.clone(),
        period,
        clock.clone(),
        link,
    ));
    #[cfg(feature = "ros2-doc-only")]
    let _ = estimator;

    let mut estimates = futures::stream::select_all([
        wrench.map(EstimatePart::Mean).boxed(),
        stddev.map(EstimatePart::Std).boxed(),
        ft.map(EstimatePart::Ft).boxed(),
    ]);
    let wait = period.mul_f64(1.5);
    let mut deadline = tokio::time::Instant::now() + wait;
    let mut report = tokio::time::interval(Duration::from_secs(1));
    let mut delay_warned = false;
    loop {
        // Each step stores its output under the lock it ran in, so that a
        // goal or a task switch in between cannot see the old one.
        let command = tokio::select! {
            part = estimates.next() => {
                let Some(part) = part else { return Ok(()) };
                let mut g = lock(&shared);
                let Some(stamp_s) = take_estimate(&mut g, part) else { continue };
                let now = clock.now_s();
                g.delays.record(stamp_s, now);
                deadline = tokio::time::Instant::now() + wait;
                let Some(out) = g.controller.as_mut().map(|c| c.tick(now)) else { continue };
                keep(&mut g, out);
                command(&g, interface, now)
            }
            // No estimate for 1.5 periods: zero velocity, every period.
            _ = tokio::time::sleep_until(deadline) => {
                deadline = tokio::time::Instant::now() + period;
                let mut g = lock(&shared);
                let now = clock.now_s();
                let late = wait.as_secs_f64();
                let Some(out) = g.controller.as_mut().map(|c| c.estimate_late(now, late)) else {
                    continue;
                };
                keep(&mut g, out);
                command(&g, interface, now)
            }
            _ = report.tick() => {
                let msg = diagnostics_msg(&mut lock(&shared), clock.now_s(), &mut delay_warned);
                if let Err(e) = diagnostics.publish(&msg) {
                    tracing::warn!("diagnostics: {e}");
                }
                continue;
            }
        };
        let sent = match command {
            Some(Command::Joints(m)) => commands.publish(&m),
            Some(Command::Twist(m)) => twists.publish(&m),
            None => Ok(()),
        };
        if let Err(e) = sent {
            tracing::warn!("command: {e}");
        }
    }
}
