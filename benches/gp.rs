//! GP costs on simulated, tared electrode data (19 features, 3 force axes):
//! the dense Cholesky limit of the machine and one likelihood+gradient
//! evaluation (isotropic and ARD) at n_train = 2000, and single-sample
//! prediction (mean+std and mean only) of the exact GP on those 2000 rows
//! against the sparse GP with m = 200 inducing points on all rows. After the
//! criterion groups, a plain loop prints the median and p99 of single-sample
//! mean+std latency of both, and their ratio, which criterion does not report.

use std::time::Instant;

use criterion::{criterion_group, criterion_main, Criterion};
use faer::Side;
use tactile_force::biotac::sim::BioTacSimConfig;
use tactile_force::learn::data::{electrode_columns, write_csv, Counts, Dataset};
use tactile_force::learn::models::gp::exact::neg_lml_and_grad;
use tactile_force::learn::models::gp::kernel::{scale_rows, se_gram};
use tactile_force::learn::models::gp::{GpParams, KernelKind, SeHyper};
use tactile_force::learn::models::scale::Standardizer;
use tactile_force::learn::models::wrench_gp::{Estimate, TareSpec, WrenchGp};
use tactile_force::sim::collect::{collect, CollectConfig};

const N: usize = 2000;

/// Inducing points of the sparse GP compared with the exact GP.
const M: usize = 200;

/// The tared `collect --seed 1` data set.
fn data() -> Dataset {
    let records = collect(&CollectConfig::default(), &BioTacSimConfig::default(), 1, 1);
    let file = tempfile::NamedTempFile::new().expect("temp file");
    write_csv(file.path(), &records).expect("write CSV");
    let mut ds = Dataset::read_csv(
        file.path(),
        &electrode_columns(tactile_force::biotac::ElectrodeLayout::Biotac),
        &"fx,fy,fz".parse().unwrap(),
        Counts::Raw,
    )
    .expect("read CSV");
    ds.tare_per_trial(50).expect("tare");
    ds
}

/// N evenly strided rows of `all`.
fn strided(all: &Dataset) -> Dataset {
    let step = all.len() / N;
    let idx: Vec<usize> = (0..N).map(|i| i * step).collect();
    all.select(&idx)
}

/// Median and p99 of single-sample mean+std latency (us) over 5000 calls.
fn latency_us(model: &WrenchGp, inputs: &[Vec<f64>]) -> (f64, f64) {
    let mut ws = model.workspace();
    let mut out = [Estimate::default(); 3];
    let mut lat: Vec<f64> = inputs
        .iter()
        .cycle()
        .take(5000)
        .map(|x| {
            let t0 = Instant::now();
            model
                .predict_one(x, &mut ws, true, &mut out)
                .expect("19 features");
            t0.elapsed().as_secs_f64() * 1e6
        })
        .collect();
    lat.sort_by(f64::total_cmp);
    (lat[lat.len() / 2], lat[lat.len() * 99 / 100])
}

fn benches(c: &mut Criterion) {
    let all = data();
    let ds = strided(&all);
    let d = ds.features.len();
    let z: Vec<f64> = Standardizer::fit(ds.x.view())
        .transform(ds.x.view())
        .iter()
        .copied()
        .collect();
    let ys = Standardizer::fit(ds.y.view()).transform(ds.y.view());
    let y: Vec<f64> = ys.column(2).to_vec();

    let mut g = c.benchmark_group("gp_n2000");
    g.sample_size(10);
    let hyper = |kind| SeHyper {
        kind,
        signal_var: 1.0,
        lengthscales: vec![(d as f64).sqrt(); d],
        noise_var: 1e-2,
    };
    let kf = se_gram(
        &scale_rows(&z, &hyper(KernelKind::Ard).lengthscales),
        d,
        1.0,
    );
    let mut k = kf.clone();
    for i in 0..N {
        k[(i, i)] += 1e-2;
    }
    g.bench_function("cholesky", |b| b.iter(|| k.llt(Side::Lower).expect("SPD")));
    for kind in [KernelKind::Isotropic, KernelKind::Ard] {
        let h = hyper(kind);
        g.bench_function(format!("lml_grad_{kind:?}").to_lowercase(), |b| {
            b.iter(|| neg_lml_and_grad(&z, d, &y, &h).expect("finite"))
        });
    }
    g.finish();

    let params = GpParams {
        restarts: 1,
        restart_subset: 300,
        max_iters: 30,
        ..GpParams::default()
    }
    .validate()
    .expect("valid");
    let tare = TareSpec {
        samples: 50,
        mean_baseline: vec![0.0; d],
    };
    let exact = WrenchGp::train(&ds, tare.clone(), &params, &mut |_, _| {}).expect("trained");
    let sparse_params = GpParams {
        inducing: Some(M),
        ..GpParams::default()
    }
    .validate()
    .expect("valid");
    let sparse = WrenchGp::train(&all, tare, &sparse_params, &mut |_, _| {}).expect("trained");
    let inputs: Vec<Vec<f64>> = ds.x.rows().into_iter().map(|r| r.to_vec()).collect();
    let mut g = c.benchmark_group("predict_one_3axes");
    for (model_name, model) in [("exact_n2000", &exact), (&format!("sparse_m{M}"), &sparse)] {
        let mut ws = model.workspace();
        let mut out = [Estimate::default(); 3];
        for (name, with_std) in [("mean_std", true), ("mean_only", false)] {
            let mut i = 0;
            g.bench_function(format!("{model_name}/{name}"), |b| {
                b.iter(|| {
                    i = (i + 1) % inputs.len();
                    model
                        .predict_one(&inputs[i], &mut ws, with_std, &mut out)
                        .expect("19 features")
                })
            });
        }
    }
    g.finish();

    let (exact_med, exact_p99) = latency_us(&exact, &inputs);
    let (sparse_med, sparse_p99) = latency_us(&sparse, &inputs);
    println!(
        "predict_one mean+std, 3 axes: exact n = {N} median {exact_med:.1} us (p99 \
         {exact_p99:.1}), sparse m = {M} median {sparse_med:.1} us (p99 {sparse_p99:.1}); \
         sparse {:.0}x faster (5000 calls each)",
        exact_med / sparse_med
    );
}

criterion_group!(gp, benches);
criterion_main!(gp);
