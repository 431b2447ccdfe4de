//! tactile_force: feel with a BioTac fingertip.
#![deny(missing_docs)]

pub mod biotac;
pub mod learn;
pub mod sim;
pub mod wrench;
