//! The wrench model the estimator runs, of any family ([`super::family`]):
//! a GP per axis ([`super::wrench_gp`]), an ensemble of networks
//! ([`super::ensemble`]), or one registered ([`super::families`]), with
//! what they share: the estimate, the tare, scratch, the errors and the
//! model file's JSON. [`super::families::load`] reads any family.

use std::any::Any;
use std::fmt::Debug;
use std::path::Path;

use dyn_clone::DynClone;
use ndarray::ArrayView2;
use serde::{Deserialize, Serialize};

use super::gp::GpError;
use super::nn::NnError;
use super::provenance::{AdaptChoice, CalibrationRecord, Making, Selection};
use super::Prediction;
use crate::exit::{Classify, ExitClass};
use crate::learn::data::Dataset;
pub use crate::learn::data::TareSpec;
use crate::params::ParamsError;
use crate::sensor::ModelInput;
use crate::wrench::Axis;
use crate::wrench::AxisSet;

/// Errors saving, loading or using a model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    /// The file could not be read.
    #[error("model file {path}: {source}")]
    Io {
        /// File path.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("model file {path}: cannot write: {source}")]
    Write {
        /// File path.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// Not JSON: truncated or corrupt.
    #[error("model file {path}: not a model file (truncated or corrupt JSON: {source})")]
    Corrupt {
        /// File path.
        path: String,
        /// Parser error, with line and column.
        source: serde_json::Error,
    },
    /// JSON, but not a tactile_force wrench model (or not of the family
    /// asked for).
    #[error("model file {path}: format is {found:?}, expected {expected}")]
    WrongFormat {
        /// File path.
        path: String,
        /// The `format` field found.
        found: String,
        /// The formats the reader takes.
        expected: String,
    },
    /// A model-file version this build cannot read.
    #[error("model file {path}: version {found}, this build reads versions {first} to {last} of its format")]
    UnsupportedVersion {
        /// File path.
        path: String,
        /// Version found.
        found: u64,
        /// The oldest version read.
        first: u32,
        /// The newest.
        last: u32,
    },
    /// The right format and version, but fields missing or of the wrong type.
    #[error("model file {path}: invalid: {source}")]
    Schema {
        /// File path.
        path: String,
        /// Parser error naming the field.
        source: serde_json::Error,
    },
    /// Parts of the file disagree (feature counts, axes, sizes).
    #[error("model file {path}: inconsistent: {what}")]
    Inconsistent {
        /// File path.
        path: String,
        /// What disagrees, with the numbers.
        what: String,
    },
    /// Features given to the model do not match the ones it was trained on.
    #[error("model expects {expected} features, got {found}")]
    FeatureCount {
        /// Features the model uses.
        expected: usize,
        /// Features given.
        found: usize,
    },
    /// Adaptation data whose features or axes are not the base model's.
    #[error("cannot adapt: the base model has features {base:?}, the data {data:?}")]
    AdaptMismatch {
        /// The base model's features and axes.
        base: String,
        /// The data's.
        data: String,
    },
    /// Training options out of range.
    #[error(transparent)]
    Options(#[from] ParamsError),
    /// Training a GP failed.
    #[error(transparent)]
    Gp(#[from] GpError),
    /// Training a network (of a network mean, or of an ensemble) failed.
    #[error("training the network: {0}")]
    Network(#[from] NnError),
    /// Options of a family that is not registered.
    #[error("no model family {name:?}: the families are {known}")]
    UnknownFamily {
        /// The name asked for.
        name: String,
        /// The families registered.
        known: String,
    },
    /// Scratch made by another model (a programming error).
    #[error("a workspace made by another model")]
    ForeignWorkspace,
    /// An ensemble of fewer than two networks (they would have no spread).
    #[error("an ensemble needs at least 2 networks, got {0}")]
    Members(usize),
    /// A GP stored in the file cannot be rebuilt (its data or
    /// hyperparameters refused).
    #[error("model file {path}: axis {axis}: {source}")]
    Stored {
        /// File path.
        path: String,
        /// The GP's axis.
        axis: Axis,
        /// Why it was refused.
        source: GpError,
    },
}

/// A file not written is a failure, a GP that did not fit says its own; the
/// rest is a model file or data refused.
impl Classify for ModelError {
    fn class(&self) -> ExitClass {
        match self {
            ModelError::Write { .. } => ExitClass::Failure,
            ModelError::Options(e) => e.class(),
            ModelError::Gp(e) => e.class(),
            ModelError::Network(e) => e.class(),
            _ => ExitClass::Refused,
        }
    }
}

/// Estimate of one wrench component: mean and 1-sigma of the latent force.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Estimate {
    /// Posterior mean (N or Nm).
    pub mean: f64,
    /// Standard deviation of the mean (N or Nm): the model's own doubt,
    /// which grows away from its training data; what the controller's
    /// doubt stop reads.
    pub std: f64,
}

/// A fitted wrench model of any family.
pub trait WrenchModel: Send + Sync + Debug + DynClone + AsAny {
    /// Its family's name (`gp`, `ensemble`), for tables.
    fn family(&self) -> &'static str;

    /// One line on it for logs: its family, its parts, its training size
    /// and axes.
    fn describe(&self) -> String;

    /// What it says of its input: features, sensor, tare samples.
    fn input(&self) -> ModelInput<'_>;

    /// Estimated axes, in output order.
    fn axes(&self) -> &AxisSet;

    /// Rows it was trained on.
    fn n_train(&self) -> usize;

    /// Scratch for [`WrenchModel::estimate`], made once per estimator.
    fn workspace(&self) -> Workspace;

    /// Estimates every axis from one row of tared features into `out`,
    /// without allocating, in `ws` (made by [`WrenchModel::workspace`] of
    /// this model); `with_std = false` may skip the standard deviation
    /// (std = 0) where it costs.
    fn estimate(
        &self,
        features: &[f64],
        ws: &mut Workspace,
        with_std: bool,
        out: &mut [Estimate],
    ) -> Result<(), ModelError>;

    /// Means and, when `with_std`, the standard deviation of a measured
    /// target (the model's own doubt with the data's noise, scaled as
    /// held-out errors said) for rows of tared features: what `eval`
    /// judges its coverage by.
    fn predict_observed(
        &self,
        x: ArrayView2<f64>,
        with_std: bool,
    ) -> Result<Prediction, ModelError>;

    /// Per axis, the errors on at most `rows` rows of `data` (tared, evenly
    /// spread) over the standard deviation of a measured target
    /// ([`WrenchModel::predict_observed`]): what
    /// [`super::wrench_gp::std_scale`] takes.
    fn standardised_errors(
        &self,
        data: &Dataset,
        rows: usize,
    ) -> Result<Vec<Vec<f64>>, ModelError> {
        let step = (data.len() / rows.max(1)).max(1);
        let picked: Vec<usize> = (0..data.len()).step_by(step).collect();
        let some = data.select(&picked);
        let p = self.predict_observed(some.x.view(), true)?;
        let Some(std) = p.std else {
            return Ok(Vec::new());
        };
        let z = (0..some.y.ncols()).map(|j| {
            let errors = some.y.column(j).into_iter().zip(p.mean.column(j));
            errors
                .zip(std.column(j))
                .map(|((y, m), s)| (y - m) / s)
                .collect()
        });
        Ok(z.collect())
    }

    /// Per axis, the scale of the standard deviation of a measured target
    /// (1: as fitted).
    fn std_scales(&self) -> Vec<f64>;

    /// The time of one [`WrenchModel::estimate`] with its standard
    /// deviation (µs, one core) predicted from its kind and size
    /// ([`super::estimate_cost`]): what the chooser reads, never a clock.
    fn predicted_estimate_us(&self) -> f64;

    /// Writes its model file, whole or not at all.
    fn save(&self, path: &Path) -> Result<(), ModelError>;

    /// Keeps `making` in the model and its file.
    fn record(&mut self, making: Making);

    /// How its options were chosen, when `train --select` chose them.
    fn selection(&self) -> Option<&Selection> {
        None
    }

    /// What `adapt` chose it over, when `adapt` made it.
    fn adapt_choice(&self) -> Option<&AdaptChoice> {
        None
    }

    /// The calibration on the robot that made it, when one did.
    fn calibration(&self) -> Option<&CalibrationRecord> {
        None
    }
}

/// A model behind its trait as [`Any`], to find its family's own type (a
/// GP, which `adapt` and the calibration adapt): implemented for every
/// `WrenchModel`.
pub trait AsAny {
    /// The model as `Any`.
    fn as_any(&self) -> &dyn Any;
}

impl<T: WrenchModel + 'static> AsAny for T {
    fn as_any(&self) -> &dyn Any {
        self
    }
}

dyn_clone::clone_trait_object!(WrenchModel);

impl<'a> dyn WrenchModel + 'a {
    /// Feature names, in input order.
    pub fn features(&self) -> &[String] {
        self.input().features
    }
}

/// A model's scratch for one row at a time, of a type only that model
/// knows.
#[derive(Debug)]
pub struct Workspace(Box<dyn Any + Send + Sync>);

impl Workspace {
    /// `scratch` as a workspace.
    pub fn new<T: Any + Send + Sync>(scratch: T) -> Self {
        Workspace(Box::new(scratch))
    }

    /// The scratch, if it is a `T` (a workspace of the model that asks).
    pub fn scratch<T: Any>(&mut self) -> Result<&mut T, ModelError> {
        self.0.downcast_mut().ok_or(ModelError::ForeignWorkspace)
    }
}

/// The model file's JSON and its `format` field (empty when absent).
pub(super) fn read_json(path: &Path) -> Result<(serde_json::Value, String), ModelError> {
    let p = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| ModelError::Io {
        path: p.clone(),
        source,
    })?;
    let value: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|source| ModelError::Corrupt { path: p, source })?;
    let format = value.get("format").and_then(|f| f.as_str()).unwrap_or("");
    let format = format.to_string();
    Ok((value, format))
}

/// Writes `file` as a model file's JSON, whole or not at all
/// ([`crate::outputs::write_whole`]).
pub(super) fn write_json(path: &Path, file: &impl Serialize) -> Result<(), ModelError> {
    let io = |source| ModelError::Write {
        path: path.display().to_string(),
        source,
    };
    let json = serde_json::to_vec(file).map_err(|e| io(e.into()))?;
    crate::outputs::write_whole(path, &json).map_err(io)
}
