//! Runs the nodes: the lockstep loop on a simulated clock (or paced by the
//! wall clock), and the scenes that configure them.

pub mod calibrate;
pub mod demo;
pub mod lockstep;
pub mod scene;

pub use lockstep::{run, Nodes, Pacing, Period};
pub use scene::Scene;
