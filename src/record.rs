//! One labelled sample, as the simulator collects it and a bag or a CSV
//! holds it: a BioTac reading and the reference wrench, with its set and
//! trial. Shared by `sim` (which makes them) and `learn` (which reads and
//! writes them), so that neither imports the other for it.

use crate::biotac::BioTacReading;
use crate::wrench::Wrench;

/// One row of a collected data set: a reading and the reference wrench.
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// Time since the start of the trial (s).
    pub t: f64,
    /// Data set number (1 = mainly x, 2 = mainly y, 3 = mainly z, 4 = combined).
    pub set: u32,
    /// Trial number within the set (1-based).
    pub trial: u32,
    /// The raw BioTac frame.
    pub reading: BioTacReading,
    /// Reference wrench from the F/T sensor, in the BioTac frame (N, Nm).
    pub wrench: Wrench,
}
