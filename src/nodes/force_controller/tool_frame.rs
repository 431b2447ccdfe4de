//! The BioTac frame on TF: the static transform from the arm's tip link to
//! the BioTac frame, from the robot's tool mount (`robot.tool_xyz_m`,
//! `robot.tool_rpy_deg`), which the ROS adapter publishes on `/tf_static`
//! for each robot description it takes. The frame's name is the parameter
//! `biotac_frame`; the estimator stamps its wrenches with its own
//! `frame_id`, and the two must be the same name (the launch files give
//! both the one launch argument `biotac_frame`).

use super::ForceControllerNode;
use crate::params::ParamsError;

/// The default BioTac frame: the estimator's default `frame_id`.
pub const BIOTAC_FRAME: &str = "biotac";

/// A static transform: where `child` sits in `parent`'s frame.
#[derive(Debug, Clone, PartialEq)]
pub struct StaticTransform {
    /// The frame it is given in (the arm's tip link).
    pub parent: String,
    /// The frame it places (the BioTac's).
    pub child: String,
    /// The child's origin in the parent's frame (m).
    pub translation: [f64; 3],
    /// The child's orientation in the parent's frame, a unit quaternion
    /// `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

/// The parameter `biotac_frame`, checked: a TF frame name (not empty, no
/// leading `/`, which tf2 refuses, no whitespace).
pub fn biotac_frame(name: &str) -> Result<String, ParamsError> {
    let invalid = |expected: &str| ParamsError::Invalid {
        key: "biotac_frame".into(),
        value: format!("{name:?}"),
        expected: expected.into(),
    };
    if name.is_empty() || name.chars().any(char::is_whitespace) {
        return Err(invalid("a frame name, without whitespace"));
    }
    if name.starts_with('/') {
        return Err(invalid("a frame name without a leading / (tf2 refuses it)"));
    }
    Ok(name.into())
}

impl ForceControllerNode {
    /// The BioTac frame `child` in the tip link of the arm in use, from the
    /// robot parameters' tool mount; None before a robot description. Err
    /// when `child` names the chain's base or tip link (a frame cannot be
    /// placed in itself, and TF would have two parents for it).
    pub fn tool_frame(&self, child: &str) -> Result<Option<StaticTransform>, ParamsError> {
        let Some(arm) = &self.arm else {
            return Ok(None);
        };
        let (base, tip) = &arm.robot.links;
        if child == base || child == tip {
            return Err(ParamsError::Invalid {
                key: "biotac_frame".into(),
                value: child.into(),
                expected: format!("a frame of its own, not the chain's link ({base} -> {tip})"),
            });
        }
        let tool = self.base.robot.tool()?;
        let q = tool.rotation.quaternion();
        Ok(Some(StaticTransform {
            parent: tip.clone(),
            child: child.into(),
            translation: tool.translation.vector.into(),
            rotation: [q.i, q.j, q.k, q.w],
        }))
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Quaternion, UnitQuaternion, Vector3};

    use super::*;
    use crate::control::ControllerParams;
    use crate::kinematics::ShippedRobot;
    use crate::nodes::force_controller::shipped_defaults;
    use crate::nodes::tasks;
    use crate::params::from_flat_params;

    /// The node as the ROS node starts on `robot` (its file's `robot.*`),
    /// with its description taken.
    fn node_on(robot: ShippedRobot) -> ForceControllerNode {
        let mut base: ControllerParams =
            from_flat_params(&shipped_defaults().unwrap(), "force_controller").unwrap();
        base.robot = robot.robot_params().unwrap();
        let mut n = ForceControllerNode::new(base, tasks::shipped(), Vec::new(), None).unwrap();
        assert!(n.take_description(robot.urdf()).unwrap());
        n
    }

    fn rotate(t: &StaticTransform, v: Vector3<f64>) -> Vector3<f64> {
        let [x, y, z, w] = t.rotation;
        UnitQuaternion::new_normalize(Quaternion::new(w, x, y, z)) * v
    }

    #[test]
    fn the_pa10s_biotac_sits_90_mm_out_along_the_flange_its_axis_across_it() {
        let n = node_on(ShippedRobot::Pa10);
        let t = n.tool_frame(BIOTAC_FRAME).unwrap().unwrap();
        assert_eq!((t.parent.as_str(), t.child.as_str()), ("link7", "biotac"));
        assert_eq!(t.translation, [0.0, 0.0, 0.09]);
        // pitch 90 deg: (0, sin 45, 0, cos 45).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        for (got, want) in t.rotation.iter().zip([0.0, h, 0.0, h]) {
            assert!((got - want).abs() < 1e-12, "{:?}", t.rotation);
        }
        // The BioTac's z (away from the pad) is the flange's x; its x (to
        // the tip) is the flange's -z.
        assert!((rotate(&t, Vector3::z()) - Vector3::x()).norm() < 1e-12);
        assert!((rotate(&t, Vector3::x()) + Vector3::z()).norm() < 1e-12);
    }

    #[test]
    fn each_shipped_robot_places_the_biotac_on_its_tip_link_by_its_file() {
        for (robot, tip, rpy) in [
            (ShippedRobot::Ur5, "tool0", [0.0, -90.0, 0.0]),
            (ShippedRobot::Panda, "panda_link8", [180.0, 0.0, 0.0]),
        ] {
            let n = node_on(robot);
            let t = n.tool_frame("fingertip").unwrap().unwrap();
            assert_eq!((t.parent.as_str(), t.child.as_str()), (tip, "fingertip"));
            assert_eq!(t.translation, [0.0, 0.0, 0.09]);
            let [r, p, y] = rpy.map(f64::to_radians);
            let want = UnitQuaternion::from_euler_angles(r, p, y);
            let v = Vector3::new(0.3, -0.5, 0.8);
            assert!((rotate(&t, v) - want * v).norm() < 1e-12, "{robot:?}");
            let norm = t.rotation.iter().map(|c| c * c).sum::<f64>().sqrt();
            assert!((norm - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn no_frame_before_a_description_and_none_onto_the_chains_links() {
        let mut base: ControllerParams =
            from_flat_params(&shipped_defaults().unwrap(), "force_controller").unwrap();
        base.robot = ShippedRobot::Pa10.robot_params().unwrap();
        let n = ForceControllerNode::new(base, tasks::shipped(), Vec::new(), None).unwrap();
        assert_eq!(n.tool_frame(BIOTAC_FRAME).unwrap(), None);
        let n = node_on(ShippedRobot::Pa10);
        for link in ["link7", "base_link"] {
            let e = n.tool_frame(link).unwrap_err().to_string();
            assert!(
                e.contains("biotac_frame") && e.contains("a frame of its own"),
                "{e}"
            );
        }
    }

    #[test]
    fn the_frame_parameter_takes_a_tf_name_only() {
        assert_eq!(biotac_frame("biotac").unwrap(), "biotac");
        assert_eq!(biotac_frame("left/biotac").unwrap(), "left/biotac");
        for bad in ["", "/biotac", "bio tac"] {
            let e = biotac_frame(bad).unwrap_err().to_string();
            assert!(e.contains("biotac_frame"), "{bad:?}: {e}");
        }
    }
}
