//! A control period allocates nothing once running: the force controller's
//! tick (forward kinematics, Jacobian, damped least squares) on arms of
//! five, six and seven joints, counted by a global allocator (this binary
//! holds one test so nothing else allocates).

use tactile_force::control::{ForceController, JointState, TaskKind};
use tactile_force::kinematics::{JointVector, Robot, RobotParams, ShippedRobot};
use tactile_force::params::WORLD_YAML;
use tactile_force::runtime::Scene;
use tactile_force::wrench::WrenchEstimate;

#[path = "common/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::{allocations, Counting};

#[global_allocator]
static GLOBAL: Counting = Counting;

/// The five-joint test arm with the world's robot defaults: the chain from
/// its root to its one leaf, the BioTac frame at the flange.
fn five_joints() -> Robot {
    let p = RobotParams::from_layers(&[WORLD_YAML]).unwrap();
    Robot::from_urdf(include_str!("data/five_joint_arm.urdf"), &p).unwrap()
}

#[test]
fn a_control_period_allocates_nothing_after_the_first() {
    let arms = [
        (ShippedRobot::Ur5.robot().unwrap(), TaskKind::Guided),
        (ShippedRobot::Panda.robot().unwrap(), TaskKind::Guided),
        (five_joints(), TaskKind::Guarded),
    ];
    for (robot, task) in arms {
        let n = robot.dof();
        let scene = Scene::builtin(task).unwrap();
        let mut js = JointState {
            stamp_s: 0.0,
            q: robot.middle(),
        };
        js.q[1] += 0.3;
        if n == 5 {
            js.q = JointVector::from_column_slice(&[0.3, 0.2, 0.4, -0.5, 0.0]);
        }
        let mut c = ForceController::new(scene.controller, robot, &scene.tasks).unwrap();
        let mut estimate = WrenchEstimate {
            stamp_s: 0.0,
            seq: 0,
            mean: Default::default(),
            std: Default::default(),
            estimated: [true; 6],
            pdc_rise: 0.0,
        };
        let mut step = |k: usize| {
            let t = k as f64 * 0.01;
            js.stamp_s = t;
            estimate.stamp_s = t;
            // Pushes to and fro along x and z: every axis of the guided
            // move moves, within its travel.
            estimate.mean.force.x = 0.5 * (k as f64 * 0.1).sin();
            estimate.mean.force.z = 1.0 + 0.5 * (k as f64 * 0.1).cos();
            c.on_joint_state(&js).unwrap();
            c.on_estimate(estimate).unwrap();
            let out = c.tick(t);
            assert!(
                out.halt.is_none() && out.reason.is_none(),
                "{n} joints: {out:?}"
            );
            js.q.zip_apply(c.command(), |q, v| *q += v * 0.01);
        };
        for k in 0..5 {
            step(k);
        }
        let before = allocations();
        for k in 5..505 {
            step(k);
        }
        let during = allocations() - before;
        assert_eq!(during, 0, "{n} joints: {during} allocations in 500 periods");
    }
}
