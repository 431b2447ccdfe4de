//! tactile_force: feel with a SynTouch BioTac fingertip.
//!
//! A Gaussian process turns the BioTac's 19 tared electrode values into a
//! contact wrench with an uncertainty (Huhnstock 2014), and a force
//! controller moves any serial arm described by its URDF on that estimate.
//! The modules follow the data flow:
//!
//! - [`biotac`]: the reading type, tare, the serial driver and a physically
//!   motivated simulator; [`nail`]: the nail camera, the second sensor;
//!   [`sensor`]: the seam between a sensor and the estimator;
//! - [`sim`]: the thesis data-collection protocol on that simulator, and the
//!   closed loop's world: arm plant, skin-object contact, a person's finger;
//!   [`record`]: one labelled sample; [`contact`]: the contact law;
//! - [`learn`]: data sets and their files, the models (GP, network, CNN)
//!   behind one fit/predict interface with the model file, and the
//!   workflows on top (selection, evaluation, adaptation, calibration);
//! - [`kinematics`]: the serial chain between two links of a URDF, its
//!   Jacobian and damped least-squares inverse;
//! - [`control`]: the force controller's stages, the PD force law, the
//!   tasks (guarded, guided, calibrate), the stability rules, safety;
//! - [`nodes`]: the transport-free nodes (estimator, controller, simulated robot);
//! - [`runtime`]: the lockstep runner, scenes, the demos;
//! - [`report`]: run traces, summaries and plots;
//! - [`params`]: ROS 2 parameter files, shared with the embedded runtime,
//!   and their checks;
//! - [`exit`]: how an error ends a run (its exit code); [`outputs`]: output
//!   files checked before the work;
//! - [`wrench`]: wrenches and the axes a scene needs;
//! - `ros` (feature `ros2`): the ROS 2 adapters.
//!
//! Train a one-axis estimator and query it for one reading:
//!
//! ```
//! use ndarray::Array2;
//! use tactile_force::learn::data::Dataset;
//! use tactile_force::learn::models::gp::GpParams;
//! use tactile_force::learn::models::wrench_gp::{Estimate, TareSpec, WrenchGp};
//!
//! // 50 samples of 2 tared electrode values; fz grows as e1 drops.
//! let x = Array2::from_shape_fn((50, 2), |(i, j)| -(i as f64) * (j as f64 + 1.0));
//! let y = x.column(0).mapv(|e| -0.01 * e).insert_axis(ndarray::Axis(1));
//! let data = Dataset {
//!     features: vec!["e1".into(), "e2".into()],
//!     x,
//!     axes: "fz".parse()?,
//!     y,
//!     set: vec![1; 50],
//!     trial: vec![1; 50],
//!     images: None,
//! };
//! let tare = TareSpec { samples: 0, mean_baseline: vec![0.0; 2] };
//! let params = GpParams::default().validate()?;
//! let model = WrenchGp::train(&data, tare, &params, &mut |_, _| {})?;
//!
//! let mut ws = model.workspace();
//! let mut fz = [Estimate::default()];
//! model.predict_one(&[-20.0, -40.0], &mut ws, true, &mut fz)?;
//! assert!((fz[0].mean - 0.2).abs() < 0.01 && fz[0].std < 0.05);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
#![deny(missing_docs)]

pub mod biotac;
pub mod calibration;
pub mod contact;
pub mod control;
pub mod exit;
pub mod kinematics;
pub mod learn;
pub mod nail;
pub mod nodes;
pub mod outputs;
pub mod params;
pub mod record;
pub mod report;
#[cfg(feature = "ros2")]
pub mod ros;
pub mod runtime;
pub mod sensor;
pub mod sim;
pub mod wrench;
