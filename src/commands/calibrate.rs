//! `demo calibrate`: the calibration on the simulated robot. Every output
//! is checked before the arm moves ([`check_outputs`]: the model file, the
//! session, the plot's format, the CSV); a path that cannot be written is
//! refused (exit 2). The arm presses the calibration block in its pattern
//! with the F/T sensor as the force; the recording is written as it is
//! recorded, a rosbag2 MCAP file flushed to disk at the end of each push;
//! the current model is adapted to it, or a model trained on it from
//! scratch, whichever estimates the held-out pushes better, and written
//! with what was chosen and the validation figures. A calibration that
//! cannot succeed writes no model (exit 1), says why, and says where its
//! session is.

use std::path::{Path, PathBuf};

use serde_json::json;

use tactile_force::calibration::{open_outputs, CalibrateParams, SessionEnd};
use tactile_force::control::TaskKind;
use tactile_force::learn::calibration::fit_and_save;
use tactile_force::learn::data::bag::SessionWriter;
use tactile_force::learn::models::provenance::CalibrationRecord;
use tactile_force::learn::models::wrench_model::WrenchModel;
use tactile_force::outputs::{check_format, check_writable};
use tactile_force::report::plot;
use tactile_force::runtime::calibrate::{record_to, Recording};
use tactile_force::runtime::{Pacing, Scene};

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
    /// Paced by the wall clock, as the robot moves.
    pub realtime: bool,
}

/// Checks that every output of a demo can be written, before any work:
/// the plot's format and folder, the CSV's folder; for a calibration also
/// the model file and the session (not opened yet).
pub(crate) fn check_outputs(
    calibrate: Option<(&Path, &Path)>,
    plot: Option<&Path>,
    csv: Option<&Path>,
) -> Result<()> {
    if let Some((model, session)) = calibrate {
        tactile_force::calibration::check_outputs(model, session)?;
    }
    if let Some(p) = plot {
        check_format(p, "plot", plot::FORMATS)?;
    }
    if let Some(p) = csv {
        check_writable(p, "trace CSV")?;
    }
    Ok(())
}

pub(crate) fn run_calibrate(
    a: &CalibrateRun,
    scene: &Scene,
    current: &dyn WrenchModel,
) -> Result<()> {
    let out = a.out;
    let limit = scene.controller.section::<CalibrateParams>()?.force_limit_n;
    // Checked again and opened with the arm still: written as recorded.
    let session: SessionWriter = open_outputs(out, &a.session)?;
    let bar = progress_bar();
    bar.set_message("calibrating: pressing the block");
    let pacing = if a.realtime {
        Pacing::Realtime
    } else {
        Pacing::Lockstep
    };
    let rec = record_to(scene, a.seed, Some(session), pacing, &mut |_, _| {})?;
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
    let (kept, session) = session_kept(rec.session.as_ref());
    let fitted = match rec.ended.failure() {
        Some(why) => Err(Failure::failed(format!(
            "calibration failed: {why}; the arm stopped; no model written (the current one \
             is kept); {kept}"
        ))),
        None => fit_and_save(
            &rec.records,
            current,
            rec.motion_s,
            rec.peak_force_n,
            session,
            out,
        )
        .with_context(|| {
            format!("calibration: no model written (the current one is kept); {kept}")
        }),
    };
    let r = match fitted {
        Ok(r) => r,
        Err(e) => {
            // The trace and the plot still show what the arm did.
            if let Err(extra) = write_extras(a, &rec, unit) {
                eprintln!("warning: {extra}");
            }
            return Err(e);
        }
    };
    let compute_s = r.compute_s;
    print_validation(&r);
    println!(
        "chose the model {}; {compute_s:.1} s of compute; model written to {}",
        r.chosen,
        out.display()
    );
    write_extras(a, &rec, unit)
        .with_context(|| format!("model written to {}; {kept}", out.display()))?;
    if a.json {
        println!("{}", json_line(&r, unit, limit, session, out));
    }
    Ok(())
}

/// The calibration's figures as one JSON line (`--json`).
fn json_line(
    r: &CalibrationRecord,
    unit: u64,
    limit: f64,
    session: Option<&Path>,
    out: &Path,
) -> serde_json::Value {
    json!({
        "task": TaskKind::Calibrate.name(),
        "unit": unit,
        "pushes": r.pushes,
        "rows": r.rows,
        "motion_s": r.motion_s,
        "compute_s": r.compute_s,
        "peak_force_n": r.peak_force_n,
        "force_limit_n": limit,
        "chosen": r.chosen,
        "validation": r.validation,
        "held_out": r.held_out,
        "pooling": r.pooling,
        "session": session.map(|p| p.display().to_string()),
        "model": out.display().to_string(),
    })
}

/// What to say of the session file, printed once it is ended, and its
/// path when it holds every record.
fn session_kept(end: Option<&SessionEnd>) -> (String, Option<&Path>) {
    match end {
        Some(SessionEnd {
            path,
            written: Ok(n),
        }) => {
            println!("session written to {} ({n} records)", path.display());
            (
                format!("the session is kept at {}", path.display()),
                Some(path),
            )
        }
        Some(SessionEnd {
            path,
            written: Err(e),
        }) => {
            eprintln!("warning: {e}; the file holds only the pushes flushed before that");
            (format!("the session {} is not whole", path.display()), None)
        }
        None => ("no session was written".into(), None),
    }
}

/// The run's trace (CSV) and plot, when asked for.
fn write_extras(a: &CalibrateRun, rec: &Recording, unit: u64) -> Result<()> {
    if let Some(path) = a.csv {
        tactile_force::report::trace::write_csv(path, &rec.rows)
            .with_context(|| format!("trace CSV {}", path.display()))?;
        println!("trace written to {}", path.display());
    }
    if let Some(path) = a.plot {
        let title = format!("calibration, BioTac unit {unit}");
        plot::plot_run(path, &title, &rec.rows)?;
        println!("plot written to {}", path.display());
    }
    Ok(())
}
