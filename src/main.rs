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

use nalgebra::Vector3;
use tactile_force::biotac::reading::FRAME_PERIOD_S;
use tactile_force::biotac::sim::BioTacSimConfig;
use tactile_force::learn::bag::{read_bag, BagTopics};
use tactile_force::learn::dataset::{channel_columns, write_csv, Channel, Dataset};
use tactile_force::learn::evaluate::{
    cross_validate, leave_one_session_out, score_model, train_test, EvalOptions, Evaluation,
    FoldScores, Progress, Scores,
};
use tactile_force::learn::gp::{GpParams, KernelKind, Subset};
use tactile_force::learn::model::{AdaptedFrom, TareSpec, WrenchGp};
use tactile_force::learn::nn::NnParams;
use tactile_force::learn::scale::InputScaling;
use tactile_force::sim::collect::{collect, CollectConfig};
use tactile_force::wrench::{Axis, AxisSet, FrameTransform, Wrench};

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
    /// Adapt a trained model to another sensor unit, session or person from
    /// a short recording of it (e.g. 80 s: `collect --trials 1`).
    Adapt(AdaptArgs),
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
    /// The simulated sensor unit (its electrode gains and baselines).
    #[arg(long, default_value_t = 1)]
    unit: u64,
    /// The session: temperature, how the finger is mounted, the pushes and the noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Trials per set (default: the protocol's 10; 1 trial per set is 80 s of data).
    #[arg(long)]
    trials: Option<u32>,
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
    /// BioTac channels the model takes as features, comma-separated: any of
    /// electrodes (e1..e19), pdc, tdc, tac; each tared per trial. The
    /// default was chosen by leave-one-out results on simulated and real
    /// data (README, "Sensor units and sessions").
    #[arg(long, value_delimiter = ',', default_value = "electrodes,pdc")]
    channels: Vec<Channel>,
    /// How the tared features reach the GP: standard (each standardised),
    /// raw (counts as they are) or pattern (the electrodes over their norm,
    /// plus the norm; then standardised).
    #[arg(long, default_value = "standard")]
    input: InputScaling,
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
    #[command(flatten)]
    source: SourceArgs,
}

/// Where the data files' wrenches come from: topics of a ROS bag (MCAP)
/// and the F/T sensor's frame.
#[derive(Args)]
struct SourceArgs {
    /// BioTac readings topic (tactile_force_msgs/msg/BioTac) in MCAP files.
    #[arg(long, default_value = "/biotac/readings")]
    biotac_topic: String,
    /// F/T sensor topic (geometry_msgs/msg/WrenchStamped) in MCAP files.
    #[arg(long, default_value = "/ft_sensor/wrench")]
    ft_topic: String,
    /// Largest header-stamp difference between a reading and its wrench in MCAP files (s).
    #[arg(long, default_value_t = 0.005)]
    pair_tolerance_s: f64,
    /// Where the F/T sensor sits in the BioTac frame, `roll,pitch,yaw,x,y,z`
    /// (deg, fixed-axis x-y-z; m): its wrenches are moved to the BioTac frame
    /// and origin. Default: the files are in the BioTac frame already.
    #[arg(long, allow_hyphen_values = true)]
    ft_to_biotac: Option<FrameTransform>,
}

#[derive(Args)]
struct TrainArgs {
    /// Training files, comma-separated: each a session, tared on its own.
    #[arg(long, value_delimiter = ',', required = true)]
    data: Vec<PathBuf>,
    /// Model file to write (JSON).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    fit: FitArgs,
}

#[derive(Args)]
struct EvalArgs {
    /// Data for trial-wise k-fold cross-validation.
    #[arg(long, conflicts_with_all = ["train", "test", "model", "sessions"], required_unless_present_any = ["train", "model", "sessions"])]
    data: Option<PathBuf>,
    /// Number of folds (per set, consecutive blocks of trials are held out).
    #[arg(long, default_value_t = 5)]
    folds: usize,
    /// Training files, comma-separated: each a session, tared on its own (with --test).
    #[arg(long, value_delimiter = ',', requires = "test", conflicts_with_all = ["model", "sessions"])]
    train: Vec<PathBuf>,
    /// Test files, comma-separated, scored one by one (with --train or --model).
    #[arg(long, value_delimiter = ',')]
    test: Vec<PathBuf>,
    /// Leave one session out: each file, comma-separated, tested on a model
    /// trained on the others.
    #[arg(long, value_delimiter = ',', conflicts_with_all = ["test", "model"])]
    sessions: Vec<PathBuf>,
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

#[derive(Args)]
struct AdaptArgs {
    /// The trained model to adapt (from `train`).
    #[arg(long)]
    model: PathBuf,
    /// The short recording(s) of the new unit, comma-separated; tared as the
    /// base model's data were.
    #[arg(long, value_delimiter = ',', required = true)]
    data: Vec<PathBuf>,
    /// The adapted model file to write (JSON).
    #[arg(long)]
    out: PathBuf,
    /// Largest number of rows the correction GP trains on (a random subset beyond it).
    #[arg(long, default_value_t = 2000)]
    max_train: usize,
    /// Optimiser starts of the hyperparameter fit.
    #[arg(long, default_value_t = 3)]
    restarts: usize,
    /// Seed of the subset and the optimiser starts.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    #[command(flatten)]
    source: SourceArgs,
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
        Command::Adapt(a) => run_adapt(a),
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
    let protocol = match a.trials {
        Some(n) => protocol.with_trials(n).context("--trials")?,
        None => protocol,
    };
    let records = collect(&protocol, &sensor, a.unit, a.seed);
    write_csv(&a.out, &records)?;
    let noise = protocol.params().ft_noise_std;
    println!(
        "wrote {} rows ({:.0} s) to {} (unit {}, session {}); F/T reference noise std: force {:?} N, torque {:?} Nm",
        records.len(),
        records.len() as f64 / protocol.params().rate_hz,
        a.out.display(),
        a.unit,
        a.seed,
        noise.force_n,
        noise.torque_nm
    );
    Ok(())
}

/// Reads one session's `features` and `axes` targets and tares each trial
/// on its first `tare_samples` rows (0: already tared); returns the
/// baselines too.
fn load_session(
    path: &Path,
    features: &[String],
    axes: &AxisSet,
    tare_samples: usize,
    source: &SourceArgs,
) -> Result<(Dataset, Vec<f64>)> {
    let mut ds = read_data(path, features, axes, source)?;
    let baseline = match tare_samples {
        0 => vec![0.0; ds.features.len()],
        n => ds
            .tare_per_trial(n)
            .with_context(|| format!("taring {}", path.display()))?,
    };
    Ok((ds, baseline))
}

/// Reads a CSV or, by its `.mcap` extension, a ROS bag; wrenches moved to
/// the BioTac frame when `--ft-to-biotac` says where the F/T sensor is.
fn read_data(
    path: &Path,
    features: &[String],
    axes: &AxisSet,
    source: &SourceArgs,
) -> Result<Dataset> {
    let name = path.display().to_string();
    let to_biotac = |w: Wrench| source.ft_to_biotac.map_or(w, |t| t.apply(&w));
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
    {
        let topics = BagTopics {
            biotac: source.biotac_topic.clone(),
            ft: source.ft_topic.clone(),
            tolerance_s: source.pair_tolerance_s,
        };
        let mut bag = read_bag(path, &topics)?;
        eprintln!(
            "{name}: {} readings paired with a wrench; unpaired: {} readings, {} wrenches",
            bag.records.len(),
            bag.unpaired_readings,
            bag.unpaired_wrenches
        );
        for r in &mut bag.records {
            r.wrench = to_biotac(r.wrench);
        }
        return Ok(Dataset::from_records(&bag.records, features, axes, &name)?);
    }
    if source.ft_to_biotac.is_none() {
        return Ok(Dataset::read_csv(path, features, axes)?);
    }
    // Every BioTac-frame component needs the whole force (and torque).
    let torques = axes.axes().iter().any(|a| a.index() >= 3);
    let read: AxisSet = if torques {
        "fx,fy,fz,tx,ty,tz"
    } else {
        "fx,fy,fz"
    }
    .parse()?;
    let mut ds = Dataset::read_csv(path, features, &read)?;
    let y = ndarray::Array2::from_shape_fn((ds.len(), axes.len()), |(i, j)| {
        let row = ds.y.row(i);
        let torque = if torques {
            Vector3::new(row[3], row[4], row[5])
        } else {
            Vector3::zeros()
        };
        to_biotac(Wrench::new(Vector3::new(row[0], row[1], row[2]), torque)).get(axes.axes()[j])
    });
    ds.y = y;
    ds.axes = axes.clone();
    Ok(ds)
}

/// Reads sessions, each tared on its own: their rows, and the tare spec a
/// model trained on them records (the baselines averaged over sessions).
fn load_sessions(
    paths: &[PathBuf],
    features: &[String],
    axes: &AxisSet,
    tare_samples: usize,
    source: &SourceArgs,
) -> Result<(Vec<Dataset>, TareSpec)> {
    let mut sessions = Vec::with_capacity(paths.len());
    let mut mean_baseline = vec![0.0; features.len()];
    for p in paths {
        let (ds, base) = load_session(p, features, axes, tare_samples, source)?;
        for (m, b) in mean_baseline.iter_mut().zip(base) {
            *m += b / paths.len() as f64;
        }
        sessions.push(ds);
    }
    let tare = TareSpec {
        samples: tare_samples,
        mean_baseline,
    };
    Ok((sessions, tare))
}

/// [`load_sessions`] with the rows of every session in one data set.
fn load_pooled(
    paths: &[PathBuf],
    features: &[String],
    axes: &AxisSet,
    tare_samples: usize,
    source: &SourceArgs,
) -> Result<(Dataset, TareSpec)> {
    let (sessions, tare) = load_sessions(paths, features, axes, tare_samples, source)?;
    let refs: Vec<&Dataset> = sessions.iter().collect();
    let pooled = Dataset::concat(&refs).context("no data file given")?;
    Ok((pooled, tare))
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
    let (ds, tare) = load_pooled(
        &a.data,
        &channel_columns(&a.fit.channels),
        &a.fit.axes,
        a.fit.tare_samples,
        &a.fit.source,
    )?;
    let params = gp_params(&a.fit)?;
    let bar = progress_bar();
    let t0 = std::time::Instant::now();
    let model = WrenchGp::train_scaled(&ds, tare, a.fit.input, &params, &mut |axis, p| {
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

fn run_adapt(a: AdaptArgs) -> Result<()> {
    let base = WrenchGp::load(&a.model)?;
    let (data, tare) = load_pooled(
        &a.data,
        base.features(),
        base.axes(),
        base.tare().samples,
        &a.source,
    )?;
    let params = GpParams {
        restarts: a.restarts,
        max_train: a.max_train,
        seed: a.seed,
        ..GpParams::default()
    }
    .validate()?;
    let seconds = data.len() as f64 * FRAME_PERIOD_S;
    let from = AdaptedFrom {
        model: a.model.display().to_string(),
        data: a.data.iter().map(|p| p.display().to_string()).collect(),
        seconds,
    };
    let bar = progress_bar();
    let t0 = std::time::Instant::now();
    let adapted = base.adapt(&data, tare, from, &params, &mut |axis, p| {
        show(&bar, Progress::Gp(axis, p))
    })?;
    let fit_s = t0.elapsed().as_secs_f64();
    bar.finish_and_clear();
    adapted
        .save(&a.out)
        .with_context(|| format!("saving the model to {}", a.out.display()))?;
    println!(
        "adapted {} ({}) with {:.0} s of data ({} rows) in {:.2} s; model written to {}",
        a.model.display(),
        base.axes(),
        seconds,
        data.len(),
        fit_s,
        a.out.display()
    );
    Ok(())
}

fn run_eval(a: EvalArgs) -> Result<()> {
    if let Some(model) = &a.model {
        return run_score(model, &a.test, &a.fit.source, a.json);
    }
    let opts = EvalOptions {
        scaling: a.fit.input,
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
    let (features, axes, n) = (
        channel_columns(&a.fit.channels),
        &a.fit.axes,
        a.fit.tare_samples,
    );
    let (eval, labels) = if let Some(data) = &a.data {
        let (ds, tare) = load_pooled(
            std::slice::from_ref(data),
            &features,
            axes,
            n,
            &a.fit.source,
        )?;
        let eval = cross_validate(&ds, a.folds, &tare, &opts, &mut on_progress)?;
        let labels = (1..=a.folds).map(|f| f.to_string()).collect();
        (eval, labels)
    } else if !a.sessions.is_empty() {
        if a.sessions.len() < 2 {
            anyhow::bail!("--sessions needs at least two files (one is left out in turn)");
        }
        let (sessions, tare) = load_sessions(&a.sessions, &features, axes, n, &a.fit.source)?;
        let eval = leave_one_session_out(&sessions, &tare, &opts, &mut on_progress)?;
        (eval, file_labels(&a.sessions))
    } else if !a.train.is_empty() && !a.test.is_empty() {
        let (train, tare) = load_pooled(&a.train, &features, axes, n, &a.fit.source)?;
        let (tests, _) = load_sessions(&a.test, &features, axes, n, &a.fit.source)?;
        let eval = train_test(&train, &tests, &tare, &opts, &mut on_progress)?;
        (eval, file_labels(&a.test))
    } else {
        anyhow::bail!(
            "give --data FILE, --train FILES --test FILES, --sessions FILES, or --model FILE --test FILES"
        )
    };
    bar.finish_and_clear();
    print_table(&a.fit.axes, &eval, &labels);
    if a.json {
        println!("{}", serde_json::to_string(&eval)?);
    }
    Ok(())
}

fn run_score(model: &Path, tests: &[PathBuf], source: &SourceArgs, json: bool) -> Result<()> {
    let model = WrenchGp::load(model)?;
    let (sessions, _) = load_sessions(
        tests,
        model.features(),
        model.axes(),
        model.tare().samples,
        source,
    )?;
    let refs: Vec<&Dataset> = sessions.iter().collect();
    let pooled = Dataset::concat(&refs).context("give --test FILES")?;
    let mut folds = Vec::with_capacity(sessions.len());
    for (i, ds) in sessions.iter().enumerate() {
        folds.push(FoldScores {
            fold: i + 1,
            n_test: ds.len(),
            gp: score_model(&model, ds)?,
            nn: None,
        });
    }
    let eval = Evaluation {
        folds,
        gp: score_model(&model, &pooled)?,
        nn: None,
    };
    print_table(model.axes(), &eval, &file_labels(tests));
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

/// The files' names without directory and extension: a table's row labels.
fn file_labels(paths: &[PathBuf]) -> Vec<String> {
    paths
        .iter()
        .map(|p| {
            p.file_stem()
                .map_or_else(|| p.display().to_string(), |s| s.to_string_lossy().into())
        })
        .collect()
}

/// The scores per fold (labelled by `labels`, e.g. session files) and overall.
fn print_table(axes: &AxisSet, eval: &Evaluation, labels: &[String]) {
    let width = labels.iter().map(String::len).max().unwrap_or(0).max(8);
    println!(
        "{:<width$} {:<5} {}  {:>8} {:>7}",
        "fold",
        "model",
        axis_headers(axes),
        "fit s",
        "n_train"
    );
    let row = |fold: &str, model: &str, s: &Scores| {
        println!(
            "{fold:<width$} {model:<5} {}  {:>8.2} {:>7}",
            axis_scores(axes, &s.rmse, &s.r2),
            s.fit_s,
            s.n_train
        );
    };
    if eval.folds.len() > 1 {
        for (f, label) in eval.folds.iter().zip(labels) {
            row(label, "GP", &f.gp);
            if let Some(nn) = &f.nn {
                row(label, "NN", nn);
            }
        }
    }
    row("overall", "GP", &eval.gp);
    if let Some(nn) = &eval.nn {
        row("overall", "NN", nn);
    }
    println!("RMSE in N (forces) and Nm (torques); overall = all test rows pooled; fit s = mean per fold.");
}
