//! The VFE bound of Titsias (2009) and its gradient with respect to the
//! hyperparameters, the inducing inputs held fixed: what a sparse GP's
//! hyperparameter search minimises.

use faer::linalg::matmul::matmul;
use faer::linalg::solvers::{DenseSolveCore, Llt};
use faer::linalg::triangular_solve::solve_upper_triangular_in_place;
use faer::{Accum, Mat, MatRef, Par};
use rayon::prelude::*;

use super::{accumulate, b_factor, check_inducing, kuu_factor, projection, BLOCK, KUU_JITTER};
use crate::learn::models::gp::exact::{check_hyper, dot};
use crate::learn::models::gp::kernel::{scale_rows, KernelKind, SeHyper};
use crate::learn::models::gp::GpError;

/// Negative VFE bound per sample, `-F / n`, and its gradient with respect to
/// the log-hyperparameters `hyper.to_log()` (same packing and sign as
/// [`neg_lml_and_grad`](crate::learn::models::gp::exact::neg_lml_and_grad)), for inputs `x`
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

    let (alpha, u) = alpha_and_u(y, &a, &lb, c, luu, sn2);
    // H = L_uu^-T (I - B^-1) / σ.
    let binv = lb.inverse();
    let tr_binv: f64 = (0..m).map(|i| binv[(i, i)]).sum();
    let mut h = Mat::<f64>::from_fn(m, m, |i, j| (f64::from(i == j) - binv[(i, j)]) / sigma);
    solve_upper_triangular_in_place(luu.transpose(), h.as_mut(), par);
    let r = r_matrix(&b, &binv, luu, &u);
    let posterior = Posterior {
        h: &h,
        a: &a,
        u: &u,
        alpha: &alpha,
        kuf: &kuf,
    };
    let (sum_m, dl_f) = kuf_term(&posterior, &xs, &zs, d);
    let (sum_n, half_dl_u) = kuu_term(&r, &kuu, &zs, d, s2);

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

/// α = C^-1 y and u = K_uu^-1 K_uf α, from A, L_B and c = L_B^-1 A y / σ.
fn alpha_and_u(
    y: &[f64],
    a: &Mat<f64>,
    lb: &Llt<f64>,
    c: Mat<f64>,
    luu: MatRef<'_, f64>,
    sn2: f64,
) -> (Mat<f64>, Mat<f64>) {
    // α = y / σ² - A^T (L_B^-T c) / σ.
    let par = Par::rayon(0);
    let sigma = sn2.sqrt();
    let mut g = c;
    solve_upper_triangular_in_place(lb.L().transpose(), g.as_mut(), par);
    let mut alpha = Mat::<f64>::from_fn(y.len(), 1, |i, _| y[i] / sn2);
    matmul(
        alpha.as_mut(),
        Accum::Add,
        a.transpose(),
        g.as_ref(),
        -1.0 / sigma,
        par,
    );
    // u = K_uu^-1 K_uf α = σ L_uu^-T A α.
    let mut u = Mat::<f64>::zeros(a.nrows(), 1);
    matmul(
        u.as_mut(),
        Accum::Replace,
        a.as_ref(),
        alpha.as_ref(),
        sigma,
        par,
    );
    solve_upper_triangular_in_place(luu.transpose(), u.as_mut(), par);
    (alpha, u)
}

/// R = u u^T + L_uu^-T (B - 2I + B^-1) L_uu^-1 (symmetric).
fn r_matrix(b: &Mat<f64>, binv: &Mat<f64>, luu: MatRef<'_, f64>, u: &Mat<f64>) -> Mat<f64> {
    let par = Par::rayon(0);
    let m = b.nrows();
    let mut r = Mat::<f64>::from_fn(m, m, |i, j| {
        b[(i, j)] + binv[(i, j)] - 2.0 * f64::from(i == j)
    });
    solve_upper_triangular_in_place(luu.transpose(), r.as_mut(), par);
    let mut r = r.transpose().to_owned();
    solve_upper_triangular_in_place(luu.transpose(), r.as_mut(), par);
    matmul(r.as_mut(), Accum::Add, u.as_ref(), u.transpose(), 1.0, par);
    r
}

/// What P = u α^T + H A is made of (m x n, built by blocks of columns), with
/// K_uf.
struct Posterior<'a> {
    h: &'a Mat<f64>,
    a: &'a Mat<f64>,
    u: &'a Mat<f64>,
    alpha: &'a Mat<f64>,
    kuf: &'a Mat<f64>,
}

/// Σ P ∘ dK_uf for ln s2 and per scaled input c, by blocks of columns, for
/// scaled rows `xs` and inducing rows `zs`. With M = P ∘ K_uf: Σ M, and
/// Σ_ij M_ij (z_ic - x_jc)^2 = Σ_i rowsum_i z_ic^2 + Σ_j colsum_j x_jc^2
/// - 2 Σ_i z_ic (M x)_ic.
fn kuf_term(p: &Posterior, xs: &[f64], zs: &[f64], d: usize) -> (f64, Vec<f64>) {
    let par = Par::rayon(0);
    let (m, n) = (p.a.nrows(), p.a.ncols());
    let zs_m = MatRef::from_row_major_slice(zs, m, d);
    let mut row_sums = vec![0.0; m];
    let mut col_term = vec![0.0; d];
    let mut mx = Mat::<f64>::zeros(m, d);
    let mut pb = Mat::<f64>::zeros(m, BLOCK.min(n));
    for j0 in (0..n).step_by(BLOCK) {
        let w = BLOCK.min(n - j0);
        let mut block = pb.as_mut().subcols_mut(0, w);
        matmul(
            block.as_mut(),
            Accum::Replace,
            p.h.as_ref(),
            p.a.as_ref().subcols(j0, w),
            1.0,
            par,
        );
        let alpha_b = p.alpha.as_ref().subrows(j0, w);
        matmul(
            block.as_mut(),
            Accum::Add,
            p.u.as_ref(),
            alpha_b.transpose(),
            1.0,
            par,
        );
        let kuf_b = p.kuf.as_ref().subcols(j0, w);
        let col_sums: Vec<f64> = block
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
                *rs += block[(i, jj)];
            }
            let row = &xs[(j0 + jj) * d..(j0 + jj + 1) * d];
            for (t, v) in col_term.iter_mut().zip(row) {
                *t += col_sums[jj] * v * v;
            }
        }
        let xs_b = MatRef::from_row_major_slice(&xs[j0 * d..(j0 + w) * d], w, d);
        matmul(mx.as_mut(), Accum::Add, block.as_ref(), xs_b, 1.0, par);
    }
    let dl_f = (0..d)
        .map(|c| {
            col_term[c]
                + (0..m)
                    .map(|i| row_sums[i] * zs_m[(i, c)].powi(2) - 2.0 * zs_m[(i, c)] * mx[(i, c)])
                    .sum::<f64>()
        })
        .collect();
    (row_sums.iter().sum(), dl_f)
}

/// 1/2 tr(R dK_uu) with N = R ∘ K_uu (symmetric): for ln s2, Σ N plus the
/// s2-proportional jitter; per scaled input c, 1/2 Σ_ij N_ij (z_ic - z_jc)^2
/// = Σ_i rowsum_i z_ic^2 - z_c^T N z_c.
fn kuu_term(r: &Mat<f64>, kuu: &Mat<f64>, zs: &[f64], d: usize, s2: f64) -> (f64, Vec<f64>) {
    let m = r.nrows();
    let zs_m = MatRef::from_row_major_slice(zs, m, d);
    let nmat = Mat::<f64>::from_fn(m, m, |i, j| r[(i, j)] * kuu[(i, j)]);
    let tr_r: f64 = (0..m).map(|i| r[(i, i)]).sum();
    let n_rows: Vec<f64> = (0..m).map(|i| nmat.row(i).iter().sum()).collect();
    let mut nz = Mat::<f64>::zeros(m, d);
    matmul(
        nz.as_mut(),
        Accum::Replace,
        nmat.as_ref(),
        zs_m,
        1.0,
        Par::rayon(0),
    );
    let half_dl_u = (0..d)
        .map(|c| {
            (0..m)
                .map(|i| zs_m[(i, c)] * (n_rows[i] * zs_m[(i, c)] - nz[(i, c)]))
                .sum()
        })
        .collect();
    (
        n_rows.iter().sum::<f64>() + KUU_JITTER * s2 * tr_r,
        half_dl_u,
    )
}
