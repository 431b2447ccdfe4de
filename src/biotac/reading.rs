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

/// One channel of a reading by its column name in the training data
/// (`e1..e19`, `pdc`, `pac_mean`, `tdc`, `tac`): what a model's feature is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Column {
    /// Electrode E1..E19 (index 0..19).
    Electrode(usize),
    /// Static pressure.
    Pdc,
    /// Mean of the 22 PAC samples.
    PacMean,
    /// Temperature.
    Tdc,
    /// Heat flow.
    Tac,
}

impl Column {
    /// The column named `name`, if a reading has it.
    pub fn from_name(name: &str) -> Option<Column> {
        Some(match name {
            "pdc" => Column::Pdc,
            "pac_mean" => Column::PacMean,
            "tdc" => Column::Tdc,
            "tac" => Column::Tac,
            _ => {
                let i: usize = name.strip_prefix('e')?.parse().ok()?;
                Column::Electrode(i.checked_sub(1).filter(|&i| i < N_ELECTRODES)?)
            }
        })
    }

    /// Its value in `r` (counts).
    pub fn value(self, r: &BioTacReading) -> f64 {
        match self {
            Column::Electrode(i) => f64::from(r.electrodes[i]),
            Column::Pdc => f64::from(r.pdc),
            Column::PacMean => r.pac_mean(),
            Column::Tdc => f64::from(r.tdc),
            Column::Tac => f64::from(r.tac),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_by_name_read_their_channel() {
        let mut r = BioTacReading {
            seq: 0,
            stamp_s: 0.0,
            electrodes: std::array::from_fn(|i| 100 + i as u16),
            pdc: 7,
            pac: [2; N_PAC],
            tdc: 8,
            tac: 9,
        };
        r.pac[0] = 24;
        let value = |name: &str| Column::from_name(name).map(|c| c.value(&r));
        assert_eq!(value("e1"), Some(100.0));
        assert_eq!(value("e19"), Some(118.0));
        assert_eq!(value("pdc"), Some(7.0));
        assert_eq!(value("pac_mean"), Some(3.0));
        assert_eq!((value("tdc"), value("tac")), (Some(8.0), Some(9.0)));
        for bad in ["e0", "e20", "e", "fz", "E1"] {
            assert_eq!(Column::from_name(bad), None, "{bad}");
        }
    }
}
