//! The single-sample prediction path allocates nothing per call (counted by a
//! global allocator; this binary holds one test so nothing else allocates).

use ndarray::Array2;
use tactile_force::learn::data::Dataset;
use tactile_force::learn::models::gp::{Gp, GpParams};
use tactile_force::learn::models::wrench_gp::{Estimate, TareSpec, WrenchGp};

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
    let model = WrenchGp::train(&data, tare, &params, &mut |_, _| {}).unwrap();
    let mut ws = model.workspace();
    let mut out = [Estimate::default(); 3];
    let input = [3.0, 5.0, 7.0, 11.0];
    for with_std in [true, false] {
        // Warm-up: the thread pool and its thread-locals start on first use.
        for _ in 0..50 {
            model
                .predict_one(&input, &mut ws, with_std, &mut out)
                .unwrap();
        }
        let before = allocations();
        for _ in 0..100 {
            model
                .predict_one(&input, &mut ws, with_std, &mut out)
                .unwrap();
        }
        let allocated = allocations() - before;
        assert_eq!(allocated, 0, "with_std = {with_std}");
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
}
