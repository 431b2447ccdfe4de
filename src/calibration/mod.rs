//! The calibration of a mounted BioTac on the robot, from the pattern to
//! the recording: the arm presses a calibration block in a scripted
//! pattern ([`mod@pattern`]) as a task of the force controller ([`task`]), with
//! the wrist's F/T sensor as the force; a goal puts that task on the
//! surface to press ([`goal`]); the F/T wrenches and the BioTac's readings
//! are paired and recorded ([`recorder`]). The model is then fitted on the
//! recording (`learn::calibration`); the embedded runtime runs it on the
//! simulated arm (`runtime::calibrate`), the ROS node as an action.

pub mod goal;
pub mod pattern;
pub mod recorder;
pub mod task;

pub use goal::{check_outputs, open_outputs, CalibrateGoal, DEFAULT_SURFACE};
pub use pattern::{pattern, CalibrateParams, Push, PushKind};
pub use recorder::{CalibrationRecorder, Ended, SessionEnd, FT_STALE_S, PAIR_TOLERANCE_S};
pub use task::CalibrateMove;
