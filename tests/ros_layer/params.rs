//! ROS 2 parameters <-> our checked parameter structs
//! (`tactile_force::ros::params`).

use std::sync::Arc;

use r2r::{Parameter, ParameterValue};
use tactile_force::control::TaskKind;
use tactile_force::kinematics::ShippedRobot;
use tactile_force::nodes::bounds::InputGuard;
use tactile_force::params::layered_flat_params;
use tactile_force::ros::params::*;
use tactile_force::runtime::scene::Scene;

#[test]
fn every_shipped_parameter_survives_the_trip_through_ros_values() {
    let runs = TaskKind::ALL
        .into_iter()
        .flat_map(|t| ShippedRobot::ALL.map(|r| (t, r)));
    for (task, robot) in runs {
        let scene = Scene::shipped(task, robot).unwrap();
        for node in ["force_controller", "sim_robot", "wrench_estimator"] {
            let defaults = layered_flat_params(&task.shipped_layers(robot), node).unwrap();
            let mut params = indexmap::IndexMap::new();
            declare(&mut params, &defaults, &|_| "test".into());
            assert_eq!(
                params.len(),
                defaults.len(),
                "{node}: every value fits a ROS type"
            );
            params.insert(
                "use_sim_time".into(),
                Parameter::new(ParameterValue::Bool(false)),
            );
            match node {
                "force_controller" => {
                    let p: tactile_force::control::ControllerParams =
                        read(&params, &[], node).unwrap();
                    assert_eq!(p, scene.controller);
                }
                "sim_robot" => {
                    let p: tactile_force::nodes::SimRobotParams = read(&params, &[], node).unwrap();
                    assert_eq!(p, scene.sim);
                }
                _ => {
                    let p: tactile_force::nodes::wrench_estimator::EstimatorParams =
                        read(&params, &[], node).unwrap();
                    assert_eq!(p, scene.estimator);
                }
            }
        }
    }
}

#[test]
fn a_launch_override_wins_and_a_bad_one_is_named() {
    let layers = TaskKind::Guarded.shipped_layers(ShippedRobot::Pa10);
    let defaults = layered_flat_params(&layers, "force_controller").unwrap();
    let mut params = indexmap::IndexMap::new();
    params.insert(
        "object".to_string(),
        Parameter::new(ParameterValue::String("carton_box".into())),
    );
    params.insert(
        "pd.derivative_filter_s".to_string(),
        Parameter::new(ParameterValue::String("fast".into())),
    );
    declare(&mut params, &defaults, &|name| format!("about {name}"));
    // Given at launch: its value kept, described as declared ones are.
    let given = &params["object"];
    assert_eq!(given.value, ParameterValue::String("carton_box".into()));
    assert_eq!(given.description, "about object");
    let err = read::<tactile_force::control::ControllerParams>(&params, &[], "force_controller")
        .unwrap_err()
        .to_string();
    // serde names the node and the bad value (not the key) for a type error.
    assert!(
        err.contains("force_controller") && err.contains("fast"),
        "{err}"
    );
    params.insert(
        "pd.derivative_filter_s".to_string(),
        Parameter::new(ParameterValue::Integer(1)),
    );
    let p: tactile_force::control::ControllerParams =
        read(&params, &[], "force_controller").unwrap();
    assert_eq!(p.object, "carton_box");
    assert_eq!(p.pd.derivative_filter_s, 1.0);
}

fn guard() -> Arc<InputGuard> {
    Arc::new(InputGuard::new())
}

#[test]
fn only_live_parameters_change_while_running_and_a_refusal_says_why() {
    use r2r::RosParams;
    let mut p = RuntimeParams::new(
        &["task"],
        Box::new(|_, v, _| match v {
            ParameterValue::String(s) if s == "guided" => Ok(()),
            other => Err(format!("{other:?}: expected guided")),
        }),
        &guard(),
    );
    let guided = ParameterValue::String("guided".into());
    assert!(p.set_parameter("task", &guided).is_ok());
    let err = p
        .set_parameter("task", &ParameterValue::String("fast".into()))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("task") && err.contains("expected guided"),
        "{err}"
    );
    let err = p.check_parameter("pd.max_speed_mps", &guided).unwrap_err();
    assert!(err.to_string().contains("read at start-up only"), "{err}");
    let err = RuntimeParams::none(&guard()).check_parameter("task", &guided);
    assert!(err
        .unwrap_err()
        .to_string()
        .contains("(may change while running: none)"));
}

#[test]
fn sets_beyond_the_rate_are_refused_with_it_before_the_node_sees_them() {
    use r2r::RosParams;
    let seen = Arc::new(std::sync::atomic::AtomicUsize::new(0));
    let counter = seen.clone();
    let g = guard();
    let mut p = RuntimeParams::new(
        &["task"],
        Box::new(move |_, _, _| {
            counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            Ok(())
        }),
        &g,
    );
    let guided = ParameterValue::String("guided".into());
    let answers: Vec<_> = (0..25).map(|_| p.set_parameter("task", &guided)).collect();
    assert_eq!(answers.iter().filter(|a| a.is_ok()).count(), 10);
    assert_eq!(seen.load(std::sync::atomic::Ordering::Relaxed), 10);
    let why = answers[24].as_ref().unwrap_err().to_string();
    assert!(
        why.contains("refused: over the rate: at most 10 parameter sets at once and 5 a second"),
        "{why}"
    );
    // Start-up-only parameters count too, checked or set.
    assert!(p.check_parameter("pd.max_speed_mps", &guided).is_err());
    assert_eq!(g.refused().parameter_sets, 16);
}
