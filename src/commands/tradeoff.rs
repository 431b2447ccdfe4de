//! `tradeoff`: accuracy against fit time and latency of the exact GP on
//! subsets, the sparse GP and the network, on held-out trials.

use std::path::PathBuf;

use clap::Args;

use tactile_force::learn::data::trialwise_folds;
use tactile_force::learn::models::gp::{GpParams, KernelKind, Subset};
use tactile_force::learn::models::nn::NnParams;
use tactile_force::learn::tradeoff::{pareto_front, tradeoff, Row, TradeoffOptions};
use tactile_force::params::Check;
use tactile_force::report::plot;
use tactile_force::wrench::AxisSet;

use super::data::{load_sessions, SourceArgs};
use super::output::{axis_headers, axis_scores, progress_bar};
use super::BadArgument;
use super::Result;
use tactile_force::learn::data::sessions::Features;

#[derive(Args)]
pub struct TradeoffArgs {
    /// Data CSV from `collect`.
    #[arg(long)]
    data: PathBuf,
    /// Wrench axes to learn: any subset of fx,fy,fz,tx,ty,tz.
    #[arg(long, default_value = "fx,fy,fz")]
    axes: AxisSet,
    /// Write a PNG: RMSE against latency and against fit time, Pareto fronts marked.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Print the rows as one JSON object on the last line.
    #[arg(long)]
    json: bool,
    /// Training-set sizes of the exact GP.
    #[arg(long, value_delimiter = ',', default_value = "250,500,1000,2000,4000")]
    exact_n: Vec<usize>,
    /// How the exact GP's rows are chosen (each size runs with each rule).
    #[arg(long, value_delimiter = ',', default_value = "random,farthest")]
    subsets: Vec<Subset>,
    /// Inducing points of the sparse GP (trained on all the training rows).
    #[arg(long, value_delimiter = ',', default_value = "25,50,100,200,400")]
    sparse_m: Vec<usize>,
    /// Skip the network.
    #[arg(long)]
    no_nn: bool,
    /// Trials are split into this many trial-wise folds; the first is held out.
    #[arg(long, default_value_t = 5)]
    folds: usize,
    /// GP kernel: iso or ard.
    #[arg(long, default_value = "iso")]
    kernel: KernelKind,
    /// Out-of-contact rows at the start of each trial used to tare it (0: already tared).
    #[arg(long, default_value_t = 50)]
    tare_samples: usize,
    /// Seed of subsets, optimiser starts and the network.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    #[command(flatten)]
    source: SourceArgs,
}

pub fn run_tradeoff(a: TradeoffArgs) -> Result<()> {
    if a.folds < 2 {
        let msg = format!("--folds {}: at least 2 (one fold is held out)", a.folds);
        return Err(BadArgument(msg).into());
    }
    let features = [tactile_force::learn::data::Channel::Electrodes];
    let sessions = load_sessions(
        std::slice::from_ref(&a.data),
        Features::Channels(&features),
        &a.axes,
        Some(a.tare_samples),
        &a.source,
        None,
    )?;
    let (data, tare) = (sessions.pooled()?, sessions.tare);
    let (train_rows, test_rows) = trialwise_folds(&data, a.folds).swap_remove(0);
    if train_rows.is_empty() || test_rows.is_empty() {
        let msg = format!(
            "{}: too few trials to hold one fold of {} out",
            a.data.display(),
            a.folds
        );
        return Err(BadArgument(msg).into());
    }
    let (train, test) = (data.select(&train_rows), data.select(&test_rows));
    let opts = TradeoffOptions {
        exact_n: a.exact_n.clone(),
        subsets: a.subsets.clone(),
        sparse_m: a.sparse_m.clone(),
        gp: GpParams {
            kernel: a.kernel,
            seed: a.seed,
            ..GpParams::default()
        },
        nn: if a.no_nn {
            None
        } else {
            Some(
                NnParams {
                    seed: a.seed,
                    ..NnParams::default()
                }
                .checked("nn")?,
            )
        },
        ..TradeoffOptions::default()
    };
    println!(
        "{}: {} training rows, {} held-out rows (fold 1 of {} trial-wise folds), axes {}",
        a.data.display(),
        train.len(),
        test.len(),
        a.folds,
        a.axes
    );
    let bar = progress_bar();
    let rows = tradeoff(&train, &test, &tare, &opts, &mut |what| {
        bar.set_message(format!("training {what}"))
    })?;
    bar.finish_and_clear();
    print_table(&a.axes, &rows);
    if let Some(path) = &a.plot {
        plot::plot_tradeoff(path, &rows)?;
        println!("plot written to {}", path.display());
    }
    if a.json {
        println!("{}", serde_json::json!({ "rows": rows }));
    }
    Ok(())
}

fn print_table(axes: &AxisSet, rows: &[Row]) {
    let front = pareto_front(rows, Row::latency_us);
    println!(
        "{:<26} {:>9} {:>10} {:>12}  {}  Pareto",
        "model",
        "fit s",
        "mean us",
        "mean+std us",
        axis_headers(axes)
    );
    for (r, on_front) in rows.iter().zip(front) {
        let mean_std = r
            .latency_mean_std_us
            .map_or("-".into(), |v| format!("{v:.1}"));
        println!(
            "{:<26} {:>9.2} {:>10.1} {:>12}  {}  {}",
            r.label(),
            r.fit_s,
            r.latency_mean_us,
            mean_std,
            axis_scores(axes, &r.rmse, &r.r2),
            if on_front { "*" } else { "" }
        );
    }
    println!(
        "RMSE in N (forces) and Nm (torques) on the held-out trials; latency: one sample, \
         every axis, median of 5 passes; Pareto: no other row is both faster (mean+std) and \
         more accurate (mean RMSE)."
    );
}
