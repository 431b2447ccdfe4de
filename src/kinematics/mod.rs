//! Arm kinematics: a 7-joint serial chain from modified DH parameters (the
//! PA10-7C by default, `config/pa10.yaml`), forward kinematics, the geometric
//! Jacobian at the tool, and a damped least-squares inverse that respects
//! joint limits.
//!
//! Conventions: base frame, metres, radians; twists are 6-vectors
//! `[vx, vy, vz, wx, wy, wz]` of the tool frame's origin, in the base frame.

pub mod chain;
pub mod dls;
pub mod robot;

pub use chain::SerialChain;
pub use dls::{joint_velocities, DlsParams, JointLimits, KinematicsError, Motion};
pub use robot::{Robot, RobotParams};

/// Joints of the arm.
pub const N_JOINTS: usize = 7;
/// Joint positions (rad) or velocities (rad/s).
pub type JointVector = nalgebra::SVector<f64, N_JOINTS>;
/// Geometric Jacobian, 6 x 7: linear rows then angular rows.
pub type Jacobian = nalgebra::SMatrix<f64, 6, N_JOINTS>;
/// Twist `[vx, vy, vz, wx, wy, wz]` (m/s, rad/s).
pub type Twist = nalgebra::Vector6<f64>;
