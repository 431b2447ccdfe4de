use super::super::KernelKind;
use super::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Random inputs in [-2, 2)^d and a smooth target with a little noise
/// (shared with the sparse GP's tests).
pub(in crate::learn::models::gp) fn data(n: usize, d: usize, seed: u64) -> (Vec<f64>, Vec<f64>) {
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

#[test]
fn shared_likelihood_is_the_mean_of_the_outputs_and_its_gradient_matches() {
    let (x, y1) = data(40, 3, 7);
    let y2: Vec<f64> = y1
        .iter()
        .enumerate()
        .map(|(i, v)| v * 0.5 - 0.1 * i as f64 / 40.0)
        .collect();
    let y: Vec<f64> = y1.iter().zip(&y2).flat_map(|(a, b)| [*a, *b]).collect();
    for kind in [KernelKind::Isotropic, KernelKind::Ard] {
        let h = hyper(kind, 3);
        let (f, g) = neg_lml_and_grad_shared(&x, 3, &y, 2, &h).unwrap();
        let (f1, g1) = neg_lml_and_grad(&x, 3, &y1, &h).unwrap();
        let (f2, g2) = neg_lml_and_grad(&x, 3, &y2, &h).unwrap();
        assert!((f - 0.5 * (f1 + f2)).abs() < 1e-12, "{f} vs {f1}, {f2}");
        for ((g, a), b) in g.iter().zip(&g1).zip(&g2) {
            assert!((g - 0.5 * (a + b)).abs() < 1e-12);
        }
        assert_gradient_matches(|h| neg_lml_and_grad_shared(&x, 3, &y, 2, h), &h);
    }
    assert!(matches!(
        check_targets(&x, 3, &y[..79], 2),
        Err(GpError::ShapeMismatch { targets: 39, .. })
    ));
    let mut bad = y.clone();
    bad[5] = f64::NAN;
    assert!(matches!(
        check_targets(&x, 3, &bad, 2),
        Err(GpError::NonFinite { row: 2, column: 4 })
    ));
}

#[test]
fn gps_fitted_on_one_factorisation_predict_as_gps_fitted_apart() {
    let (x, y1) = data(120, 3, 8);
    let y2: Vec<f64> = y1.iter().map(|v| 2.0 * v + 0.3).collect();
    let y: Vec<f64> = y1.iter().zip(&y2).flat_map(|(a, b)| [*a, *b]).collect();
    let h = hyper(KernelKind::Ard, 3);
    let shared = ExactGp::fit_shared(&x, 3, &y, 2, h.clone()).unwrap();
    assert!(shared[0].shares_kernel(&shared[1]));
    let apart = [
        ExactGp::fit(&x, 3, &y1, h.clone()).unwrap(),
        ExactGp::fit(&x, 3, &y2, h).unwrap(),
    ];
    let (z, _) = data(25, 3, 9);
    let together = ExactGp::predict_shared(&[&shared[0], &shared[1]], &z, true);
    for ((m, v), gp) in together.iter().zip(&apart) {
        let (m1, v1) = gp.predict(&z, true);
        for i in 0..25 {
            assert!((m[i] - m1[i]).abs() < 1e-9 && (v[i] - v1[i]).abs() < 1e-9);
        }
    }
    // A GP with other data does not share the kernel.
    assert!(
        !apart[0].shares_kernel(&ExactGp::fit(&z, 3, &z[..25], hyper(KernelKind::Ard, 3)).unwrap())
    );
}

/// The exact GP of `x`, `y` with `h` and its variance conditioned on at
/// most `m` rows near each point.
fn local(x: &[f64], d: usize, y: &[f64], h: &SeHyper, m: usize) -> ExactGp {
    ExactGp::fit_local(x, d, y, 1, h.clone(), m)
        .unwrap()
        .remove(0)
}

/// The exact posterior variance at `z` given every row of `x` (`d` a row),
/// s2 - k^T (K_f + sn2 I)^-1 k, solved in double precision.
fn exact_variances(x: &[f64], z: &[f64], d: usize, h: &SeHyper) -> Vec<f64> {
    let n = x.len() / d;
    let xs = scale_rows(x, &h.lengthscales);
    let mut k = se_gram(&xs, d, h.signal_var);
    (0..n).for_each(|i| k[(i, i)] += h.noise_var);
    let kt = super::super::kernel::se_cross(&xs, &scale_rows(z, &h.lengthscales), d, h.signal_var);
    let mut solved = kt.clone();
    faer::linalg::solvers::Solve::solve_in_place(&k.llt(Side::Lower).unwrap(), solved.as_mut());
    (0..z.len() / d)
        .map(|c| h.signal_var - (0..n).map(|i| kt[(i, c)] * solved[(i, c)]).sum::<f64>())
        .collect()
}

#[test]
fn with_no_more_rows_than_a_cluster_the_variance_is_the_exact_one() {
    let (x, y) = data(300, 3, 10);
    let h = hyper(KernelKind::Ard, 3);
    let (z, _) = data(40, 3, 11);
    let exact = exact_variances(&x, &z, 3, &h);
    // Up to the margin for the factor's rounding to single precision.
    let margin = 4.0 * f64::from(f32::EPSILON) * h.signal_var;
    for m in [300, VARIANCE_ROWS] {
        let gp = local(&x, 3, &y, &h, m);
        let (_, vars) = gp.predict(&z, true);
        let mut ws = GpWorkspace::new(300, 3);
        for (i, row) in z.chunks_exact(3).enumerate() {
            let (_, v) = gp.predict_one(row, &mut ws, true);
            assert!(
                (v - exact[i]).abs() < 2.0 * margin,
                "m = {m}: {v} vs {}",
                exact[i]
            );
            assert!((vars[i] - v).abs() < 1e-12);
        }
    }
}

#[test]
fn on_more_rows_the_variance_is_never_below_the_exact_one_and_close_to_it() {
    // 1200 rows in 4 inputs, clusters of 200 (12 of them): each point's
    // variance is conditioned on the 200 rows of the cluster nearest it.
    let (x, y) = data(1200, 4, 12);
    let h = hyper(KernelKind::Ard, 4);
    let exact = local(&x, 4, &y, &h, 1200);
    let near = local(&x, 4, &y, &h, 200);
    // Points among the rows and beyond them (inputs in [-3, 3)).
    let (z, _) = data(500, 4, 13);
    let z: Vec<f64> = z.iter().map(|v| 1.5 * v).collect();
    let (m0, v0) = exact.predict(&z, true);
    let (m1, v1) = near.predict(&z, true);
    let mut ws = GpWorkspace::new(1200, 4);
    let mut ratios = Vec::new();
    for (i, row) in z.chunks_exact(4).enumerate() {
        // The mean is the exact GP's: only the variance is local.
        assert_eq!(m0[i], m1[i]);
        let (m, v) = near.predict_one(row, &mut ws, true);
        assert!((m - m1[i]).abs() < 1e-12 && (v - v1[i]).abs() < 1e-9);
        assert!(
            v1[i] >= v0[i] - 1e-10,
            "point {i}: {} below {}",
            v1[i],
            v0[i]
        );
        // The standard deviation of a measured target, as eval judges it.
        ratios.push(((v1[i] + h.noise_var) / (v0[i] + h.noise_var)).sqrt());
    }
    ratios.sort_by(f64::total_cmp);
    let (median, worst) = (ratios[250], ratios[499]);
    // Measured: median 1.019, worst 1.43.
    assert!(
        median < 1.03 && worst < 1.5,
        "median {median}, worst {worst}"
    );
    assert!(worst > 1.01, "the variance is local, not the exact one");
}

#[test]
fn a_factor_in_single_precision_never_lowers_the_variance() {
    // 1000 rows (one cluster), noise from a tenth of the signal variance
    // down to the fit's floor (1e-6): the variance from the factor in
    // single precision against the exact one in double, solved apart.
    let (x, y) = data(1000, 3, 21);
    let (z, _) = data(300, 3, 22);
    for noise_var in [1e-1, 1e-3, 1e-5, 1e-6] {
        let h = SeHyper {
            noise_var,
            ..hyper(KernelKind::Ard, 3)
        };
        let exact = exact_variances(&x, &z, 3, &h);
        let (_, vars) = local(&x, 3, &y, &h, 1000).predict(&z, true);
        let margin = 4.0 * f64::from(f32::EPSILON) * h.signal_var;
        for (v, e) in vars.iter().zip(&exact) {
            assert!(
                e <= v && v - e < 2.0 * margin,
                "noise {noise_var:e}: {v:e} vs {e:e}"
            );
        }
    }
}
