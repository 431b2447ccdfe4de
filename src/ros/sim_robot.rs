//! `sim_robot`: the simulated arm, object or finger, F/T sensor and BioTac
//! ([`SimRobot`]), paced by the wall clock. The arm is the chain between
//! `robot.base_link` and `robot.tip_link` of the robot description (the
//! `robot_description` parameter, or else the first valid one on
//! `/robot_description`); until it comes the node simulates nothing, and it
//! keeps that arm for the rest of its run. Every period it publishes
//! `joint_states`, `ft_sensor/wrench` (ground truth, BioTac frame) and
//! `biotac/readings` (the simulated BioTac lives here, as in the embedded
//! runtime: its contact comes from this node's physics), then applies the
//! latest `velocity_controller/commands`. Stamps are the ROS clock's.
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

use futures::StreamExt;
use r2r::geometry_msgs::msg::{TwistStamped, WrenchStamped};
use r2r::rosgraph_msgs::msg::Clock as ClockMsg;
use r2r::sensor_msgs::msg::JointState as JointStateMsg;
use r2r::std_msgs::msg::Float64MultiArray;
use r2r::QosProfile;
use std::sync::{Arc, Mutex};

use super::description::{first_taken, joint_names_param, robot_description, Description};
use super::params::RuntimeParams;
use super::{bounded, convert, RosError};
use crate::biotac::msg::{self as biotac_msg, BioTacMeta, BIOTAC_MSG_TYPE};
use crate::biotac::BioTacSimConfig;
use crate::control::TaskKind;
use crate::kinematics::{JointVector, Robot};
use crate::nodes::bounds::{InputGuard, MESSAGE_MAX_BYTES};
use crate::nodes::sim_robot::check_real_time_factor;
use crate::nodes::{joint_names, JointState, SimRobot, SimRobotParams};
use crate::params::layered_flat_params;
use crate::params::WORLD_YAML;

/// Runs the node until the process ends.
pub async fn run() -> Result<(), RosError> {
    let mut node = super::create_node("sim_robot")?;
    let remap = joint_names_param(&node)?;
    let frame_id = super::own_string(
        &node,
        "frame_id",
        "biotac",
        "The BioTac frame (F/T wrench and readings).",
    )?;
    let seed = super::own_u64(&node, "seed", 1, "Seed of the simulated noise.")?;
    let sim_time = matches!(
        super::own_param(
            &node,
            "use_sim_time",
            r2r::ParameterValue::Bool(false),
            "Publish the simulated time on /clock and stamp with it.",
        )?,
        r2r::ParameterValue::Bool(true)
    );
    let speed = super::own_f64(
        &node,
        "real_time_factor",
        1.0,
        "Simulated seconds per wall-clock second (with use_sim_time:=true); at least 1.",
    )?;
    check_real_time_factor(speed, sim_time)?;
    let scene = TaskKind::Guarded.scene_yaml();
    let p: SimRobotParams = super::node_params(
        &node,
        "sim_robot",
        layered_flat_params(&[WORLD_YAML, scene], "sim_robot")?,
        &[
            "joint_names",
            "frame_id",
            "seed",
            "real_time_factor",
            "robot_description",
        ],
        super::describe_shared,
    )?;
    let guard = Arc::new(InputGuard::new());
    let description = robot_description(&mut node, &guard)?;
    tracing::info!(
        "object {}, BioTac unit {}, noise seed {seed}, period {} s, {}",
        p.object,
        p.sensor_unit,
        p.control_period_s,
        if sim_time {
            format!("simulated time on /clock, {speed}x real time")
        } else {
            "system time".to_string()
        }
    );
    let p_unit = p.sensor_unit;

    let joints = node.create_publisher::<JointStateMsg>("joint_states", QosProfile::default())?;
    let ft = node.create_publisher::<WrenchStamped>("ft_sensor/wrench", QosProfile::default())?;
    let readings = node.create_publisher_untyped(
        "biotac/readings",
        BIOTAC_MSG_TYPE,
        QosProfile::sensor_data(),
    )?;
    let (qos, max) = (QosProfile::default(), MESSAGE_MAX_BYTES);
    let command_type = "std_msgs/msg/Float64MultiArray";
    let topic = "velocity_controller/commands";
    let mut commands =
        bounded::typed::<Float64MultiArray>(&mut node, topic, command_type, qos, max, &guard)?;
    let biotac_twist =
        node.create_publisher::<TwistStamped>("~/biotac_twist", QosProfile::default())?;
    let finger_twist =
        node.create_publisher::<TwistStamped>("~/finger_twist", QosProfile::default())?;
    // A finger waits for the estimator's first estimate: a person pushes a
    // finger that feels (while the default model trains, it would push a
    // blind arm).
    let estimates = match p.finger_path {
        Some(_) => {
            let wrench_type = "geometry_msgs/msg/WrenchStamped";
            let qos = QosProfile::default();
            Some(bounded::typed::<WrenchStamped>(
                &mut node,
                "biotac/wrench",
                wrench_type,
                qos,
                max,
                &guard,
            )?)
        }
        None => None,
    };
    let start_frame = format!("{frame_id}_start");
    let clock_pub = node.create_publisher::<ClockMsg>("/clock", QosProfile::default())?;
    let clock = super::serve_parameters(&mut node, RuntimeParams::none(&guard))?;
    super::spin(node);

    // The arm: from the parameter, or the first valid description on the
    // topic (a refused one is logged, and the next awaited).
    let build = |text: &str| -> Result<(SimRobot, Vec<String>), RosError> {
        let robot = Robot::from_urdf(text, &p.robot)?;
        let names = joint_names(&robot, &remap)?;
        let sim = SimRobot::new(p.clone(), robot, &BioTacSimConfig::default(), seed)?;
        Ok((sim, names))
    };
    let (mut sim, names) = match description {
        Description::Given(text) => build(&text)?,
        Description::Topic(topic) => {
            tracing::info!(
                "waiting for the robot description on {}: simulating nothing until it comes",
                super::description::DESCRIPTION_TOPIC
            );
            match first_taken(topic, build).await {
                Some(built) => built,
                None => return Ok(()),
            }
        }
    };
    let robot = sim.robot();
    tracing::info!(
        "simulating {}: {} -> {}, joints {names:?}",
        robot.name,
        robot.links.0,
        robot.links.1
    );
    let estimating = Arc::new(std::sync::atomic::AtomicBool::new(false));
    if let Some(mut estimates) = estimates {
        sim.hold_finger();
        tracing::info!("the finger waits for the first estimate on biotac/wrench");
        let flag = estimating.clone();
        tokio::spawn(async move {
            if estimates.next().await.is_some() {
                flag.store(true, std::sync::atomic::Ordering::Relaxed);
            }
        });
    }
    let dof = sim.robot().dof();
    let qdot = Arc::new(Mutex::new(JointVector::zeros(dof)));
    let q = qdot.clone();
    tokio::spawn(async move {
        while let Some(m) = commands.next().await {
            match convert::qdot_from_msg(&m, dof) {
                Ok(v) => *q.lock().unwrap_or_else(|e| e.into_inner()) = v,
                Err(e) => tracing::debug!("command refused: {e}"),
            }
        }
    });
    let meta = BioTacMeta {
        frame_id: frame_id.clone(),
        // Each simulated unit its own serial (a saved tare is per sensor).
        serial: format!("simulated unit {}", p_unit),
        ..BioTacMeta::default()
    };
    let period = std::time::Duration::from_secs_f64(sim.period_s() / speed);
    let mut ticker = tokio::time::interval(period);
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    for step in 1u64.. {
        ticker.tick().await;
        if estimating.load(std::sync::atomic::Ordering::Relaxed) && sim.start_finger() {
            tracing::info!("estimates flow: the finger starts its path");
        }
        let now = if sim_time {
            let t = step as f64 * sim.period_s();
            let msg = ClockMsg {
                clock: convert::time_msg(t),
            };
            if let Err(e) = clock_pub.publish(&msg) {
                tracing::warn!("/clock: {e}");
            }
            t
        } else {
            clock.now_s()
        };
        let mut s = sim.sample();
        s.reading.stamp_s = now;
        let js = JointState {
            stamp_s: now,
            q: s.joints.q,
        };
        let sent = joints
            .publish(&convert::joint_state_msg(&js, &names))
            .and_then(|()| ft.publish(&convert::wrench_stamped(now, &frame_id, &s.ft)))
            .and_then(|()| readings.publish(biotac_msg::to_json(&s.reading, &meta)))
            .and_then(|()| {
                biotac_twist.publish(&convert::linear_twist_msg(now, &start_frame, &s.velocity))
            })
            .and_then(|()| match &s.finger {
                Some(f) => {
                    finger_twist.publish(&convert::linear_twist_msg(now, &start_frame, &f.velocity))
                }
                None => Ok(()),
            });
        if let Err(e) = sent {
            tracing::warn!("publish: {e}");
        }
        sim.command(&qdot.lock().unwrap_or_else(|e| e.into_inner()));
        sim.advance();
    }
    Ok(())
}
