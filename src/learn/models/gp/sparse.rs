//! Sparse GP regression with the variational free energy (VFE, SGPR) of
//! Titsias (2009), on standardised data, with m inducing inputs Z chosen from
//! the training rows.
//!
//! Why VFE and not FITC: the VFE objective is a lower bound on the exact log
//! marginal likelihood, so adding inducing points never lowers it and the
//! hyperparameters are not pushed to the underestimated, heteroscedastic noise
//! that FITC tends to fit (Bauer, van der Wilk & Rasmussen 2016,
//! "Understanding probabilistic sparse GP approximations").
//!
//! Notation: s2, l, sn2 = σ² the SE hyperparameters; K_uu + jitter = L_uu L_uu^T;
//! A = L_uu^-1 K_uf / σ (m x n); B = I + A A^T = L_B L_B^T; c = L_B^-1 A y / σ.
//! - bound: F = -n/2 ln 2π - Σ ln L_B,ii - n/2 ln σ² - y^T y / (2σ²) + c^T c / 2
//!   - n s2 / (2σ²) + tr(A A^T) / 2;
//! - optimal q(u) = N(μ_u, S_u): μ_u = L_uu L_B^-T c, S_u = L_uu B^-1 L_uu^T;
//! - mean(x*) = k*^T K_uu^-1 μ_u; latent variance
//!   s2 - |L_uu^-1 k*|^2 + |L_B^-1 L_uu^-1 k*|^2.
//!
//! The gradient (see [`neg_vfe_and_grad`]) never forms an n x n matrix: time
//! O(n m^2 + n m d), memory O(n m).

use faer::linalg::matmul::matmul;
use faer::linalg::solvers::{DenseSolveCore, Llt, Solve};
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Accum, Mat, MatRef, Par, Side};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::exact::{
    check_hyper, cholesky_with_jitter, clamp_var, cross_one, dot, forward_subst_packed, pack_lower,
    unpack_lower, GpWorkspace,
};
use super::kernel::{scale_rows, se_cross, se_gram, KernelKind, SeHyper};
use super::GpError;

/// Jitter always added to K_uu, relative to s2. Proportional to s2, so that
/// dK_uu / d ln s2 stays K_uu; small enough that with Z = X the bound matches
/// the exact likelihood to ~1e-8 relative.
const KUU_JITTER: f64 = 1e-8;

/// Rows of the training data handled at once when conditioning q(u), and
/// columns of K_uf per gradient block: bounds the O(m x block) scratch.
const BLOCK: usize = 4096;

/// L_uu for scaled inducing rows `zs`: the Cholesky factor of K_uu plus
/// `KUU_JITTER` s2, escalating the jitter if needed. Also returns K_uu
/// without jitter and the escalated jitter.
fn kuu_factor(zs: &[f64], d: usize, hyper: &SeHyper) -> Result<(Llt<f64>, Mat<f64>, f64), GpError> {
    let kuu = se_gram(zs, d, hyper.signal_var);
    let (llt, jitter) = cholesky_with_jitter(&kuu, KUU_JITTER * hyper.signal_var, hyper)?;
    Ok((llt, kuu, jitter))
}

/// Checks that `z` holds at least one row of `d` finite inducing inputs.
fn check_inducing(z: &[f64], d: usize) -> Result<(), GpError> {
    if z.is_empty() || !z.len().is_multiple_of(d) || z.iter().any(|v| !v.is_finite()) {
        return Err(GpError::InvalidSparse(format!(
            "{} inducing values for {d} inputs: need whole, finite rows, at least one",
            z.len()
        )));
    }
    Ok(())
}

/// K_uf and A = L_uu^-1 K_uf / σ for scaled rows `xs` (both m x rows).
fn projection(
    zs: &[f64],
    xs: &[f64],
    d: usize,
    hyper: &SeHyper,
    luu: MatRef<'_, f64>,
) -> (Mat<f64>, Mat<f64>) {
    let kuf = se_cross(zs, xs, d, hyper.signal_var);
    let mut a = kuf.clone();
    solve_lower_triangular_in_place(luu, a.as_mut(), Par::rayon(0));
    let inv_sigma = 1.0 / hyper.noise_var.sqrt();
    a.par_col_iter_mut()
        .for_each(|col| col.iter_mut().for_each(|v| *v *= inv_sigma));
    (kuf, a)
}

/// Adds A A^T to `b` and A y to `ay`.
fn accumulate(a: MatRef<'_, f64>, y: &[f64], b: &mut Mat<f64>, ay: &mut Mat<f64>) {
    let par = Par::rayon(0);
    matmul(b.as_mut(), Accum::Add, a, a.transpose(), 1.0, par);
    let y = MatRef::from_column_major_slice(y, y.len(), 1);
    matmul(ay.as_mut(), Accum::Add, a, y, 1.0, par);
}

/// L_B from B = I + A A^T, and c = L_B^-1 A y / σ.
fn b_factor(b: &Mat<f64>, ay: &Mat<f64>, hyper: &SeHyper) -> Result<(Llt<f64>, Mat<f64>), GpError> {
    let lb = b
        .llt(Side::Lower)
        .map_err(|_| GpError::NotPositiveDefinite {
            n: b.nrows(),
            jitter: 0.0,
            signal_var: hyper.signal_var,
            noise_var: hyper.noise_var,
        })?;
    let inv_sigma = 1.0 / hyper.noise_var.sqrt();
    let mut c = Mat::from_fn(ay.nrows(), 1, |i, _| ay[(i, 0)] * inv_sigma);
    solve_lower_triangular_in_place(lb.L(), c.as_mut(), Par::rayon(0));
    Ok((lb, c))
}

/// Negative VFE bound per sample, `-F / n`, and its gradient with respect to
/// the log-hyperparameters `hyper.to_log()` (same packing and sign as
/// [`neg_lml_and_grad`](super::exact::neg_lml_and_grad)), for inputs `x`
/// (row-major n x d), targets `y` and inducing inputs `z` (row-major m x d),
/// all standardised. Z is held fixed.
///
/// With Q = K_fu K_uu^-1 K_uf, C = Q + σ² I, α = C^-1 y and
/// W = α α^T - C^-1 + I / σ², P = K_uu^-1 K_uf W and R = P K_fu K_uu^-1:
/// dF = Σ P ∘ dK_uf - 1/2 tr(R dK_uu) - d tr(K_nn) / (2σ²)
///      + [1/2 (α^T α - tr C^-1) + tr(K_nn - Q) / (2σ⁴)] dσ².
/// By Woodbury, C^-1 = σ^-2 (I - A^T B^-1 A), α = y / σ² - A^T L_B^-T c / σ,
/// P = u α^T + L_uu^-T (I - B^-1) A / σ with u = K_uu^-1 K_uf α, and
/// R = u u^T + L_uu^-T (B - 2I + B^-1) L_uu^-1: time O(n m^2 + n m d),
/// memory O(n m).
pub fn neg_vfe_and_grad(
    x: &[f64],
    d: usize,
    y: &[f64],
    z: &[f64],
    hyper: &SeHyper,
) -> Result<(f64, Vec<f64>), GpError> {
    check_hyper(hyper, d)?;
    check_inducing(z, d)?;
    let par = Par::rayon(0);
    let (n, m) = (y.len(), z.len() / d);
    let (nf, mf) = (n as f64, m as f64);
    let (s2, sn2) = (hyper.signal_var, hyper.noise_var);
    let sigma = sn2.sqrt();
    let xs = scale_rows(x, &hyper.lengthscales);
    let zs = scale_rows(z, &hyper.lengthscales);
    let (luu_llt, kuu, _) = kuu_factor(&zs, d, hyper)?;
    let luu = luu_llt.L();
    let (kuf, a) = projection(&zs, &xs, d, hyper, luu);
    let mut b = Mat::<f64>::identity(m, m);
    let mut ay = Mat::<f64>::zeros(m, 1);
    accumulate(a.as_ref(), y, &mut b, &mut ay);
    let (lb, c) = b_factor(&b, &ay, hyper)?;

    let yy = dot(y, y);
    let cc: f64 = c.col(0).iter().map(|v| v * v).sum();
    let tr_aat: f64 = (0..m).map(|i| b[(i, i)] - 1.0).sum();
    let log_det_b: f64 = (0..m).map(|i| lb.L()[(i, i)].ln()).sum();
    let bound = -0.5 * nf * (2.0 * std::f64::consts::PI * sn2).ln() - log_det_b - 0.5 * yy / sn2
        + 0.5 * cc
        - 0.5 * nf * s2 / sn2
        + 0.5 * tr_aat;

    // α = y / σ² - A^T (L_B^-T c) / σ.
    let mut g = c;
    solve_upper_triangular_in_place(lb.L().transpose(), g.as_mut(), par);
    let mut alpha = Mat::<f64>::from_fn(n, 1, |i, _| y[i] / sn2);
    matmul(
        alpha.as_mut(),
        Accum::Add,
        a.transpose(),
        g.as_ref(),
        -1.0 / sigma,
        par,
    );
    // u = K_uu^-1 K_uf α = σ L_uu^-T A α.
    let mut u = Mat::<f64>::zeros(m, 1);
    matmul(
        u.as_mut(),
        Accum::Replace,
        a.as_ref(),
        alpha.as_ref(),
        sigma,
        par,
    );
    solve_upper_triangular_in_place(luu.transpose(), u.as_mut(), par);
    // H = L_uu^-T (I - B^-1) / σ, T = B - 2I + B^-1.
    let binv = lb.inverse();
    let tr_binv: f64 = (0..m).map(|i| binv[(i, i)]).sum();
    let mut h = Mat::<f64>::from_fn(m, m, |i, j| (f64::from(i == j) - binv[(i, j)]) / sigma);
    solve_upper_triangular_in_place(luu.transpose(), h.as_mut(), par);
    // R = u u^T + L_uu^-T T L_uu^-1 (symmetric).
    let mut r = Mat::<f64>::from_fn(m, m, |i, j| {
        b[(i, j)] + binv[(i, j)] - 2.0 * f64::from(i == j)
    });
    solve_upper_triangular_in_place(luu.transpose(), r.as_mut(), par);
    let mut r = r.transpose().to_owned();
    solve_upper_triangular_in_place(luu.transpose(), r.as_mut(), par);
    matmul(r.as_mut(), Accum::Add, u.as_ref(), u.transpose(), 1.0, par);

    // Σ P ∘ dK_uf by blocks of columns, with M = P ∘ K_uf: Σ M for ln s2 and,
    // per scaled input c, Σ_ij M_ij (z_ic - x_jc)^2 =
    // Σ_i rowsum_i z_ic^2 + Σ_j colsum_j x_jc^2 - 2 Σ_i z_ic (M x)_ic.
    let zs_m = MatRef::from_row_major_slice(&zs, m, d);
    let mut row_sums = vec![0.0; m];
    let mut col_term = vec![0.0; d];
    let mut mx = Mat::<f64>::zeros(m, d);
    let mut pb = Mat::<f64>::zeros(m, BLOCK.min(n));
    for j0 in (0..n).step_by(BLOCK) {
        let w = BLOCK.min(n - j0);
        let mut p = pb.as_mut().subcols_mut(0, w);
        matmul(
            p.as_mut(),
            Accum::Replace,
            h.as_ref(),
            a.as_ref().subcols(j0, w),
            1.0,
            par,
        );
        let alpha_b = alpha.as_ref().subrows(j0, w);
        matmul(
            p.as_mut(),
            Accum::Add,
            u.as_ref(),
            alpha_b.transpose(),
            1.0,
            par,
        );
        let kuf_b = kuf.as_ref().subcols(j0, w);
        let col_sums: Vec<f64> = p
            .as_mut()
            .par_col_iter_mut()
            .zip(kuf_b.par_col_iter())
            .map(|(col, kcol)| {
                let mut sum = 0.0;
                for (v, k) in col.iter_mut().zip(kcol.iter()) {
                    *v *= k;
                    sum += *v;
                }
                sum
            })
            .collect();
        for jj in 0..w {
            for (i, rs) in row_sums.iter_mut().enumerate() {
                *rs += p[(i, jj)];
            }
            let row = &xs[(j0 + jj) * d..(j0 + jj + 1) * d];
            for (t, v) in col_term.iter_mut().zip(row) {
                *t += col_sums[jj] * v * v;
            }
        }
        let xs_b = MatRef::from_row_major_slice(&xs[j0 * d..(j0 + w) * d], w, d);
        matmul(mx.as_mut(), Accum::Add, p.as_ref(), xs_b, 1.0, par);
    }
    let sum_m: f64 = row_sums.iter().sum();
    let dl_f: Vec<f64> = (0..d)
        .map(|c| {
            col_term[c]
                + (0..m)
                    .map(|i| row_sums[i] * zs_m[(i, c)].powi(2) - 2.0 * zs_m[(i, c)] * mx[(i, c)])
                    .sum::<f64>()
        })
        .collect();

    // 1/2 tr(R dK_uu) with N = R ∘ K_uu (symmetric): for ln s2, Σ N plus the
    // s2-proportional jitter; per scaled input c, 1/2 Σ_ij N_ij (z_ic - z_jc)^2
    // = Σ_i rowsum_i z_ic^2 - z_c^T N z_c.
    let nmat = Mat::<f64>::from_fn(m, m, |i, j| r[(i, j)] * kuu[(i, j)]);
    let tr_r: f64 = (0..m).map(|i| r[(i, i)]).sum();
    let n_rows: Vec<f64> = (0..m).map(|i| nmat.row(i).iter().sum()).collect();
    let mut nz = Mat::<f64>::zeros(m, d);
    matmul(nz.as_mut(), Accum::Replace, nmat.as_ref(), zs_m, 1.0, par);
    let half_dl_u: Vec<f64> = (0..d)
        .map(|c| {
            (0..m)
                .map(|i| zs_m[(i, c)] * (n_rows[i] * zs_m[(i, c)] - nz[(i, c)]))
                .sum()
        })
        .collect();
    let sum_n: f64 = n_rows.iter().sum::<f64>() + KUU_JITTER * s2 * tr_r;

    let alpha_sq: f64 = alpha.col(0).iter().map(|v| v * v).sum();
    let tr_cinv = (nf - mf + tr_binv) / sn2;
    let tr_knn_q = nf * s2 - sn2 * tr_aat;
    let d_sn2 = 0.5 * (alpha_sq - tr_cinv) + tr_knn_q / (2.0 * sn2 * sn2);

    let mut grad = vec![sum_m - 0.5 * sum_n - 0.5 * nf * s2 / sn2];
    let dl = (0..d).map(|c| dl_f[c] - half_dl_u[c]);
    match hyper.kind {
        KernelKind::Isotropic => grad.push(dl.sum()),
        KernelKind::Ard => grad.extend(dl),
    }
    grad.push(sn2 * d_sn2);
    grad.iter_mut().for_each(|g| *g = -*g / nf);
    Ok((-bound / nf, grad))
}

/// Column `c` of a column-major matrix as a slice.
fn col(k: &Mat<f64>, c: usize) -> &[f64] {
    k.col(c).try_as_col_major().unwrap().as_slice()
}

/// A fitted sparse (VFE) GP for one output, on standardised inputs and target.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(into = "SparseGpData", try_from = "SparseGpData")]
pub struct SparseGp {
    data: SparseGpData,
    /// Inducing inputs divided by the length-scales, row-major m x d.
    zs: Vec<f64>,
    /// L_uu packed by columns (see `pack_lower`).
    luu_cols: Vec<f64>,
    /// T = L_uu^-1 L_S, lower triangular with T T^T = B^-1, packed by columns.
    t_cols: Vec<f64>,
    /// K_uu^-1 μ_u.
    w: Vec<f64>,
    /// Jitter added to K_uu beyond the fixed relative one.
    jitter: f64,
}

/// What a [`SparseGp`] stores in a model file: hyperparameters, inducing
/// inputs and the posterior q(u) = N(q_mean, L_S L_S^T). The factors used for
/// prediction are recomputed (and so re-checked) on load.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SparseGpData {
    /// Kernel hyperparameters.
    pub hyper: SeHyper,
    /// Input dimension.
    pub dim: usize,
    /// Standardised inducing inputs, row-major m x dim.
    pub inducing: Vec<f64>,
    /// Posterior mean of the inducing outputs, μ_u (m).
    pub q_mean: Vec<f64>,
    /// Lower-triangular Cholesky factor L_S of the posterior covariance S_u,
    /// packed column by column (column j holds L_S[j..m, j]).
    pub q_cov_chol: Vec<f64>,
    /// Number of training rows q(u) was conditioned on.
    pub n_fit: usize,
}

impl From<SparseGp> for SparseGpData {
    fn from(gp: SparseGp) -> Self {
        gp.data
    }
}

impl TryFrom<SparseGpData> for SparseGp {
    type Error = GpError;
    fn try_from(data: SparseGpData) -> Result<Self, Self::Error> {
        let bad = |what: String| Err(GpError::InvalidSparse(what));
        let d = data.dim;
        let m = data.q_mean.len();
        if d == 0 || m == 0 {
            return bad(format!(
                "dim = {d} and {m} inducing points: both must be positive"
            ));
        }
        check_hyper(&data.hyper, d)?;
        if data.inducing.len() != m * d {
            return bad(format!(
                "{} inducing values, expected {m} points x {d} inputs",
                data.inducing.len()
            ));
        }
        if data.q_cov_chol.len() != m * (m + 1) / 2 {
            return bad(format!(
                "{} covariance-factor values, expected m (m + 1) / 2 = {} for m = {m}",
                data.q_cov_chol.len(),
                m * (m + 1) / 2
            ));
        }
        for (name, v) in [
            ("inducing", &data.inducing),
            ("q_mean", &data.q_mean),
            ("q_cov_chol", &data.q_cov_chol),
        ] {
            if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                return bad(format!("{name}[{i}] is not finite"));
            }
        }
        let ls = unpack_lower(&data.q_cov_chol, m);
        if let Some(i) = (0..m).find(|&i| ls[(i, i)] <= 0.0) {
            return bad(format!(
                "q_cov_chol has a non-positive diagonal entry at {i}"
            ));
        }
        if data.n_fit == 0 {
            return bad("n_fit = 0".into());
        }
        let zs = scale_rows(&data.inducing, &data.hyper.lengthscales);
        let (luu, _, jitter) = kuu_factor(&zs, d, &data.hyper)?;
        let mut t = ls;
        solve_lower_triangular_in_place(luu.L(), t.as_mut(), Par::rayon(0));
        let mut w = Mat::from_fn(m, 1, |i, _| data.q_mean[i]);
        luu.solve_in_place(w.as_mut());
        let gp = SparseGp {
            zs,
            luu_cols: pack_lower(luu.L()),
            t_cols: pack_lower(t.as_ref()),
            w: w.col(0).iter().copied().collect(),
            jitter,
            data,
        };
        if gp.w.iter().chain(&gp.t_cols).any(|v| !v.is_finite()) {
            return bad("the posterior is not finite given K_uu".into());
        }
        Ok(gp)
    }
}

impl SparseGp {
    /// Conditions q(u) on all of `x` (row-major n x dim) and `y`, both
    /// standardised, with fixed hyperparameters and inducing inputs `z`
    /// (row-major m x dim): the optimal q(u) of Titsias (2009). Time
    /// O(n m^2 + n m d), memory O(m^2 + m x 4096).
    pub fn fit(
        x: &[f64],
        dim: usize,
        y: &[f64],
        z: &[f64],
        hyper: SeHyper,
    ) -> Result<Self, GpError> {
        super::exact::check_data(x, dim, y)?;
        check_hyper(&hyper, dim)?;
        check_inducing(z, dim)?;
        let m = z.len() / dim;
        let par = Par::rayon(0);
        let zs = scale_rows(z, &hyper.lengthscales);
        let (luu, _, jitter) = kuu_factor(&zs, dim, &hyper)?;
        if jitter > 0.0 {
            tracing::warn!(
                m,
                jitter,
                "K_uu needed extra jitter: near-duplicate inducing inputs?"
            );
        }
        let mut b = Mat::<f64>::identity(m, m);
        let mut ay = Mat::<f64>::zeros(m, 1);
        for (xb, yb) in x.chunks(BLOCK * dim).zip(y.chunks(BLOCK)) {
            let xs = scale_rows(xb, &hyper.lengthscales);
            let (_, a) = projection(&zs, &xs, dim, &hyper, luu.L());
            accumulate(a.as_ref(), yb, &mut b, &mut ay);
        }
        let (lb, c) = b_factor(&b, &ay, &hyper)?;
        // μ_u = L_uu L_B^-T c; L_S = L_uu chol(B^-1), lower triangular.
        let mut mu = c;
        solve_upper_triangular_in_place(lb.L().transpose(), mu.as_mut(), par);
        let mu = luu.L() * mu;
        let t = lb
            .inverse()
            .llt(Side::Lower)
            .map_err(|_| GpError::NotPositiveDefinite {
                n: m,
                jitter,
                signal_var: hyper.signal_var,
                noise_var: hyper.noise_var,
            })?;
        let ls = luu.L() * t.L();
        SparseGp::try_from(SparseGpData {
            hyper,
            dim,
            inducing: z.to_vec(),
            q_mean: mu.col(0).iter().copied().collect(),
            q_cov_chol: pack_lower(ls.as_ref()),
            n_fit: y.len(),
        })
    }

    /// Number of inducing points m.
    pub fn n_inducing(&self) -> usize {
        self.w.len()
    }

    /// Number of training rows q(u) was conditioned on.
    pub fn n_fit(&self) -> usize {
        self.data.n_fit
    }

    /// Input dimension.
    pub fn dim(&self) -> usize {
        self.data.dim
    }

    /// Hyperparameters.
    pub fn hyper(&self) -> &SeHyper {
        &self.data.hyper
    }

    /// Standardised inducing inputs, row-major m x dim.
    pub fn inducing(&self) -> &[f64] {
        &self.data.inducing
    }

    /// Jitter added to K_uu beyond the fixed 1e-8 s2 (0 when none was needed).
    pub fn jitter(&self) -> f64 {
        self.jitter
    }

    /// Mean and latent variance at one standardised input, without allocating.
    ///
    /// Cost: O(m d) for the mean, O(m^2) for the variance (one forward
    /// substitution with L_uu, one triangular product). `with_var = false`
    /// skips the variance (returns 0). `ws` must have room for m points.
    pub fn predict_one(&self, z: &[f64], ws: &mut GpWorkspace, with_var: bool) -> (f64, f64) {
        let k = cross_one(&self.zs, &self.data.hyper, z, ws);
        let mean = dot(k, &self.w);
        if !with_var {
            return (mean, 0.0);
        }
        // v = L_uu^-1 k; |T^T v|^2 = Σ_j (T[j.., j] . v[j..])^2.
        forward_subst_packed(&self.luu_cols, k);
        let m = k.len();
        let mut start = 0;
        let mut explained = 0.0;
        for j in 0..m {
            let tv = dot(&self.t_cols[start..start + m - j], &k[j..]);
            explained += tv * tv;
            start += m - j;
        }
        let s2 = self.data.hyper.signal_var;
        (mean, clamp_var(s2 - dot(k, k) + explained, s2))
    }

    /// Means and latent variances at many standardised inputs (row-major
    /// rows x dim), by blocks of matrix products and triangular solves.
    pub fn predict(&self, z: &[f64], with_var: bool) -> (Vec<f64>, Vec<f64>) {
        let (d, m) = (self.data.dim, self.n_inducing());
        let hyper = &self.data.hyper;
        let s2 = hyper.signal_var;
        let rows = z.len() / d;
        let mut means = Vec::with_capacity(rows);
        let mut vars = Vec::with_capacity(rows);
        let factors = with_var.then(|| {
            (
                unpack_lower(&self.luu_cols, m),
                unpack_lower(&self.t_cols, m),
            )
        });
        for chunk in z.chunks(BLOCK * d) {
            let zs = scale_rows(chunk, &hyper.lengthscales);
            let mut kt = se_cross(&self.zs, &zs, d, s2); // m x b
            means.extend((0..kt.ncols()).map(|c| dot(col(&kt, c), &self.w)));
            if let Some((luu, t)) = &factors {
                solve_lower_triangular_in_place(luu.as_ref(), kt.as_mut(), Par::rayon(0));
                let tv = t.transpose() * &kt;
                for c in 0..kt.ncols() {
                    let (v, e) = (col(&kt, c), col(&tv, c));
                    vars.push(clamp_var(s2 - dot(v, v) + dot(e, e), s2));
                }
            } else {
                vars.extend(std::iter::repeat_n(0.0, kt.ncols()));
            }
        }
        (means, vars)
    }
}

#[cfg(test)]
mod tests;
