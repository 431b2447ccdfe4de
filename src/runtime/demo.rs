//! The demos behind `tactile_force demo`: one run of a scene, and the sweep
//! of the guarded move's approach speed against the peak force, measured
//! and predicted by the safety envelope.

use rayon::prelude::*;
use serde::Serialize;

use super::scene::{Scene, SceneError};
use super::{run, Pacing};
use crate::biotac::BioTacSimConfig;
use crate::control::{task_envelope, Envelope};
use crate::exit::{Classify, ExitClass};
use crate::learn::models::wrench_model::WrenchModel;
use crate::report::summary::{summarize, Identified, RunInfo, Summary};
use crate::report::TraceRow;
use crate::sensor::SensorSpec;

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

/// A run whose task stopped before it held (its figures are still the
/// run's): why it stopped.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("the {task} move did not hold: it stopped on {reason}")]
pub struct NotHeld {
    /// The task.
    pub task: &'static str,
    /// Why it stopped ([`crate::control::StopReason::name`]).
    pub reason: &'static str,
}

/// The task did not hold.
impl Classify for NotHeld {
    fn class(&self) -> ExitClass {
        ExitClass::NotHeld
    }
}

impl DemoRun {
    /// The run's task held, or why it stopped.
    pub fn held(&self) -> Result<(), NotHeld> {
        match self.summary.reason {
            None => Ok(()),
            Some(reason) => Err(NotHeld {
                task: self.summary.task,
                reason,
            }),
        }
    }
}

/// Runs `scene` with `model`; `seed` drives the noise.
pub fn run_scene(
    scene: &Scene,
    model: Box<dyn WrenchModel>,
    seed: u64,
    pacing: Pacing,
    on_row: &mut dyn FnMut(&TraceRow),
) -> Result<DemoRun, SceneError> {
    // The simulated BioTac has the electrodes the model was trained on.
    let sensor = match model.input().sensor {
        &SensorSpec::Biotac { electrodes } => BioTacSimConfig::default().with_layout(electrodes),
        _ => BioTacSimConfig::default(),
    };
    let mut nodes = scene.build(model, &sensor, seed)?;
    let info = RunInfo::new(
        &scene.controller,
        &scene.tasks,
        &nodes.controller.robot().name,
    )?;
    let rows = run(&mut nodes, pacing, on_row)?;
    let mut summary = summarize(&info, &rows);
    summary.identified = Some(Identified::of(&nodes.controller));
    Ok(DemoRun {
        summary,
        gains: nodes.controller.gains(),
        rows,
    })
}

/// One object of the speed sweep: its own safety envelope (the scene
/// permitting only that object).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepObject {
    /// The object.
    pub object: String,
    /// Its stiffness (N/m).
    pub stiffness_n_per_m: f64,
    /// The fastest approach the envelope accepts (m/s).
    pub max_speed_mps: f64,
    /// The force limit (N).
    pub force_limit_n: f64,
    /// The envelope, for the predicted peak at any speed.
    #[serde(skip)]
    pub envelope: Envelope,
}

/// What a run of the sweep measured (from the F/T force).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepRun {
    /// Peak force (N).
    pub peak_force_n: f64,
    /// Peak force above the target (N).
    pub overshoot_n: f64,
    /// Steady-state error (N).
    pub steady_state_error_n: Option<f64>,
    /// True when the move stopped on the force limit.
    pub aborted: bool,
}

/// One point of the speed sweep.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweepPoint {
    /// The object.
    pub object: String,
    /// Approach speed (m/s).
    pub approach_speed_mps: f64,
    /// The envelope's bound on the peak force at this speed (N).
    pub predicted_peak_n: f64,
    /// The run; None when the speed is above the envelope and was refused.
    pub run: Option<SweepRun>,
}

/// The objects' envelopes, then every object at every approach speed (m/s)
/// it accepts, the runs in parallel; points come back by object, then speed.
pub fn sweep_speeds(
    scene: &Scene,
    model: &(dyn WrenchModel + 'static),
    objects: &[String],
    speeds: &[f64],
    seed: u64,
) -> Result<(Vec<SweepObject>, Vec<SweepPoint>), SceneError> {
    let envelopes = objects
        .iter()
        .map(|o| {
            let only = scene.clone().with_only_object(o);
            let speed = task_envelope(&only.controller, &only.tasks)?;
            Ok(SweepObject {
                object: o.clone(),
                stiffness_n_per_m: speed.envelope.stiffness_n_per_m,
                max_speed_mps: speed.envelope.max_speed_mps(),
                force_limit_n: speed.envelope.limit_n,
                envelope: speed.envelope,
            })
        })
        .collect::<Result<Vec<_>, SceneError>>()?;
    let runs: Vec<(&SweepObject, f64)> = envelopes
        .iter()
        .flat_map(|o| speeds.iter().map(move |&v| (o, v)))
        .collect();
    let points = runs
        .par_iter()
        .map(|&(o, speed)| {
            let run = if speed <= o.max_speed_mps {
                let s = scene
                    .clone()
                    .with_only_object(&o.object)
                    .with_approach_speed(speed)?;
                let s = run_scene(
                    &s,
                    dyn_clone::clone_box(model),
                    seed,
                    Pacing::Lockstep,
                    &mut |_| {},
                )?
                .summary;
                Some(SweepRun {
                    peak_force_n: s.peak_force_n,
                    overshoot_n: s.overshoot_n,
                    steady_state_error_n: s.steady_state_error_n,
                    aborted: s.aborted,
                })
            } else {
                None
            };
            Ok(SweepPoint {
                object: o.object.clone(),
                approach_speed_mps: speed,
                predicted_peak_n: o.envelope.peak_force_n(speed),
                run,
            })
        })
        .collect::<Result<Vec<_>, SceneError>>()?;
    Ok((envelopes, points))
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
                match &p.run {
                    Some(r) if !r.aborted && r.overshoot_n <= bound_n => {
                        best = Some(p.approach_speed_mps)
                    }
                    _ => break,
                }
            }
            (o.clone(), best)
        })
        .collect()
}
