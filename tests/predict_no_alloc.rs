//! The single-sample prediction path of each model family allocates nothing per call (counted by a
//! global allocator; this binary holds one test so nothing else allocates).

use ndarray::Array2;
use tactile_force::learn::data::Dataset;
use tactile_force::learn::models::ensemble::{WrenchEnsemble, DEFAULT_MEMBERS};
use tactile_force::learn::models::gp::exact::VARIANCE_ROWS;
use tactile_force::learn::models::gp::{ExactGp, Gp, GpParams, KernelKind, SeHyper};
use tactile_force::learn::models::nn::NnParams;
use tactile_force::learn::models::wrench_gp::{Estimate, TareSpec, WrenchGp};
use tactile_force::learn::models::wrench_model::WrenchModel;
use tactile_force::params::Check;

#[path = "common/counting_alloc.rs"]
mod counting_alloc;
use counting_alloc::{allocations, Counting};

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn predict_one_allocates_nothing_after_warm_up() {
    let n = 80;
    let x = Array2::from_shape_fn((n, 4), |(i, j)| ((i * 31 + j * 17) % 23) as f64);
    let y = Array2::from_shape_fn((n, 3), |(i, j)| x[[i, j]] - 0.5 * x[[i, 3]]);
    let data = Dataset {
        features: (1..=4).map(|i| format!("e{i}")).collect(),
        x,
        axes: "fx,fy,fz".parse().unwrap(),
        y,
        set: vec![1; n],
        trial: vec![1; n],
        images: None,
    };
    let tare = TareSpec {
        samples: 0,
        mean_baseline: vec![0.0; 4],
    };
    let params = GpParams {
        restarts: 1,
        ..GpParams::default()
    }
    .validate()
    .unwrap();
    let gp = WrenchGp::train(&data, tare.clone(), &params, &mut |_, _| {}).unwrap();
    let nn = NnParams::default().checked("nn").unwrap();
    let ensemble = WrenchEnsemble::train(&data, tare, &nn, DEFAULT_MEMBERS).unwrap();
    // Each family through the estimator's interface.
    let models: [Box<dyn WrenchModel>; 2] = [Box::new(gp), Box::new(ensemble)];
    let mut out = [Estimate::default(); 3];
    let input = [3.0, 5.0, 7.0, 11.0];
    for (model, with_std) in models.iter().flat_map(|m| [(m, true), (m, false)]) {
        let mut ws = model.workspace();
        // Warm-up: the thread pool and its thread-locals start on first use.
        for _ in 0..50 {
            model.estimate(&input, &mut ws, with_std, &mut out).unwrap();
        }
        let before = allocations();
        for _ in 0..100 {
            model.estimate(&input, &mut ws, with_std, &mut out).unwrap();
        }
        let allocated = allocations() - before;
        assert_eq!(allocated, 0, "{}, with_std = {with_std}", model.family());
        assert!(out.iter().all(|e| e.mean.is_finite()));
    }

    // The sparse (VFE) GP's single-sample path, through the `Gp` enum.
    let xs: Vec<f64> = (0..n * 4)
        .map(|i| ((i * 7) % 13) as f64 / 6.0 - 1.0)
        .collect();
    let ys: Vec<f64> = xs.chunks_exact(4).map(|r| r[0] - 0.5 * r[3]).collect();
    let params = GpParams {
        restarts: 1,
        inducing: Some(20),
        ..GpParams::default()
    }
    .validate()
    .unwrap();
    let (gp, _) = Gp::fit(&xs, 4, &ys, &params, &mut |_| {}).unwrap();
    let mut ws = gp.workspace();
    let z = [0.1, -0.3, 0.5, 0.2];
    for with_var in [true, false] {
        for _ in 0..50 {
            gp.predict_one(&z, &mut ws, with_var);
        }
        let before = allocations();
        let mut sum = 0.0;
        for _ in 0..100 {
            let (m, v) = gp.predict_one(&z, &mut ws, with_var);
            sum += m + v;
        }
        let allocated = allocations() - before;
        assert_eq!(allocated, 0, "sparse, with_var = {with_var}");
        assert!(sum.is_finite());
    }

    // An exact GP on more rows than one variance is conditioned on: its
    // variance from the factor of the cluster nearest the input.
    let rows = VARIANCE_ROWS + 200;
    let xe: Vec<f64> = (0..rows * 4)
        .map(|i| ((i * 7919) % 1009) as f64 / 504.0 - 1.0)
        .collect();
    let ye: Vec<f64> = xe.chunks_exact(4).map(|r| r[0] - 0.5 * r[3]).collect();
    let hyper = SeHyper {
        kind: KernelKind::Isotropic,
        signal_var: 1.0,
        lengthscales: vec![0.8; 4],
        noise_var: 0.01,
    };
    let gp = Gp::Exact(ExactGp::fit(&xe, 4, &ye, hyper).unwrap());
    let mut ws = gp.workspace();
    for _ in 0..50 {
        gp.predict_one(&z, &mut ws, true);
    }
    let before = allocations();
    let mut sum = 0.0;
    for _ in 0..100 {
        let (m, v) = gp.predict_one(&z, &mut ws, true);
        sum += m + v;
    }
    assert_eq!(allocations() - before, 0, "exact GP on {rows} rows");
    assert!(sum.is_finite());
}
