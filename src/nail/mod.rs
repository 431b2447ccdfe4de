//! The nail camera: a finger-mounted grey camera seeing the fingernail,
//! whose colour follows the fingertip force as the force pushes blood out
//! from under the nail (Urban et al. 2013; Watanabe et al. 2023). The
//! package's second sensor.
//!
//! - [`frame`]: one grey frame and its PNG file;
//! - [`sim`]: the simulated camera, persons and sessions (config/nail_sim.yaml);
//! - [`collect`]: the data-collection protocols and their data directory;
//! - [`radial`]: Watanabe's 360° test, the second protocol;
//! - [`preprocess`]: Urban's registration, mask, scaling and normalisation;
//! - [`bound`]: how well one frame can tell the force's direction at all.

pub mod bound;
pub mod collect;
pub mod frame;
pub mod preprocess;
pub mod radial;
pub mod sim;

pub use frame::NailFrame;
pub use preprocess::NailPreprocess;
