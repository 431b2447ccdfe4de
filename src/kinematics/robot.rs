//! The robot: the chain from a URDF between two links (`robot.base_link`,
//! `robot.tip_link`), its joint limits (the URDF's `<limit>`, overridable
//! per joint), the BioTac's mount on the tip (`robot.tool_*`) and the
//! damped least-squares settings. The shipped robots (`config/<name>.urdf`
//! with `config/<name>.yaml`) are in [`super::shipped`].

use std::collections::BTreeMap;

use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use serde::{Deserialize, Serialize};

use super::chain::SerialChain;
use super::dls::{DlsParams, JointLimits};
use super::urdf::{read_chain, UrdfError};
use super::{JointKind, JointVector};
use crate::exit::{Classify, ExitClass};
use crate::params::{layered_node_params, ParamsError};

/// Robot parameters as written in the files (`robot.*`, for every node).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct RobotParams {
    /// First link of the chain; empty: the URDF's root link.
    pub base_link: String,
    /// The link the BioTac is mounted on; empty: the URDF's one leaf.
    pub tip_link: String,
    /// The BioTac frame's origin in the tip link's frame (m).
    pub tool_xyz_m: [f64; 3],
    /// The BioTac frame's orientation in the tip link's frame, roll-pitch-yaw (deg).
    pub tool_rpy_deg: [f64; 3],
    /// Distance to a limit within which a turning joint moving towards it is halted (deg).
    pub limit_margin_deg: f64,
    /// The same for a prismatic joint (m).
    pub limit_margin_m: f64,
    /// Smallest singular value of J below which damping switches on.
    pub dls_sigma_threshold: f64,
    /// Damping factor lambda reached at a singular value of zero.
    pub dls_lambda_max: f64,
    /// Limits that replace the URDF's, by joint name.
    #[serde(default)]
    pub joint_limits: BTreeMap<String, LimitOverride>,
}

/// A joint's limits that replace the URDF's, in the URDF's units (rad or m,
/// rad/s or m/s); absent keys keep the URDF's value.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LimitOverride {
    /// Lower position limit.
    pub lower: Option<f64>,
    /// Upper position limit.
    pub upper: Option<f64>,
    /// Velocity limit.
    pub velocity: Option<f64>,
}

/// Why a robot could not be built.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RobotError {
    /// The URDF or the links (in the message, not a source: said once).
    #[error("robot description: {0}")]
    Urdf(UrdfError),
    /// A `robot.*` parameter.
    #[error(transparent)]
    Params(#[from] ParamsError),
}

/// A robot refused, by the part that refused it.
impl Classify for RobotError {
    fn class(&self) -> ExitClass {
        match self {
            RobotError::Urdf(e) => e.class(),
            RobotError::Params(e) => e.class(),
        }
    }
}

impl From<UrdfError> for RobotError {
    fn from(e: UrdfError) -> Self {
        RobotError::Urdf(e)
    }
}

/// A checked robot: chain with the tool, limits and inverse-kinematics settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// Kinematic chain, base link to the BioTac frame.
    pub chain: SerialChain,
    /// Joint position and speed limits.
    pub limits: JointLimits,
    /// Damped least-squares settings.
    pub dls: DlsParams,
    /// The chain's base and tip links.
    pub links: (String, String),
    /// The robot's name in its URDF.
    pub name: String,
}

fn invalid(key: &str, value: String, expected: &str) -> ParamsError {
    ParamsError::Invalid {
        key: format!("robot.{key}"),
        value,
        expected: expected.into(),
    }
}

/// The `robot` section of the parameters (other keys belong to other modules).
#[derive(Deserialize)]
struct Section {
    robot: RobotParams,
}

impl RobotParams {
    /// The `robot` parameters of parameter texts layered in order.
    pub fn from_layers(texts: &[&str]) -> Result<Self, ParamsError> {
        let s: Section = layered_node_params(texts, "force_controller")?;
        Ok(s.robot)
    }

    /// The tool transform (the BioTac frame in the tip link's); refuses
    /// values that are not finite.
    pub fn tool(&self) -> Result<Isometry3<f64>, ParamsError> {
        if self
            .tool_xyz_m
            .iter()
            .chain(&self.tool_rpy_deg)
            .any(|v| !v.is_finite())
        {
            let v = format!("{:?} {:?}", self.tool_xyz_m, self.tool_rpy_deg);
            return Err(invalid("tool_xyz_m/tool_rpy_deg", v, "finite numbers"));
        }
        let [x, y, z] = self.tool_xyz_m;
        let [r, p, w] = self.tool_rpy_deg.map(f64::to_radians);
        Ok(Isometry3::from_parts(
            Translation3::new(x, y, z),
            UnitQuaternion::from_euler_angles(r, p, w),
        ))
    }

    fn dls(&self) -> Result<DlsParams, ParamsError> {
        let positive = [
            ("dls_sigma_threshold", self.dls_sigma_threshold),
            ("dls_lambda_max", self.dls_lambda_max),
        ];
        for (key, v) in positive {
            if !(v > 0.0 && v.is_finite()) {
                return Err(invalid(key, v.to_string(), "positive and finite"));
            }
        }
        Ok(DlsParams {
            sigma_threshold: self.dls_sigma_threshold,
            lambda_max: self.dls_lambda_max,
        })
    }
}

impl Robot {
    /// The robot of a URDF text with its parameters.
    pub fn from_urdf(urdf: &str, p: &RobotParams) -> Result<Self, RobotError> {
        let read = read_chain(urdf, &p.base_link, &p.tip_link)?;
        let tool = p.tool()?;
        let dls = p.dls()?;
        if !(p.limit_margin_deg >= 0.0 && p.limit_margin_deg < 45.0) {
            let v = p.limit_margin_deg.to_string();
            return Err(invalid("limit_margin_deg", v, "in [0, 45)").into());
        }
        if !(p.limit_margin_m >= 0.0 && p.limit_margin_m < 0.1) {
            let v = p.limit_margin_m.to_string();
            return Err(invalid("limit_margin_m", v, "in [0, 0.1)").into());
        }
        let joints = read.chain.joints();
        if let Some(name) = p
            .joint_limits
            .keys()
            .find(|k| !joints.iter().any(|j| &j.name == *k))
        {
            let names: Vec<&str> = joints.iter().map(|j| j.name.as_str()).collect();
            return Err(invalid(
                &format!("joint_limits.{name}"),
                name.clone(),
                &format!("a joint of the chain: {}", names.join(", ")),
            )
            .into());
        }
        let n = joints.len();
        let mut limits = JointLimits {
            min: JointVector::from_element(n, f64::NEG_INFINITY),
            max: JointVector::from_element(n, f64::INFINITY),
            speed_max: JointVector::zeros(n),
            margin: JointVector::zeros(n),
        };
        for (i, (joint, urdf)) in joints.iter().zip(&read.limits).enumerate() {
            let o = p.joint_limits.get(&joint.name);
            let key = |what: &str| format!("joint_limits.{}.{what}", joint.name);
            let (mut lo, mut hi) = urdf.position.unwrap_or((f64::NEG_INFINITY, f64::INFINITY));
            lo = o.and_then(|o| o.lower).unwrap_or(lo);
            hi = o.and_then(|o| o.upper).unwrap_or(hi);
            if lo.is_nan() || hi.is_nan() || lo >= hi {
                let v = format!("lower {lo}, upper {hi}");
                return Err(invalid(&key("lower"), v, "below the upper limit").into());
            }
            let speed = o.and_then(|o| o.velocity).unwrap_or(urdf.velocity);
            if !(speed > 0.0 && speed.is_finite()) {
                return Err(invalid(
                    &key("velocity"),
                    speed.to_string(),
                    "a positive velocity limit (the URDF's <limit velocity> is missing or 0: \
                     set this parameter)",
                )
                .into());
            }
            limits.min[i] = lo;
            limits.max[i] = hi;
            limits.speed_max[i] = speed;
            limits.margin[i] = if joint.kind.turns() {
                p.limit_margin_deg.to_radians()
            } else {
                p.limit_margin_m
            };
        }
        Ok(Robot {
            chain: read.chain.with_tool(&tool),
            limits,
            dls,
            links: read.links,
            name: read.name,
        })
    }

    /// Number of joints.
    pub fn dof(&self) -> usize {
        self.chain.dof()
    }

    /// The joints' names, base first.
    pub fn joint_names(&self) -> Vec<String> {
        self.chain.joints().iter().map(|j| j.name.clone()).collect()
    }

    /// The middle of each joint's range (0 for a joint without one).
    pub fn middle(&self) -> JointVector {
        let l = &self.limits;
        JointVector::from_fn(self.dof(), |i, _| {
            if l.min[i].is_finite() && l.max[i].is_finite() {
                0.5 * (l.min[i] + l.max[i])
            } else {
                0.0
            }
        })
    }

    /// Joint positions from the files' units (deg, or mm for a prismatic
    /// joint), checked: one per joint, within the limits.
    /// Refusals name `key`.
    pub fn positions_from_deg_mm(
        &self,
        key: &str,
        values: &[f64],
    ) -> Result<JointVector, ParamsError> {
        let converted: Vec<f64> = values
            .iter()
            .zip(self.chain.joints())
            .map(|(v, j)| {
                if j.kind.turns() {
                    v.to_radians()
                } else {
                    v * 1e-3
                }
            })
            .collect();
        self.check_positions(key, &JointVector::from_vec(converted), values)
    }

    /// Refuses positions (rad or m) of the wrong length, not finite or
    /// outside the limits, naming `key` and showing `shown`.
    pub fn check_positions(
        &self,
        key: &str,
        q: &JointVector,
        shown: &[f64],
    ) -> Result<JointVector, ParamsError> {
        let refuse = |expected: String| ParamsError::Invalid {
            key: key.into(),
            value: format!("{shown:?}"),
            expected,
        };
        if shown.len() != self.dof() {
            return Err(refuse(format!(
                "{} values, one per joint: {}",
                self.dof(),
                self.joint_names().join(", ")
            )));
        }
        let l = &self.limits;
        if let Some(i) = (0..self.dof()).find(|&i| !(q[i] >= l.min[i] && q[i] <= l.max[i])) {
            let j = &self.chain.joints()[i];
            return Err(refuse(format!(
                "values within the joint ranges: {} = {} is outside [{}, {}] {}",
                j.name,
                shown[i],
                l.min[i],
                l.max[i],
                if j.kind == JointKind::Prismatic {
                    "m"
                } else {
                    "rad"
                }
            )));
        }
        Ok(q.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::shipped::ShippedRobot;

    fn pa10_params() -> RobotParams {
        ShippedRobot::Pa10.robot_params().unwrap()
    }

    #[test]
    fn shipped_pa10_points_straight_up_at_zero() {
        let robot = Robot::pa10();
        let pose = robot.chain.forward(&JointVector::zeros(7));
        // Base 0.317 + upper arm 0.45 + forearm 0.48 + wrist 0.07 + tool 0.09 m.
        let p = pose.translation.vector;
        assert!(p.x.abs() < 1e-12 && p.y.abs() < 1e-12, "{p}");
        assert!((p.z - 1.407).abs() < 1e-12, "{p}");
        assert!((robot.limits.max[1] - 94f64.to_radians()).abs() < 1e-15);
        assert_eq!(
            robot.joint_names(),
            ["S1", "S2", "S3", "E1", "E2", "W1", "W2"]
        );
    }

    #[test]
    fn limits_can_be_overridden_by_joint_name() {
        let urdf = ShippedRobot::Pa10.urdf();
        let mut p = pa10_params();
        p.joint_limits.insert(
            "E1".into(),
            LimitOverride {
                lower: None,
                upper: Some(1.0),
                velocity: Some(0.2),
            },
        );
        let r = Robot::from_urdf(urdf, &p).unwrap();
        assert_eq!((r.limits.max[3], r.limits.speed_max[3]), (1.0, 0.2));
        assert!((r.limits.min[3] + 137f64.to_radians()).abs() < 1e-15);

        p.joint_limits.insert(
            "E9".into(),
            LimitOverride {
                lower: None,
                upper: None,
                velocity: None,
            },
        );
        let e = Robot::from_urdf(urdf, &p).unwrap_err().to_string();
        assert!(e.contains("joint_limits.E9") && e.contains("S1, S2"), "{e}");
        let mut p = pa10_params();
        p.joint_limits.insert(
            "S2".into(),
            LimitOverride {
                lower: Some(2.0),
                upper: None,
                velocity: None,
            },
        );
        let e = Robot::from_urdf(urdf, &p).unwrap_err().to_string();
        assert!(e.contains("joint_limits.S2.lower"), "{e}");
    }

    #[test]
    fn bad_parameters_are_named() {
        let urdf = ShippedRobot::Pa10.urdf();
        let mut p = pa10_params();
        p.tool_rpy_deg[1] = f64::NAN;
        let e = Robot::from_urdf(urdf, &p).unwrap_err().to_string();
        assert!(e.contains("robot.tool_xyz_m/tool_rpy_deg"), "{e}");
        let mut p = pa10_params();
        p.limit_margin_deg = 50.0;
        let e = Robot::from_urdf(urdf, &p).unwrap_err().to_string();
        assert!(e.contains("robot.limit_margin_deg = 50"), "{e}");
        let mut p = pa10_params();
        p.tip_link = "hand".into();
        let e = Robot::from_urdf(urdf, &p).unwrap_err().to_string();
        assert!(e.contains("no link `hand`") && e.contains("link7"), "{e}");

        let robot = Robot::pa10();
        for n in [6, 8] {
            let e = robot
                .positions_from_deg_mm("start_joints_deg", &vec![0.0; n])
                .unwrap_err()
                .to_string();
            assert!(e.contains("7 values") && e.contains("S1, S2"), "{e}");
        }
        let e = robot
            .positions_from_deg_mm("start_joints_deg", &[0.0, 95.0, 0.0, 0.0, 0.0, 0.0, 0.0])
            .unwrap_err()
            .to_string();
        assert!(e.contains("S2 = 95 is outside"), "{e}");
    }
}
