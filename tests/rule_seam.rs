//! The stability rules are one chain that every task runs: a rule defined
//! here, outside the crate, added to the chain alone, stops the guarded
//! move, the guided move and the calibration, each leaving the contact its
//! own way.

use tactile_force::control::rules::{Rule, RuleInput, Verdict};
use tactile_force::control::{Phase, StopReason, TaskKind};
use tactile_force::runtime::demo::run_scene;
use tactile_force::runtime::{Pacing, Scene};

mod common;
use common::model;

/// The force this rule allows (N): below every shipped task's target.
const GENTLE_N: f64 = 0.6;
/// Its reason.
const TOO_FIRM: StopReason = StopReason::abort("too_firm");

/// Stops a task once the estimated force passes [`GENTLE_N`].
#[derive(Debug, Clone, Copy)]
struct Gentle;

impl Rule for Gentle {
    fn check(&mut self, i: &RuleInput) -> Option<Verdict> {
        (i.force.norm() > GENTLE_N).then_some(Verdict::Stop(TOO_FIRM))
    }
}

#[test]
fn a_rule_added_to_the_chain_stops_every_task_which_leaves_the_contact_its_own_way() {
    for task in TaskKind::ALL {
        let scene = Scene::builtin(task).unwrap().with_rule(Gentle);
        let run = run_scene(&scene, Box::new(model()), 1, Pacing::Lockstep, &mut |_| {}).unwrap();
        let rows = &run.rows;
        // Where the task leaves the contact or stops: the rule's doing,
        // as the last row's reason says.
        let leaving = |p: Phase| p == Phase::RETRACT || p == Phase::STOPPED;
        let stop = rows
            .iter()
            .position(|r| leaving(r.phase))
            .unwrap_or_else(|| panic!("{task}: never stopped"));
        // On the first estimate past the rule's force (the calibration's
        // force is its F/T sensor's).
        let force = |i: usize| match (task, rows[i].estimate) {
            (TaskKind::Calibrate, _) => rows[i].measured.norm(),
            (_, Some((f, _))) => f.norm(),
            (_, None) => 0.0,
        };
        assert!(force(stop) > GENTLE_N, "{task}: {} N", force(stop));
        assert!((0..stop).all(|i| force(i) <= GENTLE_N), "{task}");
        // The guarded move and the calibration's press retract; the guided
        // move stops where it is.
        let retracts = rows[stop..].iter().any(|r| r.phase == Phase::RETRACT);
        assert_eq!(retracts, task != TaskKind::Guided, "{task}");
        let last = rows.last().unwrap();
        assert_eq!((last.phase, last.reason), (Phase::STOPPED, Some(TOO_FIRM)));
        assert!(run.summary.aborted && run.summary.reason == Some("too_firm"));
    }
}

#[test]
fn without_the_rule_the_guarded_move_holds() {
    let scene = Scene::builtin(TaskKind::Guarded).unwrap();
    let run = run_scene(&scene, Box::new(model()), 1, Pacing::Lockstep, &mut |_| {}).unwrap();
    assert_eq!(run.summary.reason, None);
    assert_eq!(run.summary.final_phase, "hold");
}
