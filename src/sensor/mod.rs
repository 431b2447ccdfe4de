//! The sensor seam: what the wrench estimator needs of a sensor
//! ([`SensorInput`]: its reading, how a reading becomes the model's
//! features, its contact cue) and what a model file records of the sensor
//! it was trained on ([`SensorSpec`]). One module per sensor:
//!
//! - [`biotac`]: BioTac readings (19 electrodes, 24 on a BioTac SP,
//!   pressures, temperature);
//!   the features are channels tared on the first readings out of contact;
//!   the contact cue is the PDC rise; training data are CSV files or ROS
//!   bags ([`crate::learn::data`], [`crate::learn::data::bag`]).
//! - [`nail`]: nail-camera frames; the features are Urban's registered,
//!   masked and normalised pixels projected on the training frames'
//!   principal components; there is no contact cue; training data are
//!   directories of PNG frames and labels ([`crate::nail::collect`]).
//!
//! The estimator node ([`crate::nodes::EstimatorNode`]) is generic over
//! [`SensorInput`]; `train`, `eval` and `adapt` read either sensor's data
//! into the same [`crate::learn::data::Dataset`]. A third sensor adds a
//! module here with its input and data reader, and a [`SensorSpec`] variant.

pub mod biotac;
pub mod nail;

use serde::{Deserialize, Serialize};

use crate::biotac::ElectrodeLayout;
use crate::exit::{Classify, ExitClass};
use crate::nail::preprocess::PreprocessError;

/// What a model file records of its sensor.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum SensorSpec {
    /// A BioTac: the features are its channels by name (files before this
    /// record are BioTac models), from readings of its electrode layout
    /// (files before the layout was recorded: a BioTac's 19).
    Biotac {
        /// The sensor's electrodes.
        #[serde(default)]
        electrodes: ElectrodeLayout,
    },
    /// The nail camera: the preprocessing and projection of its frames.
    Nail(Box<nail::NailSpec>),
}

impl Default for SensorSpec {
    /// A BioTac with 19 electrodes.
    fn default() -> Self {
        SensorSpec::biotac(ElectrodeLayout::Biotac)
    }
}

impl SensorSpec {
    /// A BioTac of `electrodes`.
    pub fn biotac(electrodes: ElectrodeLayout) -> Self {
        SensorSpec::Biotac { electrodes }
    }

    /// Time between two readings (s).
    pub fn sample_period_s(&self) -> f64 {
        match self {
            SensorSpec::Biotac { .. } => crate::biotac::reading::FRAME_PERIOD_S,
            SensorSpec::Nail(spec) => spec.frame_period_s,
        }
    }

    /// The sensor's name, as `--sensor` takes it.
    pub fn name(&self) -> &'static str {
        match self {
            SensorSpec::Biotac { .. } => biotac::NAME,
            SensorSpec::Nail(_) => nail::NAME,
        }
    }
}

/// What a model says of its input.
#[derive(Debug, Clone, Copy)]
pub struct ModelInput<'a> {
    /// Its feature names, in order.
    pub features: &'a [String],
    /// Its sensor.
    pub sensor: &'a SensorSpec,
    /// Readings its training data were tared on (0: not said).
    pub tare_samples: usize,
}

/// Why a sensor cannot feed a model, or a reading gives no features.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SensorError {
    /// The model was trained on another sensor.
    #[error("the model was trained on the {model} sensor; this node reads the {node}")]
    WrongSensor {
        /// The model's sensor.
        model: &'static str,
        /// The node's.
        node: &'static str,
    },
    /// The model takes a feature this sensor does not make.
    #[error("the model's features are {found:?}; this node feeds {feeds}")]
    Features {
        /// The model's features.
        found: Vec<String>,
        /// What the sensor makes.
        feeds: &'static str,
    },
    /// Readings of another electrode layout than the model's.
    #[error("model trained on {model}, readings have {readings}")]
    Layout {
        /// The model's layout.
        model: ElectrodeLayout,
        /// The readings'.
        readings: ElectrodeLayout,
    },
    /// A frame could not be preprocessed.
    #[error(transparent)]
    Preprocess(#[from] PreprocessError),
}

/// A model for another sensor, or frames that cannot be registered: refused input.
impl Classify for SensorError {
    fn class(&self) -> ExitClass {
        match self {
            SensorError::Preprocess(e) => e.class(),
            _ => ExitClass::Refused,
        }
    }
}

/// A sensor as the wrench estimator reads it.
pub trait SensorInput: Clone + std::fmt::Debug + Sized {
    /// One reading.
    type Reading;

    /// The input that feeds `model`, or why this sensor cannot.
    fn for_model(model: ModelInput) -> Result<Self, SensorError>;

    /// The reading's stamp (s) and sequence number.
    fn stamp(r: &Self::Reading) -> (f64, u16);

    /// True once the baseline is taken (always, for a sensor without one).
    fn is_ready(&self) -> bool;

    /// Readings the baseline takes.
    fn baseline_samples(&self) -> usize;

    /// Takes a reading: the features into `out` (one per model feature)
    /// and the contact cue (the BioTac's PDC rise, in counts; 0 for a
    /// sensor without one), or None while the baseline is taken.
    fn features(&mut self, r: &Self::Reading, out: &mut [f64]) -> Result<Option<f64>, SensorError>;
}
