//! Tests of fit.rs.

use super::*;
use crate::learn::models::gp::{Gp, GpWorkspace};
use rand::Rng;

/// A GP (exact or sparse, as `params` say) fitted to `x`, `y` from `start`;
/// checks that the progress callback heard of every evaluation.
fn fit_counted(x: &[f64], d: usize, y: &[f64], params: GpParams, start: &Start) -> (Gp, FitInfo) {
    let params = params.validate().unwrap();
    let data = FitData {
        x,
        d,
        y,
        params: &params,
        start,
    };
    let mut calls = 0;
    let (gp, info) = Gp::fit_from(&data, &mut |_| calls += 1).unwrap();
    assert_eq!(calls, info.evaluations);
    (gp, info)
}

#[test]
fn fit_recovers_a_smooth_function_to_within_the_noise() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (n, d, noise) = (300, 3, 0.05);
    let f = |r: &[f64]| (1.5 * r[0]).sin() + 0.5 * r[1] * r[1] - 0.5;
    let x: Vec<f64> = (0..n * d).map(|_| rng.random_range(-1.5..1.5)).collect();
    let y: Vec<f64> = x
        .chunks_exact(d)
        .map(|r| f(r) + noise * rng.sample::<f64, _>(rand_distr::StandardNormal))
        .collect();
    for kernel in [KernelKind::Isotropic, KernelKind::Ard] {
        let params = GpParams {
            kernel,
            ..GpParams::default()
        };
        let (gp, _) = fit_counted(&x, d, &y, params, &Start::Multistart);
        let mut ws = GpWorkspace::new(n, d);
        let test: Vec<f64> = (0..200 * d).map(|_| rng.random_range(-1.4..1.4)).collect();
        let mse = test
            .chunks_exact(d)
            .map(|r| (gp.predict_one(r, &mut ws, false).0 - f(r)).powi(2))
            .sum::<f64>()
            / 200.0;
        assert!(
            mse.sqrt() < noise,
            "{kernel:?}: RMSE {} vs noise {noise}",
            mse.sqrt()
        );
        // The learned noise is close to the true one.
        let sn = gp.hyper().noise_var.sqrt();
        assert!((sn - noise).abs() < 0.3 * noise, "{kernel:?}: noise {sn}");
        if kernel == KernelKind::Ard {
            // The unused third input gets a longer length-scale than the used ones.
            let l = &gp.hyper().lengthscales;
            assert!(l[2] > 3.0 * l[0] && l[2] > 3.0 * l[1], "{l:?}");
        }
    }
}

fn smooth_data(n: usize, d: usize, noise: f64, seed: u64) -> (Vec<f64>, Vec<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let x: Vec<f64> = (0..n * d).map(|_| rng.random_range(-1.5..1.5)).collect();
    let y = x
        .chunks_exact(d)
        .map(|r| smooth(r) + noise * rng.sample::<f64, _>(rand_distr::StandardNormal))
        .collect();
    (x, y)
}

fn smooth(r: &[f64]) -> f64 {
    (1.5 * r[0]).sin() + 0.5 * r[1] * r[1] - 0.5
}

#[test]
fn sparse_fit_recovers_a_smooth_function_to_within_the_noise() {
    let (n, d, noise) = (2000, 3, 0.05);
    let (x, y) = smooth_data(n, d, noise, 11);
    let params = GpParams {
        kernel: KernelKind::Ard,
        inducing: Some(50),
        ..GpParams::default()
    };
    let (gp, info) = fit_counted(&x, d, &y, params, &Start::Multistart);
    let Gp::Sparse(gp) = gp else {
        panic!("inducing points make a sparse GP")
    };
    assert!(info.full_evaluations > 0);
    assert_eq!((gp.n_inducing(), gp.n_fit()), (50, n));
    let (test, _) = smooth_data(300, d, 0.0, 12);
    let (mean, var) = gp.predict(&test, true);
    let mse = test
        .chunks_exact(d)
        .zip(&mean)
        .map(|(r, m)| (m - smooth(r)).powi(2))
        .sum::<f64>()
        / 300.0;
    assert!(mse.sqrt() < noise, "RMSE {} vs noise {noise}", mse.sqrt());
    assert!(var.iter().all(|v| (0.0..0.1).contains(v)));
    let sn = gp.hyper().noise_var.sqrt();
    assert!((sn - noise).abs() < 0.3 * noise, "noise {sn}");
}

#[test]
fn a_warm_start_at_the_optimum_stays_there_in_fewer_evaluations() {
    let (x, y) = smooth_data(400, 3, 0.05, 17);
    let params = GpParams::default();
    let (cold, cold_info) = fit_counted(&x, 3, &y, params.clone(), &Start::Multistart);
    let warm_start = Start::Warm(cold.hyper().clone());
    let (warm, warm_info) = fit_counted(&x, 3, &y, params, &warm_start);
    assert!(
        3 * warm_info.evaluations < cold_info.evaluations,
        "{warm_info:?} against {cold_info:?}"
    );
    let (a, b) = (cold.hyper().to_log(), warm.hyper().to_log());
    for (a, b) in a.iter().zip(&b) {
        assert!(
            (a - b).abs() < 1e-3,
            "{:?} against {:?}",
            cold.hyper(),
            warm.hyper()
        );
    }
    assert!(warm_info.neg_lml_per_sample <= cold_info.neg_lml_per_sample + 1e-9);
}

#[test]
fn exact_fit_keeps_max_train_rows_by_either_rule() {
    let (n, d) = (3000, 2);
    let (x, y) = smooth_data(n, d, 0.05, 13);
    for subset in [Subset::Random, Subset::FarthestPoint] {
        let params = GpParams {
            restarts: 1,
            restart_subset: 200,
            max_train: 300,
            subset,
            ..GpParams::default()
        };
        let (gp, _) = fit_counted(&x, d, &y, params, &Start::Multistart);
        assert_eq!(gp.size(), 300, "{subset:?}");
        let (test, _) = smooth_data(100, d, 0.0, 14);
        let (mean, _) = gp.predict(&test, false);
        let rmse = (test
            .chunks_exact(d)
            .zip(&mean)
            .map(|(r, m)| (m - smooth(r)).powi(2))
            .sum::<f64>()
            / 100.0)
            .sqrt();
        assert!(rmse < 0.05, "{subset:?}: RMSE {rmse}");
    }
    let json = serde_json::to_string(&Subset::FarthestPoint).unwrap();
    assert_eq!(json, "\"farthest\"");
}

#[test]
fn gp_dispatches_on_inducing_and_round_trips_tagged() {
    let (x, y) = smooth_data(400, 2, 0.05, 15);
    for inducing in [None, Some(30)] {
        let params = GpParams {
            restarts: 1,
            inducing,
            ..GpParams::default()
        }
        .validate()
        .unwrap();
        let (gp, _) = Gp::fit(&x, 2, &y, &params, &mut |_| {}).unwrap();
        assert_eq!(gp.size(), inducing.unwrap_or(400));
        let json = serde_json::to_string(&gp).unwrap();
        let tag = if inducing.is_some() {
            "{\"sparse\":"
        } else {
            "{\"exact\":"
        };
        assert!(json.starts_with(tag), "{}", &json[..20]);
        let back: Gp = serde_json::from_str(&json).unwrap();
        let mut ws = gp.workspace();
        let (z, _) = smooth_data(20, 2, 0.0, 16);
        let (means, vars) = back.predict(&z, true);
        for (i, r) in z.chunks_exact(2).enumerate() {
            let (m, v) = gp.predict_one(r, &mut ws, true);
            assert!((m - means[i]).abs() < 1e-10 && (v - vars[i]).abs() < 1e-10);
        }
    }
}

#[test]
fn shared_fit_of_like_outputs_finds_the_single_fit_and_keeps_rows_aligned() {
    let (x, y) = smooth_data(120, 3, 0.05, 11);
    let params = GpParams {
        max_train: 50,
        ..GpParams::default()
    }
    .validate()
    .unwrap();
    let data = |y| FitData {
        x: &x,
        d: 3,
        y,
        params: &params,
        start: &Start::Multistart,
    };
    let (one, one_info) = fit_gp(&data(&y), &mut |_| {}).unwrap();
    // Two equal outputs: the same likelihood per output, the same search.
    let same: Vec<f64> = y.iter().flat_map(|v| [*v, *v]).collect();
    let (both, info) = fit_gp_shared(&data(&same), 2, &mut |_| {}).unwrap();
    assert_eq!(info.evaluations, one_info.evaluations);
    for gp in &both {
        assert_eq!(gp.n_train(), 50);
        let (h, h1) = (gp.hyper().to_log(), one.hyper().to_log());
        assert!(
            h.iter().zip(&h1).all(|(a, b)| (a - b).abs() < 1e-9),
            "{h:?} vs {h1:?}"
        );
    }
    // The second output twice the first: conditioned on the same rows, its
    // mean is twice the first's.
    let twice: Vec<f64> = y.iter().flat_map(|v| [*v, 2.0 * v]).collect();
    let (both, _) = fit_gp_shared(&data(&twice), 2, &mut |_| {}).unwrap();
    assert!(both[0].shares_kernel(&both[1]));
    let (z, _) = smooth_data(20, 3, 0.0, 12);
    let (m0, m1) = (both[0].predict(&z, false).0, both[1].predict(&z, false).0);
    assert!(m0.iter().zip(&m1).all(|(a, b)| (2.0 * a - b).abs() < 1e-9));
}
