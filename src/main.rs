//! The `tactile_force` command line: parses flags, wires library calls,
//! prints results. Errors go to stderr with exit code 1.

mod commands;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use tactile_force::biotac::sim::BioTacSimConfig;
use tactile_force::learn::dataset::{electrode_columns, write_csv, Dataset};
use tactile_force::learn::evaluate::{
    cross_validate, score_model, train_test, EvalOptions, Evaluation, Progress, Scores,
};
use tactile_force::learn::gp::{GpParams, KernelKind, Subset};
use tactile_force::learn::model::{TareSpec, WrenchGp};
use tactile_force::learn::nn::NnParams;
use tactile_force::sim::collect::{collect, CollectConfig};
use tactile_force::wrench::{Axis, AxisSet};

#[derive(Parser)]
#[command(
    name = "tactile_force",
    version,
    about = "Feel with a BioTac fingertip: GP wrench estimation for guarded and guided moves"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate the thesis data-collection protocol and write a training CSV.
    Collect(CollectArgs),
    /// Train the GP wrench estimator on a CSV and write a model file.
    Train(TrainArgs),
    /// Cross-validate (or train/test) the GP against the baseline network.
    Eval(EvalArgs),
    /// Run the closed loop in simulation: a guarded or a guided move.
    Demo(commands::demo::DemoArgs),
    /// Emulate a BioTac serial bridge: simulated frames to a serial port.
    BiotacEmulator(commands::serial::EmulatorArgs),
    /// Show what a BioTac serial bridge sends: readings and link statistics.
    BiotacMonitor(commands::serial::MonitorArgs),
    /// Measure accuracy against fit time and latency: exact GP on subsets,
    /// sparse GP, network.
    Tradeoff(commands::tradeoff::TradeoffArgs),
}

#[derive(Args)]
struct CollectArgs {
    /// Output CSV (header: t,set,trial,e1..e19,pdc,pac_mean,tdc,tac,fx,fy,fz,tx,ty,tz).
    #[arg(long)]
    out: PathBuf,
    /// Seed of the simulated sensor unit, pushes and noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Simulator and protocol parameters (YAML); default: the shipped config/biotac_sim.yaml.
    #[arg(long)]
    config: Option<PathBuf>,
}

/// Options shared by `train` and `eval`.
#[derive(Args)]
struct FitArgs {
    /// Wrench axes to learn: any subset of fx,fy,fz,tx,ty,tz.
    #[arg(long, default_value = "fx,fy,fz")]
    axes: AxisSet,
    /// Largest training set of the exact GP (a subset beyond it, see --subset): time grows as n^3.
    #[arg(long, default_value_t = 2000)]
    max_train: usize,
    /// How the exact GP's subset is chosen: random, or farthest (spread over the inputs).
    #[arg(long, default_value = "random")]
    subset: Subset,
    /// Train a sparse GP with this many inducing points on every row instead
    /// of the exact GP (`train` only; `eval` trains on --max-train rows).
    #[arg(long)]
    inducing: Option<usize>,
    /// GP kernel: iso (one length-scale) or ard (one length-scale per electrode).
    #[arg(long, default_value = "iso")]
    kernel: KernelKind,
    /// Optimiser starts of the hyperparameter fit.
    #[arg(long, default_value_t = 3)]
    restarts: usize,
    /// Size of the random training subset each optimiser start runs on.
    #[arg(long, default_value_t = 500)]
    restart_subset: usize,
    /// L-BFGS iterations of the polish on all points (0: keep the subset's hyperparameters).
    #[arg(long, default_value_t = 0)]
    polish_iters: u64,
    /// Out-of-contact rows at the start of each trial used to tare it (0: the CSV is already tared).
    #[arg(long, default_value_t = 50)]
    tare_samples: usize,
    /// Seed of subsets and optimiser starts.
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

#[derive(Args)]
struct TrainArgs {
    /// Training CSV.
    #[arg(long)]
    data: PathBuf,
    /// Model file to write (JSON).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    fit: FitArgs,
}

#[derive(Args)]
struct EvalArgs {
    /// Data for trial-wise k-fold cross-validation.
    #[arg(long, conflicts_with_all = ["train", "test", "model"], required_unless_present_any = ["train", "model"])]
    data: Option<PathBuf>,
    /// Number of folds (per set, consecutive blocks of trials are held out).
    #[arg(long, default_value_t = 5)]
    folds: usize,
    /// Training CSV (with --test).
    #[arg(long, requires = "test", conflicts_with = "model")]
    train: Option<PathBuf>,
    /// Test CSV (with --train or --model).
    #[arg(long)]
    test: Option<PathBuf>,
    /// A trained model file to score on --test (no training; GP only).
    #[arg(long, requires = "test")]
    model: Option<PathBuf>,
    /// Skip the baseline network.
    #[arg(long)]
    no_nn: bool,
    /// Print the result as one JSON object on the last line.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    fit: FitArgs,
}

fn main() -> ExitCode {
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "info".into()),
        )
        .with_writer(std::io::stderr)
        .init();
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Collect(a) => run_collect(a),
        Command::Train(a) => run_train(a),
        Command::Eval(a) => run_eval(a),
        Command::Demo(a) => commands::demo::run_demo(a),
        Command::BiotacEmulator(a) => commands::serial::run_emulator(a),
        Command::BiotacMonitor(a) => commands::serial::run_monitor(a),
        Command::Tradeoff(a) => commands::tradeoff::run_tradeoff(a),
    }
}

fn run_collect(a: CollectArgs) -> Result<()> {
    let (sensor, protocol) = match &a.config {
        Some(p) => (BioTacSimConfig::from_file(p)?, CollectConfig::from_file(p)?),
        None => (BioTacSimConfig::default(), CollectConfig::default()),
    };
    let records = collect(&protocol, &sensor, a.seed);
    write_csv(&a.out, &records)?;
    let noise = protocol.params().ft_noise_std;
    println!(
        "wrote {} rows to {} (seed {}); F/T reference noise std: force {:?} N, torque {:?} Nm",
        records.len(),
        a.out.display(),
        a.seed,
        noise.force_n,
        noise.torque_nm
    );
    Ok(())
}

/// Reads a CSV's electrode features and `axes` targets and tares each trial
/// on its first `tare_samples` rows (0: already tared).
fn load_tared(path: &Path, axes: &AxisSet, tare_samples: usize) -> Result<(Dataset, TareSpec)> {
    let mut ds = Dataset::read_csv(path, &electrode_columns(), axes)?;
    let mean_baseline = match tare_samples {
        0 => vec![0.0; ds.features.len()],
        n => ds.tare_per_trial(n)?,
    };
    Ok((
        ds,
        TareSpec {
            samples: tare_samples,
            mean_baseline,
        },
    ))
}

fn gp_params(fit: &FitArgs) -> Result<tactile_force::learn::gp::ValidGpParams> {
    Ok(GpParams {
        kernel: fit.kernel,
        restarts: fit.restarts,
        restart_subset: fit.restart_subset,
        polish_iters: fit.polish_iters,
        max_train: fit.max_train,
        subset: fit.subset,
        inducing: fit.inducing,
        seed: fit.seed,
        ..GpParams::default()
    }
    .validate()?)
}

fn progress_bar() -> ProgressBar {
    let bar = ProgressBar::new_spinner();
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_spinner()),
    );
    bar.enable_steady_tick(Duration::from_millis(120));
    bar
}

fn show(bar: &ProgressBar, p: Progress) {
    match p {
        Progress::Fold(f, k) => bar.println(format!("fold {f}/{k}")),
        Progress::Gp(axis, g) => bar.set_message(format!(
            "GP {axis}: start {}, {} likelihood evaluations, -log p(y)/n = {:.4}",
            g.start + 1,
            g.evaluations,
            g.neg_lml_per_sample
        )),
        Progress::Nn => bar.set_message("neural network: training"),
    }
}

fn run_train(a: TrainArgs) -> Result<()> {
    let (ds, tare) = load_tared(&a.data, &a.fit.axes, a.fit.tare_samples)?;
    let params = gp_params(&a.fit)?;
    let bar = progress_bar();
    let t0 = std::time::Instant::now();
    let model = WrenchGp::train(&ds, tare, &params, &mut |axis, p| {
        show(&bar, Progress::Gp(axis, p))
    })?;
    let fit_s = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    model
        .save(&a.out)
        .with_context(|| format!("saving the model to {}", a.out.display()))?;
    for (axis, gp, info) in model.fits() {
        let h = gp.hyper();
        println!(
            "{axis}: {}, {} evaluations ({} on all points), -log p(y)/n = {:.4}, signal var {:.3}, noise var {:.2e}",
            gp.describe(), info.evaluations, info.full_evaluations, info.neg_lml_per_sample, h.signal_var, h.noise_var
        );
    }
    println!(
        "trained {} axes ({}) on {} samples in {:.2} s; model written to {}",
        model.axes().len(),
        model.axes(),
        model.n_train(),
        fit_s,
        a.out.display()
    );
    Ok(())
}

fn run_eval(a: EvalArgs) -> Result<()> {
    if let (Some(model), Some(test)) = (&a.model, &a.test) {
        return run_score(model, test, a.json);
    }
    let opts = EvalOptions {
        max_train: a.fit.max_train,
        gp: gp_params(&a.fit)?,
        nn: if a.no_nn {
            None
        } else {
            Some(NnParams::default().validate()?)
        },
        seed: a.fit.seed,
    };
    let bar = progress_bar();
    let mut on_progress = |p| show(&bar, p);
    let eval = match (&a.data, &a.train, &a.test) {
        (Some(data), _, _) => {
            let (ds, tare) = load_tared(data, &a.fit.axes, a.fit.tare_samples)?;
            cross_validate(&ds, a.folds, &tare, &opts, &mut on_progress)?
        }
        (None, Some(train), Some(test)) => {
            let (train, tare) = load_tared(train, &a.fit.axes, a.fit.tare_samples)?;
            let (test, _) = load_tared(test, &a.fit.axes, a.fit.tare_samples)?;
            train_test(&train, &test, &tare, &opts, &mut on_progress)?
        }
        _ => {
            anyhow::bail!("give --data FILE, --train FILE --test FILE, or --model FILE --test FILE")
        }
    };
    bar.finish_and_clear();
    print_table(&a.fit.axes, &eval);
    if a.json {
        println!("{}", serde_json::to_string(&eval)?);
    }
    Ok(())
}

fn run_score(model: &Path, test: &Path, json: bool) -> Result<()> {
    let model = WrenchGp::load(model)?;
    let mut ds = Dataset::read_csv(test, model.features(), model.axes())?;
    if model.tare().samples > 0 {
        ds.tare_per_trial(model.tare().samples)?;
    }
    let gp = score_model(&model, &ds)?;
    let eval = Evaluation {
        folds: Vec::new(),
        gp,
        nn: None,
    };
    print_table(model.axes(), &eval);
    if json {
        println!("{}", serde_json::to_string(&eval)?);
    }
    Ok(())
}

/// The "RMSE R2" column headers of a score table, one pair per axis.
fn axis_headers(axes: &AxisSet) -> String {
    let cols: Vec<String> = axes
        .axes()
        .iter()
        .map(|a| format!("{:>9} {:>7}", format!("{a} RMSE"), "R2"))
        .collect();
    cols.join("  ")
}

/// One row's RMSE and R2 under [`axis_headers`].
fn axis_scores(axes: &AxisSet, rmse: &BTreeMap<Axis, f64>, r2: &BTreeMap<Axis, f64>) -> String {
    let vals: Vec<String> = axes
        .axes()
        .iter()
        .map(|a| format!("{:>9.4} {:>7.4}", rmse[a], r2[a]))
        .collect();
    vals.join("  ")
}

fn print_table(axes: &AxisSet, eval: &Evaluation) {
    println!(
        "{:<8} {:<5} {}  {:>8} {:>7}",
        "fold",
        "model",
        axis_headers(axes),
        "fit s",
        "n_train"
    );
    let row = |fold: &str, model: &str, s: &Scores| {
        println!(
            "{fold:<8} {model:<5} {}  {:>8.2} {:>7}",
            axis_scores(axes, &s.rmse, &s.r2),
            s.fit_s,
            s.n_train
        );
    };
    if eval.folds.len() > 1 {
        for f in &eval.folds {
            row(&f.fold.to_string(), "GP", &f.gp);
            if let Some(nn) = &f.nn {
                row(&f.fold.to_string(), "NN", nn);
            }
        }
    }
    row("overall", "GP", &eval.gp);
    if let Some(nn) = &eval.nn {
        row("overall", "NN", nn);
    }
    println!("RMSE in N (forces) and Nm (torques); overall = all test rows pooled; fit s = mean per fold.");
}
