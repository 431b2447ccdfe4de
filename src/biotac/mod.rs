//! The BioTac fingertip: reading type, tare, and a simulator (forward model).

pub mod reading;

pub use reading::{BioTacReading, ADC_MAX, FRAME_PERIOD_S, N_ELECTRODES, N_PAC};
