//! Learning a wrench from a sensor's signals, in three layers:
//!
//! - [`data`]: data sets (samples x features) and their files: the CSV
//!   format, rosbag2 MCAP bags, nail-camera directories;
//! - [`models`]: the numerics behind one fit/predict interface
//!   ([`models::Learner`]): Gaussian processes, the baseline network, the
//!   nail camera's CNN, scaling and metrics, and the wrench estimator with
//!   its model file ([`models::wrench_gp`]);
//! - the workflows on top, one file each: the demos' default model, the
//!   options chosen by cross-validation (`train --select`), evaluation,
//!   the speed-accuracy trade-off, adaptation, pooled retraining and a
//!   calibration's model.
//!
//! Each layer uses only the ones below it.

pub mod data;
pub mod models;

mod adapt;
pub mod adaptation;
pub mod calibration;
pub mod candidates;
pub mod choice;
pub mod chooser;
pub mod default_model;
pub mod evaluate;
pub mod pooled;
pub mod tradeoff;
