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
use super::kernel::{scale_cols, scale_rows, se_cross, se_gram, SeHyper};
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

/// Column `c` of a column-major matrix as a slice.
fn col(k: &Mat<f64>, c: usize) -> &[f64] {
    k.col(c).try_as_col_major().unwrap().as_slice()
}

/// A fitted sparse (VFE) GP for one output, on standardised inputs and target.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(into = "SparseGpData", try_from = "SparseGpData")]
pub struct SparseGp {
    data: SparseGpData,
    /// Inducing inputs divided by the length-scales, column by column
    /// (d x m, `scale_cols`).
    zs_cols: Vec<f64>,
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
            zs_cols: scale_cols(&data.inducing, &data.hyper.lengthscales),
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
        let k = cross_one(&self.zs_cols, &self.data.hyper, z, ws);
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
        let inducing = scale_rows(&self.data.inducing, &hyper.lengthscales);
        for chunk in z.chunks(BLOCK * d) {
            let zs = scale_rows(chunk, &hyper.lengthscales);
            let mut kt = se_cross(&inducing, &zs, d, s2); // m x b
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

mod vfe;

pub use vfe::neg_vfe_and_grad;

#[cfg(test)]
mod tests;
