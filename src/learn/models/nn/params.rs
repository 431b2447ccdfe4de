//! Hyper-parameters of the network and its training, their ranges (checked
//! as every parameter is: [`Check`] into [`crate::params::Checked`]), and why
//! a network cannot be trained ([`NnError`]).

use serde::{Deserialize, Serialize};

use crate::params::{require, Check, ParamsError};
use crate::sensor::SensorSpec;

use crate::exit::{Classify, ExitClass};

/// Why a network cannot be configured or trained.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum NnError {
    /// Two sizes that must agree do not.
    #[error("shape mismatch: {what} is {got}, expected {expected}")]
    ShapeMismatch {
        /// What was measured.
        what: &'static str,
        /// The required size.
        expected: usize,
        /// The size found.
        got: usize,
    },
    /// Inputs or targets have no columns.
    #[error("{what} have no columns")]
    NoColumns {
        /// `"inputs"` or `"targets"`.
        what: &'static str,
    },
    /// Not enough rows for a training and a validation part.
    #[error("too few samples: {got}, need at least {need}")]
    TooFewSamples {
        /// Rows given.
        got: usize,
        /// Rows needed.
        need: usize,
    },
    /// An input value is NaN or infinite.
    #[error("non-finite input at row {row}, column {col}")]
    NonFiniteInput {
        /// Row (sample) index.
        row: usize,
        /// Column (feature) index.
        col: usize,
    },
    /// A target value is NaN or infinite.
    #[error("non-finite target at row {row}, column {col}")]
    NonFiniteTarget {
        /// Row (sample) index.
        row: usize,
        /// Column (output) index.
        col: usize,
    },
}

/// Options or data the network cannot take: refused input.
impl Classify for NnError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// Hyper-parameters of the network and its training, as read from a config.
///
/// | Name | Default | Purpose | Range |
/// |---|---|---|---|
/// | `hidden` | 38 | tanh hidden units (2 × 19 inputs, as in the thesis) | ≥ 1 |
/// | `l2` | 1e-4 | weight penalty `λ` in `E` (standardised units) | finite, ≥ 0 |
/// | `learning_rate` | 1e-3 | Adam step size `α` | (0, 1] |
/// | `batch_size` | 128 | rows per Adam step | ≥ 1 |
/// | `max_epochs` | 200 | upper bound on passes over the training rows | ≥ 1 |
/// | `patience` | 15 | epochs without validation improvement before stopping | ≥ 1 |
/// | `validation_fraction` | 0.15 | share of rows held out for early stopping | (0, 1) |
/// | `seed` | 0 | seeds the split, initial weights and batch order | any |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NnParams {
    /// Hidden units. Default 38; ≥ 1.
    pub hidden: usize,
    /// L2 weight penalty `λ`. Default 1e-4; finite, ≥ 0.
    pub l2: f64,
    /// Adam step size `α`. Default 1e-3; in (0, 1].
    pub learning_rate: f64,
    /// Rows per mini-batch. Default 128; ≥ 1 (capped at the training rows).
    pub batch_size: usize,
    /// Maximum epochs. Default 200; ≥ 1.
    pub max_epochs: usize,
    /// Epochs without validation improvement before stopping. Default 15; ≥ 1.
    pub patience: usize,
    /// Share of the rows held out for validation. Default 0.15; in (0, 1).
    pub validation_fraction: f64,
    /// Random seed. Default 0; any value.
    pub seed: u64,
}

impl Default for NnParams {
    fn default() -> Self {
        NnParams {
            hidden: 38,
            l2: 1e-4,
            learning_rate: 1e-3,
            batch_size: 128,
            max_epochs: 200,
            patience: 15,
            validation_fraction: 0.15,
            seed: 0,
        }
    }
}

impl NnParams {
    /// The baseline network for data of `sensor`: the thesis' for the
    /// BioTac; Urban et al. 2013's shape for the nail camera (20 hidden
    /// units, early stopping after 7 epochs without improvement). Their
    /// weight penalty, `(1 - λ) MSE + λ |W|²` with `λ = 0.3`, taken over as
    /// `l2 = λ / (1 - λ)`, drove every weight to zero on our standardised
    /// inputs (R2 0.04-0.13 on every axis), so the network keeps the
    /// default penalty.
    pub fn for_sensor(sensor: &SensorSpec) -> NnParams {
        match sensor {
            SensorSpec::Biotac { .. } => NnParams::default(),
            SensorSpec::Nail(_) => NnParams {
                hidden: 20,
                patience: 7,
                ..NnParams::default()
            },
        }
    }
}

/// Every field in its range (the table on [`NnParams`]); `key` names the
/// fields in errors (`nn.hidden`).
impl Check for NnParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        let p = &self;
        require(key, "hidden", p.hidden, p.hidden >= 1, ">= 1")?;
        let l2 = p.l2;
        require(key, "l2", l2, l2.is_finite() && l2 >= 0.0, "finite, >= 0")?;
        let schedule = Schedule {
            learning_rate: p.learning_rate,
            batch_size: p.batch_size,
            max_epochs: p.max_epochs,
            patience: p.patience,
            validation_fraction: p.validation_fraction,
        };
        schedule.check(key)?;
        Ok(self)
    }
}

/// A mini-batch training schedule with early stopping, which the network
/// and the CNN share.
pub(crate) struct Schedule {
    pub(crate) learning_rate: f64,
    pub(crate) batch_size: usize,
    pub(crate) max_epochs: usize,
    pub(crate) patience: usize,
    pub(crate) validation_fraction: f64,
}

impl Schedule {
    /// Every field in its range; `key` names them in errors.
    pub(crate) fn check(&self, key: &str) -> Result<(), ParamsError> {
        let lr = self.learning_rate;
        require(key, "learning_rate", lr, lr > 0.0 && lr <= 1.0, "in (0, 1]")?;
        let b = self.batch_size;
        require(key, "batch_size", b, b >= 1, ">= 1")?;
        let e = self.max_epochs;
        require(key, "max_epochs", e, e >= 1, ">= 1")?;
        let n = self.patience;
        require(key, "patience", n, n >= 1, ">= 1")?;
        let f = self.validation_fraction;
        require(
            key,
            "validation_fraction",
            f,
            f > 0.0 && f < 1.0,
            "in (0, 1)",
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::assert_each_refused;

    #[test]
    fn defaults_are_valid_and_match_the_thesis_net() {
        let p = NnParams::default();
        assert_eq!(p.hidden, 38);
        assert_eq!(p.clone().checked("nn").map(|v| (*v).clone()).ok(), Some(p));
    }

    #[test]
    fn invalid_parameters_and_schedules_are_named() {
        type Edit = fn(&mut NnParams);
        let cases: [(&str, Edit); 9] = [
            ("hidden", |p| p.hidden = 0),
            ("l2", |p| p.l2 = -1e-3),
            ("l2", |p| p.l2 = f64::NAN),
            ("learning_rate", |p| p.learning_rate = 0.0),
            ("learning_rate", |p| p.learning_rate = 2.0),
            ("batch_size", |p| p.batch_size = 0),
            ("max_epochs", |p| p.max_epochs = 0),
            ("patience", |p| p.patience = 0),
            ("validation_fraction", |p| p.validation_fraction = 1.0),
        ];
        assert_each_refused("nn", &cases);
        let p = NnParams {
            validation_fraction: 0.0,
            ..NnParams::default()
        };
        let err = p.checked("nn").expect_err("zero fraction");
        assert_eq!(
            err.to_string(),
            "parameter nn.validation_fraction = 0: expected in (0, 1)"
        );
    }
}
