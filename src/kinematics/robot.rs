//! The robot's parameters (`force_controller.robot.*` in `config/pa10.yaml`)
//! and their checked form.

use std::path::Path;

use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use serde::Deserialize;

use super::chain::Link;
use super::dls::{DlsParams, JointLimits};
use super::{JointVector, SerialChain, N_JOINTS};
use crate::params::{node_params, read_node_params, ParamsError, PA10_YAML};

/// Node whose parameters hold the robot.
const NODE: &str = "force_controller";

/// Robot parameters as written in the file (degrees where the file says so).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotParams {
    /// Modified DH twists alpha_{i-1} (deg).
    pub dh_alpha_deg: Vec<f64>,
    /// Modified DH lengths a_{i-1} (m).
    pub dh_a_m: Vec<f64>,
    /// Modified DH offsets d_i (m).
    pub dh_d_m: Vec<f64>,
    /// Lower joint limits (deg).
    pub joint_min_deg: Vec<f64>,
    /// Upper joint limits (deg).
    pub joint_max_deg: Vec<f64>,
    /// Joint speed limits (rad/s).
    pub joint_speed_max_rad_s: Vec<f64>,
    /// Distance to a limit within which a joint moving towards it is halted (deg).
    pub limit_margin_deg: f64,
    /// Tool origin in the flange frame (m).
    pub tool_xyz_m: [f64; 3],
    /// Tool orientation in the flange frame, roll-pitch-yaw (deg).
    pub tool_rpy_deg: [f64; 3],
    /// Smallest singular value of J below which damping switches on.
    pub dls_sigma_threshold: f64,
    /// Damping factor lambda reached at a singular value of zero.
    pub dls_lambda_max: f64,
}

/// The `force_controller` parameters this module reads; other keys belong to
/// other modules.
#[derive(Deserialize)]
struct Section {
    robot: RobotParams,
}

/// A checked robot: chain, limits and inverse-kinematics settings.
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// Kinematic chain with the tool.
    pub chain: SerialChain,
    /// Joint position and speed limits.
    pub limits: JointLimits,
    /// Damped least-squares settings.
    pub dls: DlsParams,
}

impl RobotParams {
    /// Checks lengths, finiteness and ranges; converts degrees to radians.
    pub fn validate(self) -> Result<Robot, ParamsError> {
        let invalid = |key: &str, value: String, expected: &str| ParamsError::Invalid {
            key: format!("{NODE}.robot.{key}"),
            value,
            expected: expected.into(),
        };
        let joints = |key: &str, v: &[f64]| -> Result<JointVector, ParamsError> {
            if v.len() != N_JOINTS || v.iter().any(|x| !x.is_finite()) {
                return Err(invalid(key, format!("{v:?}"), "7 finite numbers"));
            }
            Ok(JointVector::from_column_slice(v))
        };
        let alpha = joints("dh_alpha_deg", &self.dh_alpha_deg)?.map(f64::to_radians);
        let a = joints("dh_a_m", &self.dh_a_m)?;
        let d = joints("dh_d_m", &self.dh_d_m)?;
        let min = joints("joint_min_deg", &self.joint_min_deg)?.map(f64::to_radians);
        let max = joints("joint_max_deg", &self.joint_max_deg)?.map(f64::to_radians);
        let speed = joints("joint_speed_max_rad_s", &self.joint_speed_max_rad_s)?;
        if let Some(i) = (0..N_JOINTS).find(|&i| min[i] >= max[i]) {
            return Err(invalid(
                "joint_min_deg",
                self.joint_min_deg[i].to_string(),
                "below joint_max_deg of the same joint",
            ));
        }
        if let Some(s) = speed.iter().find(|s| **s <= 0.0) {
            return Err(invalid("joint_speed_max_rad_s", s.to_string(), "positive"));
        }
        let positive = [
            ("dls_sigma_threshold", self.dls_sigma_threshold),
            ("dls_lambda_max", self.dls_lambda_max),
        ];
        for (key, v) in positive {
            if !(v > 0.0 && v.is_finite()) {
                return Err(invalid(key, v.to_string(), "positive and finite"));
            }
        }
        if !(self.limit_margin_deg >= 0.0 && self.limit_margin_deg < 45.0) {
            let v = self.limit_margin_deg.to_string();
            return Err(invalid("limit_margin_deg", v, "in [0, 45)"));
        }
        let tool_finite = self.tool_xyz_m.iter().chain(&self.tool_rpy_deg);
        if tool_finite.clone().any(|v| !v.is_finite()) {
            let v = format!("{:?} {:?}", self.tool_xyz_m, self.tool_rpy_deg);
            return Err(invalid("tool_xyz_m/tool_rpy_deg", v, "finite numbers"));
        }
        let links = std::array::from_fn(|i| Link {
            alpha: alpha[i],
            a: a[i],
            d: d[i],
        });
        let [x, y, z] = self.tool_xyz_m;
        let [r, p, w] = self.tool_rpy_deg.map(f64::to_radians);
        let tool = Isometry3::from_parts(
            Translation3::new(x, y, z),
            UnitQuaternion::from_euler_angles(r, p, w),
        );
        Ok(Robot {
            chain: SerialChain::new(links, tool),
            limits: JointLimits {
                min,
                max,
                speed_max: speed,
                margin: self.limit_margin_deg.to_radians(),
            },
            dls: DlsParams {
                sigma_threshold: self.dls_sigma_threshold,
                lambda_max: self.dls_lambda_max,
            },
        })
    }
}

impl Robot {
    /// Parses the `force_controller.robot` parameters of a YAML text.
    pub fn from_yaml_str(yaml: &str) -> Result<Self, ParamsError> {
        node_params::<Section>(yaml, NODE)?.robot.validate()
    }

    /// Reads the `force_controller.robot` parameters of a file.
    pub fn from_file(path: &Path) -> Result<Self, ParamsError> {
        read_node_params::<Section>(path, NODE)?.robot.validate()
    }

    /// The PA10-7C with the BioTac tool, from the shipped `config/pa10.yaml`.
    pub fn pa10() -> Self {
        // Checked by the unit tests; fails only if the shipped file is broken.
        Self::from_yaml_str(PA10_YAML).expect("config/pa10.yaml shipped with the crate is valid")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_pa10_points_straight_up_at_zero() {
        let robot = Robot::pa10();
        let pose = robot.chain.forward(&JointVector::zeros());
        // Base 0.317 + upper arm 0.45 + forearm 0.48 + wrist 0.07 + tool 0.09 m.
        let p = pose.translation.vector;
        assert!(p.x.abs() < 1e-12 && p.y.abs() < 1e-12, "{p}");
        assert!((p.z - 1.407).abs() < 1e-12, "{p}");
        assert!((robot.limits.max[1] - 94f64.to_radians()).abs() < 1e-12);
    }

    #[test]
    fn bad_parameters_are_named() {
        let short = PA10_YAML.replace("[0.317, 0.0, 0.45, 0.0, 0.48, 0.0, 0.07]", "[0.317]");
        let err = Robot::from_yaml_str(&short).unwrap_err();
        assert!(
            err.to_string().contains("force_controller.robot.dh_d_m"),
            "{err}"
        );

        let reversed = PA10_YAML.replace("joint_min_deg: [-177.0", "joint_min_deg: [177.5");
        let err = Robot::from_yaml_str(&reversed).unwrap_err();
        assert!(err.to_string().contains("joint_min_deg = 177.5"), "{err}");

        let missing = PA10_YAML.replace("      limit_margin_deg: 5.0\n", "");
        let err = Robot::from_yaml_str(&missing).unwrap_err();
        assert!(err.to_string().contains("limit_margin_deg"), "{err}");

        let unknown = PA10_YAML.replace("limit_margin_deg:", "limit_margins_deg:");
        let err = Robot::from_yaml_str(&unknown).unwrap_err();
        assert!(err.to_string().contains("limit_margins_deg"), "{err}");

        let err = Robot::from_yaml_str("other_node:\n  ros__parameters: {}\n").unwrap_err();
        assert!(matches!(err, ParamsError::MissingNode { .. }), "{err}");
    }
}
