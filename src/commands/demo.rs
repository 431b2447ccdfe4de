//! `demo`: the closed loop in simulation (guarded or guided move, or the
//! calibration of `commands::calibrate`), and the approach-speed sweep.

use std::path::{Path, PathBuf};

use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};

use tactile_force::control::TaskKind;
use tactile_force::learn::default_model::{self, Origin, Recipe};
use tactile_force::learn::models::model_file;
use tactile_force::learn::models::wrench_gp::WrenchGp;
use tactile_force::learn::models::wrench_model::WrenchModel;
use tactile_force::report::plot::{self, SweepSeries};
use tactile_force::report::summary::Summary;
use tactile_force::report::TraceRow;
use tactile_force::runtime::demo::{
    fastest_within, run_scene, sweep_speeds, SweepObject, SweepPoint,
};
use tactile_force::runtime::scene::RobotChoice;
use tactile_force::runtime::{Pacing, Scene};

use super::calibrate::{check_outputs, run_calibrate, CalibrateRun};
use super::output::progress_bar;
use super::BadArgument;
use super::{Context, Result};

#[derive(Args)]
pub struct DemoArgs {
    /// The task: guarded (approach an object, stop on contact, hold 1 N),
    /// guided (follow a person's finger like a joystick: 1 N along z, 0 N
    /// along x/y), or calibrate (press a calibration block in a pattern with
    /// the F/T sensor as the force, then make a model of the BioTac from it:
    /// needs --out).
    #[arg(value_parser = PossibleValuesParser::new(TaskKind::ALL.map(TaskKind::name))
        .try_map(|s| s.parse::<TaskKind>()))]
    task: TaskKind,
    /// Object to touch (a name from the scene's `objects`; e.g. wooden_box,
    /// carton_box, stuffed_animal). Default: the scene's.
    #[arg(long)]
    object: Option<String>,
    /// The arm: a shipped robot (pa10, ur5, panda: config/<name>.urdf and
    /// config/<name>.yaml) or a URDF file (the chain from --base to --tip,
    /// the BioTac frame at the tip, the start pose in the middle of every
    /// joint's range unless the scene sets `start_joints_deg`).
    #[arg(long, default_value = "pa10")]
    robot: String,
    /// First link of the chain (default: the robot's; for a URDF file, its
    /// root link).
    #[arg(long)]
    base: Option<String>,
    /// The link the BioTac is mounted on (default: the robot's; for a URDF
    /// file, its one leaf).
    #[arg(long)]
    tip: Option<String>,
    /// Scene file (ROS 2 parameters, layered on config/world.yaml and the
    /// robot's file; it may override any of their keys). Default: the
    /// shipped config/guarded_move.yaml or config/guided_move.yaml.
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
    /// The simulated BioTac unit (as `collect --unit` numbers them; the
    /// default models are trained on unit 1). Default: the scene's.
    #[arg(long)]
    unit: Option<u64>,
    /// Calibrate: the model file to write.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Calibrate: the recording, as a rosbag2 MCAP file (readable by
    /// `train`, `eval`). Default: --out with the extension .mcap.
    #[arg(long)]
    session: Option<PathBuf>,
    /// Pace the simulation by the wall clock (a calibration: its motion, as
    /// on the robot).
    #[arg(long)]
    realtime: bool,
    /// Write a PNG plot (forces over time; with --sweep-speed, overshoot over
    /// speed). Its format (.png) and folder are checked before the run.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Write the run, one row per control period, as CSV.
    #[arg(long, conflicts_with = "sweep_speed")]
    csv: Option<PathBuf>,
    /// Print the figures as one JSON object on the last line.
    #[arg(long)]
    json: bool,
    /// Guarded move: sweep the approach speed against the peak force, per
    /// object (each alone in the scene, so with its own safety envelope),
    /// measured and as the envelope predicts; speeds above it are refused.
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

/// Overshoot bound of the guarded move (N), from the closed-loop issue.
const OVERSHOOT_BOUND_N: f64 = 0.1;

pub fn run_demo(a: DemoArgs) -> Result<()> {
    let task = a.task;
    check_flags(&a)?;
    // Every output checked before any work: a run that could not write
    // what it makes is refused now, not after it (a calibration: before
    // the arm moves).
    let session = match (task, a.out.as_deref()) {
        (TaskKind::Calibrate, Some(out)) => {
            let session = (a.session.clone()).unwrap_or_else(|| out.with_extension("mcap"));
            Some((out, session))
        }
        _ => None,
    };
    let files = session.as_ref().map(|(o, s)| (*o, s.as_path()));
    check_outputs(files, a.plot.as_deref(), a.csv.as_deref())?;
    let scene = demo_scene(&a)?;
    let recipe = &scene.estimator.default_model;
    let model = match a.model.as_deref() {
        Some(p) => model_file::load(p)?,
        None => Box::new(scene_default_model(recipe)?),
    };
    if task == TaskKind::Calibrate {
        let (out, session) =
            session.ok_or_else(|| BadArgument("demo calibrate needs --out".into()))?;
        let run = CalibrateRun {
            out,
            session,
            seed: a.seed,
            csv: a.csv.as_deref(),
            plot: a.plot.as_deref(),
            json: a.json,
            realtime: a.realtime,
        };
        return run_calibrate(&run, &scene, model.as_ref());
    }
    if a.sweep_speed {
        return run_sweep(&a, &scene, model.as_ref());
    }
    run_move(&a, &scene, model)
}

/// The flags that go with one task only, refused with another.
fn check_flags(a: &DemoArgs) -> Result<()> {
    if (a.out.is_some() || a.session.is_some()) != (a.task == TaskKind::Calibrate) {
        return Err(BadArgument(
            "--out (and --session) go with `demo calibrate`, which needs --out".into(),
        )
        .into());
    }
    if a.task == TaskKind::Guided && (a.sweep_speed || a.speed.is_some()) {
        return Err(
            BadArgument("--speed and --sweep-speed are for the guarded move".into()).into(),
        );
    }
    Ok(())
}

/// The task's scene (or `--scene`) on the chosen arm with the flags'
/// changes, checked before a possibly long training.
fn demo_scene(a: &DemoArgs) -> Result<Scene> {
    let robot = RobotChoice::parse(&a.robot)?;
    let text = match &a.scene {
        Some(path) => Scene::read_scene(path)?,
        None => a.task.scene_yaml().to_string(),
    };
    let mut scene =
        Scene::with_robot(&robot, &text)?.with_links(a.base.as_deref(), a.tip.as_deref());
    if let Some(o) = &a.object {
        scene = scene.with_object(o);
    }
    if let Some(v) = a.speed {
        scene = scene.with_approach_speed(v)?;
    }
    if let Some(u) = a.unit {
        scene.sim.sensor_unit = u;
    }
    scene.check()?;
    Ok(scene)
}

/// One guarded or guided move: its status line, then its summary, and
/// the trace, plot and JSON the flags ask for.
fn run_move(a: &DemoArgs, scene: &Scene, model: Box<dyn WrenchModel>) -> Result<()> {
    let bar = status_line(scene);
    let pacing = if a.realtime {
        Pacing::Realtime
    } else {
        Pacing::Lockstep
    };
    let run = run_scene(scene, model, a.seed, pacing, &mut |r| show_status(&bar, r))?;
    bar.finish_and_clear();
    if let Some(path) = &a.csv {
        tactile_force::report::trace::write_csv(path, &run.rows)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    print_summary(&run.summary, &run.gains);
    if let Some(path) = &a.plot {
        let s = &run.summary;
        let title = format!("{} move, {}, {}", s.task, s.object, s.robot);
        plot::plot_run(path, &title, &run.rows)?;
        println!("plot written to {}", shown_path(path));
    }
    if a.json {
        println!("{}", serde_json::to_string(&run.summary)?);
    }
    Ok(run.held()?)
}

/// The scene's cached default model (trained on first use).
fn scene_default_model(recipe: &Recipe) -> Result<WrenchGp> {
    let (model, origin) = default_model::load_or_train(recipe, &mut || {
        eprintln!(
            "no --model given: training the default model of the scene ({}) on \
             simulated data (collect --unit {1} --seed {1}), once; this takes about 10-20 s",
            recipe.describe(),
            default_model::DATA_SEED,
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

/// `path` made absolute, for a message the user can act on from anywhere.
fn shown_path(path: &Path) -> String {
    std::path::absolute(path)
        .unwrap_or_else(|_| path.to_path_buf())
        .display()
        .to_string()
}

/// A one-line live status on a terminal (hidden otherwise).
fn status_line(scene: &Scene) -> ProgressBar {
    let p = &scene.sim;
    let periods = (p.duration_s / p.control_period_s).round() as u64;
    let bar = ProgressBar::new(periods);
    bar.set_style(
        ProgressStyle::with_template("{bar:20} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
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
    println!("{} move, object {}, robot {}", s.task, s.object, s.robot);
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
    if s.damped_periods > 0 {
        println!(
            "  damping             {} periods near a singularity, lambda up to {:.4}",
            s.damped_periods, s.max_damping
        );
    }
    println!(
        "  end                 {} after {:.2} s{}",
        s.final_phase,
        s.duration_s,
        s.reason
            .map_or(String::new(), |r| format!(", stopped: {r}"))
    );
}

fn run_sweep(a: &DemoArgs, scene: &Scene, model: &(dyn WrenchModel + 'static)) -> Result<()> {
    let speeds: Vec<f64> = a.speeds_mm_s.iter().map(|v| v * 1e-3).collect();
    if let Some(bad) = speeds.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
        let msg = format!("--speeds-mm-s: {} is not a positive speed", bad * 1e3);
        return Err(BadArgument(msg).into());
    }
    let bar = progress_bar();
    bar.set_message(format!(
        "sweeping {} speeds x {} objects",
        speeds.len(),
        a.objects.len()
    ));
    let (objects, points) = sweep_speeds(scene, model, &a.objects, &speeds, a.seed)?;
    bar.finish_and_clear();
    print_sweep(&speeds, &a.objects, &points);
    for o in &objects {
        println!(
            "{}: the envelope accepts up to {:.1} mm/s ({:.1e} N/m, force limit {} N)",
            o.object,
            o.max_speed_mps * 1e3,
            o.stiffness_n_per_m,
            o.force_limit_n
        );
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
        plot_sweep(path, &objects, &points)?;
        println!("plot written to {}", shown_path(path));
    }
    if a.json {
        let fastest: std::collections::BTreeMap<&str, Option<f64>> =
            fastest.iter().map(|(o, v)| (o.as_str(), *v)).collect();
        println!(
            "{}",
            serde_json::json!({
                "objects": objects,
                "sweep": points,
                "overshoot_bound_n": OVERSHOOT_BOUND_N,
                "fastest_within_bound_mps": fastest,
            })
        );
    }
    Ok(())
}

/// The sweep's table: a row per speed, a column per object.
fn print_sweep(speeds: &[f64], objects: &[String], points: &[SweepPoint]) {
    println!(
        "Peak force (N) measured (overshoot) / predicted by the safety envelope; each object alone in the scene."
    );
    println!("* overshoot over {OVERSHOOT_BOUND_N} N, ! stopped on the force limit, refused: above the envelope.");
    print!("{:>10}", "mm/s");
    for o in objects {
        print!("  {o:>26}");
    }
    println!();
    for v in speeds {
        print!("{:>10.1}", v * 1e3);
        for o in objects {
            let p = points
                .iter()
                .find(|p| &p.object == o && p.approach_speed_mps == *v);
            print!("  {:>26}", p.map_or("-".into(), sweep_cell));
        }
        println!();
    }
}

/// One cell of the sweep's table: peak (overshoot) / predicted peak, and
/// its mark.
fn sweep_cell(p: &SweepPoint) -> String {
    match &p.run {
        Some(r) => {
            let mark = if r.aborted {
                "!"
            } else if r.overshoot_n > OVERSHOOT_BOUND_N {
                "*"
            } else {
                " "
            };
            format!(
                "{:.3} (+{:.3}) / {:.2}{mark}",
                r.peak_force_n, r.overshoot_n, p.predicted_peak_n
            )
        }
        None => "refused ".into(),
    }
}

/// The sweep's plot: measured peaks, the envelope's predicted peak on a
/// fine grid up to each object's limit, and the limits.
fn plot_sweep(path: &Path, objects: &[SweepObject], points: &[SweepPoint]) -> Result<()> {
    let series: Vec<SweepSeries> = objects
        .iter()
        .map(|o| {
            let mine = points.iter().filter(|p| p.object == o.object);
            let measured = mine
                .clone()
                .filter_map(|p| Some((p.approach_speed_mps, p.run.as_ref()?.peak_force_n)))
                .collect();
            let speeds = mine.map(|p| p.approach_speed_mps);
            let (slowest, fastest) = speeds.fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
            let top = o.max_speed_mps.min(fastest * 1.2);
            let predicted = (0..=100)
                .map(|i| {
                    let v = slowest + (top - slowest) * f64::from(i) / 100.0;
                    (v, o.envelope.peak_force_n(v))
                })
                .collect();
            SweepSeries {
                name: o.object.clone(),
                measured,
                predicted,
                max_speed_mps: o.max_speed_mps,
            }
        })
        .collect();
    let limit = objects.first().map_or(0.0, |o| o.force_limit_n);
    let target = objects.first().map_or(0.0, |o| o.envelope.target_n);
    plot::plot_sweep(path, &series, limit, target + OVERSHOOT_BOUND_N)?;
    Ok(())
}
