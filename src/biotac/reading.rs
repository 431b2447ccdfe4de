//! One BioTac frame: 19 electrodes (24 on a BioTac SP), PDC, its PAC
//! samples (22; 27 on a BioTac SP), TDC, TAC.
//!
//! All channels are 12-bit ADC counts (0..=4095). A BioTac's frame arrives
//! every 10 ms (44 SPI words at 4400 words/s), a BioTac SP's every 12.3 ms
//! (54 words); either samples PAC every other word (2200 Hz).

use std::ops::{Deref, DerefMut};

use serde::{Deserialize, Serialize};

/// Number of impedance electrodes of a BioTac.
pub const N_ELECTRODES: usize = 19;
/// Number of impedance electrodes of a BioTac SP, the most a reading holds.
pub const MAX_ELECTRODES: usize = 24;
/// PAC samples in a BioTac's default frame.
pub const N_PAC: usize = 22;
/// PAC samples in a BioTac SP's default frame, the most a reading holds
/// ([`ElectrodeLayout::pac_per_frame`]).
pub const MAX_PAC: usize = 27;
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

    /// PAC samples in its default frame: each electrode and PDC, TAC, TDC
    /// is followed by a PAC sample, so 22 on a BioTac and 27 on a BioTac SP.
    ///
    /// The BioTac SP's frame, E1, PAC, E2, PAC, ..., E24, PAC, PDC, PAC,
    /// TAC, PAC, TDC, PAC (54 words), is `BT_FRAME_STRUCTURE_DEFAULT` in the
    /// SP edition of SynTouch's Cheetah library (`biotac.h`, as shipped in
    /// CNCR-NTU/biotac_sp_ros, whose README's default sampling sequence is
    /// the BioTac SP Product Manual's and whose output rows hold 3 x 54
    /// samples); the BioTac's is the same with E1..E19 (44 words).
    pub const fn pac_per_frame(self) -> usize {
        self.count() + 3
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

/// A frame's PAC samples (counts), in time order: 22 from a BioTac, 27
/// from a BioTac SP ([`ElectrodeLayout::pac_per_frame`]), or as many as a
/// message carried (a Shadow hand's two), at most [`MAX_PAC`]. Stored
/// inline (no heap: readings are copied in the control loop).
#[derive(Clone, Copy, Serialize, Deserialize)]
#[serde(try_from = "Vec<u16>", into = "Vec<u16>")]
pub struct Pac {
    values: [u16; MAX_PAC],
    len: u8,
}

/// A PAC sample count no reading holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{found} PAC samples: a reading holds 1 to 27 (a BioTac's frame 22, a BioTac SP's 27)")]
pub struct PacError {
    /// The count found.
    pub found: usize,
}

impl Pac {
    /// `len` samples at `value`; `len` is clamped to 1..=[`MAX_PAC`].
    pub fn filled(len: usize, value: u16) -> Self {
        Pac {
            values: [value; MAX_PAC],
            len: len.clamp(1, MAX_PAC) as u8,
        }
    }

    /// The samples in `values`, refused when none or more than [`MAX_PAC`].
    pub fn from_slice(values: &[u16]) -> Result<Self, PacError> {
        if values.is_empty() || values.len() > MAX_PAC {
            return Err(PacError {
                found: values.len(),
            });
        }
        let mut p = Pac::filled(values.len(), 0);
        p.copy_from_slice(values);
        Ok(p)
    }
}

impl Deref for Pac {
    type Target = [u16];
    fn deref(&self) -> &[u16] {
        &self.values[..usize::from(self.len)]
    }
}

impl DerefMut for Pac {
    fn deref_mut(&mut self) -> &mut [u16] {
        &mut self.values[..usize::from(self.len)]
    }
}

impl PartialEq for Pac {
    fn eq(&self, other: &Self) -> bool {
        **self == **other
    }
}

impl std::fmt::Debug for Pac {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl<const N: usize> From<[u16; N]> for Pac {
    /// The samples of an array; a compile-time error unless 1..=27 long.
    fn from(values: [u16; N]) -> Self {
        const { assert!(N >= 1 && N <= MAX_PAC) };
        let mut p = Pac::filled(N, 0);
        p.copy_from_slice(&values);
        p
    }
}

impl TryFrom<Vec<u16>> for Pac {
    type Error = PacError;
    fn try_from(values: Vec<u16>) -> Result<Self, PacError> {
        Pac::from_slice(&values)
    }
}

impl From<Pac> for Vec<u16> {
    fn from(p: Pac) -> Vec<u16> {
        p.to_vec()
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
    /// Dynamic (AC) pressure, the frame's samples in time order (22; 27 on
    /// a BioTac SP).
    pub pac: Pac,
    /// Static temperature.
    pub tdc: u16,
    /// Heat flow (dynamic temperature).
    pub tac: u16,
}

impl BioTacReading {
    /// Every channel of `layout` at 0: electrodes and its frame's PAC
    /// samples ([`ElectrodeLayout::pac_per_frame`]); seq and stamp 0.
    pub fn zeroed(layout: ElectrodeLayout) -> Self {
        BioTacReading {
            seq: 0,
            stamp_s: 0.0,
            electrodes: Electrodes::filled(layout, 0),
            pdc: 0,
            pac: Pac::filled(layout.pac_per_frame(), 0),
            tdc: 0,
            tac: 0,
        }
    }

    /// Mean of the frame's PAC samples.
    pub fn pac_mean(&self) -> f64 {
        self.pac.iter().map(|&v| f64::from(v)).sum::<f64>() / self.pac.len() as f64
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
    /// Mean of the frame's PAC samples.
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
            pac: [2; N_PAC].into(),
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

    #[test]
    fn pac_holds_a_frames_samples_up_to_a_biotac_sps() {
        assert_eq!(ElectrodeLayout::Biotac.pac_per_frame(), N_PAC);
        assert_eq!(ElectrodeLayout::BiotacSp.pac_per_frame(), MAX_PAC);
        let sp = BioTacReading::zeroed(ElectrodeLayout::BiotacSp);
        assert_eq!((sp.electrodes.len(), sp.pac.len()), (24, 27));
        let mut r = BioTacReading::zeroed(ElectrodeLayout::Biotac);
        assert_eq!((r.electrodes.len(), r.pac.len()), (19, 22));
        r.pac = Pac::from_slice(&[
            10, 20, 30, 40, 50, 60, 70, 80, 90, 100, 110, 120, 130, 140, 150, 160, 170, 180, 190,
            200, 210, 220, 230, 240, 250, 260, 270,
        ])
        .unwrap();
        assert_eq!(r.pac_mean(), 140.0);
        r.pac = [2040, 2051].into();
        assert_eq!(r.pac_mean(), 2045.5);
        assert_ne!(r.pac, Pac::from([2040, 2051, 0]));
        for bad in [0, 28] {
            let e = Pac::from_slice(&vec![1; bad]).unwrap_err();
            assert_eq!(
                e.to_string(),
                format!("{bad} PAC samples: a reading holds 1 to 27 (a BioTac's frame 22, a BioTac SP's 27)")
            );
        }
        let json = serde_json::to_string(&sp.pac).unwrap();
        assert_eq!(serde_json::from_str::<Pac>(&json).unwrap(), sp.pac);
        assert!(serde_json::from_str::<Pac>("[]").is_err());
    }
}
