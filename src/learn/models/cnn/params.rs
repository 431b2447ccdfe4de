//! Hyper-parameters of the CNN and its training, their ranges (checked as
//! every parameter is: [`Check`] into [`crate::params::Checked`]), and why a
//! CNN cannot be trained, run or loaded ([`CnnError`]).

use serde::{Deserialize, Serialize};

use crate::exit::{Classify, ExitClass};
use crate::learn::models::nn::Schedule;
use crate::params::{require, Check, ParamsError};

/// Why a CNN cannot be trained, run or loaded.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CnnError {
    /// A size of the data or of a stored tensor is not the one required.
    #[error("shape mismatch: {what} is {got}, expected {expected}")]
    Shape {
        /// What was measured.
        what: String,
        /// The required size (or range of sizes).
        expected: String,
        /// The size found.
        got: String,
    },
    /// An image pixel is NaN or infinite.
    #[error("non-finite pixel in image {sample} at row {row}, column {col}")]
    NonFiniteImage {
        /// Image (sample) index.
        sample: usize,
        /// Pixel row.
        row: usize,
        /// Pixel column.
        col: usize,
    },
    /// A target value is NaN or infinite.
    #[error("non-finite target in sample {sample}, axis {axis}")]
    NonFiniteTarget {
        /// Sample index.
        sample: usize,
        /// Target column (force axis).
        axis: usize,
    },
    /// A stored weight is NaN or infinite.
    #[error("non-finite weight in `{tensor}` at flat index {index}")]
    NonFiniteWeight {
        /// Tensor name.
        tensor: String,
        /// Index in the row-major data.
        index: usize,
    },
    /// Not enough images for a training and a validation part.
    #[error("too few samples: {got}, need at least {need}")]
    TooFewSamples {
        /// Images given.
        got: usize,
        /// Images needed.
        need: usize,
    },
    /// candle refused an operation (a bug here rather than bad input: the
    /// shapes are checked before candle sees them).
    #[error("candle: {0}")]
    Candle(String),
}

/// candle failing is a failure; options, images or weights the CNN cannot
/// take are refused input.
impl Classify for CnnError {
    fn class(&self) -> ExitClass {
        match self {
            CnnError::Candle(_) => ExitClass::Failure,
            _ => ExitClass::Refused,
        }
    }
}

impl From<candle_core::Error> for CnnError {
    fn from(e: candle_core::Error) -> Self {
        CnnError::Candle(e.to_string())
    }
}

impl CnnError {
    /// [`CnnError::Shape`] from displayable parts.
    pub(super) fn shape(
        what: impl Into<String>,
        expected: impl std::fmt::Display,
        got: impl std::fmt::Display,
    ) -> Self {
        CnnError::Shape {
            what: what.into(),
            expected: expected.to_string(),
            got: got.to_string(),
        }
    }
}

/// Hyper-parameters of the CNN and its training, as read from a config.
///
/// | Name | Default | Purpose | Range |
/// |---|---|---|---|
/// | `channels` | [8, 16, 32] | output channels of the three 3×3 conv blocks | each ≥ 1 |
/// | `hidden` | 64 | ReLU units of the fully connected layer | ≥ 1 |
/// | `dropout` | 0.2 | drop probability of the hidden units (training only) | [0, 1) |
/// | `learning_rate` | 1e-3 | AdamW step size `α` | (0, 1] |
/// | `weight_decay` | 1e-4 | AdamW's decoupled decay `λ` of the weights (not the biases) | finite, ≥ 0 |
/// | `batch_size` | 64 | images per AdamW step | ≥ 1 |
/// | `max_epochs` | 40 | upper bound on passes over the training images | ≥ 1 |
/// | `patience` | 5 | epochs without validation improvement before stopping | ≥ 1 |
/// | `validation_fraction` | 0.15 | share of images held out for early stopping | (0, 1) |
/// | `seed` | 0 | seeds the split, initial weights, batch order and dropout | any |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CnnParams {
    /// Conv widths. Default [8, 16, 32]; each ≥ 1.
    pub channels: [usize; 3],
    /// Hidden units. Default 64; ≥ 1.
    pub hidden: usize,
    /// Dropout probability of the hidden units. Default 0.2; in [0, 1).
    pub dropout: f64,
    /// AdamW step size `α`. Default 1e-3; in (0, 1].
    pub learning_rate: f64,
    /// AdamW weight decay `λ`. Default 1e-4; finite, ≥ 0.
    pub weight_decay: f64,
    /// Images per mini-batch. Default 64; ≥ 1 (capped at the training images).
    pub batch_size: usize,
    /// Maximum epochs. Default 40; ≥ 1.
    pub max_epochs: usize,
    /// Epochs without validation improvement before stopping. Default 5; ≥ 1.
    pub patience: usize,
    /// Share of the images held out for validation. Default 0.15; in (0, 1).
    pub validation_fraction: f64,
    /// Random seed. Default 0; any value.
    pub seed: u64,
}

impl Default for CnnParams {
    fn default() -> Self {
        CnnParams {
            channels: [8, 16, 32],
            hidden: 64,
            dropout: 0.2,
            learning_rate: 1e-3,
            weight_decay: 1e-4,
            batch_size: 64,
            max_epochs: 40,
            patience: 5,
            validation_fraction: 0.15,
            seed: 0,
        }
    }
}

/// Every field in its range (the table on [`CnnParams`]); `key` names the
/// fields in errors (`cnn.dropout`).
impl Check for CnnParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        let p = &self;
        let c = p.channels;
        let each = c.iter().all(|&c| c >= 1);
        require(key, "channels", format!("{c:?}"), each, "each >= 1")?;
        require(key, "hidden", p.hidden, p.hidden >= 1, ">= 1")?;
        let d = p.dropout;
        require(key, "dropout", d, (0.0..1.0).contains(&d), "in [0, 1)")?;
        let wd = p.weight_decay;
        let ok = wd.is_finite() && wd >= 0.0;
        require(key, "weight_decay", wd, ok, "finite, >= 0")?;
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::assert_each_refused;

    #[test]
    fn defaults_are_valid() {
        let p = CnnParams::default();
        assert_eq!((p.channels, p.hidden, p.batch_size), ([8, 16, 32], 64, 64));
        assert_eq!(p.clone().checked("cnn").map(|v| (*v).clone()).ok(), Some(p));
    }

    #[test]
    fn invalid_parameters_are_refused_by_name() {
        type Edit = fn(&mut CnnParams);
        // The schedule's own checks are the network's (nn::params); one
        // shows that the CNN's schedule is checked.
        let cases: [(&str, Edit); 8] = [
            ("channels", |p| p.channels = [8, 0, 32]),
            ("hidden", |p| p.hidden = 0),
            ("dropout", |p| p.dropout = 1.0),
            ("dropout", |p| p.dropout = -0.1),
            ("dropout", |p| p.dropout = f64::NAN),
            ("learning_rate", |p| p.learning_rate = f64::INFINITY),
            ("weight_decay", |p| p.weight_decay = -1e-3),
            ("validation_fraction", |p| p.validation_fraction = 0.0),
        ];
        assert_each_refused("cnn", &cases);
        let p = CnnParams {
            channels: [0, 16, 32],
            ..CnnParams::default()
        };
        assert_eq!(
            p.checked("cnn").expect_err("zero channels").to_string(),
            "parameter cnn.channels = [0, 16, 32]: expected each >= 1"
        );
    }

    #[test]
    fn params_read_from_json_with_defaults_and_refuse_unknown_fields() {
        let p: CnnParams = serde_json::from_str(r#"{"hidden": 32, "seed": 4}"#).expect("parses");
        assert_eq!((p.hidden, p.seed, p.patience), (32, 4, 5));
        let err = serde_json::from_str::<CnnParams>(r#"{"hiden": 32}"#).expect_err("typo");
        assert!(err.to_string().contains("unknown field `hiden`"), "{err}");
    }
}
