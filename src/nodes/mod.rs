//! Transport-free node logic (architecture page, "the one design rule"): each
//! node is a plain struct with step methods; the lockstep runtime
//! ([`crate::runtime`]) and the ROS 2 adapter only move messages between them.
//!
//! - [`wrench_estimator::EstimatorNode`]: BioTac readings -> wrench estimates;
//!   [`estimate_msg`]: an estimate as the CDR bytes of its message;
//! - [`force_controller::ForceControllerNode`]: the node around the
//!   controller ([`crate::control::ForceController`], running a task of
//!   [`tasks`], the registration): robot description, task switch, goals,
//!   the estimate, status;
//!   [`guarded_goal`]: a guarded-move goal applied to it, and its outcome;
//!   [`loop_delay`]: the delay it actually sees, from header stamps;
//! - [`bounds`]: what a peer may send a node (message sizes, goal and
//!   parameter-set rates), refused before any work and counted;
//!   [`action_goals`]: the goals of an action server and their results,
//!   each kept for a bounded time;
//! - [`sim_robot::SimRobot`]: the simulated arm, object or finger, F/T sensor and BioTac;
//! - [`lifecycle`]: the managed node's states and transitions; [`input_watch`]:
//!   which input is silent, and why the graph says so;
//! - [`markers`]: what an operator sees of the estimate (the force, its
//!   1-sigma band) and of the task's phase, as RViz markers.

pub mod action_goals;
pub mod bounds;
pub mod estimate_msg;
pub mod force_controller;
pub mod guarded_goal;
pub mod input_watch;
pub mod lifecycle;
pub mod loop_delay;
pub mod markers;
pub mod own_params;
pub mod param_reference;
pub mod sim_robot;
pub mod status;
pub mod tasks;
pub mod wrench_estimator;

pub use sim_robot::{SimRobot, SimRobotParams, SimSample};
pub use wrench_estimator::EstimatorNode;

use crate::kinematics::Robot;
use crate::params::ParamsError;

/// The arm's joint names on `joint_states`: `remap` (one per joint of the
/// chain), or the URDF's when `remap` is empty.
pub fn joint_names(robot: &Robot, remap: &[String]) -> Result<Vec<String>, ParamsError> {
    if remap.is_empty() {
        return Ok(robot.joint_names());
    }
    if remap.len() != robot.dof() {
        return Err(ParamsError::Invalid {
            key: "joint_names".into(),
            value: format!("{remap:?}"),
            expected: format!(
                "one name per joint of the chain, {} in order ({}), or none",
                robot.dof(),
                robot.joint_names().join(", ")
            ),
        });
    }
    Ok(remap.to_vec())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::ShippedRobot;

    #[test]
    fn joint_names_come_from_the_chain_unless_remapped_one_to_one() {
        let ur5 = ShippedRobot::Ur5.robot().unwrap();
        assert_eq!(joint_names(&ur5, &[]).unwrap()[0], "shoulder_pan_joint");
        let remap: Vec<String> = (1..=6).map(|i| format!("j{i}")).collect();
        assert_eq!(joint_names(&ur5, &remap).unwrap(), remap);
        let e = joint_names(&ur5, &remap[..5]).unwrap_err().to_string();
        assert!(e.contains("6 in order (shoulder_pan_joint,"), "{e}");
    }
}
