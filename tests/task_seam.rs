//! The task seam is open: a task defined here, outside the crate, runs in
//! the closed loop through its registration alone, with its own phase,
//! stop reason and report figure; its parameter, declared once by its
//! field, is checked, described to ROS and listed in the parameter
//! reference.

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use tactile_force::contact::BodyParams;
use tactile_force::control::task::{TaskInput, TaskLoop};
use tactile_force::control::{
    Phase, StopReason, Task, TaskEnvelope, TaskFigures, TaskKind, TaskSection,
};
use tactile_force::kinematics::Twist;
use tactile_force::nodes::param_reference::{markdown, RosNode};
use tactile_force::nodes::tasks;
use tactile_force::params::reference::check_ranges;
use tactile_force::params::{Check, Checked, ParamsError};
use tactile_force::runtime::demo::run_scene;
use tactile_force::runtime::{Pacing, Scene};
use tactile_force::wrench::Axis;

mod common;
use common::model;

/// The section `hold_still:` of the controller's parameters.
#[derive(Debug, Clone, Serialize, Deserialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
struct HoldStillParams {
    /// How long to hold still (s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    seconds: f64,
}

impl Check for HoldStillParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        check_ranges(&self, key)?;
        Ok(self)
    }
}

/// Holds the BioTac still for a while, then stops.
#[derive(Debug, Clone)]
struct HoldStill {
    left_s: f64,
    held_s: f64,
    reason: Option<StopReason>,
}

/// Its one phase.
const STILL: Phase = Phase::named("still");
/// Why it stops on its own.
const HELD: StopReason = StopReason::named("held_long_enough");

impl TaskSection for HoldStillParams {
    const NAME: &'static str = "hold_still";

    fn build(p: Checked<Self>, _: &TaskLoop, _: &BodyParams) -> Box<dyn Task> {
        Box::new(HoldStill {
            left_s: p.seconds,
            held_s: 0.0,
            reason: None,
        })
    }

    fn envelope(
        _: &Checked<Self>,
        lp: &TaskLoop,
        body: &BodyParams,
        name: &str,
    ) -> Result<TaskEnvelope, ParamsError> {
        Ok(TaskEnvelope {
            envelope: lp.press_envelope(body, 0.1, 0.1, 1.0),
            body: name.into(),
            key: "hold_still",
            speed_mps: 0.0,
        })
    }
}

impl Task for HoldStill {
    fn step(&mut self, i: &TaskInput) -> Twist {
        if self.left_s > 0.0 {
            self.left_s -= i.dt;
            self.held_s += i.dt;
            if self.left_s <= 0.0 {
                self.reason = Some(HELD);
            }
        }
        Twist::zeros()
    }

    fn phase(&self) -> Phase {
        if self.left_s > 0.0 {
            STILL
        } else {
            Phase::STOPPED
        }
    }

    fn reason(&self) -> Option<StopReason> {
        self.reason
    }

    fn targets(&self) -> [Option<f64>; 3] {
        [None; 3]
    }

    fn gains(&self) -> [Option<f64>; 3] {
        [None; 3]
    }

    fn directions(&self) -> Vec<(String, Vector3<f64>)> {
        Vec::new()
    }

    fn force_axes(&self) -> Vec<Axis> {
        Vec::new()
    }

    fn pause(&mut self) {}

    fn stop(&mut self) {
        self.left_s = 0.0;
    }

    fn stop_on(&mut self, reason: StopReason) {
        self.left_s = 0.0;
        self.reason = Some(reason);
    }

    fn figures(&self) -> TaskFigures {
        TaskFigures {
            own: vec![("held_s", self.held_s)],
            ..TaskFigures::default()
        }
    }
}

/// The guarded scene with the task `hold_still` for 1 s.
fn hold_still_scene() -> Scene {
    let mut scene = Scene::builtin(TaskKind::Guarded).unwrap();
    scene.controller.task = "hold_still".into();
    scene
        .controller
        .set_section(&HoldStillParams { seconds: 1.0 });
    scene
}

#[test]
fn a_task_defined_outside_runs_in_the_closed_loop_through_its_registration_alone() {
    let scene = hold_still_scene().with_tasks(tasks::shipped().with::<HoldStillParams>());
    let run = run_scene(&scene, Box::new(model()), 1, Pacing::Lockstep, &mut |_| {}).unwrap();
    let rows = &run.rows;
    // It holds from its first fresh inputs (the estimator's tare first),
    // for a second, then stops on its own reason; the arm never moves.
    let first = rows.iter().position(|r| !r.halted).unwrap();
    let stop = rows.iter().position(|r| r.phase == Phase::STOPPED).unwrap();
    let held_s = rows[stop].t - rows[first].t;
    assert!((held_s - 1.0).abs() < 0.011, "held {held_s} s");
    assert!(rows[first..stop].iter().all(|r| r.phase == STILL));
    assert_eq!(rows[stop].reason, Some(HELD));
    assert!(rows.iter().all(|r| r.commanded == Vector3::zeros()));
    let moved = rows.iter().map(|r| r.offset.norm()).fold(0.0, f64::max);
    assert!(moved < 1e-9, "moved {moved} m");
    // Its report: its name, its reason (not an abort), its own figure.
    let s = &run.summary;
    assert_eq!(
        (s.task, s.reason, s.aborted),
        ("hold_still", Some("held_long_enough"), false)
    );
    let own = &s.identified.as_ref().unwrap().task_figures;
    assert!((own["held_s"] - held_s).abs() < 0.011, "{own:?}");
    let json = serde_json::to_string(s).unwrap();
    assert!(
        json.contains(r#""final_phase":"stopped""#) && json.contains(r#""held_s":"#),
        "{json}"
    );
}

#[test]
fn without_its_registration_the_task_and_its_section_are_refused_by_name() {
    let e = hold_still_scene().check().unwrap_err().to_string();
    assert!(
        e.contains("hold_still") && e.contains("guarded, guided or calibrate"),
        "{e}"
    );
    // The section of a task nobody registered, beside a shipped task.
    let mut scene = hold_still_scene();
    scene.controller.task = "guarded".into();
    let e = scene.check().unwrap_err().to_string();
    assert!(
        e.contains("hold_still") && e.contains("the section of a task"),
        "{e}"
    );
    // Registered, its own checks apply.
    let mut scene = hold_still_scene().with_tasks(tasks::shipped().with::<HoldStillParams>());
    scene
        .controller
        .set_section(&HoldStillParams { seconds: -1.0 });
    let e = scene.check().unwrap_err().to_string();
    assert!(e.contains("hold_still.seconds") && e.contains("> 0"), "{e}");
}

#[test]
fn its_parameter_declared_once_is_described_to_ros_and_in_the_reference() {
    let registry = tasks::shipped().with::<HoldStillParams>();
    let node = RosNode::ForceController;
    let said = node.describe(&registry, "hold_still.seconds");
    assert_eq!(said, "How long to hold still (s).");
    let row = "| `hold_still.seconds` | number | > 0 |  | How long to hold still (s). |";
    assert!(markdown(&registry).unwrap().contains(row));
    // Not registered: no task of that name, nothing described.
    let said = node.describe(&tasks::shipped(), "hold_still.seconds");
    assert_eq!(said, "See the config/ files.");
    assert!(!markdown(&tasks::shipped()).unwrap().contains("hold_still"));
}
