//! Exact GP regression on standardised data: fit with given hyperparameters,
//! log marginal likelihood with its gradient, and prediction.
//!
//! With K = K_f + sn2 I = L L^T and alpha = K^-1 y (Rasmussen & Williams 2006,
//! Alg. 2.1):
//! - mean(x*) = k*^T alpha, var_f(x*) = s2 - |L^-1 k*|^2 (clamped at 0);
//! - ln p(y) = -1/2 y^T alpha - sum_i ln L_ii - n/2 ln(2 pi);
//! - d ln p(y) / d theta = 1/2 tr((alpha alpha^T - K^-1) dK/dtheta) (Eq. 5.9).

use faer::linalg::solvers::DenseSolveCore;
use faer::{Mat, MatRef, Par, Side};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::kernel::{exp_kernel, scale_rows, se_cross, se_gram, SeHyper};
use super::GpError;

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
    if y.is_empty() {
        return Err(GpError::Empty);
    }
    if x.len() != y.len() * d {
        return Err(GpError::ShapeMismatch {
            values: x.len(),
            dim: d,
            targets: y.len(),
        });
    }
    if let Some(i) = x.iter().position(|v| !v.is_finite()) {
        return Err(GpError::NonFinite {
            row: i / d,
            column: i % d,
        });
    }
    if let Some(row) = y.iter().position(|v| !v.is_finite()) {
        return Err(GpError::NonFinite { row, column: d });
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
    check_hyper(hyper, d)?;
    let n = y.len();
    let xs = scale_rows(x, &hyper.lengthscales);
    let kf = se_gram(&xs, d, hyper.signal_var);
    let (llt, _) = cholesky_with_jitter(&kf, hyper.noise_var, hyper)?;
    let l = llt.L();
    let mut alpha = Mat::from_fn(n, 1, |i, _| y[i]);
    faer::linalg::solvers::Solve::solve_in_place(&llt, alpha.as_mut());
    let alpha = alpha.col(0);
    let data_fit: f64 = y.iter().zip(alpha.iter()).map(|(a, b)| a * b).sum();
    let log_det: f64 = (0..n).map(|i| l[(i, i)].ln()).sum();
    let nll = 0.5 * data_fit + log_det + 0.5 * n as f64 * (2.0 * std::f64::consts::PI).ln();

    // W = alpha alpha^T - K^-1 and M = W o K_f (elementwise), column by
    // column in K^-1's storage; per column: (W_jj, sum_i M_ij).
    let mut m = llt.inverse();
    let alpha: Vec<f64> = alpha.iter().copied().collect();
    let col_stats: Vec<(f64, f64)> = m
        .par_col_iter_mut()
        .enumerate()
        .map(|(j, col)| {
            let kf_col = kf.col(j);
            let (mut w_jj, mut sum) = (0.0, 0.0);
            for (i, (v, k)) in col.iter_mut().zip(kf_col.iter()).enumerate() {
                let w = alpha[i] * alpha[j] - *v;
                if i == j {
                    w_jj = w;
                }
                *v = w * k;
                sum += *v;
            }
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
    let nf = n as f64;
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
    /// Training inputs divided by the length-scales, row-major n x d.
    xs: Vec<f64>,
    /// K^-1 y.
    alpha: Vec<f64>,
    /// Columns of the Cholesky factor L, packed (see [`pack_lower`]).
    l_cols: Vec<f64>,
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

/// The kernel vector `k(x_i, z)` against scaled rows `xs` (the first
/// `xs.len() / d` entries of `ws.k`, returned), without allocating.
pub(super) fn cross_one<'w>(
    xs: &[f64],
    hyper: &SeHyper,
    z: &[f64],
    ws: &'w mut GpWorkspace,
) -> &'w mut [f64] {
    let d = hyper.lengthscales.len();
    for ((s, v), l) in ws.scaled.iter_mut().zip(z).zip(&hyper.lengthscales) {
        *s = v / l;
    }
    let k = &mut ws.k[..xs.len() / d];
    for (k, row) in k.iter_mut().zip(xs.chunks_exact(d)) {
        let d2: f64 = row
            .iter()
            .zip(&ws.scaled)
            .map(|(a, b)| (a - b) * (a - b))
            .sum();
        *k = hyper.signal_var * exp_kernel(-0.5 * d2);
    }
    k
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
pub(super) fn unpack_lower(cols: &[f64], n: usize) -> Mat<f64> {
    let mut l = Mat::<f64>::zeros(n, n);
    let mut start = 0;
    for j in 0..n {
        for (i, v) in cols[start..start + n - j].iter().enumerate() {
            l[(j + i, j)] = *v;
        }
        start += n - j;
    }
    l
}

/// Forward substitution `L v = k` in place, with L packed by [`pack_lower`]
/// (as many columns as `k` has entries): v_j = k_j / L_jj, then
/// k[j+1..] -= v_j L[j+1.., j].
pub(super) fn forward_subst_packed(l_cols: &[f64], k: &mut [f64]) {
    let n = k.len();
    let mut start = 0;
    for j in 0..n {
        let col = &l_cols[start..start + n - j];
        let vj = k[j] / col[0];
        k[j] = vj;
        for (k, l) in k[j + 1..].iter_mut().zip(&col[1..]) {
            *k -= vj * l;
        }
        start += n - j;
    }
}

impl ExactGp {
    /// Conditions the GP on row-major inputs `x` (n x dim) and targets `y`,
    /// both standardised, with fixed hyperparameters.
    pub fn fit(x: &[f64], dim: usize, y: &[f64], hyper: SeHyper) -> Result<Self, GpError> {
        check_data(x, dim, y)?;
        check_hyper(&hyper, dim)?;
        let n = y.len();
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
        let mut alpha = Mat::from_fn(n, 1, |i, _| y[i]);
        faer::linalg::solvers::Solve::solve_in_place(&llt, alpha.as_mut());
        let l_cols = pack_lower(llt.L());
        let gp = ExactGp {
            hyper,
            dim,
            x: x.to_vec(),
            y: y.to_vec(),
            xs,
            alpha: alpha.col(0).iter().copied().collect(),
            l_cols,
            jitter,
        };
        if gp.alpha.iter().any(|a| !a.is_finite()) {
            return Err(GpError::NotPositiveDefinite {
                n,
                jitter,
                signal_var: gp.hyper.signal_var,
                noise_var: gp.hyper.noise_var,
            });
        }
        Ok(gp)
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
    /// Cost: O(n d) for the mean, O(n^2) for the variance (one forward
    /// substitution with L). `with_var = false` skips the variance (returns
    /// 0). `ws` must have room for at least `n_train()` points.
    pub fn predict_one(&self, z: &[f64], ws: &mut GpWorkspace, with_var: bool) -> (f64, f64) {
        let k = cross_one(&self.xs, &self.hyper, z, ws);
        let mean = dot(k, &self.alpha);
        if !with_var {
            return (mean, 0.0);
        }
        forward_subst_packed(&self.l_cols, k);
        let s2 = self.hyper.signal_var;
        (mean, clamp_var(s2 - dot(k, k), s2))
    }

    /// Means and latent variances at many standardised inputs (row-major m x dim).
    ///
    /// Uses matrix products and one blocked triangular solve instead of m
    /// forward substitutions.
    pub fn predict(&self, z: &[f64], with_var: bool) -> (Vec<f64>, Vec<f64>) {
        let d = self.dim;
        let n = self.n_train();
        let m = z.len() / d;
        let zs = scale_rows(z, &self.hyper.lengthscales);
        let s2 = self.hyper.signal_var;
        let mut means = Vec::with_capacity(m);
        let mut vars = Vec::with_capacity(m);
        let l = with_var.then(|| unpack_lower(&self.l_cols, n));
        // Blocks of test points bound the n x block cross-covariance memory.
        const BLOCK: usize = 1024;
        for chunk in zs.chunks(BLOCK * d) {
            let mut kt = se_cross(&self.xs, chunk, d, s2); // n x b
            for c in 0..kt.ncols() {
                means.push(dot(
                    kt.col(c).try_as_col_major().unwrap().as_slice(),
                    &self.alpha,
                ));
            }
            if let Some(l) = &l {
                faer::linalg::triangular_solve::solve_lower_triangular_in_place(
                    l.as_ref(),
                    kt.as_mut(),
                    Par::rayon(0),
                );
                for c in 0..kt.ncols() {
                    let v: f64 = kt.col(c).iter().map(|v| v * v).sum();
                    vars.push(clamp_var(s2 - v, s2));
                }
            } else {
                vars.extend(std::iter::repeat_n(0.0, kt.ncols()));
            }
        }
        (means, vars)
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::super::KernelKind;
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Random inputs in [-2, 2)^d and a smooth target with a little noise
    /// (shared with the sparse GP's tests).
    pub(in crate::learn::models::gp) fn data(
        n: usize,
        d: usize,
        seed: u64,
    ) -> (Vec<f64>, Vec<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let x: Vec<f64> = (0..n * d).map(|_| rng.random_range(-2.0..2.0)).collect();
        let y = x
            .chunks_exact(d)
            .map(|r| r[0].sin() + 0.3 * r[d - 1] + 0.05 * rng.random_range(-1.0..1.0))
            .collect();
        (x, y)
    }

    /// Fixed hyperparameters for `d` inputs (shared with the sparse GP's tests).
    pub(in crate::learn::models::gp) fn hyper(kind: KernelKind, d: usize) -> SeHyper {
        let mut h = SeHyper {
            kind,
            signal_var: 0.8,
            lengthscales: (0..d).map(|i| 0.7 + 0.4 * i as f64).collect(),
            noise_var: 0.02,
        };
        if kind == KernelKind::Isotropic {
            h.lengthscales = vec![1.1; d];
        }
        h
    }

    /// Asserts that `objective`'s gradient matches central differences in
    /// the log-parameters around `h`, for 3 inputs (shared with the sparse
    /// GP's tests).
    pub(in crate::learn::models::gp) fn assert_gradient_matches(
        objective: impl Fn(&SeHyper) -> Result<(f64, Vec<f64>), GpError>,
        h: &SeHyper,
    ) {
        let theta = h.to_log();
        let (_, g) = objective(h).unwrap();
        for k in 0..theta.len() {
            let step = 1e-5;
            let f = |s: f64| {
                let mut t = theta.clone();
                t[k] += s;
                objective(&SeHyper::from_log(h.kind, 3, &t)).unwrap().0
            };
            let fd = (f(step) - f(-step)) / (2.0 * step);
            assert!(
                (fd - g[k]).abs() < 1e-6 * (1.0 + fd.abs()),
                "{:?} param {k}: analytic {} vs finite difference {fd}",
                h.kind,
                g[k]
            );
        }
    }

    #[test]
    fn likelihood_gradient_matches_central_differences() {
        let (x, y) = data(40, 3, 1);
        for kind in [KernelKind::Isotropic, KernelKind::Ard] {
            assert_gradient_matches(|h| neg_lml_and_grad(&x, 3, &y, h), &hyper(kind, 3));
        }
    }

    #[test]
    fn single_sample_path_matches_batch_path_and_variance_is_bounded() {
        let (x, y) = data(200, 4, 2);
        let gp = ExactGp::fit(&x, 4, &y, hyper(KernelKind::Ard, 4)).unwrap();
        let (z, _) = data(30, 4, 3);
        let (means, vars) = gp.predict(&z, true);
        let mut ws = GpWorkspace::new(gp.n_train(), 4);
        for (i, row) in z.chunks_exact(4).enumerate() {
            let (m, v) = gp.predict_one(row, &mut ws, true);
            assert!((m - means[i]).abs() < 1e-9);
            assert!((v - vars[i]).abs() < 1e-9);
            assert!((0.0..=0.8).contains(&v));
            assert_eq!(gp.predict_one(row, &mut ws, false), (m, 0.0));
        }
    }

    #[test]
    fn far_from_the_data_the_prediction_returns_to_the_prior() {
        let (x, y) = data(100, 2, 4);
        let gp = ExactGp::fit(&x, 2, &y, hyper(KernelKind::Ard, 2)).unwrap();
        let mut ws = GpWorkspace::new(100, 2);
        let (m, v) = gp.predict_one(&[1e3, -1e3], &mut ws, true);
        assert!(m.abs() < 1e-12);
        assert!((v - 0.8).abs() < 1e-12);
    }

    #[test]
    fn bad_inputs_give_named_errors() {
        let (mut x, y) = data(10, 2, 5);
        x[7] = f64::NAN;
        assert!(matches!(
            ExactGp::fit(&x, 2, &y, hyper(KernelKind::Ard, 2)),
            Err(GpError::NonFinite { row: 3, column: 1 })
        ));
        assert!(matches!(
            ExactGp::fit(&[], 2, &[], hyper(KernelKind::Ard, 2)),
            Err(GpError::Empty)
        ));
        let mut h = hyper(KernelKind::Ard, 2);
        h.noise_var = -1.0;
        let (x, y) = data(10, 2, 5);
        assert!(matches!(
            ExactGp::fit(&x, 2, &y, h),
            Err(GpError::InvalidHyper { dim: 2, .. })
        ));
    }

    #[test]
    fn model_data_round_trip_rebuilds_the_same_predictor() {
        let (x, y) = data(50, 3, 6);
        let gp = ExactGp::fit(&x, 3, &y, hyper(KernelKind::Isotropic, 3)).unwrap();
        let json = serde_json::to_string(&gp).unwrap();
        let back: ExactGp = serde_json::from_str(&json).unwrap();
        let z = [0.3, -0.2, 1.0];
        let mut ws = GpWorkspace::new(50, 3);
        assert_eq!(
            gp.predict_one(&z, &mut ws, true),
            back.predict_one(&z, &mut ws, true)
        );
    }
}
