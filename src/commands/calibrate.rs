//! `demo calibrate`: the calibration on the simulated robot. The arm presses
//! the calibration block in its pattern with the F/T sensor as the force;
//! the recording is written as a rosbag2 MCAP file; the current model is
//! adapted to it, or a model trained on it from scratch, whichever
//! estimates the held-out pushes better, and written with what was chosen
//! and the validation figures. A calibration that cannot succeed writes no
//! model (exit 1) and says why.

use std::path::{Path, PathBuf};

use serde_json::json;

use tactile_force::calibration::CalibrateParams;
use tactile_force::control::TaskKind;
use tactile_force::learn::calibration::fit_and_save;
use tactile_force::learn::models::wrench_gp::WrenchGp;
use tactile_force::runtime::calibrate::record;
use tactile_force::runtime::Scene;

use super::output::{print_validation, progress_bar};
use super::{Context, Failure, Result};

/// What `demo calibrate` writes and prints, from `demo`'s arguments.
pub(crate) struct CalibrateRun<'a> {
    /// The model file to write.
    pub out: &'a Path,
    /// The recording (a rosbag2 MCAP file).
    pub session: PathBuf,
    /// Seed of the sensor and F/T noise.
    pub seed: u64,
    /// The run, one row per control period, as CSV.
    pub csv: Option<&'a Path>,
    /// The forces over time (PNG).
    pub plot: Option<&'a Path>,
    /// The figures as one JSON line.
    pub json: bool,
}

pub(crate) fn run_calibrate(a: &CalibrateRun, scene: &Scene, current: WrenchGp) -> Result<()> {
    let (out, session) = (a.out, &a.session);
    let limit = scene.controller.section::<CalibrateParams>()?.force_limit_n;
    let bar = progress_bar();
    bar.set_message("calibrating: pressing the block");
    let rec = record(scene, a.seed, &mut |_, _| {})?;
    bar.finish_and_clear();
    let unit = scene.sim.sensor_unit;
    println!(
        "calibration, BioTac unit {unit}: {} pushes, {} rows, {:.1} s of motion; peak force \
         {:.2} N on the F/T sensor (limit {limit} N)",
        rec.records.last().map_or(0, |r| r.trial),
        rec.records.len(),
        rec.motion_s,
        rec.peak_force_n,
    );
    if let Some(path) = a.csv {
        tactile_force::report::trace::write_csv(path, &rec.rows)
            .with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = a.plot {
        let title = format!("calibration, BioTac unit {unit}");
        tactile_force::report::plot::plot_run(path, &title, &rec.rows)?;
        println!("plot written to {}", path.display());
    }
    if let Some(why) = rec.ended.failure() {
        return Err(Failure::failed(format!(
            "calibration failed: {why}; the arm stopped; no model written (the current one is kept)"
        )));
    }
    let r = fit_and_save(
        &rec.records,
        &current,
        rec.motion_s,
        rec.peak_force_n,
        session,
        out,
    )
    .with_context(|| {
        format!(
            "calibration (session written to {}): no model written (the current one is kept)",
            session.display()
        )
    })?;
    let compute_s = r.compute_s;
    println!("session written to {}", session.display());
    print_validation(&r);
    println!(
        "chose the model {}; {compute_s:.1} s of compute; model written to {}",
        r.chosen,
        out.display()
    );
    if a.json {
        let line = json!({
            "task": TaskKind::Calibrate.name(),
            "unit": unit,
            "pushes": r.pushes,
            "rows": r.rows,
            "motion_s": r.motion_s,
            "compute_s": compute_s,
            "peak_force_n": r.peak_force_n,
            "force_limit_n": limit,
            "chosen": r.chosen,
            "validation": r.validation,
            "held_out": r.held_out,
            "session": session.display().to_string(),
            "model": out.display().to_string(),
        });
        println!("{line}");
    }
    Ok(())
}
