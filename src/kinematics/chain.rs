//! A serial chain of revolute, continuous and prismatic joints, as a URDF
//! describes one: each joint is a fixed transform from its parent link (its
//! `<origin>`) followed by a motion along or about its `<axis>`. Fixed joints
//! are folded into the next joint's origin, or into the tip transform after
//! the last moving joint. Forward kinematics and the Jacobian allocate
//! nothing, so the control loop can call them every period.

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

use super::{Jacobian, JointVector};

/// How a joint moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// Turns about its axis, within position limits (rad).
    Revolute,
    /// Turns about its axis without position limits (rad).
    Continuous,
    /// Slides along its axis (m).
    Prismatic,
}

impl JointKind {
    /// The URDF type name.
    pub fn name(self) -> &'static str {
        match self {
            JointKind::Revolute => "revolute",
            JointKind::Continuous => "continuous",
            JointKind::Prismatic => "prismatic",
        }
    }

    /// True for revolute and continuous joints (positions in rad).
    pub fn turns(self) -> bool {
        self != JointKind::Prismatic
    }
}

/// One moving joint of the chain.
#[derive(Debug, Clone, PartialEq)]
pub struct ChainJoint {
    /// The joint's name in the URDF.
    pub name: String,
    /// How it moves.
    pub kind: JointKind,
    /// Its frame in the previous joint's moved frame (or the base) at q = 0.
    pub origin: Isometry3<f64>,
    /// Its axis, in its own frame.
    pub axis: Unit<Vector3<f64>>,
}

impl ChainJoint {
    /// The joint's frame, moved by `q`, in the previous joint's moved frame.
    fn moved(&self, q: f64) -> Isometry3<f64> {
        let motion = match self.kind {
            JointKind::Prismatic => Isometry3::from_parts(
                Translation3::from(self.axis.into_inner() * q),
                UnitQuaternion::identity(),
            ),
            JointKind::Revolute | JointKind::Continuous => Isometry3::from_parts(
                Translation3::identity(),
                UnitQuaternion::from_axis_angle(&self.axis, q),
            ),
        };
        self.origin * motion
    }
}

/// The moving joints from the base link to the tip, and the tip's fixed
/// transform in the last joint's moved frame (fixed joints and the tool).
#[derive(Debug, Clone, PartialEq)]
pub struct SerialChain {
    joints: Vec<ChainJoint>,
    tip: Isometry3<f64>,
}

impl SerialChain {
    /// A chain from its joints (base first) and the tip transform.
    pub fn new(joints: Vec<ChainJoint>, tip: Isometry3<f64>) -> Self {
        SerialChain { joints, tip }
    }

    /// The moving joints, base first.
    pub fn joints(&self) -> &[ChainJoint] {
        &self.joints
    }

    /// Number of moving joints.
    pub fn dof(&self) -> usize {
        self.joints.len()
    }

    /// The same chain with `tool` appended after the tip.
    pub fn with_tool(mut self, tool: &Isometry3<f64>) -> Self {
        self.tip *= tool;
        self
    }

    /// Pose of the tip in the base frame. `q` has one value per joint.
    pub fn forward(&self, q: &JointVector) -> Isometry3<f64> {
        assert_eq!(q.len(), self.dof(), "one joint position per joint");
        let mut t = Isometry3::identity();
        for (joint, &qi) in self.joints.iter().zip(q.iter()) {
            t *= joint.moved(qi);
        }
        t * self.tip
    }

    /// Writes the geometric Jacobian at the tip origin, in the base frame,
    /// into `j` (6 x dof): column i is `[z_i x (p_tip - o_i); z_i]` for a
    /// turning joint and `[z_i; 0]` for a prismatic one, z_i its axis in the
    /// base frame and o_i its origin.
    pub fn jacobian_into(&self, q: &JointVector, j: &mut Jacobian) {
        assert_eq!(j.ncols(), self.dof(), "one Jacobian column per joint");
        let p = self.forward(q).translation.vector;
        let mut t = Isometry3::identity();
        for (i, (joint, &qi)) in self.joints.iter().zip(q.iter()).enumerate() {
            t *= joint.moved(qi);
            let z = t.rotation * joint.axis.into_inner();
            let (v, w) = match joint.kind {
                JointKind::Prismatic => (z, Vector3::zeros()),
                JointKind::Revolute | JointKind::Continuous => {
                    (z.cross(&(p - t.translation.vector)), z)
                }
            };
            j.fixed_view_mut::<3, 1>(0, i).copy_from(&v);
            j.fixed_view_mut::<3, 1>(3, i).copy_from(&w);
        }
    }

    /// The Jacobian of [`SerialChain::jacobian_into`], in a new matrix.
    pub fn jacobian(&self, q: &JointVector) -> Jacobian {
        let mut j = Jacobian::zeros(self.dof());
        self.jacobian_into(q, &mut j);
        j
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn joint(kind: JointKind, origin: Isometry3<f64>, axis: Vector3<f64>) -> ChainJoint {
        ChainJoint {
            name: kind.name().into(),
            kind,
            origin,
            axis: Unit::new_normalize(axis),
        }
    }

    #[test]
    fn the_jacobian_equals_finite_differences_for_every_joint_kind() {
        let chain = SerialChain::new(
            vec![
                joint(
                    JointKind::Continuous,
                    Isometry3::translation(0.0, 0.0, 0.3),
                    Vector3::z(),
                ),
                joint(
                    JointKind::Prismatic,
                    Isometry3::new(Vector3::new(0.1, 0.0, 0.0), Vector3::new(0.4, 0.0, 0.0)),
                    Vector3::new(1.0, 1.0, 0.0),
                ),
                joint(
                    JointKind::Revolute,
                    Isometry3::new(Vector3::new(0.0, 0.2, 0.1), Vector3::new(0.0, 0.7, 0.2)),
                    Vector3::new(0.0, 1.0, 2.0),
                ),
            ],
            Isometry3::new(Vector3::new(0.05, 0.0, 0.1), Vector3::new(0.3, -0.2, 0.1)),
        );
        let q = JointVector::from_column_slice(&[0.4, 0.05, -0.8]);
        let j = chain.jacobian(&q);
        let h = 1e-6;
        for c in 0..3 {
            let mut dq = JointVector::zeros(3);
            dq[c] = h;
            let (plus, minus) = (chain.forward(&(&q + &dq)), chain.forward(&(&q - &dq)));
            let v = (plus.translation.vector - minus.translation.vector) / (2.0 * h);
            let w = (plus.rotation * minus.rotation.inverse()).scaled_axis() / (2.0 * h);
            for k in 0..3 {
                assert!((j[(k, c)] - v[k]).abs() < 1e-8, "column {c} v{k}");
                assert!((j[(k + 3, c)] - w[k]).abs() < 1e-8, "column {c} w{k}");
            }
        }
        // The prismatic joint moves the tip along its axis and turns nothing.
        assert!(j.fixed_view::<3, 1>(3, 1).norm() == 0.0);
    }

    #[test]
    #[should_panic(expected = "one joint position per joint")]
    fn a_joint_vector_of_the_wrong_length_is_a_bug() {
        let chain = SerialChain::new(Vec::new(), Isometry3::identity());
        chain.forward(&JointVector::zeros(2));
    }
}
