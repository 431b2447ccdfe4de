//! Serial chain from modified (Craig) DH parameters, all joints revolute:
//! `T_{i-1,i} = RotX(alpha_{i-1}) TransX(a_{i-1}) RotZ(q_i) TransZ(d_i)`,
//! so joint i turns about the z axis of frame i.

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::{Jacobian, JointVector, N_JOINTS};

/// Modified DH parameters of one link.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    /// Twist alpha_{i-1} (rad).
    pub alpha: f64,
    /// Length a_{i-1} (m).
    pub a: f64,
    /// Offset d_i (m).
    pub d: f64,
}

impl Link {
    fn transform(&self, q: f64) -> Isometry3<f64> {
        let x = Isometry3::from_parts(
            Translation3::new(self.a, 0.0, 0.0),
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), self.alpha),
        );
        let z = Isometry3::from_parts(
            Translation3::new(0.0, 0.0, self.d),
            UnitQuaternion::from_axis_angle(&Vector3::z_axis(), q),
        );
        x * z
    }
}

/// The arm's links and the tool frame (BioTac tip) in the flange frame.
#[derive(Debug, Clone, PartialEq)]
pub struct SerialChain {
    links: [Link; N_JOINTS],
    tool: Isometry3<f64>,
}

impl SerialChain {
    /// A chain from its links and tool transform.
    pub fn new(links: [Link; N_JOINTS], tool: Isometry3<f64>) -> Self {
        SerialChain { links, tool }
    }

    /// Joint frames in the base frame; frame i's z axis is joint i's axis.
    fn joint_frames(&self, q: &JointVector) -> [Isometry3<f64>; N_JOINTS] {
        let mut frames = [Isometry3::identity(); N_JOINTS];
        let mut t = Isometry3::identity();
        for (i, link) in self.links.iter().enumerate() {
            t *= link.transform(q[i]);
            frames[i] = t;
        }
        frames
    }

    /// Pose of the tool frame in the base frame.
    pub fn forward(&self, q: &JointVector) -> Isometry3<f64> {
        self.joint_frames(q)[N_JOINTS - 1] * self.tool
    }

    /// Geometric Jacobian at the tool origin, in the base frame:
    /// column i = `[z_i x (p_tool - o_i); z_i]`.
    pub fn jacobian(&self, q: &JointVector) -> Jacobian {
        let frames = self.joint_frames(q);
        let p = (frames[N_JOINTS - 1] * self.tool).translation.vector;
        let mut j = Jacobian::zeros();
        for (i, f) in frames.iter().enumerate() {
            let z = f.rotation * Vector3::z();
            let o = f.translation.vector;
            j.fixed_view_mut::<3, 1>(0, i).copy_from(&z.cross(&(p - o)));
            j.fixed_view_mut::<3, 1>(3, i).copy_from(&z);
        }
        j
    }
}
