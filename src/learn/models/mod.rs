//! The models and their numerics: Gaussian processes ([`gp`]), the baseline
//! network ([`nn`]), the nail camera's CNN ([`cnn`]), input and target
//! scaling ([`scale`]), error metrics ([`metrics`]), and the wrench models
//! the estimator runs ([`wrench_model`]), each family ([`family`], the
//! registry [`families`]) with its model file: a GP per axis
//! ([`wrench_gp`]) and an ensemble of networks ([`ensemble`]).
//!
//! Every model an evaluation compares sits behind one interface, as linfa's
//! `Fit` and `Predict` do: a [`Learner`] (a model kind with its options)
//! fits on a data set and gives a [`Fitted`] model, which predicts. A model
//! family is one through [`family_learner`] (fitted as `train` fits it);
//! the baselines the estimator does not run (the network alone, the CNN)
//! are learners of their own. Evaluation, the speed-accuracy trade-off and
//! their tables loop over learners without naming them.

pub mod cnn;
pub mod ensemble;
pub mod estimate_cost;
pub mod families;
pub mod family;
pub mod family_learner;
pub mod gp;
pub mod metrics;
pub mod model_file;
pub mod nn;
pub mod provenance;
pub mod scale;
pub mod wrench_gp;
pub mod wrench_model;

use ndarray::Array2;
use serde::{Deserialize, Serialize};

use crate::exit::{Classify, ExitClass};
use crate::learn::data::Dataset;
use crate::wrench::Axis;
use gp::FitProgress;

/// A model kind with its options, which fits on a data set.
pub trait Learner: Send + Sync {
    /// Its name in tables, in messages and as the key of its scores
    /// (`gp`, `nn`, `cnn`).
    fn name(&self) -> &'static str;

    /// True when it can learn from `data` (the CNN reads images).
    fn takes(&self, data: &Dataset) -> bool {
        let _ = data;
        true
    }

    /// True when it fits on every training row rather than on an
    /// evaluation's random subset of them (a GP's prior mean is fitted on
    /// every row; the GP then takes its own subset).
    fn every_row(&self) -> bool {
        false
    }

    /// Fits on `train` (tared); `progress` hears of each axis's fit where
    /// the model reports one.
    fn fit(
        &self,
        train: &Dataset,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Box<dyn Fitted>, LearnError>;
}

/// A fitted model's estimates for the rows of a data set.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// Means (rows x axes, N or Nm).
    pub mean: Array2<f64>,
    /// For a model with a standard deviation, when asked: that of a
    /// measured target (rows x axes), the model's own doubt and the noise
    /// of the data it learnt from; what held-out errors are judged against.
    pub std: Option<Array2<f64>>,
}

/// A fitted model.
pub trait Fitted: Send {
    /// Estimates for the rows of `data`, with the standard deviation when
    /// `with_std` and the model has one.
    fn predict(&self, data: &Dataset, with_std: bool) -> Result<Prediction, LearnError>;

    /// Estimates one row of features, with the standard deviation when
    /// `with_std` and the model has one ([`Fitted::has_std`]), into scratch
    /// of its own: allocates nothing, so a loop of it times the model's
    /// latency. An error for a model that reads images, not feature rows.
    fn predict_row(&mut self, features: &[f64], with_std: bool) -> Result<(), LearnError>;

    /// True when the model estimates a standard deviation.
    fn has_std(&self) -> bool;
}

/// Why a model could not fit or predict: the model and its own error,
/// whose exit class it keeps.
#[derive(Debug, thiserror::Error)]
#[error("{model}: {source}")]
pub struct LearnError {
    /// The learner's name.
    pub model: &'static str,
    class: ExitClass,
    source: Box<dyn std::error::Error + Send + Sync>,
}

impl LearnError {
    /// `error` of the model `model`.
    pub fn new<E>(model: &'static str, error: E) -> Self
    where
        E: Classify + std::error::Error + Send + Sync + 'static,
    {
        LearnError {
            model,
            class: error.class(),
            source: Box::new(error),
        }
    }
}

/// The model's own error's class.
impl Classify for LearnError {
    fn class(&self) -> ExitClass {
        self.class
    }
}

/// How a training with early stopping went (the network and the CNN):
/// mean squared errors in standardised target units, mean over rows and
/// axes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitReport {
    /// Epochs run (at most `max_epochs`).
    pub epochs: usize,
    /// 1-based epoch whose weights were kept (0 if no epoch had a finite
    /// validation error, which keeps the initial weights).
    pub best_epoch: usize,
    /// Validation error of the kept weights.
    pub best_validation_mse: f64,
    /// Per epoch: the training batches' error during the epoch (without a
    /// weight penalty; the CNN's with dropout).
    pub train_mse: Vec<f64>,
    /// Per epoch: the validation error after the epoch.
    pub validation_mse: Vec<f64>,
    /// Rows used for the optimiser's steps.
    pub n_train: usize,
    /// Rows held out for early stopping.
    pub n_val: usize,
}
