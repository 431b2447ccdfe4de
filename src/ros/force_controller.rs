//! `force_controller`: `joint_states` (sensor_msgs/JointState),
//! `biotac/wrench`, `biotac/wrench_stddev` and `biotac/pdc_rise` in -> [`ForceController`] ->
//! `velocity_controller/commands` (std_msgs/Float64MultiArray, one velocity
//! per joint in chain order: the ros2_control JointGroupVelocityController
//! convention).
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
//! The parameter `task` (`guarded` or `guided`) may be set while running:
//! the controller is rebuilt for it and checked as at start-up, or the set
//! is refused with the reason. Every other parameter is read at start-up.
//! The guarded move is also an action, `~/guarded_move`
//! (tactile_force_msgs/action/GuardedMove): see
//! [`crate::nodes::guarded_goal`]. A goal the
//! controller refuses (a value out of range, a speed beyond the safety
//! envelope) is accepted and aborted at once with `reason` "refused: ..."
//! naming the limit, so that a client can read why. r2r has no
//! untyped action server and, under its `doc-only` build, no types for our
//! interface package, so the action server is compiled only in a real ROS
//! build (`cfg(not(feature = "ros2-doc-only"))`).

mod estimates;
#[cfg(not(feature = "ros2-doc-only"))]
mod guarded_move_action;
mod status;

use std::sync::{Arc, Mutex};
use std::time::Duration;

use futures::StreamExt;
use r2r::diagnostic_msgs::msg::DiagnosticArray;
use r2r::geometry_msgs::msg::WrenchStamped;
use r2r::sensor_msgs::msg::{FluidPressure, JointState as JointStateMsg};
use r2r::std_msgs::msg::Float64MultiArray;
use r2r::QosProfile;

use super::convert::PA10_JOINTS;
use super::params::RuntimeParams;
use super::{convert, RosError};
use crate::control::TaskKind;
use crate::nodes::loop_delay::LoopDelayMonitor;
use crate::nodes::{ControlOutput, ControllerParams, ForceController};
use crate::params::{layered_flat_params, FlatParams, ParamsError};
use estimates::{take_estimate, EstimatePart};
use status::{diagnostics_msg, keep};

fn lock(s: &Mutex<Shared>) -> std::sync::MutexGuard<'_, Shared> {
    s.lock().unwrap_or_else(|e| e.into_inner())
}

/// What the loop, the subscriptions and the action share.
struct Shared {
    controller: ForceController,
    base: ControllerParams,
    /// The task running: the parameter's, or guarded after a goal.
    task: TaskKind,
    /// A guarded_move goal is running (a task switch then is refused).
    goal_active: bool,
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

/// The shipped defaults of the guarded scene, with every task's section
/// from its own scene, so that `task` can switch while running.
fn defaults() -> Result<FlatParams, ParamsError> {
    let name = "force_controller";
    let mut d = layered_flat_params(&TaskKind::Guarded.shipped_layers(), name)?;
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
        return Err("a guarded_move goal is running: cancel it first".into());
    }
    if task == g.task {
        return Ok(()); // nothing to change (a stopped task stays stopped)
    }
    let c = ForceController::switched(&g.base, task).map_err(|e| e.to_string())?;
    if apply {
        g.controller = c;
        g.task = task;
        g.last = None;
        tracing::info!("task switched to {task}");
    }
    Ok(())
}

/// Runs the node until the process ends.
pub async fn run() -> Result<(), RosError> {
    let mut node = super::create_node("force_controller")?;
    let joint_names = super::own_strings(
        &node,
        "joint_names",
        &PA10_JOINTS,
        "Arm joints in chain order: read from joint_states by name, commanded in this order.",
    )?;
    let skip = ["joint_names"];
    let base: ControllerParams = super::node_params(
        &node,
        "force_controller",
        defaults()?,
        &skip,
        super::describe_shared,
    )?;
    let period = Duration::from_secs_f64(base.control_period_s);
    let controller = ForceController::new(base.clone())?;
    let envelope = controller.envelope();
    tracing::info!(
        "task {:?} on {}, gains {:?} m/s per N, loop delays {:?}, \
         speed limit {:.1} mm/s (safety envelope for the stiffest permitted body, {:.1e} N/m), \
         joints {joint_names:?}",
        base.task,
        base.object,
        controller.gains(),
        base.loop_delays,
        envelope.max_speed_mps() * 1e3,
        envelope.stiffness_n_per_m,
    );
    let shared = Arc::new(Mutex::new(Shared {
        controller,
        task: base.task,
        goal_active: false,
        delays: LoopDelayMonitor::new(base.loop_delays.transport_delay_s),
        base,
        pdc: None,
        mean: None,
        stddev: None,
        force: nalgebra::Vector3::zeros(),
        last: None,
        rejected: 0,
    }));

    let mut joints = node.subscribe::<JointStateMsg>("joint_states", QosProfile::default())?;
    let wrench = node.subscribe::<WrenchStamped>("biotac/wrench", QosProfile::default())?;
    let mut pdc = node.subscribe::<FluidPressure>("biotac/pdc_rise", QosProfile::default())?;
    let stddev = node.subscribe::<WrenchStamped>("biotac/wrench_stddev", QosProfile::default())?;
    let commands = node.create_publisher::<Float64MultiArray>(
        "velocity_controller/commands",
        QosProfile::default(),
    )?;
    let diagnostics =
        node.create_publisher::<DiagnosticArray>("/diagnostics", QosProfile::default())?;
    #[cfg(not(feature = "ros2-doc-only"))]
    let goals = node.create_action_server::<r2r::tactile_force_msgs::action::GuardedMove::Action>(
        "~/guarded_move",
    )?;
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
    let s = shared.clone();
    let names = joint_names.clone();
    tokio::spawn(async move {
        while let Some(m) = joints.next().await {
            let mut g = lock(&s);
            let ok = convert::joint_state_from_msg(&m, &names)
                .map_err(|e| e.to_string())
                .and_then(|js| g.controller.on_joint_state(js).map_err(|e| e.to_string()));
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
    #[cfg(not(feature = "ros2-doc-only"))]
    tokio::spawn(guarded_move_action::serve(goals, shared.clone(), period));

    let mut estimates = futures::stream::select(
        wrench.map(EstimatePart::Mean),
        stddev.map(EstimatePart::Std),
    );
    let wait = period.mul_f64(1.5);
    let mut deadline = tokio::time::Instant::now() + wait;
    let mut report = tokio::time::interval(Duration::from_secs(1));
    let mut delay_warned = false;
    loop {
        // Each step stores its output under the lock it ran in, so that a
        // goal or a task switch in between cannot see the old one.
        let qdot = tokio::select! {
            part = estimates.next() => {
                let Some(part) = part else { return Ok(()) };
                let mut g = lock(&shared);
                let Some(stamp_s) = take_estimate(&mut g, part) else { continue };
                let now = clock.now_s();
                g.delays.record(stamp_s, now);
                deadline = tokio::time::Instant::now() + wait;
                let out = g.controller.tick(now);
                keep(&mut g, out)
            }
            // No estimate for 1.5 periods: zero velocity, every period.
            _ = tokio::time::sleep_until(deadline) => {
                deadline = tokio::time::Instant::now() + period;
                let mut g = lock(&shared);
                let out = g.controller.estimate_late(clock.now_s(), wait.as_secs_f64());
                keep(&mut g, out)
            }
            _ = report.tick() => {
                let msg = diagnostics_msg(&mut lock(&shared), clock.now_s(), &mut delay_warned);
                if let Err(e) = diagnostics.publish(&msg) {
                    tracing::warn!("diagnostics: {e}");
                }
                continue;
            }
        };
        if let Err(e) = commands.publish(&convert::commands_msg(&qdot)) {
            tracing::warn!("velocity_controller/commands: {e}");
        }
    }
}
