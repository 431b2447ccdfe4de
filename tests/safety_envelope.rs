//! The safety envelope (src/control/envelope.rs) in the closed loop, in the
//! lockstep runtime: every approach speed it accepts, on every object, for
//! several seeds and with the transport delay of a ROS 2 deployment (the
//! estimate one period late, as a controller on a timer takes it; and twice
//! that), peaks at or below the force limit, and the envelope's predicted
//! peak bounds the measured one. Speeds beyond it are refused with the
//! limit named, and the delayed loop still meets the guarded and guided
//! bounds. Figures from the measured (F/T) force.

use tactile_force::control::{task_envelope, ForceController, TaskKind};
use tactile_force::kinematics::Robot;
use tactile_force::report::summary::Summary;
use tactile_force::runtime::demo::run_scene;
use tactile_force::runtime::{Pacing, Scene};

const OBJECTS: [&str; 3] = ["wooden_box", "carton_box", "stuffed_animal"];

mod common;
use common::model;

fn run(scene: &Scene, seed: u64) -> Summary {
    run_scene(
        scene,
        Box::new(model()),
        seed,
        Pacing::Lockstep,
        &mut |_| {},
    )
    .expect("the run completes")
    .summary
}

/// Estimates reach the controller in the `periods`-th period after their
/// reading (1 ms of transport plus up to 9 ms of jitter beyond whole
/// periods), and the envelope's bound covers it (the gains measure it).
fn with_transport_delay(mut scene: Scene, periods: u32) -> Scene {
    if periods == 0 {
        return scene;
    }
    scene.sim.transport_delay_s = 0.001 + 0.01 * f64::from(periods - 1);
    scene.sim.transport_jitter_s = 0.009;
    scene.controller.loop_delays.transport_delay_s = 0.01 * f64::from(periods);
    scene
}

fn guarded_alone(object: &str) -> Scene {
    Scene::builtin(TaskKind::Guarded)
        .unwrap()
        .with_only_object(object)
}

#[test]
fn every_accepted_speed_peaks_within_the_force_limit() {
    for periods in [0, 1, 2] {
        for object in OBJECTS {
            let scene = with_transport_delay(guarded_alone(object), periods);
            let envelope = task_envelope(&scene.controller, &scene.tasks)
                .unwrap()
                .envelope;
            let limit = envelope.max_speed_mps();
            let mut worst = (0.0f64, 0.0);
            for fraction in [0.25, 0.5, 0.75, 1.0] {
                let speed = fraction * limit;
                for seed in [1, 2, 3] {
                    let s = run(&scene.clone().with_approach_speed(speed).unwrap(), seed);
                    let predicted = envelope.peak_force_n(speed);
                    let what = format!("{object}, {periods} periods, {speed} m/s, seed {seed}");
                    assert!(s.peak_force_n <= envelope.limit_n, "{what}: {s:?}");
                    assert!(!s.aborted, "{what}: {s:?}");
                    // Where the contact transient dominates (a prediction
                    // past the target's overshoot bound) the envelope bounds
                    // the peak; below, the peak is the regulation's.
                    if predicted > envelope.target_n + 0.1 {
                        assert!(
                            s.peak_force_n <= predicted,
                            "{what}: predicted {predicted}, {s:?}"
                        );
                    }
                    if s.peak_force_n > worst.0 {
                        worst = (s.peak_force_n, speed);
                    }
                }
            }
            eprintln!(
                "{object}, transport {periods} periods: limit {:.1} mm/s, largest peak {:.3} N (at {:.1} mm/s)",
                limit * 1e3,
                worst.0,
                worst.1 * 1e3
            );
        }
    }
}

#[test]
fn a_ros_like_transport_delay_still_holds_1n_without_oscillating() {
    for periods in [1, 2] {
        for object in OBJECTS {
            let scene = with_transport_delay(guarded_alone(object), periods)
                .with_approach_speed(0.01)
                .unwrap();
            let s = run(&scene, 1);
            let what = format!("{object}, {periods} periods");
            assert!(s.overshoot_n <= 0.1, "{what}: {s:?}");
            assert!(s.steady_state_error_n.unwrap() <= 0.05, "{what}: {s:?}");
            assert!(s.final_sd_n.unwrap() <= 0.02, "{what}: {s:?}");
            assert_eq!(s.final_phase, "hold", "{what}: {s:?}");
        }
    }
}

#[test]
fn a_ros_like_transport_delay_still_follows_the_finger() {
    for periods in [1, 2] {
        let s = run(
            &with_transport_delay(Scene::builtin(TaskKind::Guided).unwrap(), periods),
            1,
        );
        assert!(
            s.rms_force_error_by_axis_n.values().all(|&e| e <= 0.3),
            "{periods} periods: {s:?}"
        );
        assert!(s.max_off_axis_ratio.unwrap() <= 0.1, "{periods}: {s:?}");
        assert_eq!(s.final_phase, "follow", "{periods}: {s:?}");
    }
}

fn refusal(scene: Scene) -> String {
    ForceController::new(scene.controller, Robot::pa10(), &scene.tasks)
        .expect_err("refused")
        .to_string()
}

#[test]
fn the_stiffest_permitted_object_sets_the_limit() {
    // The stuffed animal alone accepts 60 mm/s; in the guarded scene, which
    // also permits anything up to rigid (`unknown`), 23.8 mm/s applies: the
    // skin alone, over the 85 ms of the loop's bounds.
    let soft = Scene::builtin(TaskKind::Guarded)
        .unwrap()
        .with_object("stuffed_animal")
        .with_approach_speed(0.06)
        .unwrap();
    let e = refusal(soft.clone());
    assert!(
        e.contains("at most 0.0238 m/s") && e.contains("unknown") && e.contains("85 ms"),
        "{e}"
    );
    let alone = soft.with_only_object("stuffed_animal");
    ForceController::new(alone.controller, Robot::pa10(), &alone.tasks)
        .expect("alone, the stuffed animal takes 60 mm/s");
    // A longer loop lowers the limit: a bound of two periods of transport,
    // 95 ms in all, 21.6 mm/s on the wooden box.
    let e = refusal(
        with_transport_delay(guarded_alone("wooden_box"), 2)
            .with_approach_speed(0.023)
            .unwrap(),
    );
    assert!(
        e.contains("at most 0.0216 m/s") && e.contains("95 ms"),
        "{e}"
    );
    // An unknown body takes the worst-case stiffness (1e6 N/m): the skin alone.
    let unknown = Scene::builtin(TaskKind::Guarded)
        .unwrap()
        .with_only_object("unknown");
    let speed = task_envelope(&unknown.controller, &unknown.tasks).unwrap();
    assert_eq!(speed.envelope.stiffness_n_per_m, 1e6);
    assert!((speed.envelope.max_speed_mps() - 0.0238).abs() < 5e-4);
    // A body the scene does not permit.
    let e = refusal(
        Scene::builtin(TaskKind::Guarded)
            .unwrap()
            .with_object("fingertip"),
    );
    assert!(
        e.contains("safety.objects") && e.contains("fingertip"),
        "{e}"
    );
}

#[test]
fn the_guided_moves_largest_speed_is_held_to_the_envelope_too() {
    // Against the fingertip (300 N/m) the normal axis allows 166 mm/s from
    // 1.2 N (target + deadband) to the 5 N limit over the 85 ms of the
    // loop's bounds; 0.5 m/s is refused.
    let guided = Scene::builtin(TaskKind::Guided).unwrap();
    let speed = task_envelope(&guided.controller, &guided.tasks).unwrap();
    assert_eq!(
        (speed.key, speed.body.as_str()),
        ("pd.max_speed_mps", "fingertip")
    );
    assert!(
        (speed.envelope.max_speed_mps() - 0.1657).abs() < 1e-3,
        "{speed:?}"
    );
    let mut fast = guided;
    fast.controller.pd.max_speed_mps = 0.5;
    let e = refusal(fast);
    assert!(
        e.contains("pd.max_speed_mps") && e.contains("at most 0.1656 m/s"),
        "{e}"
    );
}

#[test]
fn a_controller_assuming_a_faster_loop_than_the_simulation_is_refused() {
    let mut slow_transport = Scene::builtin(TaskKind::Guarded).unwrap();
    slow_transport.sim.transport_delay_s = 0.015;
    let e = slow_transport.check().unwrap_err().to_string();
    assert!(
        e.contains("loop_delays.transport_delay_s") && e.contains("at least 0.02 s"),
        "{e}"
    );
    let mut slow_arm = Scene::builtin(TaskKind::Guarded).unwrap();
    slow_arm.sim.velocity_lag_s = 0.05;
    let e = slow_arm.check().unwrap_err().to_string();
    assert!(e.contains("loop_delays.arm_lag_s"), "{e}");
}
