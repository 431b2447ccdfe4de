//! The demos behind `tactile_force demo`: one run of a scene, and the sweep
//! of the guarded move's approach speed against overshoot.

use rayon::prelude::*;
use serde::Serialize;

use super::scene::{Scene, SceneError};
use super::{run, Pacing};
use crate::biotac::BioTacSimConfig;
use crate::learn::model::WrenchGp;
use crate::report::summary::{summarize, RunInfo, Summary};
use crate::report::TraceRow;

/// A finished run.
#[derive(Debug, Clone)]
pub struct DemoRun {
    /// One row per control period.
    pub rows: Vec<TraceRow>,
    /// Its figures.
    pub summary: Summary,
    /// Proportional gain per force axis x, y, z (m/s per N).
    pub gains: [Option<f64>; 3],
}

/// Runs `scene` with `model`; `seed` drives the noise.
pub fn run_scene(
    scene: &Scene,
    model: WrenchGp,
    seed: u64,
    pacing: Pacing,
    on_row: &mut dyn FnMut(&TraceRow),
) -> Result<DemoRun, SceneError> {
    let info = RunInfo::new(&scene.controller_params()?);
    let mut nodes = scene.build(model, &BioTacSimConfig::default(), seed)?;
    let rows = run(&mut nodes, pacing, on_row)?;
    Ok(DemoRun {
        summary: summarize(&info, &rows),
        gains: nodes.controller.gains(),
        rows,
    })
}

/// One point of the speed sweep.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepPoint {
    /// The object.
    pub object: String,
    /// Approach speed (m/s).
    pub approach_speed_mps: f64,
    /// Peak force above the target (N).
    pub overshoot_n: f64,
    /// Steady-state error (N).
    pub steady_state_error_n: Option<f64>,
    /// True when the move stopped on the force limit.
    pub aborted: bool,
}

/// Runs the guarded `scene` for every object and approach speed (m/s), the
/// runs in parallel; points come back by object, then speed.
pub fn sweep_speeds(
    scene: &Scene,
    model: &WrenchGp,
    objects: &[String],
    speeds: &[f64],
    seed: u64,
) -> Result<Vec<SweepPoint>, SceneError> {
    let runs: Vec<(&String, f64)> = objects
        .iter()
        .flat_map(|o| speeds.iter().map(move |&v| (o, v)))
        .collect();
    runs.par_iter()
        .map(|&(object, speed)| {
            let s = scene.clone().with_object(object).with_approach_speed(speed);
            let run = run_scene(&s, model.clone(), seed, Pacing::Lockstep, &mut |_| {})?;
            Ok(SweepPoint {
                object: object.clone(),
                approach_speed_mps: speed,
                overshoot_n: run.summary.overshoot_n,
                steady_state_error_n: run.summary.steady_state_error_n,
                aborted: run.summary.aborted,
            })
        })
        .collect()
}

/// The fastest speed of each object whose overshoot is within `bound_n`,
/// with every slower speed also within it (None when even the slowest fails).
pub fn fastest_within(
    points: &[SweepPoint],
    objects: &[String],
    bound_n: f64,
) -> Vec<(String, Option<f64>)> {
    objects
        .iter()
        .map(|o| {
            let mut best = None;
            let mut mine: Vec<&SweepPoint> = points.iter().filter(|p| &p.object == o).collect();
            mine.sort_by(|a, b| a.approach_speed_mps.total_cmp(&b.approach_speed_mps));
            for p in mine {
                if p.aborted || p.overshoot_n > bound_n {
                    break;
                }
                best = Some(p.approach_speed_mps);
            }
            (o.clone(), best)
        })
        .collect()
}
