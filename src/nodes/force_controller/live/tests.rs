use serde_yaml_ng::Value;

use super::super::tests::{estimate, node, pa10};
use super::*;
use crate::control::{GuardedParams, GuidedParams, Phase, StopReason, TaskKind};
use crate::nodes::guarded_goal::GuardedGoal;
use crate::nodes::tasks;
use crate::params::{from_flat_params, is_named, layered_flat_params, WORLD_YAML};

/// A node of the guided scene, its move started on the PA10 and stepped
/// through `steps` estimates of no force: it reaches for a finger.
fn guided(steps: usize) -> ForceControllerNode {
    let flat = layered_flat_params(
        &[WORLD_YAML, TaskKind::Guided.scene_yaml()],
        "force_controller",
    );
    let base = from_flat_params(&flat.unwrap(), "force_controller").unwrap();
    let mut n = ForceControllerNode::new(base, tasks::shipped(), Vec::new(), None).unwrap();
    n.take_description(pa10()).unwrap();
    n.set_task("guided", true).unwrap();
    for k in 0..steps {
        estimate(&mut n, k as f64 * 0.01, 0.0).unwrap();
    }
    n
}

fn number(v: f64) -> Value {
    serde_yaml_ng::to_value(v).unwrap()
}

/// The BioTac speed commanded on the next estimate, at `t` (m/s).
fn speed(n: &mut ForceControllerNode, t: f64, force: f64) -> f64 {
    estimate(n, t, force).unwrap().velocity.norm()
}

#[test]
fn the_live_parameters_are_the_task_its_sections_the_speed_limit_and_the_rules() {
    let live = live_params(&tasks::shipped());
    for name in [
        "task",
        "guided.deadband_n",
        "guided.margins.gain",
        "guarded.approach_speed_mps",
        "calibrate.pushes",
        "pd.max_speed_mps",
        "oscillation.threshold_n",
        "out_of_range.max_std_n",
    ] {
        assert!(is_named(&live, name), "{name} not live in {live:?}");
    }
    for name in [
        "guidedx",
        "pd.derivative_filter_s",
        "skin.k_n_per_m",
        "control_period_s",
    ] {
        assert!(!is_named(&live, name), "{name} live in {live:?}");
    }
}

#[test]
fn a_running_guided_move_takes_a_set_at_once_and_keeps_its_start() {
    let mut n = guided(20);
    let before = speed(&mut n, 0.2, 0.0);
    assert!(before > 0.004, "reaching for a finger at {before} m/s");
    // The speed limit, at once.
    let takes = n.set_live("pd.max_speed_mps", number(0.004), true).unwrap();
    assert_eq!(takes, Takes::Now);
    let after = speed(&mut n, 0.21, 0.0);
    assert!((after - 0.004).abs() < 1e-12, "{after} m/s");
    // The target, at once: 0 N everywhere, nothing to press: still.
    let zero = serde_yaml_ng::to_value([0.0, 0.0, 0.0]).unwrap();
    assert_eq!(
        n.set_live("guided.target_force_n", zero, true),
        Ok(Takes::Now)
    );
    assert_eq!(speed(&mut n, 0.22, 0.0), 0.0);
    // The deadband, at once: a 0.5 N push on a 1 N target within a 0.6 N
    // deadband moves nothing.
    let one = serde_yaml_ng::to_value([0.0, 0.0, 1.0]).unwrap();
    n.set_live("guided.target_force_n", one, true).unwrap();
    n.set_live("guided.deadband_n", number(0.6), true).unwrap();
    assert_eq!(speed(&mut n, 0.23, 0.5), 0.0);
    assert!(speed(&mut n, 0.24, 0.0) > 0.0, "0 N is beyond the deadband");
    // The same controller: its start and what it measured stay.
    assert!(n.controller().unwrap().started());
    assert_eq!(
        n.params().section::<GuidedParams>().unwrap().deadband_n,
        0.6
    );
    let s = n.status();
    let set = s.values.iter().find(|(k, _)| k == "last_parameter_set");
    assert_eq!(
        set.map(|(_, v)| v.as_str()),
        Some("guided.deadband_n = 0.6: taken at once by the running guided")
    );
    // A stability rule's threshold, at once: the estimates' 1 mN std is
    // now beyond the trusted.
    let tight = number(0.0005);
    assert_eq!(
        n.set_live("out_of_range.max_std_n", tight, true),
        Ok(Takes::Now)
    );
    let out = estimate(&mut n, 0.25, 0.0).unwrap();
    assert_eq!(out.reason, Some(StopReason::OUT_OF_RANGE), "{out:?}");
}

#[test]
fn a_refused_set_says_why_and_changes_nothing() {
    let mut n = guided(20);
    let cases = [
        ("guided.deadband_n", number(-0.1), "deadband_n"),
        (
            "guided.force_limit_n",
            number(0.5),
            "above the target force",
        ),
        (
            "guided.deadband_n",
            Value::String("wide".into()),
            "invalid type",
        ),
        ("guided.nope", number(1.0), "unknown parameter"),
        // Beyond what stops within the force limit against a fingertip.
        ("pd.max_speed_mps", number(5.0), "pd.max_speed_mps"),
        ("oscillation.gain_factor", number(1.5), "gain_factor"),
    ];
    for (name, value, why) in cases {
        for apply in [false, true] {
            let e = n.set_live(name, value.clone(), apply).unwrap_err();
            assert!(e.contains(why), "{name}: {e}");
        }
    }
    let p = n.params();
    assert_eq!(p.pd.max_speed_mps, 0.08);
    assert_eq!(p.section::<GuidedParams>().unwrap().deadband_n, 0.2);
    assert!(n.live_set().is_none());
    // Checking alone changes nothing either.
    n.set_live("guided.deadband_n", number(0.3), false).unwrap();
    assert_eq!(
        n.params().section::<GuidedParams>().unwrap().deadband_n,
        0.2
    );
}

#[test]
fn a_guarded_goal_keeps_its_own_settings_and_the_next_goal_takes_the_set() {
    let mut n = node(None);
    n.take_description(pa10()).unwrap();
    n.start_guarded(&GuardedGoal::default()).unwrap();
    let approach = |n: &mut ForceControllerNode, t: f64| {
        let out = estimate(n, t, 0.0).unwrap();
        assert_eq!(out.phase, Phase::APPROACH);
        out.velocity.norm()
    };
    assert!((approach(&mut n, 0.0) - 0.01).abs() < 1e-9);
    let slower = number(0.004);
    let takes = n.set_live("guarded.approach_speed_mps", slower, true);
    assert_eq!(takes, Ok(Takes::NextStart));
    assert!(
        (approach(&mut n, 0.01) - 0.01).abs() < 1e-9,
        "the goal's own"
    );
    assert_eq!(
        n.live_set().unwrap().to_string(),
        "guarded.approach_speed_mps = 0.004: taken from the next goal or task start"
    );
    n.cancel_goal(0.02);
    estimate(&mut n, 0.02, 0.0);
    n.end_goal();
    n.start_guarded(&GuardedGoal::default()).unwrap();
    assert!(
        (approach(&mut n, 0.03) - 0.004).abs() < 1e-9,
        "the next goal's"
    );
    let g: GuardedParams = n.params().section().unwrap();
    assert_eq!(g.approach_speed_mps, 0.004);
}

#[test]
fn a_shared_setting_is_checked_on_the_task_running_and_a_stopped_move_takes_it_next() {
    // The guarded move's envelope reads its approach speed, not the PD's
    // limit: taken, for the next start.
    let mut n = node(None);
    n.take_description(pa10()).unwrap();
    let fast = number(0.2);
    assert_eq!(
        n.set_live("pd.max_speed_mps", fast.clone(), true),
        Ok(Takes::NextStart)
    );
    // The guided move's envelope reads it: refused, naming it and the limit.
    let mut n = guided(20);
    let e = n.set_live("pd.max_speed_mps", fast, true).unwrap_err();
    assert!(
        e.contains("pd.max_speed_mps") && e.contains("at most"),
        "{e}"
    );
    // A move stopped takes a set from its next start.
    n.stop(super::super::stop::Stopped::Service);
    estimate(&mut n, 0.3, 0.0);
    assert!(!n.running());
    let takes = n.set_live("guided.deadband_n", number(0.3), true);
    assert_eq!(takes, Ok(Takes::NextStart));
    // `task` and the others through one door; an unset value refused.
    assert!(n
        .set_param("guided.deadband_n", None, true)
        .unwrap_err()
        .contains("unset"));
    let e = n.set_param("task", Some(number(1.0)), true).unwrap_err();
    assert!(e.contains("expected a task's name"), "{e}");
    n.set_param("task", Some(Value::String("guided".into())), true)
        .unwrap();
    assert!(
        estimate(&mut n, 1.0, 0.0).unwrap().velocity.norm() > 0.0,
        "started again"
    );
}
