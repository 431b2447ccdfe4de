//! `force_controller`: `joint_states` (sensor_msgs/JointState),
//! `biotac/wrench_estimate` (tactile_force_msgs/WrenchEstimate) in -> [`ForceController`](crate::control::ForceController) ->
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
//! by default they are the URDF's. For each description it takes, it
//! publishes the BioTac frame (the parameter `biotac_frame`, the name the
//! estimator's `frame_id` stamps its wrenches with) on `/tf_static`, in the
//! tip link, from the tool mount `robot.tool_*` ([`crate::nodes::force_controller::tool_frame`]).
//!
//! Every way out stops the arm (`force_controller/way_out.rs`): SIGINT,
//! SIGTERM, a panic in any thread, a fatal error, `~/stop`
//! (std_srvs/Trigger) and the lifecycle's `deactivate` publish a zero on
//! both command outputs and end the goal running with the reason. It is a
//! managed node (`force_controller/managed.rs`, `start_state`); its inputs
//! are best effort, each named when silent, and its wrenches' frames are
//! checked ([`crate::nodes::force_controller::frames`]).
//!
//! Each estimate is drawn for an operator on `~/markers`
//! (visualization_msgs/MarkerArray: the force, its 1-sigma band, the
//! phase; [`crate::nodes::markers`]), 20 sets a second.
//!
//! The controller steps on each new estimate, so an estimate acts as soon as it arrives rather than
//! up to a period later on a timer of its own. With no estimate for longer
//! than the bound it measured, it commands zero velocity, every period,
//! until estimates return
//! ([`estimate_late`](crate::control::ForceController::estimate_late)).
//! The age of each estimate's reading when stepped on is measured from its
//! stamp ([`LoopDelayMonitor`](crate::nodes::loop_delay::LoopDelayMonitor)) and
//! reported on `/diagnostics` once a second, with a warning when it exceeds
//! what the gains assume.
//!
//! The parameter `task` (`guarded`, `guided` or `calibrate`) may be set
//! while running: the controller is rebuilt for it and checked as at
//! start-up, or the set is refused with the reason (`calibrate` waits, the
//! arm still, for a calibration goal). The other live parameters retune
//! the task ([`crate::nodes::force_controller::live`]); every other is read
//! at start-up.
//!
//! The files a calibration goal names stay in `models_dir` (default: the
//! model cache folder; [`crate::outputs::models_dir`]). The calibration is
//! an action, `~/calibrate`
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
//! A canceled goal ends once the pad has withdrawn out of contact.
//! Every input is bounded ([`crate::nodes::bounds`], through
//! [`super::bounded`]): a message over its size is dropped before it is
//! decoded, goals and parameter sets beyond their rates are refused, each
//! counted on `/diagnostics`; the control loop (`force_controller/stepping.rs`)
//! takes only the force topics, on a thread of its own.
//! r2r has no untyped action server and, under its `doc-only` build, no
//! types for our interface package, so the action server is compiled only
//! in a real ROS build (`cfg(not(feature = "ros2-doc-only"))`).

#[cfg(not(feature = "ros2-doc-only"))]
mod calibrate_action;
#[cfg(not(feature = "ros2-doc-only"))]
mod cancel;
mod commands;
#[cfg(not(feature = "ros2-doc-only"))]
mod estimator_link;
#[cfg(not(feature = "ros2-doc-only"))]
mod guarded_move_action;
mod managed;
mod markers;
mod settings;
mod stepping;
mod tool_frame;
mod way_out;

use std::sync::{Arc, Mutex};
use std::time::Duration;

use r2r::sensor_msgs::msg::JointState as JointStateMsg;
use r2r::QosProfile;

#[cfg(not(feature = "ros2-doc-only"))]
use super::action_server;
use super::bounded;
use super::description::{robot_description, Description};
use super::ending::Endings;
use super::inputs::Inputs;
use super::{convert, lock, RosError};
use crate::nodes::bounds::{InputGuard, MESSAGE_MAX_BYTES};
use crate::nodes::force_controller::ForceControllerNode;
use crate::nodes::tasks;
use commands::Commands;

#[cfg(not(feature = "ros2-doc-only"))]
impl action_server::Served for r2r::tactile_force_msgs::action::GuardedMove::Action {}
#[cfg(not(feature = "ros2-doc-only"))]
impl action_server::Served for r2r::tactile_force_msgs::action::Calibrate::Action {}

/// Runs the node until a signal, a panic or a fatal error ends it: its
/// settings declared, the node made, every input and output wired, its
/// lifecycle brought to `start_state`, then one step a period; at the end
/// the arm is stopped (`force_controller/way_out.rs`).
pub async fn run(endings: Endings) -> Result<(), RosError> {
    let mut node = super::create_node("force_controller")?;
    let tasks = tasks::shipped();
    let settings = settings::declare(&node, &tasks)?;
    let guard = Arc::new(InputGuard::with_goals());
    let host = settings.node(tasks.clone(), &guard)?.managed();
    let period = Duration::from_secs_f64(host.params().control_period_s);
    tracing::info!("{}, commands: {:?}", host.summary()?, settings.interface);
    let shared = Arc::new(Mutex::new(host));
    let description = robot_description(&mut node, &guard)?;

    // Every input bounded in size, refused before it is decoded.
    let inputs = stepping::watched(settings.silent_after_s);
    let (forces, markers) = stepping::topics(&mut node, &guard)?;
    hand_on(&mut node, &guard, &shared, &inputs)?;
    let commands = Arc::new(Commands::create(&mut node, settings.interface)?);
    let c = commands.clone();
    endings.on_panic(move || c.zero_on_panic());
    let diagnostics = node.create_publisher("/diagnostics", QosProfile::default())?;
    #[cfg(not(feature = "ros2-doc-only"))]
    let goals = bounded::goals(
        action_server::create(&mut node, "~/guarded_move")?,
        &guard,
        guarded_move_action::refused,
    );
    #[cfg(not(feature = "ros2-doc-only"))]
    let calibrations = bounded::goals(
        action_server::create(&mut node, "~/calibrate")?,
        &guard,
        calibrate_action::refused,
    );
    #[cfg(not(feature = "ros2-doc-only"))]
    let link = estimator_link::EstimatorLink::new(&mut node, &settings.estimator)?;
    let live = settings::live(&shared, &guard, node.params.clone());
    let clock = super::serve_parameters(&mut node, live)?;
    let tf = tool_frame::ToolFrame::new(&mut node, settings.child.clone(), clock.clone())?;
    take_description(description, &shared, &tf)?;
    #[cfg(not(feature = "ros2-doc-only"))]
    way_out::serve_stop(&mut node, shared.clone(), commands.clone(), clock.clone())?;
    let managed = managed::Controller {
        params: node.params.clone(),
        tasks,
        guard,
        shared: shared.clone(),
        commands: commands.clone(),
        tf,
        clock: clock.clone(),
    };
    let _lifecycle = super::lifecycle::serve(&mut node, managed, settings.start)?;
    let spinning = super::spin(node);
    tokio::spawn(stepping::report(
        shared.clone(),
        inputs.clone(),
        diagnostics,
        spinning.graph(),
        clock.clone(),
    ));

    #[cfg(not(feature = "ros2-doc-only"))]
    tokio::spawn(guarded_move_action::serve(
        goals,
        shared.clone(),
        period,
        clock.clone(),
    ));
    #[cfg(not(feature = "ros2-doc-only"))]
    tokio::spawn(calibrate_action::serve(
        calibrations,
        shared.clone(),
        period,
        clock.clone(),
        link,
        settings.models,
    ));
    #[cfg(feature = "ros2-doc-only")]
    let _ = (settings.estimator, settings.models);

    let stepping = stepping::run(&shared, forces, &commands, markers, &inputs, &clock, period);
    way_out::run_to_the_end(stepping, endings, &shared, &commands, &clock, period).await
}

/// The arm from the `robot_description` parameter, or from each description
/// on the topic until one is taken; the tool frame published for it.
fn take_description(
    description: Description,
    shared: &Arc<Mutex<ForceControllerNode>>,
    tf: &tool_frame::ToolFrame,
) -> Result<(), RosError> {
    match description {
        Description::Given(text) => {
            let mut n = lock(shared);
            n.take_description(&text)?;
            tf.publish(&n);
        }
        Description::Topic(topic) => {
            tracing::info!(
                "waiting for the robot description on {}: commanding nothing until it comes \
                 (or set the robot_description parameter)",
                super::description::DESCRIPTION_TOPIC
            );
            let tf = tf.clone();
            super::each(topic, shared, move |n, text: String| {
                match n.take_description(&text) {
                    Ok(true) => tf.publish(n),
                    Ok(false) => {}
                    Err(e) => tracing::warn!("robot description refused: {e}"),
                }
            });
        }
    }
    Ok(())
}

/// Hands the joint states, the PDC rise and (while a calibration records
/// them) the BioTac readings to the node: the callbacks only convert and
/// hand on (STYLE 3); the stepping loop steps.
fn hand_on(
    node: &mut r2r::Node,
    guard: &Arc<InputGuard>,
    shared: &Arc<Mutex<ForceControllerNode>>,
    inputs: &Arc<Inputs>,
) -> Result<(), RosError> {
    let (qos, max) = (super::input_qos, MESSAGE_MAX_BYTES);
    let joint_type = "sensor_msgs/msg/JointState";
    let joints = bounded::typed(node, "joint_states", joint_type, qos(), max, guard)?;
    let joints = inputs.watched("joint_states", joints);
    super::each(
        joints,
        shared,
        |n, m: JointStateMsg| match convert::joint_state_from_msg(&m, n.joint_names()) {
            Ok(js) => n.on_joint_state(&js),
            Err(e) => n.reject(&format!("joint_states: {e}")),
        },
    );
    let reading_type = crate::biotac::msg::BIOTAC_MSG_TYPE;
    let sensor_qos = QosProfile::sensor_data();
    let readings = bounded::raw(
        node,
        "biotac/readings",
        reading_type,
        sensor_qos,
        max,
        guard,
    )?;
    let readings = inputs.watched("biotac/readings", readings);
    super::each(readings, shared, |n, bytes: Vec<u8>| {
        if n.wants_readings() {
            match crate::biotac::msg::from_cdr(&bytes) {
                Ok((r, meta)) if meta.invalid_channels.is_empty() => n.on_reading(r),
                _ => n.reject("biotac/readings: not decoded, or invalid channels"),
            }
        }
    });
    Ok(())
}
