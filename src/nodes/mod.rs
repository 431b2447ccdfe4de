//! Transport-free node logic (architecture page, "the one design rule"): each
//! node is a plain struct with step methods; the lockstep runtime
//! ([`crate::runtime`]) and the ROS 2 adapter only move messages between them.
//!
//! - [`estimator::EstimatorNode`]: BioTac readings -> wrench estimates (GP);
//! - [`controller::ForceController`]: estimates and joint states -> joint velocities;
//!   [`guarded_goal`]: a guarded-move goal applied to it, and its outcome;
//!   [`calibration`]: a calibration goal, and the F/T wrench as its force,
//!   recorded with the BioTac's readings;
//!   [`loop_delay`]: the delay it actually sees, from header stamps;
//! - [`sim_robot::SimRobot`]: the simulated arm, object or finger, F/T sensor and BioTac.

pub mod calibration;
pub mod controller;
pub mod estimator;
pub mod guarded_goal;
pub mod loop_delay;
pub mod sim_robot;

pub use controller::{ControlOutput, ControllerParams, ForceController, Goal};
pub use estimator::{EstimatorNode, WrenchEstimate};
pub use sim_robot::{SimRobot, SimRobotParams, SimSample};

use crate::kinematics::JointVector;

/// Joint positions at a time (the `joint_states` topic).
#[derive(Debug, Clone, PartialEq)]
pub struct JointState {
    /// Time of the measurement (s).
    pub stamp_s: f64,
    /// Joint positions (rad or m), one per joint in chain order.
    pub q: JointVector,
}
