//! What the columns of a data set hold: the BioTac channels a model may
//! take as features, and the values that cannot be true in a channel or a
//! wrench column (a logging glitch).

use crate::biotac::reading::Column;
use crate::biotac::{ElectrodeLayout, ADC_MAX, MAX_ELECTRODES};
use crate::wrench::Axis;

/// What the BioTac channel columns of a file hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Counts {
    /// Raw 12-bit ADC counts, 0 to 4095 (docs/ARCHITECTURE.md, "BioTac").
    Raw,
    /// Counts already tared: -4095 to 4095.
    Tared,
}

/// The largest force (N) in a data file that can be true: a million
/// newtons, beyond what any six-axis F/T sensor measures and anything a
/// fingertip survives. A modelling bound that catches logging glitches.
pub const MAX_FORCE_N: f64 = 1e6;
/// The same for torques (Nm).
pub const MAX_TORQUE_NM: f64 = 1e5;

/// The values a column can hold: a BioTac channel within the 12-bit range,
/// a force or torque within any sensor's. Found once per column, checked
/// per value.
pub(super) struct Plausible {
    low: f64,
    high: f64,
    expected: String,
}

impl Plausible {
    /// The range of column `name`; None when the column is no BioTac
    /// channel or wrench axis (any value can be true).
    pub(super) fn of(name: &str, counts: Counts) -> Option<Self> {
        let adc = f64::from(ADC_MAX);
        if Column::from_name(name).is_some() {
            let (low, what) = match counts {
                Counts::Raw => (0.0, "a raw"),
                Counts::Tared => (-adc, "a tared"),
            };
            return Some(Plausible {
                low,
                high: adc,
                expected: format!("{what} 12-bit BioTac count, {low} to {adc}"),
            });
        }
        let axis: Axis = name.parse().ok()?;
        let (max, unit) = if axis.index() < 3 {
            (MAX_FORCE_N, "N")
        } else {
            (MAX_TORQUE_NM, "Nm")
        };
        Some(Plausible {
            low: -max,
            high: max,
            expected: format!("a wrench within +-{max:e} {unit}, what an F/T sensor can measure"),
        })
    }

    /// What the column must hold, when `value` cannot be true there.
    pub(super) fn check(&self, value: f64) -> Option<&str> {
        (!(self.low..=self.high).contains(&value)).then_some(self.expected.as_str())
    }
}

/// Names of the electrode columns of `layout`, `e1..e19` or `e1..e24`: the
/// GP's features.
pub fn electrode_columns(layout: ElectrodeLayout) -> Vec<String> {
    (1..=layout.count()).map(|i| format!("e{i}")).collect()
}

/// The layout whose electrode columns `names` hold: a BioTac SP's when
/// any of `e20..e24` is there, else a BioTac's.
pub fn layout_of(names: &[String]) -> ElectrodeLayout {
    let sp = (20..=MAX_ELECTRODES).any(|i| names.iter().any(|n| *n == format!("e{i}")));
    match sp {
        true => ElectrodeLayout::BiotacSp,
        false => ElectrodeLayout::Biotac,
    }
}

/// A group of BioTac channels a model may take as features.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Channel {
    /// The impedance electrodes, `e1..e19` (`e1..e24` on a BioTac SP).
    Electrodes,
    /// Static pressure, `pdc`.
    Pdc,
    /// Temperature, `tdc`.
    Tdc,
    /// Heat flow, `tac`.
    Tac,
}

impl std::str::FromStr for Channel {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim() {
            "electrodes" => Ok(Channel::Electrodes),
            "pdc" => Ok(Channel::Pdc),
            "tdc" => Ok(Channel::Tdc),
            "tac" => Ok(Channel::Tac),
            other => Err(format!(
                "unknown channel {other:?}: expected electrodes, pdc, tdc or tac"
            )),
        }
    }
}

impl Channel {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Channel::Electrodes => "electrodes",
            Channel::Pdc => "pdc",
            Channel::Tdc => "tdc",
            Channel::Tac => "tac",
        }
    }
}

/// The feature columns of `channels` on a sensor of `layout`, in the order
/// given.
pub fn channel_columns(channels: &[Channel], layout: ElectrodeLayout) -> Vec<String> {
    channels
        .iter()
        .flat_map(|c| match c {
            Channel::Electrodes => electrode_columns(layout),
            Channel::Pdc => vec!["pdc".into()],
            Channel::Tdc => vec!["tdc".into()],
            Channel::Tac => vec!["tac".into()],
        })
        .collect()
}
