//! Both moves with one parameter set (nothing declared: the object
//! `unknown` to the controller, the shipped loop bounds) in the embedded
//! loop, across arms that take commands on a cycle of their own (2-16 ms),
//! servo lags (0-30 ms) and bodies from 50 N/m to rigid, approaching at
//! 10 mm/s; the guided move over the same latency grid. Prints one row per
//! run against issue 34's bounds and exits 1 when a run misses one.
//!
//! ```sh
//! cargo run --release --example hold_sweep
//! ```
//!
//! `-- --approach-mm-s V` approaches at V mm/s instead (the safety envelope
//! refuses what the unknown body does not allow): in contact the guarded
//! move presses no faster than its approach, so this shows how much of the
//! time from contact to `hold` that cap costs.
//!
//! Subsets: `--cycles 2,8` and `--lags 0,20` (ms), `--bodies 50,1e6`
//! (N/m), `--moves guarded` or `guided`.
//!
//! The same sweep over DDS: tests/ros/hold_sweep.py.

use std::process::ExitCode;

use tactile_force::contact::BodyParams;
use tactile_force::control::TaskKind;
use tactile_force::learn::default_model::load_or_train;
use tactile_force::learn::models::wrench_gp::WrenchGp;
use tactile_force::report::summary::Summary;
use tactile_force::runtime::demo::run_scene;
use tactile_force::runtime::scene::SceneError;
use tactile_force::runtime::{Pacing, Scene};

const CYCLES_S: [f64; 4] = [0.002, 0.004, 0.008, 0.016];
const LAGS_S: [f64; 4] = [0.0, 0.01, 0.02, 0.03];
const STIFFNESS_N_PER_M: [f64; 9] = [50.0, 100.0, 300.0, 1e3, 3e3, 1e4, 3.7e4, 1e5, 1e6];

fn main() -> Result<ExitCode, Box<dyn std::error::Error>> {
    let mut missed = 0;
    let Some(guarded) = approach(Scene::builtin(TaskKind::Guarded)?) else {
        return Ok(ExitCode::from(2));
    };
    let (Some(cycles), Some(lags), Some(bodies)) = (
        list("--cycles", &CYCLES_S.map(|c| c * 1e3)),
        list("--lags", &LAGS_S.map(|l| l * 1e3)),
        list("--bodies", &STIFFNESS_N_PER_M),
    ) else {
        return Ok(ExitCode::from(2));
    };
    let grid = || {
        cycles
            .iter()
            .flat_map(|&c| lags.iter().map(move |&l| (c * 1e-3, l * 1e-3)))
    };
    let moves = arg("--moves").unwrap_or_default();
    let (do_guarded, do_guided) = (moves != "guided", moves != "guarded");
    if do_guarded {
        println!(
        "guarded move, hold 1 N (bounds: hold, peak <= 1.1 N, |mean - 1| <= 0.05 N, sd <= 0.02 N)"
    );
        println!("cycle ms  lag ms  body N/m  result  peak N  |mean-1| N  sd N    contact->hold s");
        let (model, _) = load_or_train(&guarded.estimator.default_model, &mut || {})?;
        for (cycle, lag) in grid() {
            for &k in &bodies {
                let body = BodyParams {
                    stiffness_n_per_m: k,
                    damping_n_s_per_m: 0.06 * k.sqrt(),
                    friction: 0.5,
                };
                let mut s = guarded.clone().with_body("sweep", body);
                s.controller.object = "unknown".into();
                s.controller.safety.objects = vec!["unknown".into()];
                s.sim.object = "sweep".into();
                s.sim.duration_s = 12.0;
                let m = run_at(s, cycle, lag, &model)?;
                let ok = m.final_phase == "hold"
                    && m.peak_force_n <= 1.1
                    && m.steady_state_error_n.is_some_and(|e| e <= 0.05)
                    && m.final_sd_n.is_some_and(|sd| sd <= 0.02);
                missed += usize::from(!ok);
                println!(
                    "{:8.0}  {:6.0}  {k:8.0}  {:<6}  {:.3}   {:.4}      {:.4}  {}{}",
                    cycle * 1e3,
                    lag * 1e3,
                    m.final_phase,
                    m.peak_force_n,
                    m.steady_state_error_n.unwrap_or(f64::NAN),
                    m.final_sd_n.unwrap_or(f64::NAN),
                    figure(m.hold_after_contact_s),
                    if ok { "" } else { "  MISSED" }
                );
            }
        }
    }
    if do_guided {
        println!("guided move, the finger of config/guided_move.yaml (bounds: RMS <= 0.3 N per axis, off-axis <= 10 %)");
        println!("cycle ms  lag ms  RMS fx, fy, fz N       off-axis");
        let guided = Scene::builtin(TaskKind::Guided)?;
        let (model, _) = load_or_train(&guided.estimator.default_model, &mut || {})?;
        for (cycle, lag) in grid() {
            let m = run_at(guided.clone(), cycle, lag, &model)?;
            let ok = guided_ok(&m);
            missed += usize::from(!ok);
            let rms: Vec<String> = m
                .rms_force_error_by_axis_n
                .values()
                .map(|e| format!("{e:.3}"))
                .collect();
            println!(
                "{:8.0}  {:6.0}  {:<21}  {:.1} %{}",
                cycle * 1e3,
                lag * 1e3,
                rms.join(" "),
                100.0 * m.max_off_axis_ratio.unwrap_or(f64::NAN),
                if ok { "" } else { "  MISSED" }
            );
        }
    }
    println!("{missed} runs missed a bound");
    Ok(if missed == 0 {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// The guarded scene at the speed of `--approach-mm-s`, when given; None
/// (said on stderr) when it is not a speed or the envelope refuses it.
fn approach(scene: Scene) -> Option<Scene> {
    let Some(v) = arg("--approach-mm-s") else {
        return Some(scene);
    };
    let mps = match v.parse::<f64>() {
        Ok(v) if v > 0.0 => v * 1e-3,
        _ => {
            eprintln!("hold_sweep: --approach-mm-s: expected a speed above 0 (mm/s)");
            return None;
        }
    };
    let mut s = scene;
    s.controller.object = "unknown".into();
    s.controller.safety.objects = vec!["unknown".into()];
    let checked = match s.with_approach_speed(mps) {
        Ok(s) => s.check().map(|()| s).map_err(|e| e.to_string()),
        Err(e) => Err(e.to_string()),
    };
    match checked {
        Ok(s) => Some(s),
        Err(e) => {
            eprintln!("hold_sweep: --approach-mm-s: {e}");
            None
        }
    }
}

/// The value after `name` on the command line.
fn arg(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    let i = args.iter().position(|a| a == name)?;
    args.get(i + 1).cloned()
}

/// The comma-separated numbers after `name`, `all` when absent; None (said
/// on stderr) when one is not a number.
fn list(name: &str, all: &[f64]) -> Option<Vec<f64>> {
    let Some(v) = arg(name) else {
        return Some(all.to_vec());
    };
    let parsed: Result<Vec<f64>, _> = v.split(',').map(str::parse::<f64>).collect();
    match parsed {
        Ok(l) if !l.is_empty() => Some(l),
        _ => {
            eprintln!("hold_sweep: {name}: expected numbers separated by commas, got {v}");
            None
        }
    }
}

/// The summary of `s` run in lockstep with `model`, the simulated arm
/// taking commands every `cycle` s (pure latency), then through a servo lag
/// of `lag` s.
fn run_at(mut s: Scene, cycle: f64, lag: f64, model: &WrenchGp) -> Result<Summary, SceneError> {
    s.sim.command_cycle_s = cycle;
    s.sim.command_latency_s = 0.0;
    s.sim.velocity_lag_s = lag;
    Ok(run_scene(
        &s,
        Box::new(model.clone()),
        1,
        Pacing::Lockstep,
        &mut |_| {},
    )?
    .summary)
}

fn guided_ok(m: &Summary) -> bool {
    m.final_phase != "stopped"
        && m.rms_force_error_by_axis_n.len() == 3
        && m.rms_force_error_by_axis_n.values().all(|&e| e <= 0.3)
        && m.max_off_axis_ratio.is_some_and(|r| r <= 0.1)
}

fn figure(v: Option<f64>) -> String {
    v.map_or("-".into(), |v| format!("{v:.2}"))
}
