//! Gaussian-process regression: SE kernels, the exact GP with its log marginal
//! likelihood and gradient, and hyperparameter fitting.
//!
//! Every function here works on standardised data (see
//! [`crate::learn::scale`]); one GP models one output axis, with its own
//! hyperparameters, as in Huhnstock (2014) and Urban et al. (2013).

pub mod exact;
pub mod fit;
pub mod kernel;

pub use exact::{ExactGp, GpWorkspace};
pub use fit::{fit_gp, FitInfo, GpParams, ValidGpParams};
pub use kernel::{KernelKind, SeHyper};

/// Errors of GP training and prediction.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpError {
    /// The kernel matrix could not be factorised even with the largest jitter.
    #[error(
        "kernel matrix is not positive definite (n = {n}) even with jitter {jitter:e} added \
         to the diagonal (signal variance {signal_var:e}, noise variance {noise_var:e}): \
         the inputs are probably duplicated or degenerate with almost no noise, or the \
         hyperparameters are extreme"
    )]
    NotPositiveDefinite {
        /// Training set size.
        n: usize,
        /// Largest jitter tried.
        jitter: f64,
        /// Signal variance in use.
        signal_var: f64,
        /// Noise variance in use.
        noise_var: f64,
    },
    /// A training input or target is NaN or infinite.
    #[error("training data has a non-finite value at row {row}, column {column}")]
    NonFinite {
        /// Row (sample) index.
        row: usize,
        /// Column index: features first, then targets.
        column: usize,
    },
    /// Hyperparameters that are not finite and positive, or of the wrong length.
    #[error("invalid hyperparameters for {dim} inputs: {hyper:?}")]
    InvalidHyper {
        /// Input dimension.
        dim: usize,
        /// The offending values.
        hyper: SeHyper,
    },
    /// No training data.
    #[error("no training samples")]
    Empty,
    /// Inputs and targets of different lengths.
    #[error("{inputs} input rows but {targets} targets")]
    ShapeMismatch {
        /// Number of input rows.
        inputs: usize,
        /// Number of targets.
        targets: usize,
    },
    /// Invalid fitting option.
    #[error("invalid GP option {name} = {value}: {expected}")]
    InvalidParam {
        /// Option name.
        name: &'static str,
        /// Given value.
        value: String,
        /// What is accepted.
        expected: &'static str,
    },
    /// The optimiser failed on every start.
    #[error("hyperparameter optimisation failed on every start: {0}")]
    Optimisation(String),
}
