//! Choosing training rows or inducing points from standardised inputs
//! (row-major n x d).
//!
//! - [`greedy_variance`]: greedy conditional-variance selection, i.e. the
//!   pivoted (partial) Cholesky factorisation of K_f (Fine & Scheinberg 2001).
//!   Burt, Rasmussen & van der Wilk (2019, "Rates of convergence for sparse
//!   variational GP regression") use it to place inducing points.
//! - [`farthest_point`]: greedy k-center (farthest-point) selection in
//!   length-scale-scaled space (Gonzalez 1985), a 2-approximation of the
//!   smallest covering radius. Cheap enough for a whole data set.

use rayon::prelude::*;

use super::kernel::{exp_kernel, SeHyper};

/// Below this fraction of the signal variance the remaining prior variance
/// counts as zero: every other row (nearly) duplicates a chosen one.
const MIN_REL_VARIANCE: f64 = 1e-12;

/// Rows of the pivoted Cholesky factorisation of a row block processed by one
/// rayon task.
const ROWS_PER_TASK: usize = 256;

/// Picks up to `m` rows of `x` (n x d) greedily: each step takes the row with
/// the largest prior variance conditional on the rows already taken (SE
/// kernel `hyper`, noise-free), which is the pivot of a partial Cholesky
/// factorisation of K_f (Fine & Scheinberg 2001; Burt et al. 2019).
///
/// Returns the indices in the order picked; the first is row 0 (all prior
/// variances are equal, ties go to the lowest index). Stops early when the
/// largest remaining variance is below 1e-12 s2 (the rest duplicate chosen
/// rows). `m >= n` returns at most n rows. O(n m^2 + n m d) time, O(n m) memory.
pub fn greedy_variance(x: &[f64], d: usize, hyper: &SeHyper, m: usize) -> Vec<usize> {
    let n = x.len() / d;
    let m = m.min(n);
    let s2 = hyper.signal_var;
    let inv_l: Vec<f64> = hyper.lengthscales.iter().map(|l| 1.0 / l).collect();
    // Remaining variances (chosen rows: -inf) and the factor's rows, n x m.
    let mut var = vec![s2; n];
    let mut l = vec![0.0; n * m];
    let mut chosen = Vec::with_capacity(m);
    for k in 0..m {
        let (p, vp) = argmax(&var);
        if vp.is_nan() || vp <= MIN_REL_VARIANCE * s2 {
            break;
        }
        chosen.push(p);
        let xp = &x[p * d..(p + 1) * d];
        let lp: Vec<f64> = l[p * m..p * m + k].to_vec();
        let sp = vp.sqrt();
        l.par_chunks_mut(m * ROWS_PER_TASK)
            .zip(var.par_chunks_mut(ROWS_PER_TASK))
            .zip(x.par_chunks(d * ROWS_PER_TASK))
            .for_each(|((lb, vb), xb)| {
                for ((row, v), xi) in lb.chunks_exact_mut(m).zip(vb).zip(xb.chunks_exact(d)) {
                    if *v == f64::NEG_INFINITY {
                        continue;
                    }
                    let kip = s2 * exp_kernel(-0.5 * scaled_sq_dist(xi, xp, &inv_l));
                    let proj: f64 = row[..k].iter().zip(&lp).map(|(a, b)| a * b).sum();
                    let lik = (kip - proj) / sp;
                    row[k] = lik;
                    *v -= lik * lik;
                }
            });
        var[p] = f64::NEG_INFINITY;
    }
    chosen
}

/// |(a - b) / l|^2, given 1 / l.
fn scaled_sq_dist(a: &[f64], b: &[f64], inv_l: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .zip(inv_l)
        .map(|((a, b), il)| ((a - b) * il).powi(2))
        .sum()
}

/// Index and value of the largest entry; ties go to the lowest index.
fn argmax(v: &[f64]) -> (usize, f64) {
    v.par_iter()
        .enumerate()
        .map(|(i, &x)| (i, x))
        .reduce(|| (usize::MAX, f64::NEG_INFINITY), pick_larger)
}

/// The larger of two (index, value) pairs, the lower index on a tie: an
/// associative choice, so a parallel reduction is deterministic.
fn pick_larger(a: (usize, f64), b: (usize, f64)) -> (usize, f64) {
    if b.1 > a.1 || (b.1 == a.1 && b.0 < a.0) {
        b
    } else {
        a
    }
}

/// Picks up to `m` rows of `x` (n x d) by greedy k-center (farthest-point)
/// selection with the distance |(a - b) / l|, `l` the length-scales: each
/// step takes the row farthest from the rows already taken.
///
/// The first row is row 0; ties go to the lowest index. Returns the indices
/// in the order picked, distinct (duplicated inputs are picked once every
/// distinct row is in); `m >= n` returns every row. O(n m d) time, O(n) memory.
pub fn farthest_point(x: &[f64], d: usize, lengthscales: &[f64], m: usize) -> Vec<usize> {
    let n = x.len() / d;
    let m = m.min(n);
    let inv_l: Vec<f64> = lengthscales.iter().map(|l| 1.0 / l).collect();
    // Squared scaled distance of each row to the nearest chosen row; -inf once chosen.
    let mut dist = vec![f64::INFINITY; n];
    let mut chosen = Vec::with_capacity(m);
    let mut p = 0;
    for _ in 0..m {
        chosen.push(p);
        dist[p] = f64::NEG_INFINITY;
        let xp = &x[p * d..(p + 1) * d];
        p = dist
            .par_iter_mut()
            .zip(x.par_chunks_exact(d))
            .enumerate()
            .map(|(i, (di, xi))| {
                if *di != f64::NEG_INFINITY {
                    *di = di.min(scaled_sq_dist(xi, xp, &inv_l));
                }
                (i, *di)
            })
            .reduce(|| (usize::MAX, f64::NEG_INFINITY), pick_larger)
            .0;
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::super::KernelKind;
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_x(n: usize, d: usize, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n * d).map(|_| rng.random_range(-2.0..2.0)).collect()
    }

    fn iso(l: f64, d: usize) -> SeHyper {
        SeHyper {
            kind: KernelKind::Isotropic,
            signal_var: 1.3,
            lengthscales: vec![l; d],
            noise_var: 0.01,
        }
    }

    fn assert_distinct_in_range(idx: &[usize], n: usize) {
        let mut s = idx.to_vec();
        s.sort_unstable();
        s.dedup();
        assert_eq!(s.len(), idx.len(), "repeated indices in {idx:?}");
        assert!(idx.iter().all(|&i| i < n));
    }

    #[test]
    fn selections_are_distinct_in_range_and_capped_at_n() {
        let x = random_x(300, 3, 1);
        let g = greedy_variance(&x, 3, &iso(0.8, 3), 40);
        let f = farthest_point(&x, 3, &[0.5, 1.0, 2.0], 40);
        for idx in [&g, &f] {
            assert_eq!(idx.len(), 40);
            assert_eq!(idx[0], 0);
            assert_distinct_in_range(idx, 300);
        }
        let x = random_x(12, 2, 2);
        let mut g = greedy_variance(&x, 2, &iso(0.5, 2), 50);
        let mut f = farthest_point(&x, 2, &[1.0, 1.0], 50);
        g.sort_unstable();
        f.sort_unstable();
        assert_eq!(g, (0..12).collect::<Vec<_>>());
        assert_eq!(f, (0..12).collect::<Vec<_>>());
    }

    #[test]
    fn greedy_variance_stops_at_duplicates() {
        // Three distinct points, each repeated four times.
        let base = [0.0, 0.0, 3.0, 0.0, 0.0, 3.0];
        let x: Vec<f64> = (0..12)
            .flat_map(|i| base[2 * (i % 3)..2 * (i % 3) + 2].to_vec())
            .collect();
        let g = greedy_variance(&x, 2, &iso(1.0, 2), 10);
        assert_eq!(g, vec![0, 1, 2]);
        // Farthest-point still returns distinct indices, distinct rows first.
        let f = farthest_point(&x, 2, &[1.0, 1.0], 5);
        assert_distinct_in_range(&f, 12);
        let mut first: Vec<usize> = f[..3].iter().map(|i| i % 3).collect();
        first.sort_unstable();
        assert_eq!(first, vec![0, 1, 2]);
    }

    #[test]
    fn greedy_variance_spreads_points_on_a_line() {
        // 101 points on [0, 10], l = 3: the first pick is 0, the second the
        // far end, the third near the middle, and none bunch up.
        let x: Vec<f64> = (0..=100).map(|i| i as f64 / 10.0).collect();
        let g = greedy_variance(&x, 1, &iso(3.0, 1), 6);
        assert_eq!(&g[..2], &[0, 100]);
        assert!((45..=55).contains(&g[2]), "{g:?}");
        let mut s: Vec<f64> = g.iter().map(|&i| x[i]).collect();
        s.sort_by(f64::total_cmp);
        let min_gap = s.windows(2).map(|w| w[1] - w[0]).fold(f64::MAX, f64::min);
        assert!(min_gap > 1.0, "picks {s:?} bunch up");
    }

    #[test]
    fn farthest_point_matches_brute_force_and_its_radius_shrinks() {
        let (n, d) = (200, 3);
        let x = random_x(n, d, 3);
        let ls = [0.5, 1.0, 2.0];
        let dist2 = |i: usize, j: usize| -> f64 {
            (0..d)
                .map(|c| ((x[i * d + c] - x[j * d + c]) / ls[c]).powi(2))
                .sum()
        };
        let picks = farthest_point(&x, d, &ls, 30);
        // Brute force: recompute every nearest distance from scratch per step.
        let mut reference = vec![0];
        let mut radii = Vec::new();
        while reference.len() < 30 {
            let near = |i: usize| {
                reference
                    .iter()
                    .map(|&j| dist2(i, j))
                    .fold(f64::MAX, f64::min)
            };
            let (best, r) = (0..n)
                .filter(|i| !reference.contains(i))
                .map(|i| (i, near(i)))
                .fold((usize::MAX, -1.0), |a, b| if b.1 > a.1 { b } else { a });
            radii.push(r);
            reference.push(best);
        }
        assert_eq!(picks, reference);
        assert!(radii.windows(2).all(|w| w[1] <= w[0]), "{radii:?}");
        assert!(radii[28] < 0.5 * radii[0]);
    }
}
