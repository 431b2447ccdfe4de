//! The time of one estimate (3 axes with their standard deviation) of each
//! candidate `train --select` may choose, as the estimator makes it
//! ([`WrenchModel::estimate`] on one thread, with a workspace made once):
//! the exact GP on 1000, 2000 and 4000 rows, the sparse GP with 200 and 500
//! inducing points, the exact GP on 2000 rows with a network prior mean, and
//! the ensemble of networks. Each is trained on 8000 rows of simulated,
//! tared electrode data (`collect --seed 1`) and timed on other rows of it;
//! prints p50 and p99 in µs per candidate. The BioTac samples at 100 Hz:
//! the target is 1 ms at the 99th percentile.
//!
//! `cargo bench --bench estimate`

use std::time::{Duration, Instant};

use tactile_force::biotac::sim::BioTacSimConfig;
use tactile_force::biotac::ElectrodeLayout;
use tactile_force::learn::data::{electrode_columns, write_csv, Counts, Dataset};
use tactile_force::learn::models::ensemble::WrenchEnsemble;
use tactile_force::learn::models::gp::{GpParams, MeanKind};
use tactile_force::learn::models::wrench_gp::{Estimate, TareSpec, WrenchGp};
use tactile_force::learn::models::wrench_model::WrenchModel;
use tactile_force::sensor::SensorSpec;
use tactile_force::sim::collect::{collect, CollectConfig};

/// Rows every candidate is trained on.
const TRAIN_ROWS: usize = 8000;
/// Timed estimates per candidate, after [`WARM_UP`] untimed ones...
const CALLS: usize = 3000;
/// ...unless they take longer than this in all.
const MAX_TIMED: Duration = Duration::from_secs(20);
const WARM_UP: usize = 50;

/// The tared `collect --seed 1` data set.
fn data() -> Dataset {
    let records = collect(&CollectConfig::default(), &BioTacSimConfig::default(), 1, 1);
    let file = tempfile::NamedTempFile::new().expect("temp file");
    write_csv(file.path(), &records).expect("write CSV");
    let mut ds = Dataset::read_csv(
        file.path(),
        &electrode_columns(ElectrodeLayout::Biotac),
        &"fx,fy,fz".parse().expect("axes"),
        Counts::Raw,
    )
    .expect("read CSV");
    ds.tare_per_trial(50).expect("tare");
    ds
}

/// A candidate of `train --select`.
enum Candidate {
    /// The exact GP on this many rows.
    Exact(usize),
    /// The sparse GP with this many inducing points.
    Sparse(usize),
    /// The exact GP on 2000 rows with a network prior mean.
    NetworkMean,
    /// The ensemble of networks.
    Ensemble,
}

impl Candidate {
    fn name(&self) -> String {
        match self {
            Candidate::Exact(n) => format!("exact GP, {n} rows"),
            Candidate::Sparse(m) => format!("sparse GP, {m} inducing points"),
            Candidate::NetworkMean => "exact GP, 2000 rows, network mean".into(),
            Candidate::Ensemble => "ensemble of 5 networks".into(),
        }
    }

    /// Trained on `data`. The GPs' search is a quick one (one start on 300
    /// rows, as in benches/gp.rs; the sparse GP's on 4000 rows): an
    /// estimate's cost does not depend on how well the hyperparameters fit.
    fn train(&self, data: &Dataset, tare: &TareSpec) -> Box<dyn WrenchModel> {
        let quick = GpParams {
            restarts: 1,
            restart_subset: 300,
            max_iters: 30,
            sparse_candidates: TRAIN_ROWS,
            sparse_fit_subset: 4000,
            sparse_iters: 20,
            ..GpParams::default()
        };
        let params = match *self {
            Candidate::Exact(n) => GpParams {
                max_train: n,
                ..quick
            },
            Candidate::Sparse(m) => GpParams {
                inducing: Some(m),
                ..quick
            },
            Candidate::NetworkMean => GpParams {
                max_train: 2000,
                mean: MeanKind::Network,
                ..quick
            },
            Candidate::Ensemble => {
                let model =
                    WrenchEnsemble::train_default(data, tare.clone(), SensorSpec::default(), 0);
                return Box::new(model.expect("trained"));
            }
        };
        let params = params.validate().expect("valid options");
        let model = WrenchGp::train(data, tare.clone(), &params, &mut |_, _| {});
        Box::new(model.expect("trained"))
    }
}

/// p50 and p99 (µs) of single estimates with their std, and the calls timed.
fn latency_us(model: &dyn WrenchModel, inputs: &[Vec<f64>]) -> (f64, f64, usize) {
    let mut ws = model.workspace();
    let mut out = [Estimate::default(); 3];
    let mut call = |x: &Vec<f64>| {
        model
            .estimate(x, &mut ws, true, &mut out)
            .expect("the model's features")
    };
    inputs.iter().cycle().take(WARM_UP).for_each(&mut call);
    let start = Instant::now();
    let mut lat: Vec<f64> = Vec::with_capacity(CALLS);
    for x in inputs.iter().cycle().take(CALLS) {
        let t0 = Instant::now();
        call(x);
        lat.push(t0.elapsed().as_secs_f64() * 1e6);
        if start.elapsed() > MAX_TIMED {
            break;
        }
    }
    lat.sort_by(f64::total_cmp);
    let at = |q: f64| lat[((lat.len() as f64 * q).ceil() as usize).clamp(1, lat.len()) - 1];
    (at(0.5), at(0.99), lat.len())
}

fn main() {
    let all = data();
    let step = all.len() / TRAIN_ROWS;
    let train = all.select(&(0..TRAIN_ROWS).map(|i| i * step).collect::<Vec<_>>());
    // Rows between the training rows.
    let held: Vec<usize> = (0..2000)
        .map(|i| i * (all.len() / 2000) + step / 2)
        .collect();
    let inputs: Vec<Vec<f64>> = all
        .select(&held)
        .x
        .rows()
        .into_iter()
        .map(|r| r.to_vec())
        .collect();
    let tare = TareSpec {
        samples: 50,
        mean_baseline: vec![0.0; train.features.len()],
    };
    let candidates = [
        Candidate::Exact(1000),
        Candidate::Exact(2000),
        Candidate::Exact(4000),
        Candidate::Sparse(200),
        Candidate::Sparse(500),
        Candidate::NetworkMean,
        Candidate::Ensemble,
    ];
    println!(
        "One estimate (3 axes with std), {} features, {TRAIN_ROWS} training rows, one thread:",
        train.features.len()
    );
    println!("| candidate | p50 µs | p99 µs | calls | fit s |");
    println!("|---|---|---|---|---|");
    for c in candidates {
        let t0 = Instant::now();
        let model = c.train(&train, &tare);
        let fit_s = t0.elapsed().as_secs_f64();
        let (p50, p99, calls) = latency_us(model.as_ref(), &inputs);
        println!(
            "| {} | {p50:.0} | {p99:.0} | {calls} | {fit_s:.1} |",
            c.name()
        );
    }
}
