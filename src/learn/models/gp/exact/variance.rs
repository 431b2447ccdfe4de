//! The exact GP's latent variance, conditioned on the training rows near
//! the point: the rows are covered by overlapping clusters of at most
//! [`VARIANCE_ROWS`], each with the Cholesky factor of its own K + sn2 I,
//! and a point's variance is the exact posterior variance given the
//! cluster whose centre is nearest it (same hyperparameters, noise and
//! jitter). Conditioning on fewer rows never lowers the variance, so it is
//! never below the one given every row; with n <= [`VARIANCE_ROWS`] the
//! one cluster is every row and the variance is exact (but for the
//! rounding margin below). Per point: O(K d)
//! to find the cluster and O(m^2) for the variance, against O(n^2).
//!
//! The factors are kept in single precision (the substitution runs in
//! double): an estimate's variance is bound by reading them from memory,
//! and half the bytes took an exact GP on 4000 rows from p99 1059 µs to
//! about 500 (docs/results.md, "Estimate time per candidate"). What the
//! rounding may take from a variance is added back ([`ROUNDING_MARGIN`]).
//!
//! One subset for every point is no substitute: the posterior variance at
//! a point is set by the many rows near it. On another lab's robotic
//! finger (train on recording 1, test on 2; docs/results.md), conditioning
//! on 500 or 750 of 2000 or 4000 rows chosen once (greedy variance, as for
//! inducing points), or a sparse GP's variance with those rows as inducing
//! points, raised the 2-sigma coverage by 0.02 to 0.10; the 1000 rows
//! nearest each point gave the std of a measured target within 2 %
//! (median) of the exact GP's.

use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{MatRef, Par};

use super::{
    cholesky_with_jitter, clamp_var, dot, forward_subst_packed, pack_lower, rows_of, unpack_lower,
};
use crate::learn::models::gp::kernel::{se_cross, se_gram, SeHyper};
use crate::learn::models::gp::select::farthest_point;
use crate::learn::models::gp::GpError;

/// Most training rows a variance is conditioned on (m). At 1000 the
/// 2-sigma coverage on the real recordings moved by at most 0.016 from the
/// exact GP's (docs/results.md, "Estimate time per candidate"), at 850 by
/// 0.017, at 700 by 0.020; and the exact GP on 1000 rows, a candidate of
/// `train --select`, stays exact (but for a rounding margin). Three axes'
/// variances read 6 MB of factors an estimate.
pub const VARIANCE_ROWS: usize = 1000;

/// What a variance from a factor in single precision adds, per unit of
/// signal variance, so that it is never below the variance in double
/// precision: four unit roundoffs of single precision (4.8e-7). The
/// rounding moved the variance by at most 1.3 of them (1000 rows, noise
/// from 0.1 down to the fit's floor of 1e-6; tests); the standard
/// deviation grows by at most 7e-4 of the signal's.
const ROUNDING_MARGIN: f64 = 4.0 * f32::EPSILON as f64;

/// Clusters a training row is in, on average: K = ceil(COVER n / m), so
/// that a point near the edge of one cluster's cell is still well inside
/// another's rows.
const COVER: usize = 2;

/// Lloyd (k-means) iterations that move the centres from their
/// farthest-point start (which picks outlying rows) to their cells' means.
const LLOYD_ITERS: usize = 10;

/// The clusters of an exact GP's training rows and their factors, built
/// when the GP is conditioned.
#[derive(Debug, Clone)]
pub(super) struct LocalVariance {
    /// Centres in scaled inputs, row-major K x d.
    centres: Vec<f64>,
    clusters: Vec<Cluster>,
}

#[derive(Debug, Clone)]
struct Cluster {
    /// Its training rows, ascending.
    rows: Vec<usize>,
    /// The Cholesky factor of its K + (sn2 + jitter) I, packed by columns,
    /// in single precision.
    l_cols: Vec<f32>,
}

impl LocalVariance {
    /// The clusters of scaled training rows `xs` (n x `d`) of at most `m`
    /// rows, with the noise `noise` (sn2 plus the jitter the whole factor
    /// `full` needed); with n <= m, `full` is the one cluster's factor.
    pub(super) fn new(
        xs: &[f64],
        d: usize,
        hyper: &SeHyper,
        noise: f64,
        full: MatRef<'_, f64>,
        m: usize,
    ) -> Result<Self, GpError> {
        let n = xs.len() / d;
        if n <= m {
            return Ok(LocalVariance {
                centres: xs[..d].to_vec(),
                clusters: vec![Cluster {
                    rows: (0..n).collect(),
                    l_cols: single(pack_lower(full)),
                }],
            });
        }
        let (centres, members) = clusters(xs, d, (COVER * n).div_ceil(m), m);
        let clusters = members
            .into_iter()
            .map(|rows| {
                let k = se_gram(&rows_of(xs, d, &rows), d, hyper.signal_var);
                let (llt, _) = cholesky_with_jitter(&k, noise, hyper)?;
                Ok(Cluster {
                    rows,
                    l_cols: single(pack_lower(llt.L())),
                })
            })
            .collect::<Result<_, GpError>>()?;
        Ok(LocalVariance { centres, clusters })
    }

    /// The cluster whose centre is nearest the scaled point `zs`.
    fn nearest(&self, zs: &[f64]) -> &Cluster {
        &self.clusters[nearest(&self.centres, zs)]
    }

    /// The latent variance at the scaled point `zs`, from its kernel values
    /// `k` against every training row (used as scratch), without
    /// allocating; `s2` the signal variance.
    pub(super) fn at(&self, zs: &[f64], k: &mut [f64], s2: f64) -> f64 {
        let c = self.nearest(zs);
        // Rows ascending: row r >= i, so k[r] is read before it is written.
        for (i, &r) in c.rows.iter().enumerate() {
            k[i] = k[r];
        }
        let v = &mut k[..c.rows.len()];
        forward_subst_packed(&c.l_cols, v);
        with_margin(s2 - dot(v, v), s2)
    }

    /// [`LocalVariance::at`] of many scaled points `zs` (row-major, `d` a
    /// row), `xs` the scaled training rows: per cluster, one cross-covariance
    /// and one blocked triangular solve of the points nearest it.
    pub(super) fn at_many(&self, xs: &[f64], zs: &[f64], d: usize, s2: f64) -> Vec<f64> {
        /// Points per block: bounds the m x block cross-covariance.
        const BLOCK: usize = 1024;
        let owner: Vec<usize> = (zs.chunks_exact(d))
            .map(|z| nearest(&self.centres, z))
            .collect();
        let mut vars = vec![0.0; owner.len()];
        for (j, c) in self.clusters.iter().enumerate() {
            let points: Vec<usize> = (0..owner.len()).filter(|&p| owner[p] == j).collect();
            if points.is_empty() {
                continue;
            }
            let rows = rows_of(xs, d, &c.rows);
            let l = unpack_lower(&c.l_cols, c.rows.len());
            for block in points.chunks(BLOCK) {
                let mut kt = se_cross(&rows, &rows_of(zs, d, block), d, s2);
                solve_lower_triangular_in_place(l.as_ref(), kt.as_mut(), Par::rayon(0));
                for (col, &p) in kt.col_iter().zip(block) {
                    let v: f64 = col.iter().map(|v| v * v).sum();
                    vars[p] = with_margin(s2 - v, s2);
                }
            }
        }
        vars
    }
}

/// The variance `var` from a factor in single precision (non-finite: `s2`,
/// the signal variance) plus [`ROUNDING_MARGIN`] `s2`, at most `s2`.
fn with_margin(var: f64, s2: f64) -> f64 {
    (clamp_var(var, s2) + ROUNDING_MARGIN * s2).min(s2)
}

/// `v` in single precision.
fn single(v: Vec<f64>) -> Vec<f32> {
    v.into_iter().map(|v| v as f32).collect()
}

/// |a - b|^2.
fn sq_dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(a, b)| (a - b) * (a - b)).sum()
}

/// Index of the centre (row-major, `z.len()` a row) nearest `z`; the
/// lowest on a tie.
fn nearest(centres: &[f64], z: &[f64]) -> usize {
    let dists = centres.chunks_exact(z.len()).map(|c| sq_dist(c, z));
    let (best, _) = dists.enumerate().fold(
        (0, f64::INFINITY),
        |b, (j, v)| if v < b.1 { (j, v) } else { b },
    );
    best
}

/// `k` overlapping clusters of `m` of the scaled rows `xs` (n x `d`, n > m):
/// centres from farthest-point selection, moved by Lloyd iterations; the
/// cluster of a centre holds its cell (the rows nearest it) first, nearest
/// first, then the nearest other rows, `m` in all, ascending. Returns the
/// centres (row-major k x d) and the clusters' rows.
fn clusters(xs: &[f64], d: usize, k: usize, m: usize) -> (Vec<f64>, Vec<Vec<usize>>) {
    let mut centres = rows_of(xs, d, &farthest_point(xs, d, &vec![1.0; d], k));
    let owners = |c: &[f64]| -> Vec<usize> { xs.chunks_exact(d).map(|r| nearest(c, r)).collect() };
    for _ in 0..LLOYD_ITERS {
        let owner = owners(&centres);
        let mut sums = vec![0.0; centres.len()];
        let mut counts = vec![0usize; k];
        for (row, &o) in xs.chunks_exact(d).zip(&owner) {
            counts[o] += 1;
            sums[o * d..(o + 1) * d]
                .iter_mut()
                .zip(row)
                .for_each(|(s, v)| *s += v);
        }
        for ((c, s), &count) in centres
            .chunks_exact_mut(d)
            .zip(sums.chunks_exact(d))
            .zip(&counts)
        {
            if count > 0 {
                c.iter_mut().zip(s).for_each(|(c, s)| *c = s / count as f64);
            }
        }
    }
    let owner = owners(&centres);
    let n = owner.len();
    let members = (centres.chunks_exact(d).enumerate())
        .map(|(j, c)| {
            let key = |i: usize| (owner[i] != j, sq_dist(&xs[i * d..(i + 1) * d], c));
            let mut rows: Vec<usize> = (0..n).collect();
            rows.sort_by(|&a, &b| {
                let (ka, kb) = (key(a), key(b));
                ka.0.cmp(&kb.0).then(ka.1.total_cmp(&kb.1))
            });
            rows.truncate(m);
            rows.sort_unstable();
            rows
        })
        .collect();
    (centres, members)
}
