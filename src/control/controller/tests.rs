use super::*;
use crate::control::TaskKind;
use crate::kinematics::RobotParams;
use crate::nodes::tasks::shipped;
use crate::runtime::scene::Scene;

/// A controller for the task `task` with the other parameters of `base`:
/// a task switch while running, checked as at start-up.
fn switched(
    base: &ControllerParams,
    task: &str,
    robot: Robot,
) -> Result<ForceController, ParamsError> {
    let p = ControllerParams {
        task: task.into(),
        ..base.clone()
    };
    ForceController::new(p, robot, &shipped())
}

/// A scene's parameters with both tasks' sections, as the ROS node
/// declares them.
fn both_sections(task: TaskKind) -> ControllerParams {
    let guarded = Scene::builtin(TaskKind::Guarded).unwrap().controller;
    let guided = Scene::builtin(TaskKind::Guided).unwrap().controller;
    let mut p = if task == TaskKind::Guarded {
        guarded.clone()
    } else {
        guided.clone()
    };
    p.sections.extend(guarded.sections);
    p.sections.extend(guided.sections);
    p
}

#[test]
fn a_task_switch_is_checked_as_at_start_up() {
    assert_eq!("guided".parse::<TaskKind>().unwrap(), TaskKind::Guided);
    let err = "fast".parse::<TaskKind>().unwrap_err().to_string();
    assert!(
        err.contains("fast") && err.contains("guarded, guided or calibrate"),
        "{err}"
    );
    let pa10 = Robot::pa10;
    // The joystick scene may switch to the guarded move, and back.
    let guided = both_sections(TaskKind::Guided);
    let c = switched(&guided, "guarded", pa10()).unwrap();
    assert!(c.gains()[2].is_some() && c.gains()[0].is_none());
    switched(&guided, "guided", pa10()).unwrap();
    // Without the other task's section the switch names what is missing.
    let only = Scene::builtin(TaskKind::Guided).unwrap().controller;
    let err = switched(&only, "guarded", pa10()).unwrap_err();
    assert!(err.to_string().contains("guarded"), "{err}");
    // The guided move's speeds are beyond the envelope of a wooden box.
    let guarded = both_sections(TaskKind::Guarded);
    let err = switched(&guarded, "guided", pa10())
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("pd.max_speed_mps") && err.contains("against unknown"),
        "{err}"
    );
}

fn estimate(t: f64) -> WrenchEstimate {
    WrenchEstimate {
        stamp_s: t,
        seq: 0,
        mean: Default::default(),
        std: Default::default(),
        estimated: [true; 6],
        pdc_rise: 0.0,
    }
}

/// The guarded scene and the PA10's start pose in it.
fn guarded_on_pa10() -> (Scene, JointVector) {
    let scene = Scene::builtin(TaskKind::Guarded).unwrap();
    let q = Robot::pa10()
        .positions_from_deg_mm("start", scene.sim.start_joints_deg.as_ref().unwrap())
        .unwrap();
    (scene, q)
}

/// Hands `c` the joint positions `q` and a zero estimate, both stamped `t`.
fn feed(c: &mut ForceController, q: &JointVector, t: f64) {
    let js = JointState {
        stamp_s: t,
        q: q.clone(),
    };
    c.on_joint_state(&js).unwrap();
    c.on_estimate(estimate(t)).unwrap();
}

#[test]
fn a_late_estimate_stops_the_arm_at_once_and_the_next_one_resumes() {
    let (scene, q) = guarded_on_pa10();
    let mut c = ForceController::new(scene.controller, Robot::pa10(), &scene.tasks).unwrap();
    let inputs = |c: &mut ForceController, t: f64| feed(c, &q, t);
    inputs(&mut c, 0.0);
    let out = c.tick(0.002);
    assert!(
        out.halt.is_none() && c.command().norm() > 0.0,
        "approaching"
    );
    // 15 ms without an estimate: well inside the watchdog's 30 ms.
    let out = c.estimate_late(0.015);
    assert_eq!(c.command(), &JointVector::zeros(7));
    assert!(
        matches!(out.halt, Some(Halt::Stale { .. })),
        "{:?}",
        out.halt
    );
    inputs(&mut c, 0.02);
    let out = c.tick(0.022);
    assert!(
        out.halt.is_none() && c.command().norm() > 0.0,
        "approaching again"
    );
    // A joint state of another arm is refused and counted.
    let other = JointState {
        stamp_s: 0.03,
        q: JointVector::zeros(6),
    };
    let e = c.on_joint_state(&other).unwrap_err();
    assert!(
        matches!(
            e,
            Halt::JointCount {
                expected: 7,
                found: 6
            }
        ),
        "{e}"
    );
    assert_eq!(c.rejected(), 1);
}

/// The five-joint test arm with the world's robot defaults: the chain
/// from its root to its one leaf, the BioTac frame at the flange.
fn five_joints() -> Robot {
    let p = RobotParams::from_layers(&[crate::params::WORLD_YAML]).unwrap();
    Robot::from_urdf(include_str!("../../../tests/data/five_joint_arm.urdf"), &p).unwrap()
}

#[test]
fn an_arm_of_five_joints_runs_the_axes_it_can_realise_and_names_the_one_it_cannot() {
    // Wrist roll at zero: the pad's normal lies in the arm's plane.
    let q = JointVector::from_column_slice(&[0.3, 0.2, 0.4, -0.5, 0.0]);
    // The guarded move presses along the pad's normal: the planar
    // joints make that motion exactly.
    let guarded = Scene::builtin(TaskKind::Guarded).unwrap().controller;
    let mut c = ForceController::new(guarded, five_joints(), &shipped()).unwrap();
    c.check_start(&q).unwrap();
    let js = JointState {
        stamp_s: 0.0,
        q: q.clone(),
    };
    c.on_joint_state(&js).unwrap();
    c.on_estimate(estimate(0.0)).unwrap();
    let out = c.tick(0.001);
    assert!(out.halt.is_none() && out.reason.is_none(), "{out:?}");
    let made = c.robot().chain.jacobian(&q) * c.command();
    let pose = c.robot().chain.forward(&q);
    let wanted = pose.rotation * Vector3::new(0.0, 0.0, -0.01);
    assert!((made.fixed_rows::<3>(0) - wanted).norm() < 1e-12, "{made}");
    assert!(made.fixed_rows::<3>(3).norm() < 1e-12, "orientation held");

    // The guided move needs y as well, which only the pan could give.
    let guided = Scene::builtin(TaskKind::Guided).unwrap().controller;
    let mut c = ForceController::new(guided, five_joints(), &shipped()).unwrap();
    let e = c.check_start(&q).unwrap_err().to_string();
    assert!(
        e.contains("y of the BioTac frame") && e.contains("5 joints"),
        "{e}"
    );
    // Started anyway (as over ROS), it stops at once and says why.
    c.on_joint_state(&js).unwrap();
    c.on_estimate(estimate(0.0)).unwrap();
    let out = c.tick(0.001);
    assert_eq!(
        (out.phase, out.reason),
        (Phase::STOPPED, Some(StopReason::UNREALISABLE))
    );
    assert_eq!(c.command(), &JointVector::zeros(5));
    assert!(c.refusal().unwrap().contains("y of the BioTac frame"));

    // Rolled, the pad's normal leaves that plane: refused too.
    let rolled = JointVector::from_column_slice(&[0.3, 0.2, 0.4, -0.5, 0.1]);
    let guarded = Scene::builtin(TaskKind::Guarded).unwrap().controller;
    let mut c = ForceController::new(guarded, five_joints(), &shipped()).unwrap();
    let e = c.check_start(&rolled).unwrap_err().to_string();
    assert!(e.contains("the approach direction [0, 0, -1]"), "{e}");
}

/// An inverse kinematics of the test's own: the damped least-squares
/// inverse's joint velocities halved, its solves counted.
#[derive(Debug, Clone)]
struct HalfSpeed {
    dls: Dls,
    solves: std::sync::Arc<std::sync::atomic::AtomicUsize>,
}

impl InverseKinematics for HalfSpeed {
    fn solve(
        &mut self,
        robot: &Robot,
        q: &JointVector,
        twist: &Twist,
        qdot: &mut JointVector,
    ) -> Result<Made, Halt> {
        self.solves
            .fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        let made = InverseKinematics::solve(&mut self.dls, robot, q, twist, qdot)?;
        *qdot *= 0.5;
        Ok(Made {
            scale: made.scale * 0.5,
            ..made
        })
    }

    fn unmade(&mut self, robot: &Robot, q: &JointVector, twist: &Twist) -> f64 {
        self.dls.unmade(robot, q, twist)
    }
}

#[test]
fn the_inverse_kinematics_stage_takes_any_solver() {
    let (scene, q) = guarded_on_pa10();
    let build = || ForceController::new(scene.controller.clone(), Robot::pa10(), &scene.tasks);
    let solves = std::sync::Arc::default();
    let mut shipped = build().unwrap();
    let mut half = build().unwrap().with_inverse(HalfSpeed {
        dls: Dls::new(&Robot::pa10()),
        solves: std::sync::Arc::clone(&solves),
    });
    let cycle = |c: &mut ForceController| {
        feed(c, &q, 0.0);
        c.tick(0.002)
    };
    let (a, b) = (cycle(&mut shipped), cycle(&mut half));
    assert_eq!(solves.load(std::sync::atomic::Ordering::SeqCst), 1);
    assert!(shipped.command().norm() > 0.0, "approaching");
    assert!((half.command() - shipped.command() * 0.5).norm() < 1e-12);
    // What the arm will do: the solver's scale, in the start frame.
    assert!((b.velocity - a.velocity * 0.5).norm() < 1e-12, "{b:?}");
}

#[test]
fn an_estimate_without_a_task_axis_or_with_a_negative_std_is_out_of_range() {
    let p = both_sections(TaskKind::Guarded);
    let mut inputs = Inputs::new(&p, vec![Axis::Fz]);
    inputs
        .on_joint_state(
            &JointState {
                stamp_s: 0.0,
                q: JointVector::zeros(7),
            },
            7,
        )
        .unwrap();
    let mut read = |e: WrenchEstimate| {
        inputs.on_estimate(e).unwrap();
        inputs.read(0.0).unwrap().out_of_range
    };
    assert!(!read(estimate(0.0)), "fz estimated, std 0");
    let mut e = estimate(0.0);
    e.estimated[Axis::Fx.index()] = false;
    assert!(!read(e), "an axis the task does not read may be missing");
    e.estimated[Axis::Fz.index()] = false;
    assert!(read(e), "the model lacks fz: no force to act on");
    let mut e = estimate(0.0);
    e.std.force.z = -0.01;
    assert!(read(e), "a negative std is no std");
    e.std.force.z = p.out_of_range.max_std_n * 2.0;
    assert!(read(e), "too uncertain");
}
