//! Exact GP regression on standardised data: fit with given hyperparameters,
//! log marginal likelihood with its gradient, and prediction.
//!
//! With K = K_f + sn2 I = L L^T and alpha = K^-1 y (Rasmussen & Williams 2006,
//! Alg. 2.1):
//! - mean(x*) = k*^T alpha, var_f(x*) = s2 - |L^-1 k*|^2 (clamped at 0), with
//!   K and k* of the rows near x* when n > [`VARIANCE_ROWS`] (`variance.rs`);
//! - ln p(y) = -1/2 y^T alpha - sum_i ln L_ii - n/2 ln(2 pi);
//! - d ln p(y) / d theta = 1/2 tr((alpha alpha^T - K^-1) dK/dtheta) (Eq. 5.9).

use std::sync::Arc;

use faer::linalg::solvers::DenseSolveCore;
use faer::{Mat, MatRef, Par, Side};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::kernel::{scale_cols, scale_rows, se_against, se_cross_into, se_gram, SeHyper};
use super::GpError;
use variance::LocalVariance;
pub use variance::VARIANCE_ROWS;

mod variance;

/// First jitter tried, relative to the mean diagonal of K.
const JITTER_START: f64 = 1e-10;
/// Largest jitter tried, relative to the mean diagonal of K.
const JITTER_MAX: f64 = 1e-4;

/// Cholesky factor of `K_f + (diag + jitter) I`, escalating the jitter
/// tenfold from zero, then `JITTER_START`, up to `JITTER_MAX` times
/// `s2 + diag` (the mean diagonal). `diag` is the noise variance for the
/// exact GP, a fixed small jitter for the inducing-point covariance K_uu.
/// Returns the factor and the escalated jitter that was needed.
pub(super) fn cholesky_with_jitter(
    kf: &Mat<f64>,
    diag: f64,
    hyper: &SeHyper,
) -> Result<(faer::linalg::solvers::Llt<f64>, f64), GpError> {
    let n = kf.nrows();
    let scale = hyper.signal_var + diag;
    let mut k = kf.clone();
    let mut jitter = 0.0;
    loop {
        for i in 0..n {
            k[(i, i)] = kf[(i, i)] + diag + jitter;
        }
        if let Ok(llt) = k.llt(Side::Lower) {
            return Ok((llt, jitter));
        }
        jitter = if jitter == 0.0 {
            JITTER_START * scale
        } else {
            jitter * 10.0
        };
        if !jitter.is_finite() || jitter > JITTER_MAX * scale * 1.0001 {
            return Err(GpError::NotPositiveDefinite {
                n,
                jitter: jitter / 10.0,
                signal_var: hyper.signal_var,
                noise_var: hyper.noise_var,
            });
        }
    }
}

/// Checks shapes and finiteness of row-major inputs `x` (n x d) and targets `y`.
pub(crate) fn check_data(x: &[f64], d: usize, y: &[f64]) -> Result<(), GpError> {
    check_targets(x, d, y, 1)
}

/// [`check_data`] for `k` targets per row (`y` row-major n x k).
pub(crate) fn check_targets(x: &[f64], d: usize, y: &[f64], k: usize) -> Result<(), GpError> {
    if y.is_empty() {
        return Err(GpError::Empty);
    }
    if x.len() * k != y.len() * d || !y.len().is_multiple_of(k) {
        return Err(GpError::ShapeMismatch {
            values: x.len(),
            dim: d,
            targets: y.len() / k,
        });
    }
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        return Err(GpError::NonFinite {
            row: i / d,
            column: i % d,
        });
    }
    if let Some(i) = y.iter().position(|v| !v.is_finite()) {
        return Err(GpError::NonFinite {
            row: i / k,
            column: d + i % k,
        });
    }
    Ok(())
}

pub(super) fn check_hyper(hyper: &SeHyper, d: usize) -> Result<(), GpError> {
    if hyper.is_valid(d) {
        Ok(())
    } else {
        Err(GpError::InvalidHyper {
            dim: d,
            hyper: hyper.clone(),
        })
    }
}

/// Negative log marginal likelihood per sample, `-ln p(y) / n`, and its
/// gradient with respect to the log-hyperparameters `hyper.to_log()`.
///
/// `x` is row-major n x d (standardised), `y` has n standardised targets.
/// Costs one Cholesky, one inverse and two n x n x d products.
pub fn neg_lml_and_grad(
    x: &[f64],
    d: usize,
    y: &[f64],
    hyper: &SeHyper,
) -> Result<(f64, Vec<f64>), GpError> {
    neg_lml_and_grad_shared(x, d, y, 1, hyper)
}

/// [`neg_lml_and_grad`] of `k` outputs that share the hyperparameters
/// (independent given them): `y` is row-major n x k, the likelihood is the
/// sum of the outputs', given per sample and output, `-ln p(Y) / (n k)`.
/// One factorisation serves every output: the cost is that of one.
pub fn neg_lml_and_grad_shared(
    x: &[f64],
    d: usize,
    y: &[f64],
    k: usize,
    hyper: &SeHyper,
) -> Result<(f64, Vec<f64>), GpError> {
    check_hyper(hyper, d)?;
    let n = y.len() / k;
    let xs = scale_rows(x, &hyper.lengthscales);
    let kf = se_gram(&xs, d, hyper.signal_var);
    let (llt, _) = cholesky_with_jitter(&kf, hyper.noise_var, hyper)?;
    let l = llt.L();
    let mut alpha = Mat::from_fn(n, k, |i, c| y[i * k + c]);
    faer::linalg::solvers::Solve::solve_in_place(&llt, alpha.as_mut());
    let alpha_col = |c: usize| alpha.col(c).try_as_col_major().unwrap().as_slice();
    let data_fit: f64 = (0..k)
        .map(|c| (0..n).map(|i| y[i * k + c] * alpha_col(c)[i]).sum::<f64>())
        .sum();
    let log_det: f64 = (0..n).map(|i| l[(i, i)].ln()).sum();
    let kf64 = k as f64;
    let nll =
        0.5 * data_fit + kf64 * log_det + 0.5 * (n * k) as f64 * (2.0 * std::f64::consts::PI).ln();

    // W = sum_c alpha_c alpha_c^T - k K^-1 and M = W o K_f (elementwise),
    // column by column in K^-1's storage; per column: (W_jj, sum_i M_ij).
    // Each step is a loop over one column, which stays in cache.
    let mut m = llt.inverse();
    let col_stats: Vec<(f64, f64)> = m
        .par_col_iter_mut()
        .enumerate()
        .map(|(j, col)| {
            let col = col.try_as_col_major_mut().unwrap().as_slice_mut();
            let kf_col = kf.col(j).try_as_col_major().unwrap().as_slice();
            col.iter_mut().for_each(|v| *v *= -kf64);
            for c in 0..k {
                let (a, aj) = (alpha_col(c), alpha_col(c)[j]);
                col.iter_mut().zip(a).for_each(|(v, ai)| *v += ai * aj);
            }
            let (w_jj, sum) = (col[j], dot(col, kf_col));
            col.iter_mut().zip(kf_col).for_each(|(v, kv)| *v *= kv);
            (w_jj, sum)
        })
        .collect();
    drop(kf);
    let trace_w: f64 = col_stats.iter().map(|c| c.0).sum();
    let sum_m: f64 = col_stats.iter().map(|c| c.1).sum();
    // M is symmetric, so its row sums are its column sums.
    // 1/2 sum_ij M_ij (a_i - a_j)^2 = sum_i r_i a_i^2 - a^T M a per scaled input a.
    let xs_m = MatRef::from_row_major_slice(&xs, n, d);
    let mut mx = Mat::<f64>::zeros(n, d);
    faer::linalg::matmul::matmul(
        mx.as_mut(),
        faer::Accum::Replace,
        m.as_ref(),
        xs_m,
        1.0,
        Par::rayon(0),
    );
    let mut dl = vec![0.0; d];
    for (c, g) in dl.iter_mut().enumerate() {
        *g = (0..n)
            .map(|i| {
                let a = xs_m[(i, c)];
                col_stats[i].1 * a * a - a * mx[(i, c)]
            })
            .sum::<f64>();
    }
    // Gradient of ln p: d/d ln s2 = 1/2 sum M; d/d ln sn2 = 1/2 sn2 tr W;
    // d/d ln l_c = 1/2 sum_ij M_ij (a_ic - a_jc)^2.
    let mut grad = vec![-0.5 * sum_m];
    match hyper.kind {
        super::KernelKind::Isotropic => grad.push(-dl.iter().sum::<f64>()),
        super::KernelKind::Ard => grad.extend(dl.iter().map(|g| -g)),
    }
    grad.push(-0.5 * hyper.noise_var * trace_w);
    let nf = (n * k) as f64;
    grad.iter_mut().for_each(|g| *g /= nf);
    Ok((nll / nf, grad))
}

/// A fitted exact GP for one output, on standardised inputs and target.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(into = "ExactGpData", try_from = "ExactGpData")]
pub struct ExactGp {
    hyper: SeHyper,
    dim: usize,
    /// Standardised training inputs, row-major n x d.
    x: Vec<f64>,
    /// Standardised training targets.
    y: Vec<f64>,
    /// Training inputs divided by the length-scales, column by column
    /// (d x n, [`scale_cols`]).
    xs_cols: Vec<f64>,
    /// K^-1 y.
    alpha: Vec<f64>,
    /// What the latent variance is conditioned on, shared by the GPs of one
    /// factorisation.
    variance: Arc<LocalVariance>,
    /// Jitter that the factorisation needed.
    jitter: f64,
}

/// What an [`ExactGp`] stores in a model file: hyperparameters and training
/// data. The factorisation is recomputed (and so re-checked) on load.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExactGpData {
    /// Kernel hyperparameters.
    pub hyper: SeHyper,
    /// Input dimension.
    pub dim: usize,
    /// Standardised training inputs, row-major n x dim.
    pub x: Vec<f64>,
    /// Standardised training targets.
    pub y: Vec<f64>,
}

impl From<ExactGp> for ExactGpData {
    fn from(gp: ExactGp) -> Self {
        ExactGpData {
            hyper: gp.hyper,
            dim: gp.dim,
            x: gp.x,
            y: gp.y,
        }
    }
}

impl TryFrom<ExactGpData> for ExactGp {
    type Error = GpError;
    fn try_from(data: ExactGpData) -> Result<Self, Self::Error> {
        ExactGp::fit(&data.x, data.dim, &data.y, data.hyper)
    }
}

/// Per-call scratch for [`ExactGp::predict_one`] and
/// [`SparseGp::predict_one`](super::SparseGp::predict_one), allocated once.
#[derive(Debug, Clone)]
pub struct GpWorkspace {
    pub(super) scaled: Vec<f64>,
    pub(super) k: Vec<f64>,
}

impl GpWorkspace {
    /// Scratch for a GP with at most `n` training (or inducing) points and
    /// `dim` inputs; one workspace serves every GP up to that size.
    pub fn new(n: usize, dim: usize) -> Self {
        GpWorkspace {
            scaled: vec![0.0; dim],
            k: vec![0.0; n],
        }
    }
}

/// Dot product with four accumulators, so the compiler can vectorise it.
#[inline]
pub(super) fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = ca
        .remainder()
        .iter()
        .zip(cb.remainder())
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in ca.zip(cb) {
        for k in 0..4 {
            acc[k] += x[k] * y[k];
        }
    }
    acc[0] + acc[1] + acc[2] + acc[3] + tail
}

/// The kernel vector `k(x_i, z)` against scaled rows stored column by
/// column in `xs_cols` ([`scale_cols`]; the first `xs_cols.len() / d`
/// entries of `ws.k`, returned), without allocating; `z` scaled is left in
/// `ws.scaled`.
pub(super) fn cross_one<'w>(
    xs_cols: &[f64],
    hyper: &SeHyper,
    z: &[f64],
    ws: &'w mut GpWorkspace,
) -> &'w mut [f64] {
    let d = hyper.lengthscales.len();
    for ((s, v), l) in ws.scaled.iter_mut().zip(z).zip(&hyper.lengthscales) {
        *s = v / l;
    }
    let k = &mut ws.k[..xs_cols.len() / d];
    se_against(xs_cols, &ws.scaled, hyper.signal_var, k);
    k
}

/// The rows `idx` of a row-major matrix with `d` columns, in that order.
pub(super) fn rows_of(x: &[f64], d: usize, idx: &[usize]) -> Vec<f64> {
    idx.iter()
        .flat_map(|&i| &x[i * d..(i + 1) * d])
        .copied()
        .collect()
}

/// A latent variance clamped at 0; non-finite values fall back to the prior `s2`.
pub(super) fn clamp_var(var: f64, s2: f64) -> f64 {
    let var = var.max(0.0);
    if var.is_finite() {
        var
    } else {
        s2
    }
}

/// The lower triangle of a square matrix, packed column by column: column j
/// contributes L[j..n, j].
pub(super) fn pack_lower(l: MatRef<'_, f64>) -> Vec<f64> {
    let n = l.nrows();
    let mut cols = Vec::with_capacity(n * (n + 1) / 2);
    for j in 0..n {
        cols.extend(l.col(j).iter().skip(j));
    }
    cols
}

/// The n x n lower-triangular matrix of [`pack_lower`]'s packing.
pub(super) fn unpack_lower<T: Copy + Into<f64>>(cols: &[T], n: usize) -> Mat<f64> {
    let mut l = Mat::<f64>::zeros(n, n);
    let mut start = 0;
    for j in 0..n {
        for (i, v) in cols[start..start + n - j].iter().enumerate() {
            l[(j + i, j)] = (*v).into();
        }
        start += n - j;
    }
    l
}

/// Forward substitution `L v = k` in place, with L packed by [`pack_lower`]
/// (as many columns as `k` has entries): v_j = k_j / L_jj, then
/// k[j+1..] -= v_j L[j+1.., j]. In the widest vector instructions the CPU
/// has (pulp's run-time dispatch, as the kernel's exponentials): with a
/// factor of 1000 rows in cache, 65 us instead of 100 us in the baseline
/// build.
pub(super) fn forward_subst_packed<T: Copy + Into<f64>>(l_cols: &[T], k: &mut [f64]) {
    pulp::Arch::new().dispatch(ForwardSubst { l_cols, k });
}

/// [`forward_subst_packed`]'s arguments (a type, not a closure, so that
/// its body is compiled for the dispatched instructions).
struct ForwardSubst<'a, T> {
    l_cols: &'a [T],
    k: &'a mut [f64],
}

impl<T: Copy + Into<f64>> pulp::WithSimd for ForwardSubst<'_, T> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) {
        let (l_cols, k) = (self.l_cols, self.k);
        let n = k.len();
        let mut start = 0;
        for j in 0..n {
            let col = &l_cols[start..start + n - j];
            let vj = k[j] / col[0].into();
            k[j] = vj;
            for (k, l) in k[j + 1..].iter_mut().zip(&col[1..]) {
                *k -= vj * (*l).into();
            }
            start += n - j;
        }
    }
}

impl ExactGp {
    /// Conditions the GP on row-major inputs `x` (n x dim) and targets `y`,
    /// both standardised, with fixed hyperparameters.
    pub fn fit(x: &[f64], dim: usize, y: &[f64], hyper: SeHyper) -> Result<Self, GpError> {
        let mut gps = Self::fit_shared(x, dim, y, 1, hyper)?;
        Ok(gps.remove(0))
    }

    /// One GP per output of `y` (row-major n x k), all with `hyper`, on one
    /// factorisation; their variances conditioned on at most
    /// [`VARIANCE_ROWS`] rows near each point.
    pub fn fit_shared(
        x: &[f64],
        dim: usize,
        y: &[f64],
        k: usize,
        hyper: SeHyper,
    ) -> Result<Vec<Self>, GpError> {
        Self::fit_local(x, dim, y, k, hyper, VARIANCE_ROWS)
    }

    /// [`ExactGp::fit_shared`], the variances conditioned on at most `m`
    /// rows near each point.
    fn fit_local(
        x: &[f64],
        dim: usize,
        y: &[f64],
        k: usize,
        hyper: SeHyper,
        m: usize,
    ) -> Result<Vec<Self>, GpError> {
        check_targets(x, dim, y, k)?;
        check_hyper(&hyper, dim)?;
        let n = y.len() / k;
        let xs = scale_rows(x, &hyper.lengthscales);
        let kf = se_gram(&xs, dim, hyper.signal_var);
        let (llt, jitter) = cholesky_with_jitter(&kf, hyper.noise_var, &hyper)?;
        if jitter > 0.0 {
            tracing::warn!(
                n,
                jitter,
                noise_var = hyper.noise_var,
                "kernel matrix needed jitter to factorise: duplicated or degenerate inputs?"
            );
        }
        let mut alpha = Mat::from_fn(n, k, |i, c| y[i * k + c]);
        faer::linalg::solvers::Solve::solve_in_place(&llt, alpha.as_mut());
        if alpha
            .col_iter()
            .flat_map(|c| c.iter())
            .any(|a| !a.is_finite())
        {
            return Err(GpError::NotPositiveDefinite {
                n,
                jitter,
                signal_var: hyper.signal_var,
                noise_var: hyper.noise_var,
            });
        }
        let noise = hyper.noise_var + jitter;
        let variance = LocalVariance::new(&xs, dim, &hyper, noise, llt.L(), m)?;
        let variance = Arc::new(variance);
        let xs_cols = scale_cols(x, &hyper.lengthscales);
        Ok((0..k)
            .map(|c| ExactGp {
                hyper: hyper.clone(),
                dim,
                x: x.to_vec(),
                y: (0..n).map(|i| y[i * k + c]).collect(),
                xs_cols: xs_cols.clone(),
                alpha: alpha.col(c).iter().copied().collect(),
                variance: Arc::clone(&variance),
                jitter,
            })
            .collect())
    }

    /// Number of training points.
    pub fn n_train(&self) -> usize {
        self.alpha.len()
    }

    /// Input dimension.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Hyperparameters.
    pub fn hyper(&self) -> &SeHyper {
        &self.hyper
    }

    /// Jitter added to the diagonal to factorise K (0 when none was needed).
    pub fn jitter(&self) -> f64 {
        self.jitter
    }

    /// Mean and latent variance at one standardised input, without allocating.
    ///
    /// Cost: O(n d) for the mean, O(m^2) for the variance (one forward
    /// substitution with the factor of the m <= [`VARIANCE_ROWS`] rows near
    /// the input). `with_var = false` skips the variance (returns 0). `ws`
    /// must have room for at least `n_train()` points.
    pub fn predict_one(&self, z: &[f64], ws: &mut GpWorkspace, with_var: bool) -> (f64, f64) {
        let n = self.n_train();
        cross_one(&self.xs_cols, &self.hyper, z, ws);
        let mean = dot(&ws.k[..n], &self.alpha);
        if !with_var {
            return (mean, 0.0);
        }
        let s2 = self.hyper.signal_var;
        (mean, self.variance.at(&ws.scaled, &mut ws.k[..n], s2))
    }

    /// Means and latent variances at many standardised inputs (row-major m x dim),
    /// the variances as [`ExactGp::predict_one`]'s.
    ///
    /// Uses matrix products and blocked triangular solves instead of m
    /// forward substitutions.
    pub fn predict(&self, z: &[f64], with_var: bool) -> (Vec<f64>, Vec<f64>) {
        Self::predict_shared(&[self], z, with_var).remove(0)
    }

    /// Whether `other` has the same kernel and training inputs (as the GPs
    /// of [`ExactGp::fit_shared`]): then one cross-covariance serves both.
    pub fn shares_kernel(&self, other: &ExactGp) -> bool {
        self.hyper == other.hyper && self.x == other.x
    }

    /// [`ExactGp::predict`] of GPs that [share](ExactGp::shares_kernel)
    /// the first one's kernel, on one cross-covariance (their variances are
    /// the same); means and variances per GP.
    pub fn predict_shared(
        gps: &[&ExactGp],
        z: &[f64],
        with_var: bool,
    ) -> Vec<(Vec<f64>, Vec<f64>)> {
        let Some(first) = gps.first() else {
            return Vec::new();
        };
        debug_assert!(gps.iter().all(|g| first.shares_kernel(g)));
        let d = first.dim;
        let n = first.n_train();
        let m = z.len() / d;
        let xs = scale_rows(&first.x, &first.hyper.lengthscales);
        let zs = scale_rows(z, &first.hyper.lengthscales);
        let s2 = first.hyper.signal_var;
        let mut means = vec![Vec::with_capacity(m); gps.len()];
        let alpha = Mat::from_fn(n, gps.len(), |i, c| gps[c].alpha[i]);
        // Blocks of test points bound the n x block cross-covariance memory.
        const BLOCK: usize = 1024;
        let mut buffer = Mat::zeros(n, BLOCK.min(m));
        for chunk in zs.chunks(BLOCK * d) {
            let mut kt = buffer.as_mut().subcols_mut(0, chunk.len() / d); // n x b
            se_cross_into(&xs, chunk, d, s2, kt.as_mut());
            let mut block_means = Mat::<f64>::zeros(kt.ncols(), gps.len());
            faer::linalg::matmul::matmul(
                block_means.as_mut(),
                faer::Accum::Replace,
                kt.as_ref().transpose(),
                alpha.as_ref(),
                1.0,
                Par::rayon(0),
            );
            for (mean, col) in means.iter_mut().zip(block_means.col_iter()) {
                mean.extend(col.iter());
            }
        }
        let vars = match with_var {
            true => first.variance.at_many(&xs, &zs, d, s2),
            false => vec![0.0; m],
        };
        means.into_iter().map(|mean| (mean, vars.clone())).collect()
    }
}

#[cfg(test)]
pub(super) mod tests;
