use super::super::frames::Frames;
use super::super::tests::{est, estimate, fz, node, pa10};
use super::super::{Force, ForcePart};
use super::*;
use crate::control::Phase;
use crate::nodes::guarded_goal::GuardedGoal;
use crate::nodes::status::Level;

/// A node on the PA10 with a guarded goal approaching.
fn approaching() -> ForceControllerNode {
    let mut n = node(None);
    n.take_description(pa10()).unwrap();
    n.start_guarded(&GuardedGoal::default()).unwrap();
    estimate(&mut n, 0.0, 0.0);
    assert!(
        n.controller().unwrap().command().norm() > 0.0,
        "approaching"
    );
    n
}

fn still(n: &ForceControllerNode) -> bool {
    n.controller().unwrap().command().norm() == 0.0
}

#[test]
fn every_reason_names_what_stopped_the_arm() {
    assert_eq!(Stopped::Terminate.reason(), "stopped: SIGTERM");
    assert_eq!(Stopped::Interrupt.reason(), "stopped: SIGINT");
    assert_eq!(Stopped::Service.reason(), "stopped: service");
    assert_eq!(Stopped::Deactivated.reason(), "stopped: deactivated");
}

#[test]
fn a_stop_ends_the_goal_with_its_reason_and_leaves_the_node_idle_until_asked() {
    let mut n = approaching();
    assert_eq!(n.goal_end(), None);
    n.stop(Stopped::Terminate);
    assert_eq!(n.goal_end(), Some("stopped: SIGTERM"));
    assert_eq!(n.zero_command(), Some(7), "a zero per joint of the PA10");
    let out = estimate(&mut n, 0.01, 0.0).unwrap();
    assert_eq!(out.phase, Phase::STOPPED);
    assert!(still(&n));
    // Its result sent, the goal ends: idle, commanding zero.
    n.end_goal();
    assert_eq!(n.goal_end(), None);
    estimate(&mut n, 0.02, 0.0);
    assert!(still(&n) && !n.running());
    // A task set asks for motion again.
    n.set_task("guarded", true).unwrap();
    estimate(&mut n, 0.03, 0.0);
    assert!(!still(&n), "approaching again");
    // Stopped without a goal: nothing to end.
    n.stop(Stopped::Service);
    assert_eq!(n.goal_end(), None);
}

#[test]
fn a_node_that_is_not_active_commands_nothing_and_refuses_goals_and_tasks() {
    let mut n = node(None).managed();
    n.take_description(pa10()).unwrap();
    assert_eq!(n.state(), State::Unconfigured);
    assert!(estimate(&mut n, 0.0, 0.0).is_none() && n.on_late(1.0).is_none());
    let e = n.start_guarded(&GuardedGoal::default()).unwrap_err();
    assert!(
        e.contains("unconfigured (lifecycle)") && e.contains("configure, then activate"),
        "{e}"
    );
    n.configured();
    let e = n.set_task("guarded", true).unwrap_err();
    assert!(
        e.contains("inactive (lifecycle)") && e.contains("set NODE activate"),
        "{e}"
    );
    assert!(!n.status().message.is_empty() && n.needs("biotac/wrench_estimate"));
    n.activate();
    n.start_guarded(&GuardedGoal::default()).unwrap();
    estimate(&mut n, 0.01, 0.0);
    assert!(!still(&n), "active: it approaches");
    // Deactivated while it approaches: the arm stopped, a zero due, the
    // goal ended with the reason; nothing steps while inactive.
    assert!(n.leave_active(Stopped::Deactivated, State::Inactive));
    assert_eq!(n.goal_end(), Some("stopped: deactivated"));
    assert!(estimate(&mut n, 0.02, 0.0).is_none());
    assert!(
        !n.leave_active(Stopped::Shutdown, State::Finalized),
        "not active: no zero due"
    );
    assert!(
        !n.needs("biotac/wrench_estimate"),
        "finalized needs nothing"
    );
}

#[test]
fn a_wrench_in_another_frame_is_refused_and_ends_the_goal_that_uses_it() {
    let mut n = approaching().with_frames(Frames::new("biotac", "ft_link", true).unwrap());
    // The F/T wrench is not what a guarded move uses: refused, said, the goal runs on.
    assert!(!n.on_force_msg(
        ForcePart::Ft,
        "biotac",
        Ok(Force::Ft((0.01, fz(1.0)))),
        0.011
    ));
    assert_eq!(n.goal_end(), None);
    assert!(
        n.on_force_msg(
            ForcePart::Estimate,
            "tool0",
            Ok(est(0.01, 0.0, 0.001)),
            0.011
        ),
        "the task that used it stopped: its zero is due"
    );
    assert!(still(&n), "a zero command at once");
    let why = n.goal_end().unwrap();
    assert!(
        why.starts_with("refused: biotac/wrench_estimate came in frame \"tool0\", not \"biotac\""),
        "{why}"
    );
    let s = n.status();
    assert_eq!(s.level, Level::Error);
    let said: Vec<_> = s
        .values
        .iter()
        .filter(|(k, _)| k.starts_with("frame_refused"))
        .collect();
    assert_eq!(said.len(), 2, "{said:?}");
    // In the right frames, taken.
    assert!(n.on_force_msg(
        ForcePart::Estimate,
        "biotac",
        Ok(est(0.02, 0.0, 0.001)),
        0.021
    ));
}
