//! The simulator's parameters: the `sensor:` section of
//! `config/biotac_sim.yaml`, its checks and its errors.

use std::path::{Path, PathBuf};

use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use super::DEFAULT_CONFIG_YAML;
use crate::biotac::{ElectrodeLayout, ADC_MAX};
use crate::exit::{Classify, ExitClass};

/// Why a simulator configuration is not usable.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ConfigError {
    /// The file could not be read.
    #[error("cannot read simulator configuration {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// The YAML does not parse, or a key is missing, unknown or of the wrong type.
    #[error("simulator configuration: {0}")]
    Yaml(#[from] serde_yaml_ng::Error),
    /// A number is out of its range or not finite.
    #[error("simulator configuration: {key} = {value}: expected {expected}")]
    Value {
        /// Dotted key, e.g. `sensor.electrodes.noise_counts`.
        key: String,
        /// The value found.
        value: f64,
        /// What the value must be.
        expected: String,
    },
    /// A `[low, high]` range with low > high.
    #[error("simulator configuration: {key} = [{low}, {high}]: expected low <= high")]
    Range {
        /// Dotted key.
        key: String,
        /// The low end found.
        low: f64,
        /// The high end found.
        high: f64,
    },
    /// A list that must not be empty is empty.
    #[error("simulator configuration: {key} is empty")]
    Empty {
        /// Dotted key.
        key: String,
    },
}

/// A sensor or protocol file refused: refused input.
impl Classify for ConfigError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// Checks `low <= value <= high` and finiteness; names `key` on failure.
pub(crate) fn check_value(key: &str, value: f64, low: f64, high: f64) -> Result<(), ConfigError> {
    if value.is_finite() && value >= low && value <= high {
        Ok(())
    } else {
        Err(ConfigError::Value {
            key: key.to_string(),
            value,
            expected: format!("a finite number in [{low}, {high}]"),
        })
    }
}

/// Checks a `[low, high]` range: both ends within `[min, max]`, low <= high.
pub(crate) fn check_range(key: &str, r: [f64; 2], min: f64, max: f64) -> Result<(), ConfigError> {
    check_value(&format!("{key}[0]"), r[0], min, max)?;
    check_value(&format!("{key}[1]"), r[1], min, max)?;
    if r[0] > r[1] {
        return Err(ConfigError::Range {
            key: key.to_string(),
            low: r[0],
            high: r[1],
        });
    }
    Ok(())
}

/// A uniform draw from the range `[low, high]` (a point range gives its value).
pub(crate) fn uniform(rng: &mut impl Rng, r: [f64; 2]) -> f64 {
    r[0] + (r[1] - r[0]) * rng.random::<f64>()
}

/// A zero-mean normal draw with standard deviation `std`.
pub(crate) fn gaussian(rng: &mut impl Rng, std: f64) -> f64 {
    std * rng.sample::<f64, _>(StandardNormal)
}

/// Thermal baseline coefficient ranges, drawn per electrode (architecture page).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThermalRanges {
    /// `a`: amplitude of the thermal rise (counts), range.
    pub a_counts: [f64; 2],
    /// `b`: temperature offset (TDC counts), range.
    pub b_counts: [f64; 2],
    /// `c`: thermal rate (1 / TDC count, negative), range.
    pub c_per_count: [f64; 2],
    /// `d`: baseline at TDC = -b (counts), range.
    pub d_counts: [f64; 2],
}

/// Electrode model parameters (`sensor.electrodes`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElectrodeParams {
    /// Std of the electrode ADC noise (counts).
    pub noise_counts: f64,
    /// Thermal baseline coefficient ranges.
    pub thermal: ThermalRanges,
    /// Relative spread of the per-electrode impedance gain (gain in 1 +- spread).
    pub gain_spread: f64,
    /// Std of the Gaussian pressure footprint on the skin (mm).
    pub pressure_width_mm: f64,
    /// Std of the region the skin slides over under tangential force (mm).
    pub shear_width_mm: f64,
    /// Compression (N-equivalent) per N of tangential force one shear width ahead.
    pub shear_gain: f64,
    /// Largest impedance rise when the skin bottoms out on the core (kOhm).
    pub compression_max_kohm: f64,
    /// Compression at which the rise reaches tanh(1) of its maximum (N).
    pub compression_sat_n: f64,
    /// Largest fraction of the baseline impedance lost when the skin lifts off.
    pub release_max_fraction: f64,
}

/// Static pressure parameters (`sensor.pdc`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PdcParams {
    /// Out-of-contact PDC, drawn per unit (counts), range.
    pub baseline_counts: [f64; 2],
    /// Largest rise with normal force (counts).
    pub rise_max_counts: f64,
    /// Normal force at which the rise reaches 63 % (N).
    pub sat_n: f64,
    /// Std of the noise (counts).
    pub noise_counts: f64,
}

/// Dynamic pressure parameters (`sensor.pac`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PacParams {
    /// Out-of-contact PAC, drawn per unit (counts), range.
    pub baseline_counts: [f64; 2],
    /// Response to the rate of change of normal force (counts per N/s).
    pub rate_gain_counts_per_n_per_s: f64,
    /// Std of the noise (counts).
    pub noise_counts: f64,
}

/// Heat-flow parameters (`sensor.tac`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TacParams {
    /// Baseline, drawn per unit (counts), range.
    pub baseline_counts: [f64; 2],
    /// Std of the noise (counts).
    pub noise_counts: f64,
}

/// Temperature parameters (`sensor.tdc`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TdcParams {
    /// TDC at power-up, drawn per unit (counts), range.
    pub initial_counts: [f64; 2],
    /// Std of the noise (counts).
    pub noise_counts: f64,
}

/// The forward-model parameters as written in the `sensor:` section.
/// Validate them with [`SensorParams::validate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SensorParams {
    /// Which sensor: 19 electrodes (a BioTac, the default) or 24 (a BioTac
    /// SP; its E20..E24 sit where [`crate::biotac::geometry::SP_EXTRA`] says).
    #[serde(default)]
    pub layout: ElectrodeLayout,
    /// Electrode model.
    pub electrodes: ElectrodeParams,
    /// Static pressure.
    pub pdc: PdcParams,
    /// Dynamic pressure.
    pub pac: PacParams,
    /// Heat flow.
    pub tac: TacParams,
    /// Temperature.
    pub tdc: TdcParams,
}

/// The shape of the simulator file as the sensor model reads it: the
/// `protocol:` section belongs to [`crate::sim::collect::CollectConfig`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SensorFile {
    sensor: SensorParams,
    #[serde(default, rename = "protocol")]
    _protocol: serde::de::IgnoredAny,
}

pub(super) const ADC: f64 = ADC_MAX as f64;

impl SensorParams {
    /// Checks every value (finite, in range) and returns the checked config.
    pub fn validate(self) -> Result<BioTacSimConfig, ConfigError> {
        let (e, t) = (&self.electrodes, &self.electrodes.thermal);
        let (pdc, pac, tac, tdc) = (&self.pdc, &self.pac, &self.tac, &self.tdc);
        // Key, value, allowed [min, max].
        #[rustfmt::skip]
        let values = [
            ("sensor.electrodes.noise_counts", e.noise_counts, 0.0, 100.0),
            ("sensor.electrodes.gain_spread", e.gain_spread, 0.0, 0.9),
            ("sensor.electrodes.pressure_width_mm", e.pressure_width_mm, 0.1, 50.0),
            ("sensor.electrodes.shear_width_mm", e.shear_width_mm, 0.1, 50.0),
            ("sensor.electrodes.shear_gain", e.shear_gain, 0.0, 100.0),
            ("sensor.electrodes.compression_max_kohm", e.compression_max_kohm, 0.0, 1e4),
            ("sensor.electrodes.compression_sat_n", e.compression_sat_n, 1e-3, 1e3),
            ("sensor.electrodes.release_max_fraction", e.release_max_fraction, 1e-3, 0.99),
            ("sensor.pdc.rise_max_counts", pdc.rise_max_counts, 0.0, ADC),
            ("sensor.pdc.sat_n", pdc.sat_n, 1e-3, 1e3),
            ("sensor.pdc.noise_counts", pdc.noise_counts, 0.0, 100.0),
            ("sensor.pac.rate_gain_counts_per_n_per_s", pac.rate_gain_counts_per_n_per_s, -1e3, 1e3),
            ("sensor.pac.noise_counts", pac.noise_counts, 0.0, 100.0),
            ("sensor.tac.noise_counts", tac.noise_counts, 0.0, 100.0),
            ("sensor.tdc.noise_counts", tdc.noise_counts, 0.0, 100.0),
        ];
        for (key, value, min, max) in values {
            check_value(key, value, min, max)?;
        }
        // Key, [low, high], allowed [min, max] for both ends.
        #[rustfmt::skip]
        let ranges = [
            ("sensor.electrodes.thermal.a_counts", t.a_counts, 0.0, ADC),
            ("sensor.electrodes.thermal.b_counts", t.b_counts, -1e5, 1e5),
            ("sensor.electrodes.thermal.c_per_count", t.c_per_count, -1.0, 0.0),
            ("sensor.electrodes.thermal.d_counts", t.d_counts, 1.0, ADC - 1.0),
            ("sensor.pdc.baseline_counts", pdc.baseline_counts, 0.0, ADC),
            ("sensor.pac.baseline_counts", pac.baseline_counts, 0.0, ADC),
            ("sensor.tac.baseline_counts", tac.baseline_counts, 0.0, ADC),
            ("sensor.tdc.initial_counts", tdc.initial_counts, 0.0, ADC),
        ];
        for (key, range, min, max) in ranges {
            check_range(key, range, min, max)?;
        }
        Ok(BioTacSimConfig { params: self })
    }
}

/// The text of a simulator YAML file.
pub(crate) fn read_config(path: &Path) -> Result<String, ConfigError> {
    std::fs::read_to_string(path).map_err(|source| ConfigError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Checked forward-model parameters; build with [`BioTacSimConfig::from_yaml_str`],
/// [`BioTacSimConfig::from_file`] or `Default` (the shipped `config/biotac_sim.yaml`).
#[derive(Debug, Clone, PartialEq)]
pub struct BioTacSimConfig {
    pub(in crate::biotac::sim) params: SensorParams,
}

impl BioTacSimConfig {
    /// Parses the `sensor:` section of a simulator YAML file and validates it.
    pub fn from_yaml_str(yaml: &str) -> Result<Self, ConfigError> {
        let file: SensorFile = serde_yaml_ng::from_str(yaml)?;
        file.sensor.validate()
    }

    /// Reads and validates a simulator YAML file.
    pub fn from_file(path: &Path) -> Result<Self, ConfigError> {
        Self::from_yaml_str(&read_config(path)?)
    }

    /// The validated parameters.
    pub fn params(&self) -> &SensorParams {
        &self.params
    }

    /// The same sensor model with `layout`'s electrodes.
    pub fn with_layout(mut self, layout: ElectrodeLayout) -> Self {
        self.params.layout = layout;
        self
    }
}

impl Default for BioTacSimConfig {
    /// The shipped `config/biotac_sim.yaml`.
    fn default() -> Self {
        // The embedded file is checked by the unit tests, so this cannot fail
        // at run time unless the shipped file is broken.
        Self::from_yaml_str(DEFAULT_CONFIG_YAML)
            .expect("config/biotac_sim.yaml shipped with the crate is valid")
    }
}
