//! One BioTac frame: 19 electrodes (24 on a BioTac SP), PDC, 22 PAC
//! samples, TDC, TAC.
//!
//! All channels are 12-bit ADC counts (0..=4095). A frame arrives every 10 ms
//! (44 SPI words at 4400 words/s), and PAC is sampled 22 times per frame
//! (2200 Hz).

use std::ops::{Deref, DerefMut};

use serde::{Deserialize, Serialize};

/// Number of impedance electrodes of a BioTac.
pub const N_ELECTRODES: usize = 19;
/// Number of impedance electrodes of a BioTac SP, the most a reading holds.
pub const MAX_ELECTRODES: usize = 24;
/// PAC samples per frame.
pub const N_PAC: usize = 22;
/// Largest 12-bit ADC count.
pub const ADC_MAX: u16 = 4095;
/// Frame period of the default sampling loop (s).
pub const FRAME_PERIOD_S: f64 = 0.01;

/// Which electrodes a sensor has: a BioTac's 19 or a BioTac SP's 24
/// (SynTouch's product lines). Written in files as the count.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(try_from = "usize", into = "usize")]
pub enum ElectrodeLayout {
    /// The BioTac: E1..E19.
    #[default]
    Biotac,
    /// The BioTac SP: E1..E24.
    BiotacSp,
}

impl ElectrodeLayout {
    /// Its number of electrodes.
    pub const fn count(self) -> usize {
        match self {
            ElectrodeLayout::Biotac => N_ELECTRODES,
            ElectrodeLayout::BiotacSp => MAX_ELECTRODES,
        }
    }

    /// The layout with `count` electrodes.
    pub fn with_count(count: usize) -> Result<Self, LayoutError> {
        match count {
            N_ELECTRODES => Ok(ElectrodeLayout::Biotac),
            MAX_ELECTRODES => Ok(ElectrodeLayout::BiotacSp),
            found => Err(LayoutError { found }),
        }
    }
}

impl std::fmt::Display for ElectrodeLayout {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} electrodes", self.count())
    }
}

impl TryFrom<usize> for ElectrodeLayout {
    type Error = LayoutError;
    fn try_from(count: usize) -> Result<Self, LayoutError> {
        ElectrodeLayout::with_count(count)
    }
}

impl From<ElectrodeLayout> for usize {
    fn from(layout: ElectrodeLayout) -> usize {
        layout.count()
    }
}

/// An electrode count no BioTac has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{found} electrodes: a BioTac has 19, a BioTac SP 24")]
pub struct LayoutError {
    /// The count found.
    pub found: usize,
}

/// The electrode values of a frame (counts), E1 first: a slice of the
/// layout's length, stored inline (no heap: readings are copied in the
/// control loop).
#[derive(Clone, Copy, Serialize, Deserialize)]
#[serde(try_from = "Vec<u16>", into = "Vec<u16>")]
pub struct Electrodes {
    values: [u16; MAX_ELECTRODES],
    layout: ElectrodeLayout,
}

impl Electrodes {
    /// Every electrode of `layout` at `value`.
    pub fn filled(layout: ElectrodeLayout, value: u16) -> Self {
        Electrodes {
            values: [value; MAX_ELECTRODES],
            layout,
        }
    }

    /// The values in `values`, refused unless a BioTac's or a BioTac SP's count.
    pub fn from_slice(values: &[u16]) -> Result<Self, LayoutError> {
        let mut e = Electrodes::filled(ElectrodeLayout::with_count(values.len())?, 0);
        e.copy_from_slice(values);
        Ok(e)
    }

    /// Which sensor's electrodes these are.
    pub fn layout(&self) -> ElectrodeLayout {
        self.layout
    }
}

impl Deref for Electrodes {
    type Target = [u16];
    fn deref(&self) -> &[u16] {
        &self.values[..self.layout.count()]
    }
}

impl DerefMut for Electrodes {
    fn deref_mut(&mut self) -> &mut [u16] {
        &mut self.values[..self.layout.count()]
    }
}

impl PartialEq for Electrodes {
    fn eq(&self, other: &Self) -> bool {
        **self == **other
    }
}

impl std::fmt::Debug for Electrodes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl From<[u16; N_ELECTRODES]> for Electrodes {
    fn from(values: [u16; N_ELECTRODES]) -> Self {
        let mut e = Electrodes::filled(ElectrodeLayout::Biotac, 0);
        e.copy_from_slice(&values);
        e
    }
}

impl From<[u16; MAX_ELECTRODES]> for Electrodes {
    fn from(values: [u16; MAX_ELECTRODES]) -> Self {
        Electrodes {
            values,
            layout: ElectrodeLayout::BiotacSp,
        }
    }
}

impl TryFrom<Vec<u16>> for Electrodes {
    type Error = LayoutError;
    fn try_from(values: Vec<u16>) -> Result<Self, LayoutError> {
        Electrodes::from_slice(&values)
    }
}

impl From<Electrodes> for Vec<u16> {
    fn from(e: Electrodes) -> Vec<u16> {
        e.to_vec()
    }
}

/// One BioTac frame in raw ADC counts.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BioTacReading {
    /// Frame sequence number from the source (wraps at `u16::MAX`).
    pub seq: u16,
    /// Time the frame was sampled, in seconds on the source clock.
    pub stamp_s: f64,
    /// Electrode impedance channels E1..E19 (E1..E24 on a BioTac SP);
    /// values drop as the skin compresses.
    pub electrodes: Electrodes,
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
/// (`e1..e24`, `pdc`, `pac_mean`, `tdc`, `tac`): what a model's feature is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Column {
    /// Electrode E1..E24 (index 0..24); E20..E24 only on a BioTac SP.
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
                Column::Electrode(i.checked_sub(1).filter(|&i| i < MAX_ELECTRODES)?)
            }
        })
    }

    /// Its value in `r` (counts); an electrode `r`'s layout lacks reads 0
    /// (a model refuses readings of another layout before it reads them).
    pub fn value(self, r: &BioTacReading) -> f64 {
        match self {
            Column::Electrode(i) => r.electrodes.get(i).copied().map_or(0.0, f64::from),
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
            electrodes: std::array::from_fn::<u16, 19, _>(|i| 100 + i as u16).into(),
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
        assert_eq!(value("e24"), Some(0.0), "not on a 19-electrode BioTac");
        for bad in ["e0", "e25", "e", "fz", "E1"] {
            assert_eq!(Column::from_name(bad), None, "{bad}");
        }
    }

    #[test]
    fn electrodes_are_a_slice_of_their_layout() {
        let sp = Electrodes::from_slice(&[7; 24]).unwrap();
        assert_eq!((sp.len(), sp.layout()), (24, ElectrodeLayout::BiotacSp));
        let bt = Electrodes::from([7; 19]);
        assert_eq!((bt.len(), bt.layout()), (19, ElectrodeLayout::Biotac));
        assert_ne!(sp, bt);
        let e = Electrodes::from_slice(&[1; 20]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "20 electrodes: a BioTac has 19, a BioTac SP 24"
        );
        let json = serde_json::to_string(&sp).unwrap();
        assert_eq!(serde_json::from_str::<Electrodes>(&json).unwrap(), sp);
        assert!(serde_json::from_str::<Electrodes>("[1,2]").is_err());
        let layout: ElectrodeLayout = serde_json::from_str("24").unwrap();
        assert_eq!(layout, ElectrodeLayout::BiotacSp);
        assert!(serde_json::from_str::<ElectrodeLayout>("23").is_err());
    }
}
