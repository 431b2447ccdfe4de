//! The robots shipped with the package: each a robot description
//! (`config/<name>.urdf`) and a parameter file (`config/<name>.yaml`: the
//! links, the BioTac's mount, the start pose, the servos' latency and lag),
//! embedded so that the demos run from anywhere.

use super::{Robot, RobotError, RobotParams};
use crate::params::{ParamsError, WORLD_YAML};

/// A shipped robot.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShippedRobot {
    /// Mitsubishi PA10-7C (7 joints), the thesis' arm.
    Pa10,
    /// Universal Robots UR5 (6 joints).
    Ur5,
    /// Franka Emika Panda (7 joints).
    Panda,
}

impl ShippedRobot {
    /// Every shipped robot.
    pub const ALL: [ShippedRobot; 3] = [ShippedRobot::Pa10, ShippedRobot::Ur5, ShippedRobot::Panda];

    /// Its name (`--robot`, the launch argument `robot`).
    pub fn name(self) -> &'static str {
        match self {
            ShippedRobot::Pa10 => "pa10",
            ShippedRobot::Ur5 => "ur5",
            ShippedRobot::Panda => "panda",
        }
    }

    /// Its parameter file, `config/<name>.yaml`.
    pub fn yaml(self) -> &'static str {
        match self {
            ShippedRobot::Pa10 => include_str!("../../config/pa10.yaml"),
            ShippedRobot::Ur5 => include_str!("../../config/ur5.yaml"),
            ShippedRobot::Panda => include_str!("../../config/panda.yaml"),
        }
    }

    /// Its robot description, `config/<name>.urdf`.
    pub fn urdf(self) -> &'static str {
        match self {
            ShippedRobot::Pa10 => include_str!("../../config/pa10.urdf"),
            ShippedRobot::Ur5 => include_str!("../../config/ur5.urdf"),
            ShippedRobot::Panda => include_str!("../../config/panda.urdf"),
        }
    }

    /// Its `robot` parameters: the world's defaults under its own file.
    pub fn robot_params(self) -> Result<RobotParams, ParamsError> {
        RobotParams::from_layers(&[WORLD_YAML, self.yaml()])
    }

    /// The robot, checked.
    pub fn robot(self) -> Result<Robot, RobotError> {
        Robot::from_urdf(self.urdf(), &self.robot_params()?)
    }

    /// The names of every shipped robot, for messages ("pa10, ur5, panda").
    pub fn names() -> String {
        let names: Vec<&str> = Self::ALL.iter().map(|r| r.name()).collect();
        names.join(", ")
    }
}

impl std::str::FromStr for ShippedRobot {
    type Err = ParamsError;

    fn from_str(s: &str) -> Result<Self, ParamsError> {
        Self::ALL
            .into_iter()
            .find(|r| r.name() == s)
            .ok_or_else(|| ParamsError::Invalid {
                key: "robot".into(),
                value: s.into(),
                expected: format!("a shipped robot ({}) or a URDF file", Self::names()),
            })
    }
}

impl Robot {
    /// The PA10-7C with the BioTac tool, from the shipped files.
    pub fn pa10() -> Self {
        // Checked by the unit tests; fails only if a shipped file is broken.
        ShippedRobot::Pa10
            .robot()
            .expect("config/pa10.urdf and config/pa10.yaml shipped with the crate are valid")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::JointVector;
    use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn every_shipped_robot_builds_and_names_parse_back() {
        for r in ShippedRobot::ALL {
            assert_eq!(r.name().parse::<ShippedRobot>().unwrap(), r);
            r.robot().unwrap();
        }
        let e = "ur10".parse::<ShippedRobot>().unwrap_err().to_string();
        assert!(e.contains("pa10, ur5, panda"), "{e}");
    }

    /// The PA10's chain before it came from a URDF: modified (Craig) DH
    /// links `RotX(alpha) TransX(a) RotZ(q) TransZ(d)` (a = 0), then the tool.
    fn pa10_from_dh(q: &JointVector) -> (Isometry3<f64>, Vec<Isometry3<f64>>) {
        let alpha = [0.0, -90.0, 90.0, -90.0, 90.0, -90.0, 90.0f64].map(f64::to_radians);
        let d = [0.317, 0.0, 0.45, 0.0, 0.48, 0.0, 0.07];
        let mut t = Isometry3::identity();
        let mut frames = Vec::new();
        for i in 0..7 {
            t *= Isometry3::from_parts(
                Translation3::identity(),
                UnitQuaternion::from_axis_angle(&Vector3::x_axis(), alpha[i]),
            ) * Isometry3::from_parts(
                Translation3::new(0.0, 0.0, d[i]),
                UnitQuaternion::from_axis_angle(&Vector3::z_axis(), q[i]),
            );
            frames.push(t);
        }
        let tool = Isometry3::from_parts(
            Translation3::new(0.0, 0.0, 0.09),
            UnitQuaternion::from_euler_angles(0.0, 90f64.to_radians(), 0.0),
        );
        (t * tool, frames)
    }

    #[test]
    fn the_pa10_urdf_equals_its_dh_chain() {
        let robot = Robot::pa10();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for _ in 0..100 {
            let q = JointVector::from_fn(7, |i, _| {
                rng.random_range(robot.limits.min[i]..robot.limits.max[i])
            });
            let (pose, frames) = pa10_from_dh(&q);
            let ours = robot.chain.forward(&q);
            assert!((ours.translation.vector - pose.translation.vector).norm() < 1e-12);
            let r = ours.rotation.to_rotation_matrix().into_inner();
            assert!((r - pose.rotation.to_rotation_matrix().into_inner()).amax() < 1e-12);
            let p = pose.translation.vector;
            let j = robot.chain.jacobian(&q);
            for (i, f) in frames.iter().enumerate() {
                let z = f.rotation * Vector3::z();
                let v = z.cross(&(p - f.translation.vector));
                for k in 0..3 {
                    assert!((j[(k, i)] - v[k]).abs() < 1e-12, "joint {i} v{k}");
                    assert!((j[(k + 3, i)] - z[k]).abs() < 1e-12, "joint {i} w{k}");
                }
            }
        }
    }
}
