//! GP extremes: every case ends in finite outputs or a clear error, never a
//! panic or a NaN (issue "GP wrench estimator", Tests / Extremes). The cases
//! that train a model run for the exact GP and for the sparse GP.

use ndarray::{Array2, Axis as NdAxis};
use tactile_force::learn::data::Dataset;
use tactile_force::learn::models::gp::{
    ExactGp, GpError, GpParams, GpWorkspace, KernelKind, SeHyper,
};
use tactile_force::learn::models::wrench_gp::{Estimate, ModelError, TareSpec, WrenchGp};

/// 60 rows of 3 features on [-1, 1] and a smooth target.
fn inputs(n: usize) -> Array2<f64> {
    Array2::from_shape_fn((n, 3), |(i, j)| {
        ((i * (j + 3) * 7919 % 200) as f64) / 100.0 - 1.0
    })
}

fn target(x: &Array2<f64>) -> Array2<f64> {
    let y: Vec<f64> = x
        .rows()
        .into_iter()
        .map(|r| r[0].sin() + 0.5 * r[1])
        .collect();
    Array2::from_shape_vec((x.nrows(), 1), y).unwrap()
}

fn dataset(x: Array2<f64>, y: Array2<f64>) -> Dataset {
    let n = x.nrows();
    Dataset {
        features: (1..=x.ncols()).map(|i| format!("e{i}")).collect(),
        x,
        axes: "fz".parse().unwrap(),
        y,
        set: vec![1; n],
        trial: vec![1; n],
        images: None,
    }
}

/// The GPs every training case runs with: exact, and sparse with 20
/// inducing points.
const INDUCING: [Option<usize>; 2] = [None, Some(20)];

fn train(
    ds: &Dataset,
    kernel: KernelKind,
    inducing: Option<usize>,
) -> Result<WrenchGp, ModelError> {
    let params = GpParams {
        kernel,
        restarts: 2,
        inducing,
        ..GpParams::default()
    }
    .validate()
    .unwrap();
    let tare = TareSpec {
        samples: 0,
        mean_baseline: vec![0.0; ds.features.len()],
    };
    WrenchGp::train(ds, tare, &params, &mut |_, _| {})
}

/// Predicts at the training rows and far outside them; returns the estimates.
fn predict_everywhere(model: &WrenchGp, x: &Array2<f64>) -> Vec<Estimate> {
    let mut ws = model.workspace();
    let mut out = [Estimate::default()];
    let far = vec![1e9; x.ncols()];
    let mut all = Vec::new();
    for row in x.rows().into_iter().map(|r| r.to_vec()).chain([far]) {
        model.predict_one(&row, &mut ws, true, &mut out).unwrap();
        assert!(
            out[0].mean.is_finite() && out[0].std.is_finite() && out[0].std >= 0.0,
            "{out:?}"
        );
        all.push(out[0]);
    }
    all
}

fn flat(x: &Array2<f64>) -> Vec<f64> {
    x.iter().copied().collect()
}

#[test]
fn noise_variance_near_zero_with_duplicated_inputs_is_jittered_or_refused() {
    let x = inputs(30);
    let x2 = ndarray::concatenate(NdAxis(0), &[x.view(), x.view()]).unwrap();
    let y = target(&x2);
    let hyper = SeHyper {
        kind: KernelKind::Isotropic,
        signal_var: 1.0,
        lengthscales: vec![0.5; 3],
        noise_var: 1e-10,
    };
    match ExactGp::fit(&flat(&x2), 3, y.as_slice().unwrap(), hyper) {
        Ok(gp) => {
            // Nearly noise-free: the GP interpolates its (consistent) duplicates.
            let mut ws = GpWorkspace::new(gp.n_train(), 3);
            for (row, t) in x.rows().into_iter().zip(y.iter()) {
                let (m, v) = gp.predict_one(row.as_slice().unwrap(), &mut ws, true);
                assert!((m - t).abs() < 1e-3, "{m} vs {t}");
                assert!(v.is_finite() && (0.0..=1.0).contains(&v));
            }
        }
        Err(e) => assert!(matches!(e, GpError::NotPositiveDefinite { .. }), "{e}"),
    }
}

#[test]
fn length_scales_far_below_and_above_the_data_scale_give_finite_bounded_predictions() {
    let x = inputs(60);
    let y = target(&x);
    for l in [1e-4, 1e4] {
        let hyper = SeHyper {
            kind: KernelKind::Ard,
            signal_var: 2.0,
            lengthscales: vec![l; 3],
            noise_var: 1e-2,
        };
        let gp = ExactGp::fit(&flat(&x), 3, y.as_slice().unwrap(), hyper).unwrap();
        let (means, vars) = gp.predict(&flat(&inputs(17)), true);
        for (m, v) in means.iter().zip(&vars) {
            assert!(m.is_finite() && (0.0..=2.0).contains(v), "l = {l}: {m} {v}");
        }
    }
}

#[test]
fn duplicated_inputs_train_to_the_same_function() {
    let x = inputs(40);
    let x2 = ndarray::concatenate(NdAxis(0), &[x.view(), x.view()]).unwrap();
    for m in INDUCING {
        let model = train(&dataset(x2.clone(), target(&x2)), KernelKind::Ard, m).unwrap();
        let est = predict_everywhere(&model, &x);
        for (e, y) in est.iter().zip(target(&x).iter()) {
            assert!((e.mean - y).abs() < 0.05, "{m:?}: {} vs {y}", e.mean);
        }
    }
}

#[test]
fn constant_inputs_predict_the_target_mean() {
    let x = Array2::from_elem((25, 3), 7.0);
    let y = target(&inputs(25));
    let mean = y.mean().unwrap();
    for m in INDUCING {
        let model = train(&dataset(x.clone(), y.clone()), KernelKind::Isotropic, m).unwrap();
        for e in predict_everywhere(&model, &x).iter().take(25) {
            assert!((e.mean - mean).abs() < 1e-6, "{m:?}: {} vs {mean}", e.mean);
        }
    }
}

#[test]
fn inputs_scaled_by_1e6_give_the_same_predictions() {
    let x = inputs(50);
    let y = target(&x);
    let big = &x * 1e6;
    for m in INDUCING {
        let a = train(&dataset(x.clone(), y.clone()), KernelKind::Ard, m).unwrap();
        let b = train(&dataset(big.clone(), y.clone()), KernelKind::Ard, m).unwrap();
        let (pa, pb) = (predict_everywhere(&a, &x), predict_everywhere(&b, &big));
        for (ea, eb) in pa.iter().zip(&pb).take(50) {
            // Round-off in the standardisation nudges the optimiser's path.
            assert!((ea.mean - eb.mean).abs() < 1e-5, "{m:?}: {ea:?} vs {eb:?}");
        }
    }
}

#[test]
fn a_single_training_point_is_fitted_and_predicted() {
    let x = Array2::from_shape_vec((1, 3), vec![0.5, -0.5, 1.0]).unwrap();
    let y = Array2::from_elem((1, 1), 3.0);
    for m in INDUCING {
        let model = train(&dataset(x.clone(), y.clone()), KernelKind::Isotropic, m).unwrap();
        let est = predict_everywhere(&model, &x);
        assert!((est[0].mean - 3.0).abs() < 1e-3, "{m:?}: {:?}", est[0]);
    }
}

#[test]
fn targets_all_equal_predict_that_value() {
    let x = inputs(30);
    let y = Array2::from_elem((30, 1), -1.25);
    for m in INDUCING {
        let model = train(&dataset(x.clone(), y.clone()), KernelKind::Ard, m).unwrap();
        for e in predict_everywhere(&model, &x) {
            assert!((e.mean + 1.25).abs() < 1e-9, "{m:?}: {e:?}");
        }
    }
}

#[test]
fn non_finite_training_data_is_refused_with_its_position() {
    let mut x = inputs(10);
    x[[4, 2]] = f64::INFINITY;
    for m in INDUCING {
        let err = train(
            &dataset(x.clone(), target(&inputs(10))),
            KernelKind::Isotropic,
            m,
        )
        .unwrap_err();
        assert!(err.to_string().contains("row 4, column 2"), "{m:?}: {err}");
    }
}
