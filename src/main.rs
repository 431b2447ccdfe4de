//! The `tactile_force` command line: parses flags, wires library calls,
//! prints results. Errors go to stderr with exit code 1.

mod commands;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};

use tactile_force::biotac::sim::BioTacSimConfig;
use tactile_force::learn::dataset::{electrode_columns, write_csv, Dataset};
use tactile_force::learn::default_model::{self, Origin};
use tactile_force::learn::evaluate::{
    cross_validate, score_model, train_test, EvalOptions, Evaluation, Progress, Scores,
};
use tactile_force::learn::gp::{GpParams, KernelKind};
use tactile_force::learn::model::{TareSpec, WrenchGp};
use tactile_force::learn::nn::NnParams;
use tactile_force::nodes::controller::TaskKind;
use tactile_force::report::summary::Summary;
use tactile_force::report::{plot, TraceRow};
use tactile_force::runtime::demo::{fastest_within, run_scene, sweep_speeds};
use tactile_force::runtime::{Pacing, Scene};
use tactile_force::sim::collect::{collect, CollectConfig};
use tactile_force::wrench::AxisSet;

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
    Demo(DemoArgs),
    /// Emulate a BioTac serial bridge: simulated frames to a serial port.
    BiotacEmulator(commands::serial::EmulatorArgs),
    /// Show what a BioTac serial bridge sends: readings and link statistics.
    BiotacMonitor(commands::serial::MonitorArgs),
}

#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum DemoTask {
    /// Approach an object, stop on contact, hold 1 N.
    Guarded,
    /// Follow a person's finger like a joystick (1 N along z, 0 N along x/y).
    Guided,
}

#[derive(Args)]
struct DemoArgs {
    /// The task.
    task: DemoTask,
    /// Object to touch (a name from the scene's `objects`; e.g. wooden_box,
    /// carton_box, stuffed_animal). Default: the scene's.
    #[arg(long)]
    object: Option<String>,
    /// Scene file (ROS 2 parameters, layered on config/pa10.yaml and
    /// config/world.yaml). Default: the shipped config/guarded_move.yaml or
    /// config/guided_move.yaml.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Model file from `train`. Default: a model trained on simulated data on
    /// first use and cached.
    #[arg(long)]
    model: Option<PathBuf>,
    /// Guarded move: approach speed (m/s). Default: the scene's.
    #[arg(long)]
    speed: Option<f64>,
    /// Seed of the sensor and F/T noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Pace the simulation by the wall clock.
    #[arg(long)]
    realtime: bool,
    /// Write a PNG plot (forces over time; with --sweep-speed, overshoot over speed).
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Write the run, one row per control period, as CSV.
    #[arg(long, conflicts_with = "sweep_speed")]
    csv: Option<PathBuf>,
    /// Print the figures as one JSON object on the last line.
    #[arg(long)]
    json: bool,
    /// Guarded move: sweep the approach speed against overshoot, per object.
    #[arg(long, conflicts_with = "realtime")]
    sweep_speed: bool,
    /// Objects of the sweep.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "wooden_box,carton_box,stuffed_animal"
    )]
    objects: Vec<String>,
    /// Approach speeds of the sweep (mm/s).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "5,10,15,20,25,30,35,40,50,60,80,100,150,200"
    )]
    speeds_mm_s: Vec<f64>,
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
    /// Largest training set for the exact GP (a seeded random subset beyond it): time grows as n^3.
    #[arg(long, default_value_t = 2000)]
    max_train: usize,
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
        Command::Demo(a) => run_demo(a),
        Command::BiotacEmulator(a) => commands::serial::run_emulator(a),
        Command::BiotacMonitor(a) => commands::serial::run_monitor(a),
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

/// Reads a CSV's electrode features and `axes` targets and tares each trial.
fn load_tared(path: &Path, fit: &FitArgs) -> Result<(Dataset, TareSpec)> {
    let mut ds = Dataset::read_csv(path, &electrode_columns(), &fit.axes)?;
    let mean_baseline = match fit.tare_samples {
        0 => vec![0.0; ds.features.len()],
        n => ds.tare_per_trial(n)?,
    };
    Ok((
        ds,
        TareSpec {
            samples: fit.tare_samples,
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
    let (mut ds, tare) = load_tared(&a.data, &a.fit)?;
    {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(a.fit.seed);
        ds = ds.random_rows(a.fit.max_train, &mut rng);
    }
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
            "{axis}: {} evaluations ({} on all points), -log p(y)/n = {:.4}, signal var {:.3}, noise var {:.2e}",
            info.evaluations, info.full_evaluations, info.neg_lml_per_sample, h.signal_var, h.noise_var
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
            let (ds, tare) = load_tared(data, &a.fit)?;
            cross_validate(&ds, a.folds, &tare, &opts, &mut on_progress)?
        }
        (None, Some(train), Some(test)) => {
            let (train, tare) = load_tared(train, &a.fit)?;
            let (test, _) = load_tared(test, &a.fit)?;
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

fn print_table(axes: &AxisSet, eval: &Evaluation) {
    let cols: Vec<String> = axes
        .axes()
        .iter()
        .map(|a| format!("{:>9} {:>7}", format!("{a} RMSE"), "R2"))
        .collect();
    println!(
        "{:<8} {:<5} {}  {:>8} {:>7}",
        "fold",
        "model",
        cols.join("  "),
        "fit s",
        "n_train"
    );
    let row = |fold: &str, model: &str, s: &Scores| {
        let vals: Vec<String> = axes
            .axes()
            .iter()
            .map(|a| format!("{:>9.4} {:>7.4}", s.rmse[a], s.r2[a]))
            .collect();
        println!(
            "{fold:<8} {model:<5} {}  {:>8.2} {:>7}",
            vals.join("  "),
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

/// Overshoot bound of the guarded move (N), from the closed-loop issue.
const OVERSHOOT_BOUND_N: f64 = 0.1;

fn run_demo(a: DemoArgs) -> Result<()> {
    let task = match a.task {
        DemoTask::Guarded => TaskKind::Guarded,
        DemoTask::Guided => TaskKind::Guided,
    };
    if task == TaskKind::Guided && (a.sweep_speed || a.speed.is_some()) {
        anyhow::bail!("--speed and --sweep-speed are for the guarded move");
    }
    let mut scene = match &a.scene {
        Some(path) => Scene::from_file(path)?,
        None => Scene::builtin(task),
    };
    if let Some(o) = &a.object {
        scene = scene.with_object(o);
    }
    if let Some(v) = a.speed {
        scene = scene.with_approach_speed(v);
    }
    // Check the scene before a possibly long training.
    scene.check()?;
    let model = demo_model(a.model.as_deref())?;
    if a.sweep_speed {
        return run_sweep(&a, &scene, &model);
    }
    let bar = status_line(&scene)?;
    let pacing = if a.realtime {
        Pacing::Realtime
    } else {
        Pacing::Lockstep
    };
    let run = run_scene(&scene, model, a.seed, pacing, &mut |r| show_status(&bar, r))?;
    bar.finish_and_clear();
    if let Some(path) = &a.csv {
        tactile_force::report::trace::write_csv(path, &run.rows)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = &a.plot {
        let s = &run.summary;
        let title = format!("{} move, {}", s.task, s.object);
        plot::plot_run(path, &title, &run.rows)?;
        println!("plot written to {}", path.display());
    }
    print_summary(&run.summary, &run.gains);
    if a.json {
        println!("{}", serde_json::to_string(&run.summary)?);
    }
    Ok(())
}

/// The model of `--model`, or the cached default (trained on first use).
fn demo_model(path: Option<&Path>) -> Result<WrenchGp> {
    if let Some(p) = path {
        return Ok(WrenchGp::load(p)?);
    }
    let (model, origin) = default_model::load_or_train(&mut || {
        eprintln!(
            "no --model given: training the default model on simulated data \
             (collect --seed {}, {} rows), once; this takes a few seconds",
            default_model::DATA_SEED,
            default_model::MAX_TRAIN
        )
    })?;
    match origin {
        Origin::Cached(p) => eprintln!("default model: {}", p.display()),
        Origin::TrainedAndCached(p) => {
            eprintln!("default model trained and cached at {}", p.display())
        }
        Origin::TrainedNotCached(why) => eprintln!("default model trained, not cached: {why}"),
    }
    Ok(model)
}

/// A one-line live status on a terminal (hidden otherwise).
fn status_line(scene: &Scene) -> Result<ProgressBar> {
    let p = scene.sim_params()?;
    let periods = (p.duration_s / p.control_period_s).round() as u64;
    let bar = ProgressBar::new(periods);
    bar.set_style(
        ProgressStyle::with_template("{bar:20} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    Ok(bar)
}

fn show_status(bar: &ProgressBar, r: &TraceRow) {
    bar.inc(1);
    // One update in ten periods is enough to read.
    if !bar.position().is_multiple_of(10) {
        return;
    }
    let axis = r.targets.iter().rposition(Option::is_some).unwrap_or(2);
    let name = ["Fx", "Fy", "Fz"][axis];
    let est = r.estimate.map_or("taring".to_string(), |(m, s)| {
        format!("{:+.3} N (+-{:.3})", m[axis], 2.0 * s[axis])
    });
    let halted = if r.halted { "  [halted]" } else { "" };
    bar.set_message(format!(
        "t {:5.2} s  {:8}  {name} estimate {est}  measured {:+.3} N{halted}",
        r.t,
        r.phase.name(),
        r.measured[axis]
    ));
}

fn print_summary(s: &Summary, gains: &[Option<f64>; 3]) {
    let opt = |v: Option<f64>, unit: &str| v.map_or("-".into(), |v| format!("{v:.3} {unit}"));
    println!("{} move, object {}", s.task, s.object);
    if let Some(v) = s.approach_speed_mps {
        println!("  approach speed      {:.1} mm/s", v * 1e3);
    }
    for (axis, g) in ["x", "y", "z"].iter().zip(gains) {
        if let Some(g) = g {
            println!("  gain {axis}              {:.4} m/s per N", g);
        }
    }
    println!("  contact at          {}", opt(s.contact_time_s, "s"));
    println!(
        "  peak force          {:.3} N (overshoot {:.3} N)",
        s.peak_force_n, s.overshoot_n
    );
    println!("  steady-state error  {}", opt(s.steady_state_error_n, "N"));
    println!("  settle time         {}", opt(s.settle_time_s, "s"));
    for (axis, v) in &s.rms_force_error_by_axis_n {
        println!("  RMS error {axis}        {v:.3} N");
    }
    println!(
        "  off-axis speed      {:.2} mm/s{}",
        s.max_off_axis_speed_mps * 1e3,
        s.max_off_axis_ratio.map_or(String::new(), |r| format!(
            " ({:.1} % of the commanded speed)",
            r * 100.0
        ))
    );
    println!(
        "  end                 {} after {:.2} s{}",
        s.final_phase,
        s.duration_s,
        s.reason
            .map_or(String::new(), |r| format!(", stopped: {r}"))
    );
}

fn run_sweep(a: &DemoArgs, scene: &Scene, model: &WrenchGp) -> Result<()> {
    let speeds: Vec<f64> = a.speeds_mm_s.iter().map(|v| v * 1e-3).collect();
    if let Some(bad) = speeds.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        anyhow::bail!("--speeds-mm-s: {} is not a positive speed", bad * 1e3);
    }
    let bar = progress_bar();
    bar.set_message(format!(
        "sweeping {} speeds x {} objects",
        speeds.len(),
        a.objects.len()
    ));
    let points = sweep_speeds(scene, model, &a.objects, &speeds, a.seed)?;
    bar.finish_and_clear();
    print!("{:>12}", "speed mm/s");
    for o in &a.objects {
        print!("  {o:>16}");
    }
    println!("   (overshoot N; * = over {OVERSHOOT_BOUND_N} N, ! = aborted)");
    for v in &speeds {
        print!("{:>12.1}", v * 1e3);
        for o in &a.objects {
            let p = points
                .iter()
                .find(|p| &p.object == o && p.approach_speed_mps == *v);
            let cell = p.map_or("-".into(), |p| {
                let mark = if p.aborted {
                    "!"
                } else if p.overshoot_n > OVERSHOOT_BOUND_N {
                    "*"
                } else {
                    " "
                };
                format!("{:.3}{mark}", p.overshoot_n)
            });
            print!("  {cell:>16}");
        }
        println!();
    }
    let fastest = fastest_within(&points, &a.objects, OVERSHOOT_BOUND_N);
    for (o, v) in &fastest {
        match v {
            Some(v) => println!(
                "{o}: fastest approach within {OVERSHOOT_BOUND_N} N overshoot: {:.1} mm/s",
                v * 1e3
            ),
            None => {
                println!("{o}: no swept speed keeps the overshoot within {OVERSHOOT_BOUND_N} N")
            }
        }
    }
    if let Some(path) = &a.plot {
        let series: Vec<(String, Vec<(f64, f64)>)> = a
            .objects
            .iter()
            .map(|o| {
                let pts = points
                    .iter()
                    .filter(|p| &p.object == o)
                    .map(|p| (p.approach_speed_mps, p.overshoot_n))
                    .collect();
                (o.clone(), pts)
            })
            .collect();
        plot::plot_sweep(path, &series, OVERSHOOT_BOUND_N)?;
        println!("plot written to {}", path.display());
    }
    if a.json {
        let fastest: std::collections::BTreeMap<&str, Option<f64>> =
            fastest.iter().map(|(o, v)| (o.as_str(), *v)).collect();
        println!(
            "{}",
            serde_json::json!({"sweep": points, "overshoot_bound_n": OVERSHOOT_BOUND_N, "fastest_within_bound_mps": fastest})
        );
    }
    Ok(())
}
