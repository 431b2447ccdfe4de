//! Gaussian-process regression: SE kernels, the exact GP with its log marginal
//! likelihood and gradient, the sparse variational GP (Titsias 2009) with its
//! bound and gradient, training-row and inducing-point selection, and
//! hyperparameter fitting.
//!
//! Every function here works on standardised data (see
//! [`crate::learn::models::scale`]); one GP models one output axis, with its own
//! hyperparameters, as in Huhnstock (2014) and Urban et al. (2013).

pub mod exact;
pub mod fit;
pub mod kernel;
pub mod mean;
pub mod params;
pub mod select;
pub mod sparse;

use serde::{Deserialize, Serialize};

use crate::params::Checked;

use crate::exit::{Classify, ExitClass};

pub use exact::{neg_lml_and_grad_shared, ExactGp, ExactGpData, GpWorkspace};
pub use fit::{fit_gp, fit_gp_shared, fit_sparse, FitData, FitInfo, FitProgress, Start};
pub use kernel::{KernelKind, SeHyper};
pub use mean::{LinearMean, MeanKind};
pub use params::{GpParams, Subset, DEFAULT_MAX_TRAIN};
pub use select::{farthest_point, greedy_variance};
pub use sparse::{SparseGp, SparseGpData};

/// A fitted GP for one output: exact, or sparse (VFE) with inducing points.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(into = "GpData", try_from = "GpData")]
pub enum Gp {
    /// Exact GP on (a subset of) the training rows.
    Exact(ExactGp),
    /// Sparse variational GP (Titsias 2009).
    Sparse(SparseGp),
}

/// What a [`Gp`] stores in a model file, tagged `exact` or `sparse`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum GpData {
    /// An [`ExactGp`]'s data.
    Exact(ExactGpData),
    /// A [`SparseGp`]'s data.
    Sparse(SparseGpData),
}

impl From<Gp> for GpData {
    fn from(gp: Gp) -> Self {
        match gp {
            Gp::Exact(g) => GpData::Exact(g.into()),
            Gp::Sparse(g) => GpData::Sparse(g.into()),
        }
    }
}

impl GpData {
    /// Input dimension.
    pub fn dim(&self) -> usize {
        match self {
            GpData::Exact(d) => d.dim,
            GpData::Sparse(d) => d.dim,
        }
    }
}

impl TryFrom<GpData> for Gp {
    type Error = GpError;
    fn try_from(data: GpData) -> Result<Self, Self::Error> {
        Ok(match data {
            GpData::Exact(d) => Gp::Exact(d.try_into()?),
            GpData::Sparse(d) => Gp::Sparse(d.try_into()?),
        })
    }
}

impl Gp {
    /// Fits an exact GP ([`fit_gp`]) when `params.inducing` is `None`, else a
    /// sparse one ([`fit_sparse`]), from the default [`Start`].
    pub fn fit(
        x: &[f64],
        d: usize,
        y: &[f64],
        params: &Checked<GpParams>,
        progress: &mut dyn FnMut(FitProgress),
    ) -> Result<(Gp, FitInfo), GpError> {
        let start = Start::Multistart;
        Self::fit_from(
            &FitData {
                x,
                d,
                y,
                params,
                start: &start,
            },
            progress,
        )
    }

    /// [`Gp::fit`] of `data`, its hyperparameter search started as
    /// `data.start` says.
    pub fn fit_from(
        data: &FitData<'_>,
        progress: &mut dyn FnMut(FitProgress),
    ) -> Result<(Gp, FitInfo), GpError> {
        Ok(match data.params.inducing {
            None => {
                let (gp, info) = fit_gp(data, progress)?;
                (Gp::Exact(gp), info)
            }
            Some(_) => {
                let (gp, info) = fit_sparse(data, progress)?;
                (Gp::Sparse(gp), info)
            }
        })
    }

    /// Input dimension.
    pub fn dim(&self) -> usize {
        match self {
            Gp::Exact(g) => g.dim(),
            Gp::Sparse(g) => g.dim(),
        }
    }

    /// Hyperparameters.
    pub fn hyper(&self) -> &SeHyper {
        match self {
            Gp::Exact(g) => g.hyper(),
            Gp::Sparse(g) => g.hyper(),
        }
    }

    /// Points a prediction sums over: training rows (exact) or inducing points (sparse).
    pub fn size(&self) -> usize {
        match self {
            Gp::Exact(g) => g.n_train(),
            Gp::Sparse(g) => g.n_inducing(),
        }
    }

    /// What the GP is, for messages: `exact GP on 2000 rows`, `sparse GP,
    /// 200 inducing points`.
    pub fn describe(&self) -> String {
        match self {
            Gp::Exact(g) => format!("exact GP on {} rows", g.n_train()),
            Gp::Sparse(g) => format!("sparse GP, {} inducing points", g.n_inducing()),
        }
    }

    /// Scratch for [`Gp::predict_one`] with this GP.
    pub fn workspace(&self) -> GpWorkspace {
        GpWorkspace::new(self.size(), self.dim())
    }

    /// Mean and latent variance at one standardised input, without
    /// allocating; `ws` must have room for [`Gp::size`] points.
    pub fn predict_one(&self, z: &[f64], ws: &mut GpWorkspace, with_var: bool) -> (f64, f64) {
        match self {
            Gp::Exact(g) => g.predict_one(z, ws, with_var),
            Gp::Sparse(g) => g.predict_one(z, ws, with_var),
        }
    }

    /// Means and latent variances at many standardised inputs (row-major).
    pub fn predict(&self, z: &[f64], with_var: bool) -> (Vec<f64>, Vec<f64>) {
        match self {
            Gp::Exact(g) => g.predict(z, with_var),
            Gp::Sparse(g) => g.predict(z, with_var),
        }
    }

    /// [`Gp::predict`] of several GPs: exact GPs that share a kernel
    /// ([`ExactGp::shares_kernel`], as fitted with shared hyperparameters)
    /// share one cross-covariance ([`ExactGp::predict_shared`]).
    pub fn predict_all(gps: &[&Gp], z: &[f64], with_var: bool) -> Vec<(Vec<f64>, Vec<f64>)> {
        let exact: Option<Vec<&ExactGp>> = gps
            .iter()
            .map(|g| match g {
                Gp::Exact(e) => Some(e),
                Gp::Sparse(_) => None,
            })
            .collect();
        match exact {
            Some(e) if e.len() > 1 && e.iter().all(|g| e[0].shares_kernel(g)) => {
                ExactGp::predict_shared(&e, z, with_var)
            }
            _ => gps.iter().map(|g| g.predict(z, with_var)).collect(),
        }
    }
}

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
    #[error(
        "invalid hyperparameters for {dim} inputs: signal variance {}, noise variance {}, \
         lengthscales {:?} (each finite and positive, one per input)",
        hyper.signal_var, hyper.noise_var, hyper.lengthscales
    )]
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
    #[error(
        "{values} input values for {targets} targets of {dim} inputs each (expected {})",
        targets * dim
    )]
    ShapeMismatch {
        /// Number of input values.
        values: usize,
        /// Inputs per row.
        dim: usize,
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
    /// Stored sparse-GP data of the wrong shape or with invalid values.
    #[error("invalid sparse GP data: {0}")]
    InvalidSparse(String),
    /// The optimiser failed on every start.
    #[error("hyperparameter optimisation failed on every start: {0}")]
    Optimisation(String),
}

/// A fit that failed numerically is a failure; data, options or stored values
/// that are refused are refused input.
impl Classify for GpError {
    fn class(&self) -> ExitClass {
        match self {
            GpError::NotPositiveDefinite { .. } | GpError::Optimisation(_) => ExitClass::Failure,
            _ => ExitClass::Refused,
        }
    }
}
