//! The simulated world around the BioTac. So far: the thesis data-collection
//! protocol (pushes with a wooden plate while an F/T sensor records the
//! reference wrench), driving the forward model in [`crate::biotac::sim`].

pub mod collect;

pub use collect::{collect, CollectConfig};
