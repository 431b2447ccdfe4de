//! `sim_robot`: the simulated arm, object or finger, F/T sensor and BioTac
//! ([`SimRobot`]), paced by the wall clock. The arm is the chain between
//! `robot.base_link` and `robot.tip_link` of the robot description (the
//! `robot_description` parameter, or else the first valid one on
//! `/robot_description`); until it comes the node simulates nothing, and it
//! keeps that arm for the rest of its run. Every period it publishes
//! `joint_states`, `ft_sensor/wrench` (ground truth, BioTac frame) and
//! `biotac/readings` (the simulated BioTac lives here, as in the embedded
//! runtime: its contact comes from this node's physics), then applies the
//! latest `velocity_controller/commands`: held for ever, as ros2_control's
//! forward command controllers hold it, or with `command_timeout_s` zero
//! once none came for that long ([`HeldCommand`]). Stamps are the ROS
//! clock's. SIGINT and SIGTERM end it (exit code 0).
//! Ground truth for tests and plots, in the BioTac frame at the start
//! (frame_id `<frame_id>_start`): `~/biotac_twist`, the BioTac's velocity
//! over the last period, and, when a finger moves the body, `~/finger_twist`
//! (geometry_msgs/TwistStamped, linear part only). A finger starts its
//! path at the first estimate on `biotac/wrench`.
//!
//! With `use_sim_time:=true` it is the clock: it publishes its simulated
//! time on `/clock` every period and stamps with it, and it may run
//! `real_time_factor` times faster than the wall clock (the other nodes,
//! started with `use_sim_time:=true` too, follow `/clock`).
//!
//! Its input is bounded as the other nodes' ([`crate::nodes::bounds`]): a
//! description over 10 MiB or another message over 64 KiB is dropped
//! before it is decoded, and logged.

mod outputs;
mod settings;

use futures::StreamExt;
use r2r::geometry_msgs::msg::WrenchStamped;
use r2r::std_msgs::msg::Float64MultiArray;
use r2r::QosProfile;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

use super::bounded::{self, Messages};
use super::description::{first_taken, robot_description, Description};
use super::ending::Endings;
use super::params::RuntimeParams;
use super::{convert, RosError};
use crate::biotac::msg::BioTacMeta;
use crate::biotac::BioTacSimConfig;
use crate::kinematics::Robot;
use crate::nodes::bounds::{InputGuard, MESSAGE_MAX_BYTES};
use crate::nodes::sim_robot::HeldCommand;
use crate::nodes::{joint_names, SimRobot};
use outputs::{Outputs, Step};
use settings::{declare, Settings};

/// Runs the node until a signal ends it: its settings declared, its
/// topics wired, the arm built from its description, then one step a
/// period.
pub async fn run(mut endings: Endings) -> Result<(), RosError> {
    endings.until(simulate()).await
}

async fn simulate() -> Result<(), RosError> {
    let mut node = super::create_node("sim_robot")?;
    let settings = declare(&node)?;
    let guard = Arc::new(InputGuard::new());
    let description = robot_description(&mut node, &guard)?;
    settings.log();
    let outputs = Outputs::create(&mut node)?;
    let (qos, max) = (QosProfile::default(), MESSAGE_MAX_BYTES);
    let command_type = "std_msgs/msg/Float64MultiArray";
    let topic = "velocity_controller/commands";
    let commands =
        bounded::typed::<Float64MultiArray>(&mut node, topic, command_type, qos, max, &guard)?;
    // A finger waits for the estimator's first estimate: a person pushes a
    // finger that feels (while the default model trains, it would push a
    // blind arm).
    let estimates = match settings.p.finger_path {
        Some(_) => Some(bounded::typed::<WrenchStamped>(
            &mut node,
            "biotac/wrench",
            "geometry_msgs/msg/WrenchStamped",
            super::input_qos(),
            max,
            &guard,
        )?),
        None => None,
    };
    let clock = super::serve_parameters(&mut node, RuntimeParams::none(&guard))?;
    let _spinning = super::spin(node);

    let Some((mut sim, names)) = build_arm(description, &settings).await? else {
        return Ok(());
    };
    let estimating = estimates.map(|e| wait_for_estimate(e, &mut sim));
    let held = HeldCommand::new(sim.robot().dof(), settings.command_timeout_s)?;
    let start = std::time::Instant::now();
    let qdot = follow_commands(commands, held, start);
    let step = Step {
        settings: &settings,
        outputs: &outputs,
        names: &names,
        meta: BioTacMeta {
            frame_id: settings.frame_id.clone(),
            // Each simulated unit its own serial (a saved tare is per sensor).
            serial: format!("simulated unit {}", settings.p.sensor_unit),
            ..BioTacMeta::default()
        },
        start_frame: format!("{}_start", settings.frame_id),
    };
    let period = std::time::Duration::from_secs_f64(sim.period_s() / settings.speed);
    let mut ticker = tokio::time::interval(period);
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    for n in 1u64.. {
        ticker.tick().await;
        let started = estimating
            .as_ref()
            .is_some_and(|e| e.load(Ordering::Relaxed));
        if started && sim.start_finger() {
            tracing::info!("estimates flow: the finger starts its path");
        }
        let now = if settings.sim_time {
            step.tick_clock(n as f64 * sim.period_s())
        } else {
            clock.now_s()
        };
        step.publish(&mut sim, now);
        sim.command(super::lock(&qdot).at(start.elapsed().as_secs_f64()));
        sim.advance();
    }
    Ok(())
}

/// The arm from the parameter, or from the first valid description on the
/// topic (a refused one is logged, and the next awaited); None if the topic
/// ends first.
async fn build_arm(
    description: Description,
    s: &Settings,
) -> Result<Option<(SimRobot, Vec<String>)>, RosError> {
    let build = |text: &str| -> Result<(SimRobot, Vec<String>), RosError> {
        let robot = Robot::from_urdf(text, &s.p.robot)?;
        let names = joint_names(&robot, &s.remap)?;
        let sim = SimRobot::new(s.p.clone(), robot, &BioTacSimConfig::default(), s.seed)?;
        Ok((sim, names))
    };
    let built = match description {
        Description::Given(text) => build(&text)?,
        Description::Topic(topic) => {
            tracing::info!(
                "waiting for the robot description on {}: simulating nothing until it comes",
                super::description::DESCRIPTION_TOPIC
            );
            match first_taken(topic, build).await {
                Some(built) => built,
                None => return Ok(None),
            }
        }
    };
    let robot = built.0.robot();
    tracing::info!(
        "simulating {}: {} -> {}, joints {:?}",
        robot.name,
        robot.links.0,
        robot.links.1,
        built.1
    );
    Ok(Some(built))
}

/// Holds the finger until the first estimate; the flag says it came.
fn wait_for_estimate(
    mut estimates: impl Messages<WrenchStamped>,
    sim: &mut SimRobot,
) -> Arc<AtomicBool> {
    sim.hold_finger();
    tracing::info!("the finger waits for the first estimate on biotac/wrench");
    let flag = Arc::new(AtomicBool::new(false));
    let came = flag.clone();
    tokio::spawn(async move {
        if estimates.next().await.is_some() {
            came.store(true, Ordering::Relaxed);
        }
    });
    flag
}

/// The joint velocity commands as `held` follows them (zero until one
/// comes; one that does not convert is refused), each stamped with the
/// seconds since `start`.
fn follow_commands(
    mut commands: impl Messages<Float64MultiArray>,
    held: HeldCommand,
    start: std::time::Instant,
) -> Arc<Mutex<HeldCommand>> {
    let dof = held.at(0.0).len();
    let qdot = Arc::new(Mutex::new(held));
    let latest = qdot.clone();
    tokio::spawn(async move {
        while let Some(m) = commands.next().await {
            match convert::qdot_from_msg(&m, dof) {
                Ok(v) => super::lock(&latest).command(v, start.elapsed().as_secs_f64()),
                Err(e) => tracing::debug!("command refused: {e}"),
            }
        }
    });
    qdot
}
