//! Arm kinematics: a serial chain read from a URDF between two links (any
//! number of revolute, continuous and prismatic joints), forward
//! kinematics, the geometric Jacobian at the tool, and a damped
//! least-squares inverse that respects joint limits.
//!
//! Conventions: base frame, metres, radians; twists are 6-vectors
//! `[vx, vy, vz, wx, wy, wz]` of the tool frame's origin, in the base frame
//! (Pinocchio's LOCAL_WORLD_ALIGNED).

pub mod chain;
pub mod dls;
pub mod robot;
pub mod shipped;
pub mod urdf;

pub use chain::{ChainJoint, JointKind, SerialChain};
pub use dls::{Dls, DlsParams, JointLimits, KinematicsError, Motion};
pub use robot::{LimitOverride, Robot, RobotError, RobotParams};
pub use shipped::ShippedRobot;

/// Joint positions (rad or m) or velocities (rad/s or m/s), one per joint.
pub type JointVector = nalgebra::DVector<f64>;
/// Geometric Jacobian, 6 x n: linear rows then angular rows.
pub type Jacobian = nalgebra::Matrix6xX<f64>;
/// Twist `[vx, vy, vz, wx, wy, wz]` (m/s, rad/s).
pub type Twist = nalgebra::Vector6<f64>;
