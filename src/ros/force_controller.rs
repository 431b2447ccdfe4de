//! `force_controller`: `joint_states` (sensor_msgs/JointState),
//! `biotac/wrench`, `biotac/wrench_stddev` and `biotac/pdc_rise` in -> [`ForceController`] ->
//! `velocity_controller/commands` (std_msgs/Float64MultiArray, one velocity
//! per joint in chain order: the ros2_control JointGroupVelocityController
//! convention).
//!
//! The controller steps on each new estimate (the mean and the std of one
//! reading both in), so an estimate acts as soon as it arrives rather than
//! up to a period later on a timer of its own; with no estimate for 1.5
//! periods it steps anyway, and the watchdog stops the arm.
//!
//! The watchdog is the embedded one: inputs older than `stale_periods`
//! periods, or not finite, command zero velocity. Setting the parameter
//! `task` to `guided` or `guarded` while running switches the mode (the
//! controller is rebuilt from the start-up parameters with the new task).
//! The guarded move is also an action, `~/guarded_move`
//! (tactile_force_msgs/action/GuardedMove): see
//! [`crate::nodes::guarded_goal`]. A goal the
//! controller refuses (a value out of range, a speed beyond the safety
//! envelope) is accepted and aborted at once with `reason` "refused: ..."
//! naming the limit, so that a client can read why. r2r has no
//! untyped action server and, under its `doc-only` build, no types for our
//! interface package, so the action server is compiled only in a real ROS
//! build (`cfg(not(feature = "ros2-doc-only"))`); the goal handling it
//! calls is plain Rust, tested here.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use futures::StreamExt;
use r2r::geometry_msgs::msg::WrenchStamped;
use r2r::sensor_msgs::msg::{FluidPressure, JointState as JointStateMsg};
use r2r::std_msgs::msg::Float64MultiArray;
use r2r::QosProfile;

use super::{convert, RosError};
use crate::kinematics::robot::PA10_YAML;
use crate::nodes::controller::TaskKind;
use crate::nodes::{ControlOutput, ControllerParams, ForceController};
use crate::params::ParamsError;
use crate::runtime::scene::{GUARDED_YAML, WORLD_YAML};

/// The PA10-7C's joint names (S1 S2 S3 E1 E2 W1 W2), the default of `joint_names`.
pub const PA10_JOINTS: [&str; 7] = ["S1", "S2", "S3", "E1", "E2", "W1", "W2"];

fn lock(s: &Mutex<Shared>) -> std::sync::MutexGuard<'_, Shared> {
    s.lock().unwrap_or_else(|e| e.into_inner())
}

/// What the loop, the subscriptions and the action share.
struct Shared {
    controller: ForceController,
    base: ControllerParams,
    pdc: Option<FluidPressure>,
    /// The newest mean and std not yet stepped on.
    mean: Option<WrenchStamped>,
    stddev: Option<WrenchStamped>,
    /// The latest estimated force, BioTac frame (N): the action's feedback.
    force: nalgebra::Vector3<f64>,
    last: Option<ControlOutput>,
    rejected: u64,
}

fn rebuild(s: &mut Shared, p: ControllerParams) -> Result<(), ParamsError> {
    s.controller = ForceController::new(p)?;
    s.last = None;
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
        &[PA10_YAML, WORLD_YAML, GUARDED_YAML],
        &skip,
        super::describe_shared,
    )?;
    let period = Duration::from_secs_f64(base.control_period_s);
    let controller = ForceController::new(base.clone())?;
    let envelope = controller.envelope();
    tracing::info!(
        "force_controller: task {:?} on {}, gains {:?} m/s per N, loop delays {:?}, \
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
    let (handler, mut events) = node.make_parameter_handler()?;
    tokio::spawn(handler);
    #[cfg(not(feature = "ros2-doc-only"))]
    let goals = node.create_action_server::<r2r::tactile_force_msgs::action::GuardedMove::Action>(
        "~/guarded_move",
    )?;
    let mut clock = r2r::Clock::create(r2r::ClockType::RosTime)?;
    super::spin(node);

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
    let s = shared.clone();
    tokio::spawn(async move {
        while let Some((name, value)) = events.next().await {
            if name != "task" {
                tracing::warn!("parameter {name} changed: read at start-up only, restart the node");
                continue;
            }
            let task = match &value {
                r2r::ParameterValue::String(t) if t == "guarded" => TaskKind::Guarded,
                r2r::ParameterValue::String(t) if t == "guided" => TaskKind::Guided,
                other => {
                    tracing::warn!("task = {other:?}: expected guarded or guided; unchanged");
                    continue;
                }
            };
            let mut g = lock(&s);
            let mut p = g.base.clone();
            p.task = task;
            match rebuild(&mut g, p) {
                Ok(()) => tracing::info!("task switched to {task:?}"),
                Err(e) => tracing::warn!("task {task:?} refused: {e}"),
            }
        }
    });
    #[cfg(not(feature = "ros2-doc-only"))]
    tokio::spawn(action::serve(goals, shared.clone(), period));

    let mut estimates = futures::stream::select(
        wrench.map(EstimatePart::Mean),
        stddev.map(EstimatePart::Std),
    );
    let wait = period.mul_f64(1.5);
    loop {
        let step = match tokio::time::timeout(wait, estimates.next()).await {
            Ok(Some(part)) => take_estimate(&mut lock(&shared), part),
            Ok(None) => return Ok(()),
            // Nothing for 1.5 periods: step, and the watchdog halts the arm.
            Err(_) => true,
        };
        if !step {
            continue;
        }
        let now = super::now_s(&mut clock);
        let out = {
            let mut g = lock(&shared);
            let out = g.controller.tick(now);
            g.last = Some(out.clone());
            out
        };
        if let Err(e) = commands.publish(&convert::commands_msg(&out.qdot)) {
            tracing::warn!("velocity_controller/commands: {e}");
        }
    }
}

/// One of the two messages of an estimate.
enum EstimatePart {
    Mean(WrenchStamped),
    Std(WrenchStamped),
}

/// Stores `part`; once the mean and the std of one reading are both in,
/// hands the estimate to the controller and returns true (time to step).
fn take_estimate(g: &mut Shared, part: EstimatePart) -> bool {
    match part {
        EstimatePart::Mean(m) => g.mean = Some(m),
        EstimatePart::Std(m) => g.stddev = Some(m),
    }
    let paired =
        matches!((&g.mean, &g.stddev), (Some(m), Some(s)) if m.header.stamp == s.header.stamp);
    if !paired {
        return false;
    }
    let (Some(mean), Some(std)) = (g.mean.take(), g.stddev.take()) else {
        return false;
    };
    let ok = convert::estimate_from_msgs(&mean, Some(&std), g.pdc.as_ref())
        .map_err(|e| e.to_string())
        .and_then(|e| {
            g.force = e.mean.force;
            g.controller.on_estimate(e).map_err(|e| e.to_string())
        });
    if let Err(e) = ok {
        g.rejected += 1;
        tracing::debug!("biotac/wrench refused: {e}");
    }
    true
}

/// The guarded-move action server (needs r2r's generated types for
/// tactile_force_msgs, so a real ROS build only).
#[cfg(not(feature = "ros2-doc-only"))]
mod action {
    use super::*;
    use crate::nodes::guarded_goal::{guarded_outcome, GuardedGoal};
    use r2r::tactile_force_msgs::action::GuardedMove;

    pub(super) async fn serve(
        mut goals: impl futures::Stream<Item = r2r::ActionServerGoalRequest<GuardedMove::Action>>
            + Unpin,
        shared: Arc<Mutex<Shared>>,
        period: Duration,
    ) {
        while let Some(req) = goals.next().await {
            let d = &req.goal.direction;
            let goal = GuardedGoal {
                direction: [d.x, d.y, d.z],
                speed_mps: req.goal.speed_mps,
                target_force_n: req.goal.target_force_n,
                max_distance_m: req.goal.max_distance_m,
            };
            let started = {
                let mut g = shared.lock().unwrap_or_else(|e| e.into_inner());
                goal.start(&g.base).map(|c| {
                    g.controller = c;
                    g.last = None;
                })
            };
            let Ok((mut handle, mut cancel)) = req.accept() else {
                continue;
            };
            if let Err(e) = started {
                tracing::warn!("guarded_move goal refused: {e}");
                let _ = handle.abort(GuardedMove::Result {
                    reason: format!("refused: {e}"),
                    ..Default::default()
                });
                continue;
            }
            let mut ticker = tokio::time::interval(period);
            loop {
                ticker.tick().await;
                if let Some(Some(c)) = futures::FutureExt::now_or_never(cancel.next()) {
                    lock(&shared).controller.stop();
                    c.accept();
                    let _ = handle.cancel(GuardedMove::Result {
                        reason: "canceled".into(),
                        ..Default::default()
                    });
                    break;
                }
                let (last, force) = {
                    let g = shared.lock().unwrap_or_else(|e| e.into_inner());
                    (g.last.clone(), g.force)
                };
                let Some(out) = last else { continue };
                // The estimated force on the controlled axis.
                let axis = out.targets.iter().position(Option::is_some).unwrap_or(2);
                let force_n = force[axis];
                let _ = handle.publish_feedback(GuardedMove::Feedback {
                    force_n,
                    phase: out.phase.name().into(),
                });
                // A halt (inputs missing or stale, e.g. right after the
                // goal rebuilt the controller) pauses the move; the goal
                // ends on the task's own outcome.
                if let Some(reason) = guarded_outcome(&out) {
                    let result = GuardedMove::Result {
                        force_n,
                        reason: reason.into(),
                        ..Default::default()
                    };
                    let _ = if reason == "hold" {
                        handle.succeed(result)
                    } else {
                        handle.abort(result)
                    };
                    break;
                }
            }
        }
    }
}
