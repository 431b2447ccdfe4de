//! Hyperparameter fitting: maximise the log marginal likelihood with L-BFGS
//! (argmin, More-Thuente line search) in log space, from several starts.
//!
//! Multi-start scheme: every start is optimised on a random subset of at most
//! `restart_subset` points (cheap: the cost is cubic in n); the best of them
//! can then be polished on the full training set (`polish_iters`), and the GP
//! is conditioned on all points. Starts after the first are drawn
//! log-uniformly around the first, which is s2 = 1, l = sqrt(d), sn2 = 0.01 on
//! standardised data.
//!
//! The exact GP is then conditioned on at most `max_train` rows (random or
//! farthest-point, see [`Subset`]). A sparse fit ([`fit_sparse`]) starts from
//! the same multistart, then optimises the VFE bound of Titsias (2009).
//!
//! Why no polish by default: on `collect --seed 1` (n = 2000, held-out
//! trials) 15 polish iterations made the fit 12x slower (1.7 s -> 19.9 s for
//! three axes) and did not lower the test RMSE (docs/results.md, "Training choices").

use std::borrow::Cow;
use std::cell::{Cell, RefCell};

use argmin::core::{CostFunction, Executor, Gradient, State};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::quasinewton::LBFGS;
use rand::seq::index::sample;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::exact::{check_targets, neg_lml_and_grad_shared, rows_of, ExactGp};
use super::kernel::{KernelKind, SeHyper};
use super::params::{GpParams, Subset};
use super::select::{farthest_point, greedy_variance};
use super::sparse::{neg_vfe_and_grad, SparseGp};
use super::GpError;
use crate::params::Checked;

/// What a fit did.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitInfo {
    /// Likelihood-and-gradient evaluations, all starts together.
    pub evaluations: usize,
    /// Of which in the final stage: the polish on all points (exact GP) or
    /// the VFE optimisation (sparse GP).
    pub full_evaluations: usize,
    /// Final negative log marginal likelihood per sample, on the points it was
    /// optimised on (the subset, or all points after a polish); for a sparse
    /// GP the negative VFE bound per sample on `sparse_fit_subset` rows.
    pub neg_lml_per_sample: f64,
}

/// Progress of a fit, reported after every likelihood evaluation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitProgress {
    /// Evaluations so far.
    pub evaluations: usize,
    /// Start being optimised (0-based); `restarts` means the final stage
    /// (polish, or the VFE optimisation of a sparse fit).
    pub start: usize,
    /// Negative log marginal likelihood per sample at the last evaluation.
    pub neg_lml_per_sample: f64,
}

/// Where a fit's hyperparameter search starts.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum Start {
    /// `restarts` starts, the first at s2 = 1, l = sqrt(d), sn2 = 0.01, the
    /// others drawn around it.
    #[default]
    Multistart,
    /// One start at these hyperparameters: a warm start from a fit on
    /// similar data (another fold of a cross-validation, or another size of
    /// the same GP), which converges in a few evaluations.
    Warm(SeHyper),
}

/// Bounds of the log-parameters in standardised units.
struct Bounds {
    lo: Vec<f64>,
    hi: Vec<f64>,
}

impl Bounds {
    fn new(kind: KernelKind, d: usize, min_noise_var: f64, min_signal_var: f64) -> Self {
        let n = SeHyper::n_params(kind, d);
        let mut lo = vec![1e-3f64.ln(); n];
        let mut hi = vec![1e4f64.ln(); n];
        lo[0] = min_signal_var.ln();
        lo[n - 1] = min_noise_var.ln();
        hi[n - 1] = 10f64.ln();
        Bounds { lo, hi }
    }

    fn clamp(&self, theta: &[f64]) -> Vec<f64> {
        theta
            .iter()
            .zip(self.lo.iter().zip(&self.hi))
            .map(|(t, (lo, hi))| t.clamp(*lo, *hi))
            .collect()
    }
}

/// A negative objective per sample and its gradient with respect to the
/// log-hyperparameters (the exact likelihood or the VFE bound).
type NegObjective<'a> = dyn Fn(&SeHyper) -> Result<(f64, Vec<f64>), GpError> + 'a;

/// Counts objective evaluations and reports each one.
struct Tracker<'p> {
    evaluations: Cell<usize>,
    /// Start being optimised; `restarts` for the final stage.
    start: Cell<usize>,
    progress: RefCell<&'p mut dyn FnMut(FitProgress)>,
}

impl<'p> Tracker<'p> {
    fn new(progress: &'p mut dyn FnMut(FitProgress)) -> Self {
        Tracker {
            evaluations: Cell::new(0),
            start: Cell::new(0),
            progress: RefCell::new(progress),
        }
    }

    fn report(&self, f: f64) {
        self.evaluations.set(self.evaluations.get() + 1);
        (self.progress.borrow_mut())(FitProgress {
            evaluations: self.evaluations.get(),
            start: self.start.get(),
            neg_lml_per_sample: f,
        });
    }
}

/// The objective as argmin sees it: `neg` at the clamped parameters, plus
/// 1/2 |theta - clamp(theta)|^2, so that the optimiser is pulled back inside
/// the bounds smoothly.
struct Objective<'a, 't> {
    neg: &'a NegObjective<'a>,
    d: usize,
    kind: KernelKind,
    bounds: &'a Bounds,
    /// Last evaluation: argmin asks for the cost and the gradient separately.
    cache: RefCell<Option<Evaluation>>,
    tracker: &'a Tracker<'t>,
}

/// Log-parameters with the cost and gradient there.
struct Evaluation {
    theta: Vec<f64>,
    cost: f64,
    grad: Vec<f64>,
}

impl Objective<'_, '_> {
    fn eval(&self, theta: &[f64]) -> Result<(f64, Vec<f64>), argmin::core::Error> {
        if let Some(e) = self.cache.borrow().as_ref() {
            if e.theta == theta {
                return Ok((e.cost, e.grad.clone()));
            }
        }
        let tc = self.bounds.clamp(theta);
        let hyper = SeHyper::from_log(self.kind, self.d, &tc);
        let (mut f, mut g) = (self.neg)(&hyper)?;
        for ((gi, t), c) in g.iter_mut().zip(theta).zip(&tc) {
            f += 0.5 * (t - c) * (t - c);
            *gi += t - c;
        }
        self.tracker.report(f);
        *self.cache.borrow_mut() = Some(Evaluation {
            theta: theta.to_vec(),
            cost: f,
            grad: g.clone(),
        });
        Ok((f, g))
    }
}

impl CostFunction for Objective<'_, '_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, theta: &Self::Param) -> Result<f64, argmin::core::Error> {
        Ok(self.eval(theta)?.0)
    }
}

impl Gradient for Objective<'_, '_> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, theta: &Self::Param) -> Result<Vec<f64>, argmin::core::Error> {
        Ok(self.eval(theta)?.1)
    }
}

/// What a fit is given: standardised inputs `x` (row-major n x `d`) and
/// targets `y`, the options, and where the hyperparameter search starts.
#[derive(Debug, Clone, Copy)]
pub struct FitData<'a> {
    /// Inputs, row-major n x d.
    pub x: &'a [f64],
    /// Inputs per row.
    pub d: usize,
    /// Targets, n.
    pub y: &'a [f64],
    /// The options.
    pub params: &'a Checked<GpParams>,
    /// Where the search starts.
    pub start: &'a Start,
}

/// What every fit shares: options, bounds, the seeded generator and the
/// evaluation counter.
struct Fitter<'a> {
    p: &'a GpParams,
    d: usize,
    bounds: Bounds,
    rng: ChaCha8Rng,
    tracker: Tracker<'a>,
}

impl<'a> Fitter<'a> {
    /// The fitter of `data`, once its rows are checked.
    fn checked<'d>(
        data: &FitData<'d>,
        k: usize,
        progress: &'a mut dyn FnMut(FitProgress),
    ) -> Result<(Self, FitData<'d>), GpError>
    where
        'd: 'a,
    {
        check_targets(data.x, data.d, data.y, k)?;
        Ok((Fitter::new(data.params, data.d, progress), *data))
    }

    fn new(
        params: &'a Checked<GpParams>,
        d: usize,
        progress: &'a mut dyn FnMut(FitProgress),
    ) -> Self {
        let p: &GpParams = params;
        Fitter {
            p,
            d,
            bounds: Bounds::new(p.kernel, d, p.min_noise_var, p.min_signal_var),
            rng: ChaCha8Rng::seed_from_u64(p.seed),
            tracker: Tracker::new(progress),
        }
    }

    /// Runs L-BFGS on `neg` from `start`; returns the best clamped
    /// log-parameters and cost.
    fn minimise(
        &self,
        neg: &NegObjective<'_>,
        start: Vec<f64>,
        max_iters: u64,
    ) -> Result<(Vec<f64>, f64), GpError> {
        let obj = Objective {
            neg,
            d: self.d,
            kind: self.p.kernel,
            bounds: &self.bounds,
            cache: RefCell::new(None),
            tracker: &self.tracker,
        };
        let fail = |e: argmin::core::Error| GpError::Optimisation(e.to_string());
        let solver = LBFGS::new(MoreThuenteLineSearch::new(), 7)
            .with_tolerance_grad(1e-6)
            .map_err(fail)?
            .with_tolerance_cost(1e-9)
            .map_err(fail)?;
        let res = Executor::new(obj, solver)
            .configure(|s| s.param(start).max_iters(max_iters))
            .run()
            .map_err(fail)?;
        let state = res.state();
        let best = state
            .get_best_param()
            .ok_or_else(|| GpError::Optimisation("no parameter evaluated".into()))?;
        Ok((self.bounds.clamp(best), state.get_best_cost()))
    }

    /// Maximum-likelihood hyperparameters of the exact GP of the `k`
    /// outputs of `y` (row-major n x k, shared hyperparameters): every start
    /// optimised on one random subset of at most `restart_subset` rows.
    /// Returns the best clamped log-parameters and their cost.
    fn multistart(
        &mut self,
        x: &[f64],
        y: &[f64],
        k: usize,
        start: &Start,
    ) -> Result<(Vec<f64>, f64), GpError> {
        let (p, d) = (self.p, self.d);
        let warm = match start {
            Start::Warm(h) if h.kind == p.kernel && h.is_valid(d) => Some(h.to_log()),
            _ => None,
        };
        let first = SeHyper {
            kind: p.kernel,
            signal_var: p.min_signal_var.max(1.0),
            lengthscales: vec![(d as f64).sqrt(); d],
            noise_var: 0.01f64.max(p.min_noise_var),
        }
        .to_log();
        let restarts = if warm.is_some() { 1 } else { p.restarts };
        let starts: Vec<Vec<f64>> = (0..restarts)
            .map(|s| {
                if let Some(w) = &warm {
                    return w.clone();
                }
                if s == 0 {
                    first.clone()
                } else {
                    first
                        .iter()
                        .map(|t| t + self.rng.random_range(-1.5..1.5))
                        .collect()
                }
            })
            .collect();
        let (sub_x, sub_y) = self.random_rows(x, y, k, p.restart_subset);
        let exact = |h: &SeHyper| neg_lml_and_grad_shared(&sub_x, d, &sub_y, k, h);
        let mut best: Option<(Vec<f64>, f64)> = None;
        let mut last_error = None;
        for (s, start) in starts.into_iter().enumerate() {
            self.tracker.start.set(s);
            match self.minimise(&exact, start, p.max_iters) {
                Ok((theta, cost)) if best.as_ref().is_none_or(|b| cost < b.1) => {
                    best = Some((theta, cost))
                }
                Ok(_) => {}
                Err(e) => {
                    tracing::warn!(start = s, "hyperparameter start failed: {e}");
                    last_error = Some(e)
                }
            }
        }
        match (best, last_error) {
            (Some(b), _) => Ok(b),
            (None, Some(e)) => Err(e),
            (None, None) => Err(GpError::Optimisation("no start".into())),
        }
    }

    /// At most `count` rows of `x` and of `y` (`k` targets per row) drawn
    /// at random without replacement, or all rows when there are no more
    /// than `count`.
    fn random_rows<'x>(
        &mut self,
        x: &'x [f64],
        y: &'x [f64],
        k: usize,
        count: usize,
    ) -> (Cow<'x, [f64]>, Cow<'x, [f64]>) {
        let n = y.len() / k;
        if n <= count {
            return (Cow::Borrowed(x), Cow::Borrowed(y));
        }
        let idx = sample(&mut self.rng, n, count).into_vec();
        let (sx, sy) = gather(x, self.d, y, k, &idx);
        (Cow::Owned(sx), Cow::Owned(sy))
    }

    fn info(&self, final_from: usize, cost: f64) -> FitInfo {
        let evaluations = self.tracker.evaluations.get();
        FitInfo {
            evaluations,
            full_evaluations: evaluations - final_from,
            neg_lml_per_sample: cost,
        }
    }
}

/// Rows `idx` of `x` (row-major, `d` columns) and of `y` (row-major, `k` columns).
fn gather(x: &[f64], d: usize, y: &[f64], k: usize, idx: &[usize]) -> (Vec<f64>, Vec<f64>) {
    (rows_of(x, d, idx), rows_of(y, k, idx))
}

/// Fits SE-kernel hyperparameters by maximum marginal likelihood and
/// conditions an exact GP on `data`'s rows: on all of them, or when n > `max_train` on `max_train` rows
/// chosen by `subset` (random, or [`farthest_point`] with the fitted
/// length-scales). The search starts as `data.start` says. `progress` is called
/// after every likelihood evaluation.
pub fn fit_gp(
    data: &FitData<'_>,
    progress: &mut dyn FnMut(FitProgress),
) -> Result<(ExactGp, FitInfo), GpError> {
    let (mut gps, info) = fit_gp_shared(data, 1, progress)?;
    Ok((gps.remove(0), info))
}

/// [`fit_gp`] for `k` outputs that share one set of hyperparameters:
/// `data.y` is row-major n x k, the likelihood maximised is the sum of the
/// outputs' ([`neg_lml_and_grad_shared`]: one factorisation per evaluation
/// for all of them), and one GP per output is conditioned on the same rows.
pub fn fit_gp_shared(
    data: &FitData<'_>,
    k: usize,
    progress: &mut dyn FnMut(FitProgress),
) -> Result<(Vec<ExactGp>, FitInfo), GpError> {
    let (mut fit, FitData { x, d, y, start, .. }) = Fitter::checked(data, k, progress)?;
    let p = fit.p;
    let n = y.len() / k;
    let (mut theta, mut cost) = fit.multistart(x, y, k, start)?;
    let before_full = fit.tracker.evaluations.get();
    if n > p.restart_subset && p.polish_iters > 0 {
        fit.tracker.start.set(p.restarts);
        // Keep the subset optimum if the polish fails (e.g. a singular K on all points).
        let exact = |h: &SeHyper| neg_lml_and_grad_shared(x, d, y, k, h);
        match fit.minimise(&exact, theta.clone(), p.polish_iters) {
            Ok((t, c)) => (theta, cost) = (t, c),
            Err(e) => {
                tracing::warn!("polish on all points failed, keeping the subset optimum: {e}")
            }
        }
    }
    let hyper = SeHyper::from_log(p.kernel, d, &theta);
    let gps = match p.subset {
        _ if n <= p.max_train => ExactGp::fit_shared(x, d, y, k, hyper)?,
        Subset::Random => {
            let (sx, sy) = fit.random_rows(x, y, k, p.max_train);
            ExactGp::fit_shared(&sx, d, &sy, k, hyper)?
        }
        Subset::FarthestPoint => {
            let idx = farthest_point(x, d, &hyper.lengthscales, p.max_train);
            let (sx, sy) = gather(x, d, y, k, &idx);
            ExactGp::fit_shared(&sx, d, &sy, k, hyper)?
        }
    };
    Ok((gps, fit.info(before_full, cost)))
}

/// Fits a sparse VFE GP (Titsias 2009) with `inducing` = m inducing points
/// to `data`'s rows:
/// 1. start hyperparameters from the exact-GP multistart on `restart_subset`
///    rows (from `data.start`);
/// 2. inducing inputs by [`greedy_variance`] with them, among at most
///    `sparse_candidates` random rows;
/// 3. L-BFGS on the VFE bound ([`neg_vfe_and_grad`]) over the
///    hyperparameters, Z fixed, on at most `sparse_fit_subset` random rows
///    for `sparse_iters` iterations (start kept if that fails);
/// 4. q(u) conditioned on all rows ([`SparseGp::fit`]).
///
/// [`FitInfo::full_evaluations`] counts the VFE evaluations and
/// [`FitInfo::neg_lml_per_sample`] is the final negative bound per sample.
pub fn fit_sparse(
    data: &FitData<'_>,
    progress: &mut dyn FnMut(FitProgress),
) -> Result<(SparseGp, FitInfo), GpError> {
    let (mut fit, FitData { x, d, y, start, .. }) = Fitter::checked(data, 1, progress)?;
    let p = fit.p;
    let m = p.inducing.ok_or(GpError::InvalidParam {
        name: "inducing",
        value: "none".into(),
        expected: "a number of inducing points for a sparse fit",
    })?;
    let (theta0, _) = fit.multistart(x, y, 1, start)?;
    let hyper0 = SeHyper::from_log(p.kernel, d, &theta0);

    let n = y.len();
    let candidates: Vec<usize> = if n > p.sparse_candidates {
        let mut idx = sample(&mut fit.rng, n, p.sparse_candidates).into_vec();
        idx.sort_unstable();
        idx
    } else {
        (0..n).collect()
    };
    let (cand_x, _) = gather(x, d, y, 1, &candidates);
    let chosen: Vec<usize> = greedy_variance(&cand_x, d, &hyper0, m)
        .into_iter()
        .map(|i| candidates[i])
        .collect();
    let (z, _) = gather(x, d, y, 1, &chosen);

    let (fx, fy) = fit.random_rows(x, y, 1, p.sparse_fit_subset);
    let vfe = |h: &SeHyper| neg_vfe_and_grad(&fx, d, &fy, &z, h);
    let before_vfe = fit.tracker.evaluations.get();
    fit.tracker.start.set(p.restarts);
    let (theta, cost) = match fit.minimise(&vfe, theta0.clone(), p.sparse_iters) {
        Ok(best) => best,
        Err(e) => {
            tracing::warn!("VFE optimisation failed, keeping the exact-GP start: {e}");
            let cost = vfe(&hyper0)?.0;
            (theta0, cost)
        }
    };
    let gp = SparseGp::fit(x, d, y, &z, SeHyper::from_log(p.kernel, d, &theta))?;
    Ok((gp, fit.info(before_vfe, cost)))
}

#[cfg(test)]
mod tests;
