//! One BioTac frame: 19 electrodes, PDC, 22 PAC samples, TDC, TAC.
//!
//! All channels are 12-bit ADC counts (0..=4095). A frame arrives every 10 ms
//! (44 SPI words at 4400 words/s), and PAC is sampled 22 times per frame
//! (2200 Hz).

use serde::{Deserialize, Serialize};

/// Number of impedance electrodes.
pub const N_ELECTRODES: usize = 19;
/// PAC samples per frame.
pub const N_PAC: usize = 22;
/// Largest 12-bit ADC count.
pub const ADC_MAX: u16 = 4095;
/// Frame period of the default sampling loop (s).
pub const FRAME_PERIOD_S: f64 = 0.01;

/// One BioTac frame in raw ADC counts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BioTacReading {
    /// Frame sequence number from the source (wraps at `u16::MAX`).
    pub seq: u16,
    /// Time the frame was sampled, in seconds on the source clock.
    pub stamp_s: f64,
    /// Electrode impedance channels E1..E19; values drop as the skin compresses.
    pub electrodes: [u16; N_ELECTRODES],
    /// Static (DC) fluid pressure; rises with contact force.
    pub pdc: u16,
    /// Dynamic (AC) pressure, 22 samples over the frame.
    pub pac: [u16; N_PAC],
    /// Static temperature.
    pub tdc: u16,
    /// Heat flow (dynamic temperature).
    pub tac: u16,
}

impl BioTacReading {
    /// Mean of the 22 PAC samples of the frame.
    pub fn pac_mean(&self) -> f64 {
        self.pac.iter().map(|&v| f64::from(v)).sum::<f64>() / N_PAC as f64
    }
}
