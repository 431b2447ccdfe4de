//! The controller's last stages, inverse kinematics -> command: the joint
//! velocities that move the BioTac with the task's twist, by an
//! [`InverseKinematics`] (the shipped one: the damped least-squares
//! inverse, src/kinematics/dls.rs); and, for an arm with fewer than six
//! joints, whether it can make the task's directions at all.

use std::fmt;

use dyn_clone::DynClone;

use crate::control::{Halt, Task};
use crate::kinematics::{Dls, JointVector, Robot, Twist};
use crate::params::ParamsError;

use super::REALISABLE_TOLERANCE;

/// The inverse-kinematics stage: the joint velocities that move the BioTac
/// with a twist. The shipped one is [`Dls`]; another joins a controller
/// with [`super::ForceController::with_inverse`].
pub trait InverseKinematics: fmt::Debug + Send + DynClone {
    /// Writes to `qdot` the joint velocities at `q` that make `twist`
    /// (base frame, not zero), and says what the solve did to it; Err halts
    /// the arm for the cycle.
    fn solve(
        &mut self,
        robot: &Robot,
        q: &JointVector,
        twist: &Twist,
        qdot: &mut JointVector,
    ) -> Result<Made, Halt>;

    /// The share of `twist` at `q` that no joint velocities make (0: all of
    /// it is made).
    fn unmade(&mut self, robot: &Robot, q: &JointVector, twist: &Twist) -> f64;
}

/// The damped least-squares inverse, speeds scaled to the joints' limits.
impl InverseKinematics for Dls {
    fn solve(
        &mut self,
        robot: &Robot,
        q: &JointVector,
        twist: &Twist,
        qdot: &mut JointVector,
    ) -> Result<Made, Halt> {
        let motion = Dls::solve(self, robot, q, twist, None)?;
        qdot.copy_from(self.qdot());
        Ok(Made {
            scale: motion.scale,
            damping: motion.damping,
        })
    }

    fn unmade(&mut self, robot: &Robot, q: &JointVector, twist: &Twist) -> f64 {
        Dls::unmade(self, robot, q, twist)
    }
}

dyn_clone::clone_trait_object!(InverseKinematics);

/// The joint velocities of the last cycle and the twist they make.
#[derive(Debug, Clone)]
pub(super) struct JointCommand {
    inverse: Box<dyn InverseKinematics>,
    command: JointVector,
    twist: Twist,
}

/// What an [`InverseKinematics`] did to a twist.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Made {
    /// The factor every velocity was scaled by for the speed limits (1: none).
    pub scale: f64,
    /// The damping factor of the inverse (0: away from singularity).
    pub damping: f64,
}

impl JointCommand {
    /// Zero velocity for `robot`'s joints, solved by `inverse`.
    pub(super) fn new(robot: &Robot, inverse: Box<dyn InverseKinematics>) -> Self {
        JointCommand {
            inverse,
            command: JointVector::zeros(robot.dof()),
            twist: Twist::zeros(),
        }
    }

    /// The joint velocities (rad/s or m/s, chain order).
    pub(super) fn command(&self) -> &JointVector {
        &self.command
    }

    /// The BioTac's twist (base frame).
    pub(super) fn twist(&self) -> &Twist {
        &self.twist
    }

    /// Zero velocity.
    pub(super) fn zero(&mut self) {
        self.command.fill(0.0);
        self.twist = Twist::zeros();
    }

    /// The joint velocities at `q` that make `twist` (zero for none).
    pub(super) fn solve(
        &mut self,
        robot: &Robot,
        q: &JointVector,
        twist: Twist,
    ) -> Result<Made, Halt> {
        self.twist = twist;
        if twist == Twist::zeros() {
            self.command.fill(0.0);
            return Ok(Made {
                scale: 1.0,
                damping: 0.0,
            });
        }
        self.inverse.solve(robot, q, &twist, &mut self.command)
    }

    /// Refuses a pose `q` at which an arm with fewer than six joints cannot
    /// move the BioTac along a direction of `task` while holding its
    /// orientation, naming the direction. Arms with six joints or more pass
    /// (near a singularity the damping slows them instead).
    pub(super) fn realisable(
        &mut self,
        robot: &Robot,
        task: &dyn Task,
        q: &JointVector,
    ) -> Result<(), ParamsError> {
        let dof = robot.dof();
        if dof >= 6 {
            return Ok(());
        }
        let pose = robot.chain.forward(q);
        for (name, d) in task.directions() {
            let v = pose.rotation * d;
            let twist = Twist::new(v.x, v.y, v.z, 0.0, 0.0, 0.0);
            let unmade = self.inverse.unmade(robot, q, &twist);
            if unmade > REALISABLE_TOLERANCE {
                return Err(ParamsError::Invalid {
                    key: "start pose".into(),
                    value: format!("{:?} rad", q.as_slice()),
                    expected: format!(
                        "a pose where the arm ({dof} joints) can move the BioTac along {name} \
                         while holding its orientation: {:.0} % of that motion cannot be made \
                         (at most {:.0} %); choose another start pose or a task without that \
                         axis",
                        unmade * 100.0,
                        REALISABLE_TOLERANCE * 100.0
                    ),
                });
            }
        }
        Ok(())
    }
}
