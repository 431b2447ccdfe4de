//! A calibration's fit once the arm has stopped, on a blocking thread (the
//! loop keeps commanding zero velocity), and the estimator given the model.

use std::path::{Path, PathBuf};

use r2r::tactile_force_msgs::action::Calibrate;

use super::EstimatorLink;
use crate::learn::calibration::fit_and_save;
use crate::learn::models::model_file;
use crate::record::Record;

/// The fit once the arm has stopped, and the estimator given the model.
/// `recorded`: the result's figures of the recording.
pub(super) async fn fit(
    recorded: Calibrate::Result,
    records: Vec<Record>,
    estimator: &EstimatorLink,
    model_path: PathBuf,
    (kept, session_path): (String, Option<PathBuf>),
) -> Result<Calibrate::Result, Calibrate::Result> {
    let refuse = |why: String| {
        let why = format!("{why}; {kept}");
        tracing::warn!("calibration: {why}");
        Calibrate::Result {
            reason: why,
            ..recorded.clone()
        }
    };
    let current_file = estimator.model_file().await.map_err(refuse)?;
    if current_file.is_empty() {
        return Err(refuse(format!(
            "{} does not say its model file (model_file is empty)",
            estimator.name()
        )));
    }
    tracing::info!(
        "calibration: {} pushes recorded; fitting (the estimator's model {current_file}, adapted, or a new one)",
        recorded.pushes
    );
    let (motion_s, peak) = (recorded.motion_s, recorded.peak_force_n);
    let (model, session) = (model_path.clone(), session_path.clone());
    let fitted = tokio::task::spawn_blocking(move || {
        let current = model_file::load(Path::new(&current_file)).map_err(|e| e.to_string())?;
        fit_and_save(
            &records,
            current.as_ref(),
            motion_s,
            peak,
            session.as_deref(),
            &model,
        )
        .map_err(|e| e.to_string())
    })
    .await
    .map_err(|e| e.to_string())
    .and_then(|r| r)
    .map_err(|e| {
        refuse(format!(
            "{e}; no model written (the estimator keeps its own)"
        ))
    })?;
    let path = model_path.display().to_string();
    let (updated, message) = match estimator.set_model_file(&path).await {
        Ok((true, _)) => (true, format!("{} estimates with {path}", estimator.name())),
        Ok((false, why)) if why.is_empty() => (
            false,
            format!("{} refused {path}, without a reason", estimator.name()),
        ),
        Ok((false, why)) => (false, why),
        Err(e) => (false, e),
    };
    tracing::info!(
        "calibration: chose the model {}, {:.1} s of compute, written to {path}; {message}",
        fitted.chosen,
        fitted.compute_s
    );
    Ok(Calibrate::Result {
        reason: fitted.outcome(),
        model_file: path,
        session_file: session_path.map_or(String::new(), |p| p.display().to_string()),
        current_rmse_n: fitted.rmse_of("current"),
        chosen_rmse_n: fitted.rmse_of(&fitted.chosen),
        chosen: fitted.chosen,
        pushes: fitted.pushes,
        motion_s: fitted.motion_s,
        compute_s: fitted.compute_s,
        peak_force_n: fitted.peak_force_n,
        estimator_updated: updated,
        estimator_message: message,
    })
}
