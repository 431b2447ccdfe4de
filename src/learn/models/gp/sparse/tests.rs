//! The sparse GP against the exact one, its gradient, and its stored form.

use super::super::exact::tests::{assert_gradient_matches, data, hyper};
use super::super::exact::{neg_lml_and_grad, ExactGp};
use super::super::kernel::KernelKind;
use super::super::select::greedy_variance;
use super::*;

fn rows(x: &[f64], d: usize, idx: &[usize]) -> Vec<f64> {
    idx.iter()
        .flat_map(|&i| x[i * d..(i + 1) * d].to_vec())
        .collect()
}

#[test]
fn bound_gradient_matches_central_differences() {
    let (x, y) = data(60, 3, 1);
    let z = rows(&x, 3, &[0, 5, 9, 17, 22, 31, 40, 48]);
    for kind in [KernelKind::Isotropic, KernelKind::Ard] {
        assert_gradient_matches(|h| neg_vfe_and_grad(&x, 3, &y, &z, h), &hyper(kind, 3));
    }
}

#[test]
fn with_every_row_inducing_the_sparse_gp_is_the_exact_gp() {
    let (x, y) = data(50, 2, 2);
    let h = hyper(KernelKind::Ard, 2);
    let (exact, exact_g) = neg_lml_and_grad(&x, 2, &y, &h).unwrap();
    let (vfe, vfe_g) = neg_vfe_and_grad(&x, 2, &y, &x, &h).unwrap();
    // Equal up to the effect of the 1e-8 s2 jitter on K_uu.
    assert!((exact - vfe).abs() < 1e-6, "{exact} vs {vfe}");
    for (a, b) in exact_g.iter().zip(&vfe_g) {
        assert!((a - b).abs() < 1e-5, "{exact_g:?} vs {vfe_g:?}");
    }
    let egp = ExactGp::fit(&x, 2, &y, h.clone()).unwrap();
    let sgp = SparseGp::fit(&x, 2, &y, &x, h).unwrap();
    let (t, _) = data(40, 2, 3);
    let (em, ev) = egp.predict(&t, true);
    let (sm, sv) = sgp.predict(&t, true);
    for i in 0..40 {
        assert!((em[i] - sm[i]).abs() < 1e-6, "{} vs {}", em[i], sm[i]);
        assert!((ev[i] - sv[i]).abs() < 1e-6, "{} vs {}", ev[i], sv[i]);
    }
}

#[test]
fn the_bound_is_below_the_likelihood_and_rises_with_more_inducing_points() {
    let (x, y) = data(200, 3, 4);
    let h = hyper(KernelKind::Isotropic, 3);
    let exact = -neg_lml_and_grad(&x, 3, &y, &h).unwrap().0;
    let order = greedy_variance(&x, 3, &h, 200);
    assert_eq!(order.len(), 200);
    let mut last = f64::NEG_INFINITY;
    for m in [1, 5, 10, 20, 40, 80, 120, 200] {
        let bound = -neg_vfe_and_grad(&x, 3, &y, &rows(&x, 3, &order[..m]), &h)
            .unwrap()
            .0;
        assert!(bound <= exact + 1e-9, "m = {m}: {bound} > {exact}");
        assert!(bound >= last - 1e-9, "m = {m}: {bound} < {last}");
        last = bound;
    }
    // Every row inducing closes the gap (up to the K_uu jitter).
    assert!(exact - last < 1e-6, "gap {}", exact - last);
}

#[test]
fn single_sample_path_matches_batch_path() {
    let (x, y) = data(300, 4, 5);
    let h = hyper(KernelKind::Ard, 4);
    let z = rows(&x, 4, &greedy_variance(&x, 4, &h, 30));
    let gp = SparseGp::fit(&x, 4, &y, &z, h).unwrap();
    assert_eq!((gp.n_inducing(), gp.n_fit()), (30, 300));
    let (t, _) = data(25, 4, 6);
    let (means, vars) = gp.predict(&t, true);
    // A workspace larger than needed also works.
    let mut ws = GpWorkspace::new(100, 4);
    for (i, row) in t.chunks_exact(4).enumerate() {
        let (m, v) = gp.predict_one(row, &mut ws, true);
        assert!((m - means[i]).abs() < 1e-10, "{m} vs {}", means[i]);
        assert!((v - vars[i]).abs() < 1e-10, "{v} vs {}", vars[i]);
        assert!((0.0..=0.8).contains(&v));
        assert_eq!(gp.predict_one(row, &mut ws, false), (m, 0.0));
    }
    let (far_m, far_v) = gp.predict_one(&[1e3; 4], &mut ws, true);
    assert!(far_m.abs() < 1e-12 && (far_v - 0.8).abs() < 1e-12);
}

#[test]
fn model_data_round_trip_rebuilds_the_same_predictor() {
    let (x, y) = data(120, 3, 7);
    let h = hyper(KernelKind::Isotropic, 3);
    let z = rows(&x, 3, &greedy_variance(&x, 3, &h, 15));
    let gp = SparseGp::fit(&x, 3, &y, &z, h).unwrap();
    let json = serde_json::to_string(&gp).unwrap();
    let back: SparseGp = serde_json::from_str(&json).unwrap();
    let mut ws = GpWorkspace::new(15, 3);
    for t in [[0.3, -0.2, 1.0], [1.5, 0.1, -0.7]] {
        assert_eq!(
            gp.predict_one(&t, &mut ws, true),
            back.predict_one(&t, &mut ws, true)
        );
    }
    let wrapped: super::super::Gp =
        serde_json::from_str(&format!("{{\"sparse\":{json}}}")).unwrap();
    assert_eq!(wrapped.size(), 15);
    assert!(
        serde_json::from_str::<SparseGp>(&json.replace("\"n_fit\"", "\"extra\":1,\"n_fit\""))
            .is_err()
    );
}

#[test]
fn corrupt_data_gives_errors_not_panics() {
    let (x, y) = data(80, 2, 8);
    let h = hyper(KernelKind::Ard, 2);
    let z = rows(&x, 2, &greedy_variance(&x, 2, &h, 10));
    assert!(matches!(
        neg_vfe_and_grad(&x, 2, &y, &z[..3], &h),
        Err(GpError::InvalidSparse(_))
    ));
    assert!(SparseGp::fit(&x, 2, &y, &[], h.clone()).is_err());
    let good: SparseGpData = SparseGp::fit(&x, 2, &y, &z, h).unwrap().into();
    let check = |f: &dyn Fn(&mut SparseGpData), expect: &str| {
        let mut d = good.clone();
        f(&mut d);
        match SparseGp::try_from(d) {
            Err(e) => assert!(
                expect.split('|').any(|s| e.to_string().contains(s)),
                "{e} lacks {expect:?}"
            ),
            Ok(_) => panic!("accepted corrupt data ({expect})"),
        }
    };
    check(
        &|d| d.inducing.pop().map(drop).unwrap_or(()),
        "inducing values",
    );
    check(&|d| d.q_cov_chol.push(1.0), "covariance-factor values");
    check(&|d| d.q_mean[3] = f64::NAN, "q_mean[3] is not finite");
    check(&|d| d.q_cov_chol[0] = -1.0, "non-positive diagonal");
    check(&|d| d.hyper.noise_var = 0.0, "invalid hyperparameters");
    check(&|d| d.q_mean.clear(), "must be positive");
    check(&|d| d.dim = 0, "must be positive");
    // A signal variance whose K_uu overflows in the factorisation.
    check(
        &|d| d.hyper.signal_var = f64::MAX,
        "not positive definite|not finite",
    );
}
