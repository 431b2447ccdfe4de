use nalgebra::Vector3;

use super::goals::{CalibrationProgress, WITHDRAW_S};
use super::*;
use crate::calibration::{CalibrateGoal, Ended};
use crate::control::{Halt, StopReason};
use crate::kinematics::{JointVector, ShippedRobot};
use crate::nodes::guarded_goal::GuardedGoal;
use crate::nodes::status::{Level, Status};
use crate::nodes::tasks;
use crate::params::from_flat_params;
use crate::runtime::scene::Scene;

/// A node with the shipped defaults (every task's section), as the ROS
/// node starts.
pub(super) fn node(ft_to_biotac: Option<FrameTransform>) -> ForceControllerNode {
    let base = from_flat_params(&shipped_defaults().unwrap(), "force_controller").unwrap();
    ForceControllerNode::new(base, tasks::shipped(), Vec::new(), ft_to_biotac).unwrap()
}

pub(super) fn pa10() -> &'static str {
    ShippedRobot::Pa10.urdf()
}

/// The PA10's start pose of the shipped scenes.
fn start_pose() -> JointVector {
    let scene = Scene::builtin(TaskKind::Guarded).unwrap();
    Robot::pa10()
        .positions_from_deg_mm("start", scene.sim.start_joints_deg.as_ref().unwrap())
        .unwrap()
}

pub(super) fn joints(t: f64) -> JointState {
    JointState {
        stamp_s: t,
        q: start_pose(),
    }
}

pub(super) fn fz(v: f64) -> Wrench {
    Wrench::new(Vector3::new(0.0, 0.0, v), Vector3::zeros())
}

/// An estimate of the reading at `t`: `force` along z, `std` on every axis.
pub(super) fn est(t: f64, force: f64, std: f64) -> Force {
    Force::Estimate(WrenchEstimate {
        stamp_s: t,
        seq: 0,
        mean: fz(force),
        std: Wrench::new(Vector3::repeat(std), Vector3::repeat(std)),
        estimated: [true; 6],
        pdc_rise: 0.0,
    })
}

/// One estimate at `t`: the output when it stepped.
pub(super) fn estimate(n: &mut ForceControllerNode, t: f64, force: f64) -> Option<ControlOutput> {
    n.on_joint_state(&joints(t));
    n.on_force(est(t, force, 0.001), t + 0.001).cloned()
}

#[test]
fn nothing_is_commanded_before_a_description_and_the_status_says_so() {
    let mut n = node(None);
    assert!(n.controller().is_none() && n.joint_names().is_empty());
    assert!(estimate(&mut n, 0.0, 0.0).is_none());
    assert!(n.on_late(0.1).is_none());
    let s = n.status();
    assert_eq!(s.level, Level::Warn);
    assert!(
        s.message.contains("waiting for the robot description"),
        "{s:?}"
    );
}

#[test]
fn a_description_is_taken_once_and_refused_while_a_task_runs() {
    let mut n = node(None);
    assert!(n.take_description("<robot").is_err());
    assert!(
        n.controller().is_none(),
        "a refused description commands nothing"
    );
    assert!(n.take_description(pa10()).unwrap());
    assert_eq!(n.joint_names().len(), 7);
    assert!(!n.take_description(pa10()).unwrap(), "the one in use");
    // Asked, the guarded move begins on its first estimate: another arm
    // is refused.
    n.set_task("guarded", true).unwrap();
    let out = estimate(&mut n, 0.0, 0.0).unwrap();
    assert_eq!((out.phase, out.halt), (Phase::APPROACH, None));
    let five = include_str!("../../../tests/data/five_joint_arm.urdf");
    let e = n.take_description(five).unwrap_err();
    assert!(matches!(e, DescriptionError::Running), "{e}");
    assert_eq!(n.joint_names().len(), 7, "the PA10 stays");
    // Once the task has stopped, the other arm is taken.
    n.cancel_goal(0.005);
    estimate(&mut n, 0.01, 0.0);
    assert!(!n.running());
    assert!(n.take_description(five).unwrap());
    assert_eq!(n.joint_names().len(), 5);
}

#[test]
fn a_task_switch_is_checked_as_at_start_up_and_refused_during_a_goal() {
    let mut n = node(None);
    let e = n.set_task("admittance", true).unwrap_err();
    assert!(e.contains("guarded, guided or calibrate"), "{e}");
    // Checked without a description: the guided move's speeds are beyond
    // the envelope of the guarded scene's bodies (anything, up to rigid).
    let e = n.set_task("guided", true).unwrap_err();
    assert!(
        e.contains("pd.max_speed_mps") && e.contains("unknown"),
        "{e}"
    );
    // Checking alone changes nothing; applying switches.
    n.set_task("calibrate", false).unwrap();
    assert_eq!(n.status().values[0], ("task".into(), "guarded".into()));
    n.set_task("calibrate", true).unwrap();
    assert_eq!(n.status().values[0], ("task".into(), "calibrate".into()));
    // Built with the description: the calibration waits, the arm still.
    n.take_description(pa10()).unwrap();
    let out = estimate(&mut n, 0.0, 0.0).unwrap();
    assert_eq!(out.phase, Phase::STOPPED);
    assert_eq!(n.controller().unwrap().command(), &JointVector::zeros(7));
    n.set_task("guarded", true).unwrap();
    n.start_guarded(&GuardedGoal::default()).unwrap();
    let e = n.set_task("calibrate", true).unwrap_err();
    assert!(e.contains("cancel it first"), "{e}");
}

#[test]
fn launched_with_estimates_flowing_it_commands_zero_until_asked_and_a_set_restarts() {
    let mut n = node(None);
    n.take_description(pa10()).unwrap();
    for k in 0..10 {
        let out = estimate(&mut n, k as f64 * 0.01, 0.0).unwrap();
        assert_eq!(out.phase, Phase::STOPPED);
        assert_eq!(n.controller().unwrap().command(), &JointVector::zeros(7));
    }
    assert!(n.status().message.contains("waiting to be asked"));
    n.set_task("guarded", true).unwrap();
    let out = estimate(&mut n, 0.1, 0.0).unwrap();
    assert_eq!(out.phase, Phase::APPROACH);
    assert!(n.controller().unwrap().command().norm() > 0.0);
    // While it runs, the same task again cannot take effect: refused.
    let e = n.set_task("guarded", true).unwrap_err();
    assert!(e.contains("is running"), "{e}");
    // Stopped, a set starts it again.
    n.cancel_goal(0.105);
    estimate(&mut n, 0.11, 0.0);
    assert!(!n.running());
    n.set_task("guarded", true).unwrap();
    let out = estimate(&mut n, 1.0, 0.0).unwrap();
    assert_eq!(out.phase, Phase::APPROACH);
}

#[test]
fn an_estimate_steps_and_a_late_one_halts() {
    let mut n = node(None);
    n.take_description(pa10()).unwrap();
    n.set_task("guarded", true).unwrap();
    let out = estimate(&mut n, 0.0, 0.0).unwrap();
    assert!(
        out.halt.is_none() && out.velocity.z < 0.0,
        "approaching: {out:?}"
    );
    // Not stale yet: the arm goes on with the last command.
    let stale = n.controller().unwrap().stale_after_s();
    assert!(n.on_late(0.015).is_none(), "stale after {stale} s");
    assert!(n.until_stale_s(0.015) >= stale - 0.015 - 1e-9);
    let out = n.on_late(stale + 0.001).unwrap().clone();
    assert!(matches!(out.halt, Some(Halt::Stale { .. })), "{out:?}");
    assert_eq!(n.controller().unwrap().command(), &JointVector::zeros(7));
    assert!(n.status().message.contains("halted"));
    // A refused estimate is counted and not stepped on.
    assert!(n.on_force(est(0.02, f64::NAN, 0.0), 0.021).is_none());
    let unread = Err("biotac/wrench_estimate: a value is not finite".into());
    assert!(!n.on_force_msg(ForcePart::Estimate, "biotac", unread, 0.021));
    let s = n.status();
    assert!(s.values.contains(&("rejected".into(), "2".into())), "{s:?}");
}

#[test]
fn the_status_says_what_its_guard_refused() {
    let mut n = node(None);
    let refused = (0..8).filter(|_| n.guard().admit_goal().is_err()).count();
    assert_eq!(refused, 3, "the burst of 5 admitted");
    let s = n.status();
    assert!(
        s.values
            .contains(&("refused_goals_over_rate".into(), "3".into())),
        "{s:?}"
    );
    assert!(
        s.values.contains(&("refused_oversized".into(), "0".into())),
        "{s:?}"
    );
    assert!(
        s.message.ends_with("; 3 inputs refused by their bounds"),
        "{s:?}"
    );
}

#[test]
fn the_status_says_the_loop_it_measured_and_warns_once_beyond_the_bounds() {
    let mut n = node(None);
    n.take_description(pa10()).unwrap();
    // Estimates 20 ms old: beyond the 10 ms bound of loop_delays.
    n.on_joint_state(&joints(0.0));
    n.on_force(est(0.0, 0.0, 0.001), 0.02);
    let s = n.status();
    assert_eq!(s.level, Level::Warn);
    assert!(s.message.contains("older than loop_delays bounds"), "{s:?}");
    assert!(n.delay_warned);
    let value = |name: &str| {
        s.values
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.clone())
    };
    assert_eq!(value("transport_ms").as_deref(), Some("20.0"), "{s:?}");
    assert_eq!(value("arm_fitted").as_deref(), Some("false"));
    assert!(value("gain_z_mm_s_per_n").is_some() && value("stiffness_z_n_per_m").is_some());
    let s = n.status();
    assert!(
        !s.message.contains("loop delay"),
        "no steps, no report: {s:?}"
    );
}

#[test]
fn a_guarded_goal_runs_reports_and_ends_and_only_one_goal_at_a_time() {
    let mut n = node(None);
    let goal = GuardedGoal::default();
    let e = n.start_guarded(&goal).unwrap_err();
    assert!(e.contains("no robot description"), "{e}");
    n.take_description(pa10()).unwrap();
    let fast = GuardedGoal {
        speed_mps: 5.0,
        ..goal
    };
    let e = n.start_guarded(&fast).unwrap_err();
    assert!(e.contains("approach_speed_mps"), "{e}");
    n.start_guarded(&goal).unwrap();
    assert!(n.running());
    let e = n.start_guarded(&goal).unwrap_err();
    assert!(e.contains("a goal is running"), "{e}");
    assert_eq!(n.guarded_progress(), None, "not stepped yet");
    estimate(&mut n, 0.0, 0.2);
    let p = n.guarded_progress().unwrap();
    assert_eq!((p.phase, p.outcome), (Phase::REGULATE, None));
    assert!((p.force_n - 0.2).abs() < 1e-12, "{p:?}");
    // What it measured so far: the estimate's age (1 ms); the arm's
    // bounds and the stiffest body as priors.
    assert!((p.loop_delay_s - 0.066).abs() < 1e-9, "{p:?}");
    assert!(p.stiffness_n_per_m.is_some() && p.gain_m_per_s_per_n.is_some());
    assert_eq!(p.settled_sd_n, None, "the window is not full");
    // Canceled in contact: it retracts; an arm that does not follow
    // (these joints stay) is stopped where it is once the bound has passed.
    n.cancel_goal(0.005);
    assert_eq!(n.withdrawn(0.005), None);
    estimate(&mut n, 0.01, 0.2);
    let p = n.guarded_progress().unwrap();
    assert_eq!((p.phase, p.outcome), (Phase::RETRACT, None));
    assert!(
        n.controller().unwrap().command().norm() > 0.0,
        "moving away"
    );
    assert_eq!(n.withdrawn(0.005 + WITHDRAW_S - 0.01), None);
    let e = n.withdrawn(0.005 + WITHDRAW_S).unwrap().unwrap_err();
    assert!(e.contains("did not leave contact"), "{e}");
    estimate(&mut n, 0.02, 0.2);
    let p = n.guarded_progress().unwrap();
    assert_eq!(
        (p.force_n, p.phase, p.outcome),
        (0.2, Phase::STOPPED, Some("stopped"))
    );
    assert!(
        n.take_recording().is_none(),
        "a guarded move records nothing"
    );
    n.end_goal();
    n.set_task("calibrate", true).unwrap();
}

/// The node on the PA10 whose joints follow its commands after a latency
/// `l` and a lag `tau`, nothing touched: waiting until `t_goal` (s), then
/// a guarded goal, to `t_end`. Joint states every 4 ms, estimates every
/// 10 ms; the goal's controller.
fn arm_under_a_goal(l: f64, tau: f64, t_goal: f64, t_end: f64) -> ForceControllerNode {
    let mut n = node(None);
    n.take_description(pa10()).unwrap();
    let (dt, mut q) = (1e-4, start_pose());
    let mut qdot = q.clone() * 0.0;
    let mut sent: Vec<(f64, JointVector)> = vec![(-1.0, qdot.clone())];
    for k in 0..(t_end / dt).round() as usize {
        let t = k as f64 * dt;
        if k == (t_goal / dt).round() as usize {
            n.start_guarded(&GuardedGoal::default()).unwrap();
        }
        if k % 40 == 0 {
            n.on_joint_state(&JointState {
                stamp_s: t,
                q: q.clone(),
            });
        }
        if k % 100 == 0 {
            n.on_force(est(t, 0.0, 0.001), t + 0.001);
            sent.push((t + 0.001, n.controller().unwrap().command().clone()));
        }
        let u = &sent.iter().rev().find(|(ts, _)| ts + l <= t).unwrap().1;
        qdot += (u - &qdot) * (dt / tau);
        q += &qdot * dt;
    }
    n
}

#[test]
fn a_goal_fits_the_arm_from_its_start_from_rest_on_any_body() {
    // 0.5 s of an approach at a steady speed, nothing touched yet: the
    // step from rest at the goal's start is all the fit sees.
    for (l, tau) in [(0.02, 0.01), (0.008, 0.03)] {
        let n = arm_under_a_goal(l, tau, 1.0, 1.5);
        let arm = n.controller().unwrap().arm_response().expect("fitted");
        assert!(
            (arm.latency_s - l).abs() <= 0.005 && (arm.lag_s - tau).abs() <= 0.005,
            "{l} {tau}: {arm:?}"
        );
    }
}

#[test]
fn a_calibration_steps_on_the_ft_wrench_and_records_it_with_its_reading() {
    // The F/T sensor mounted upside down: its +z is the BioTac's -z.
    let flipped: FrameTransform = "180,0,0,0,0,0".parse().unwrap();
    let mut n = node(Some(flipped));
    n.take_description(pa10()).unwrap();
    n.start_calibration(&CalibrateGoal::default(), 0.0, None)
        .unwrap();
    assert!(n.wants_readings());
    assert_eq!(n.calibration_progress(0.0), CalibrationProgress::Starting);
    // Estimates wait; the F/T wrench steps, moved to the BioTac frame.
    n.on_joint_state(&joints(0.0));
    assert!(n.on_force(est(0.0, 0.0, 0.0), 0.0).is_none());
    let reading = |t: f64| BioTacReading {
        seq: 0,
        stamp_s: t,
        electrodes: [3000; crate::biotac::N_ELECTRODES].into(),
        pdc: 2000,
        pac: [2000; crate::biotac::N_PAC].into(),
        tdc: 1800,
        tac: 2000,
    };
    n.on_reading(reading(0.0));
    let out = n.on_force(Force::Ft((0.0, fz(-0.01))), 0.001).unwrap();
    assert_eq!(out.phase, Phase::REST);
    match n.calibration_progress(0.001) {
        CalibrationProgress::Running {
            push,
            pushes,
            force_n,
            ..
        } => assert_eq!((push, pushes, force_n), (1, 24, 0.01)),
        other => panic!("{other:?}"),
    }
    // Over the rest's force the calibration stops in contact.
    n.on_reading(reading(0.01));
    n.on_force(Force::Ft((0.01, fz(-1.0))), 0.011);
    assert_eq!(
        n.calibration_progress(0.011),
        CalibrationProgress::Ended(Ended::Stopped(StopReason::IN_CONTACT))
    );
    let rec = n.take_recording().unwrap();
    assert_eq!(rec.records().len(), 2, "each wrench with its reading");
    assert!((rec.records()[1].wrench.force.z - 1.0).abs() < 1e-12);
    assert!(!n.wants_readings(), "estimates are the force again");
    let e = n.set_task("guarded", true).unwrap_err();
    assert!(
        e.contains("cancel it first"),
        "the fit is part of the goal: {e}"
    );
    n.end_goal();
    assert!(!n.running());
}

#[test]
fn a_silent_ft_sensor_halts_the_calibration() {
    let mut n = node(None);
    n.take_description(pa10()).unwrap();
    n.start_calibration(&CalibrateGoal::default(), 1.0, None)
        .unwrap();
    assert_eq!(n.calibration_progress(1.2), CalibrationProgress::Starting);
    assert_eq!(
        n.calibration_progress(1.5),
        CalibrationProgress::Ended(Ended::FtStale(0.0))
    );
    n.end_goal();
    // Without the calibration, the F/T wrench is not the force.
    assert!(n.on_force(Force::Ft((1.6, fz(0.0))), 1.6).is_none());
}

#[test]
fn the_adapter_parameters_are_parsed_or_named() {
    assert_eq!(
        "twist".parse::<CommandInterface>().unwrap(),
        CommandInterface::Twist
    );
    let e = "torque"
        .parse::<CommandInterface>()
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("command_interface") && e.contains("joint_velocities or twist"),
        "{e}"
    );
    assert_eq!(ft_to_biotac("").unwrap(), None);
    assert!(ft_to_biotac("0,0,90,0,0,0.05").unwrap().is_some());
    let e = ft_to_biotac("0,0,90").unwrap_err().to_string();
    assert!(e.contains("ft_to_biotac"), "{e}");
    let n = node(None);
    let s = n.summary().unwrap();
    assert!(
        s.contains("task guarded") && s.contains("speed limit"),
        "{s}"
    );
}

/// A status value by name.
fn status_value(s: &Status, name: &str) -> Option<String> {
    s.values
        .iter()
        .find(|(k, _)| k == name)
        .map(|(_, v)| v.clone())
}

/// The node's loop as src/ros/force_controller/stepping.rs runs it, the
/// guarded move approaching nothing, on an arm that publishes its joint
/// states and takes the command every `cycle_s` (acting a cycle later,
/// through a first-order lag `lag_s`): estimates at 100 Hz, stamped every
/// 10 ms until `stop_s`, each arriving 2 ms plus up to `jitter_s` after
/// its stamp (`u^8 jitter_s`, u uniform and seeded: mostly little, with a
/// tail, as over DDS; in order); the late timer at `until_stale_s`
/// after each step. Runs `seconds`: the node and when it halted for a stale
/// estimate (each halt once).
fn stepping_loop(
    cycle_s: f64,
    lag_s: f64,
    jitter_s: f64,
    stop_s: f64,
    seconds: f64,
) -> (ForceControllerNode, Vec<f64>) {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(48);
    let mut n = node(None);
    n.take_description(pa10()).unwrap();
    n.set_task("guarded", true).unwrap();
    let (mut q, mut v, mut acting) = (start_pose(), JointVector::zeros(7), JointVector::zeros(7));
    let follow = if lag_s > 0.0 {
        1.0 - (-cycle_s / lag_s).exp()
    } else {
        1.0
    };
    let (mut k, mut arrival, mut cycles) = (0_u32, 0.0_f64, 0_u32);
    let (mut deadline, mut halts, mut halted) = (f64::INFINITY, Vec::new(), false);
    loop {
        let stamp = f64::from(k) * 0.01;
        if arrival <= stamp {
            arrival = arrival.max(stamp + 0.002 + jitter_s * rng.random::<f64>().powi(8));
        }
        let est_t = if stamp < stop_s {
            arrival
        } else {
            f64::INFINITY
        };
        let js_t = f64::from(cycles) * cycle_s;
        let now = est_t.min(js_t).min(deadline);
        if now > seconds {
            return (n, halts);
        }
        let out = if now == js_t {
            cycles += 1;
            q += &v * cycle_s;
            v += (&acting - &v) * follow;
            acting = n.controller().unwrap().command().clone();
            n.on_joint_state(&JointState {
                stamp_s: now,
                q: q.clone(),
            });
            continue;
        } else if now == est_t {
            k += 1;
            n.on_force(est(stamp, 0.0, 0.001), now).cloned()
        } else {
            n.on_late(now).cloned()
        };
        deadline = now + n.until_stale_s(now);
        if let Some(out) = out {
            let stale = matches!(out.halt, Some(Halt::Stale { .. }));
            if stale && !halted {
                halts.push(now);
            }
            halted = stale;
        }
    }
}

/// A status value as a number.
fn status_f64(s: &Status, name: &str) -> f64 {
    status_value(s, name).unwrap().parse().unwrap()
}

#[test]
fn estimates_on_time_never_halt_at_any_arm_cycle_lag_or_jitter() {
    // Issue 48: on a 2 ms arm, "stale: 0.012 s old, limit 0.012 s" halted
    // it when fed at 100 Hz with 2 ms of jitter. The old bound (the usual
    // age plus the loop's delay, at least a period) halted this grid 61
    // times (3, 8 and 50 at a 2 ms cycle without lag), each run 40 s.
    for cycle_ms in [2.0, 4.0, 8.0, 16.0] {
        for lag_ms in [0.0, 10.0, 20.0, 30.0] {
            for jitter_ms in [0.0, 2.0, 5.0] {
                let (mut n, halts) =
                    stepping_loop(cycle_ms * 1e-3, lag_ms * 1e-3, jitter_ms * 1e-3, 41.0, 40.0);
                let s = n.status();
                let case = format!("{cycle_ms} ms cycle, {lag_ms} ms lag, {jitter_ms} ms: {s:?}");
                assert!(halts.is_empty(), "halted at {halts:?}: {case}");
                assert_eq!(status_value(&s, "stale_halts").as_deref(), Some("0"));
                let p50 = status_f64(&s, "estimate_interval_p50_ms");
                let p99 = status_f64(&s, "estimate_interval_p99_ms");
                assert!((p50 - 10.0).abs() <= jitter_ms / 2.0 + 0.05, "{case}");
                assert!(p99 >= p50 && p99 <= 10.0 + jitter_ms + 0.05, "{case}");
                // Due at 12 ms of age (the median jitter is ~0), then three
                // periods, and twice the jitter's spread.
                let bound = status_f64(&s, "stale_after_ms");
                assert!((31.9..=32.1 + 2.0 * jitter_ms).contains(&bound), "{case}");
            }
        }
    }
}

#[test]
fn waiting_for_the_first_estimate_halts_but_is_no_stale_halt() {
    let mut n = node(None);
    n.take_description(pa10()).unwrap();
    n.set_task("guarded", true).unwrap();
    let out = n.on_late(0.5).cloned().unwrap();
    assert!(
        matches!(out.halt, Some(Halt::Stale { age_s, .. }) if age_s.is_infinite()),
        "{out:?}"
    );
    assert_eq!(
        status_value(&n.status(), "stale_halts").as_deref(),
        Some("0")
    );
}

#[test]
fn a_stream_that_stops_halts_three_periods_after_the_next_was_due() {
    // 100 Hz, 2 ms of transport, a 2 ms arm: the last estimate, stamped
    // 2.99 s, halts the arm once 2 + 3 x 10 = 32 ms old, or at the next
    // look (a cycle).
    let (mut n, halts) = stepping_loop(0.002, 0.0, 0.0, 3.0, 3.5);
    assert_eq!(halts.len(), 1, "one halt, however long: {halts:?}");
    assert!(
        halts[0] >= 2.99 + 0.032 - 1e-9 && halts[0] <= 2.99 + 0.034 + 1e-9,
        "{halts:?}"
    );
    let s = n.status();
    assert_eq!(status_value(&s, "stale_after_ms").as_deref(), Some("32.0"));
    assert_eq!(
        status_value(&s, "estimate_interval_p50_ms").as_deref(),
        Some("10.0")
    );
    assert_eq!(status_value(&s, "stale_halts").as_deref(), Some("1"));
    // With up to 5 ms of jitter the bound widens by twice its spread.
    let (mut n, halts) = stepping_loop(0.002, 0.0, 0.005, 3.0, 3.5);
    let bound = status_f64(&n.status(), "stale_after_ms");
    assert!((38.0..=43.0).contains(&bound), "{bound}");
    let due = 2.99 + bound * 1e-3;
    assert!(
        halts.len() == 1 && (due - 1e-4..=due + 0.002 + 1e-4).contains(&halts[0]),
        "{halts:?}"
    );
}
