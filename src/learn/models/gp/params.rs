//! Options of GP training ([`GpParams`], checked as every parameter is:
//! [`Check`] into [`crate::params::Checked`]), and how an exact GP picks its
//! rows ([`Subset`]).

use serde::{Deserialize, Serialize};

use super::kernel::KernelKind;
use super::mean::MeanKind;
use crate::params::{require, Check, Checked, ParamsError};

/// The exact GP's largest training set by default: its fit grows as n^3,
/// and 2000 rows fit in seconds (docs/results.md).
pub const DEFAULT_MAX_TRAIN: usize = 2000;

/// Options of GP training.
///
/// | Name | Default | Purpose | Range |
/// |---|---|---|---|
/// | kernel | iso | length-scale structure | iso, ard |
/// | mean | zero | prior mean, fitted on every row | zero, linear, cubic |
/// | shared | false | one set of hyperparameters for every axis (exact GP) | true, false |
/// | restarts | 3 | optimiser starts | >= 1 |
/// | restart_subset | 500 | points used to optimise each start | >= 10 |
/// | max_iters | 100 | L-BFGS iterations of each start on the subset | >= 1 |
/// | polish_iters | 0 | L-BFGS iterations of the best start on all points | >= 0 |
/// | min_noise_var | 1e-6 | lower bound of the noise variance (standardised) | (0, 1) |
/// | min_signal_var | 1e-4 | lower bound of the signal variance (standardised) | (0, 1e4) |
/// | seed | 0 | starts and subsets | any |
/// | max_train | 2000 | exact GP: rows it is conditioned on | >= 1 |
/// | subset | random | exact GP: how those rows are chosen when n > max_train | random, farthest |
/// | inducing | none | none: exact GP; m: sparse VFE GP with m inducing points | >= 1 |
/// | sparse_candidates | 20000 | sparse: random rows the inducing points are chosen from | >= inducing |
/// | sparse_fit_subset | 20000 | sparse: random rows the VFE bound is optimised on | >= 10 |
/// | sparse_iters | 50 | sparse: L-BFGS iterations on the VFE bound | >= 1 |
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GpParams {
    /// Isotropic or ARD squared-exponential kernel.
    pub kernel: KernelKind,
    /// Prior mean: zero, a least-squares line on every training row, or that
    /// line with the products and cubes of the axes' lines (cubic).
    pub mean: MeanKind,
    /// Exact GP: the axes share one set of hyperparameters, fitted on the
    /// sum of their likelihoods ([`fit_gp_shared`](super::fit_gp_shared):
    /// one factorisation per evaluation for every axis, the model of
    /// scikit-learn's GP given several outputs); a sparse GP fits each axis.
    pub shared: bool,
    /// Number of optimiser starts.
    pub restarts: usize,
    /// Size of the random subset each start is optimised on.
    pub restart_subset: usize,
    /// Iteration limit of each start on the subset.
    pub max_iters: u64,
    /// Iteration limit of the polish of the best start on all points (0: none).
    pub polish_iters: u64,
    /// Lower bound of the noise variance, in standardised target units.
    pub min_noise_var: f64,
    /// Lower bound of the signal variance, in standardised target units
    /// (the network mean's GPs: [`super::MeanKind::Network`]).
    pub min_signal_var: f64,
    /// Seed of the starts and of the random subsets.
    pub seed: u64,
    /// Exact GP: most rows it is conditioned on (the cost is O(n^3) to fit,
    /// O(n) per mean; its variance is conditioned on at most 1000 of them).
    pub max_train: usize,
    /// Exact GP: how the `max_train` rows are chosen from more.
    pub subset: Subset,
    /// `None`: exact GP; `Some(m)`: sparse VFE GP with m inducing points
    /// ([`fit_sparse`](super::fit_sparse)).
    pub inducing: Option<usize>,
    /// Sparse: the inducing points are chosen among this many random rows,
    /// which bounds the O(n m) memory of [`greedy_variance`](super::greedy_variance).
    pub sparse_candidates: usize,
    /// Sparse: the VFE bound is optimised on this many random rows (q(u) is
    /// then conditioned on all rows).
    ///
    /// Measured on 2 cores (`collect --seed 1`, 72000 training rows, d = 19):
    /// one bound-and-gradient evaluation at n = 64000 takes 66 ms (m = 25),
    /// 0.41 s (m = 200), 1.0 s (m = 400); 0.11 s at n = 20000, m = 200. One
    /// axis at m = 200 fits in 6 s (iso) / 10 s (ARD) on 20000 rows against
    /// 22 s / 28 s on all rows, with the same held-out RMSE (0.038 / 0.040 N
    /// against 0.038 / 0.044 N); three ARD axes in parallel take 29 s.
    pub sparse_fit_subset: usize,
    /// Sparse: L-BFGS iteration limit on the VFE bound.
    pub sparse_iters: u64,
}

/// How an exact GP picks the rows it is conditioned on from a larger set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Subset {
    /// Uniformly at random (seeded by `seed`).
    #[default]
    Random,
    /// Greedy farthest-point (k-center) selection in length-scale-scaled
    /// space ([`farthest_point`](super::farthest_point)): covers the input space evenly.
    #[serde(rename = "farthest")]
    FarthestPoint,
}

impl Subset {
    /// The name in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Subset::Random => "random",
            Subset::FarthestPoint => "farthest",
        }
    }
}

impl std::str::FromStr for Subset {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        [Subset::Random, Subset::FarthestPoint]
            .into_iter()
            .find(|r| r.name() == s)
            .ok_or_else(|| format!("unknown subset rule {s:?}: expected random or farthest"))
    }
}

impl Default for GpParams {
    fn default() -> Self {
        GpParams {
            kernel: KernelKind::Isotropic,
            mean: MeanKind::Zero,
            shared: false,
            restarts: 3,
            restart_subset: 500,
            max_iters: 100,
            polish_iters: 0,
            min_noise_var: 1e-6,
            min_signal_var: 1e-4,
            seed: 0,
            max_train: DEFAULT_MAX_TRAIN,
            subset: Subset::Random,
            inducing: None,
            sparse_candidates: 20_000,
            sparse_fit_subset: 20_000,
            sparse_iters: 50,
        }
    }
}

impl GpParams {
    /// The options checked under the key `gp` ([`Check::checked`]).
    pub fn validate(self) -> Result<Checked<GpParams>, ParamsError> {
        self.checked("gp")
    }
}

/// Every option in its range (the table on [`GpParams`]); `key` names the
/// options in errors (`gp.restarts`).
impl Check for GpParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        let p = &self;
        require(key, "restarts", p.restarts, p.restarts >= 1, "at least 1")?;
        let n = p.restart_subset;
        require(key, "restart_subset", n, n >= 10, "at least 10")?;
        require(
            key,
            "max_iters",
            p.max_iters,
            p.max_iters >= 1,
            "at least 1",
        )?;
        let v = p.min_noise_var;
        require(key, "min_noise_var", v, v > 0.0 && v < 1.0, "in (0, 1)")?;
        let v = p.min_signal_var;
        require(key, "min_signal_var", v, v > 0.0 && v < 1e4, "in (0, 1e4)")?;
        require(
            key,
            "max_train",
            p.max_train,
            p.max_train >= 1,
            "at least 1",
        )?;
        if let Some(m) = p.inducing {
            let expected = "at least 1 (or none for an exact GP)";
            require(key, "inducing", m, m >= 1, expected)?;
            let c = p.sparse_candidates;
            let expected = "at least the number of inducing points";
            require(key, "sparse_candidates", c, c >= m, expected)?;
        }
        let n = p.sparse_fit_subset;
        require(key, "sparse_fit_subset", n, n >= 10, "at least 10")?;
        let n = p.sparse_iters;
        require(key, "sparse_iters", n, n >= 1, "at least 1")?;
        Ok(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_options_are_rejected_by_name() {
        type Edit = fn(&mut GpParams);
        let cases: [(&str, Edit); 6] = [
            ("inducing", |p| p.inducing = Some(0)),
            ("sparse_candidates", |p| {
                p.inducing = Some(500);
                p.sparse_candidates = 100;
            }),
            ("max_train", |p| p.max_train = 0),
            ("restarts", |p| p.restarts = 0),
            ("min_noise_var", |p| p.min_noise_var = f64::NAN),
            ("min_signal_var", |p| p.min_signal_var = 0.0),
        ];
        for (name, edit) in cases {
            let mut p = GpParams::default();
            edit(&mut p);
            match p.checked("gp") {
                Err(ParamsError::Invalid { key, .. }) => assert_eq!(key, format!("gp.{name}")),
                other => panic!("{name}: {other:?}"),
            }
        }
        assert!(GpParams::default().checked("gp").is_ok());
    }
}
