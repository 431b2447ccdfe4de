//! The `~/calibrate` action server of `force_controller` (needs r2r's
//! generated types for tactile_force_msgs, so a real ROS build only).
//!
//! A goal's outputs are resolved in the node's `models_dir`
//! ([`CalibrateGoal::outputs`]: a name leading out of it, or naming a file
//! that exists without `overwrite`, refuses the goal), checked and its
//! session file opened before the arm moves ([`open_outputs`]: a model
//! file or session that cannot be written refuses the goal); it then starts the calibration task on its
//! surface ([`CalibrateGoal`]); while it runs the node steps on the F/T
//! wrench and records it with the BioTac's readings, written to the
//! session as they come and flushed at each push's end
//! ([`CalibrationRecorder`]; the life cycle is [`ForceControllerNode`]'s).
//! A cancel ends the goal once the pad has withdrawn out of contact.
//! When the arm has stopped: the session file is ended, the estimator's model
//! (its `model_file` parameter, asked through its parameter service) is
//! adapted or a model trained from scratch, whichever validates better
//! (`calibrate_action/fit.rs`), and the estimator is given the new model
//! file. A calibration that cannot succeed ends aborted with the reason,
//! the arm stopped, and no model written or handed on. Each goal runs on a
//! task of its own, so that one that comes while it runs is refused at
//! once.

mod fit;

use std::path::PathBuf;

use r2r::tactile_force_msgs::action::Calibrate;

use futures::StreamExt;

use crate::ros::action_server::{CancelRequest, GoalHandle, GoalRequest};

use super::cancel::{CancelWatch, Canceling};
use super::estimator_link::EstimatorLink;
use super::*;
use crate::calibration::{open_outputs, CalibrateGoal, CalibrationRecorder, Ended, SessionEnd};
use crate::nodes::force_controller::goals::CalibrationProgress;
use crate::outputs::models_dir::ModelsDir;
use crate::ros::RosClock;
use fit::fit;

/// The result of a calibration that made no model.
fn failed(reason: String, rec: Option<&CalibrationRecorder>) -> Calibrate::Result {
    Calibrate::Result {
        reason,
        pushes: rec.and_then(|r| r.records().last()).map_or(0, |r| r.trial),
        motion_s: rec.map_or(0.0, CalibrationRecorder::motion_s),
        peak_force_n: rec.map_or(0.0, CalibrationRecorder::peak_force_n),
        ..Default::default()
    }
}

/// The result of a goal refused for `reason`.
pub(super) fn refused(reason: String) -> Calibrate::Result {
    failed(reason, None)
}

/// Serves the goals: each is started, or refused with the reason, as it
/// comes, and then run on a task of its own, so that a goal that comes
/// while one runs is refused at once.
pub(super) async fn serve(
    mut goals: impl futures::Stream<Item = GoalRequest<Calibrate::Action>> + Unpin,
    shared: Arc<Mutex<ForceControllerNode>>,
    period: Duration,
    clock: RosClock,
    estimator: EstimatorLink,
    models: ModelsDir,
) {
    let estimator = Arc::new(estimator);
    while let Some(req) = goals.next().await {
        let goal = CalibrateGoal {
            surface: req.goal.surface.clone(),
            model_file: req.goal.model_file.clone(),
            session_file: req.goal.session_file.clone(),
            overwrite: req.goal.overwrite,
        };
        let started = start(&goal, &models, &shared, &clock);
        let Ok((mut handle, cancel)) = req.accept() else {
            if started.is_ok() {
                lock(&shared).end_goal();
            }
            continue;
        };
        let model_path = match started {
            Ok(path) => path,
            Err(e) => {
                tracing::warn!("calibrate goal refused: {e}");
                handle.abort(refused(format!("refused: {e}")));
                continue;
            }
        };
        let (shared, clock, estimator) = (shared.clone(), clock.clone(), estimator.clone());
        tokio::spawn(async move {
            let cancel = CancelWatch::new(cancel);
            let why = motion(&mut handle, cancel, &shared, period, &clock).await;
            end(handle, why, &shared, &estimator, model_path).await;
            lock(&shared).end_goal();
        });
    }
}

/// The end of a calibration whose arm has stopped (`why` not, if it did
/// not end its pattern): its session ended, the fit and its result.
async fn end(
    mut handle: GoalHandle<Calibrate::Action>,
    why: Option<(String, bool)>,
    shared: &Mutex<ForceControllerNode>,
    estimator: &EstimatorLink,
    model_path: PathBuf,
) {
    let Some(mut rec) = lock(shared).take_recording() else {
        return;
    };
    let session = SessionEnd::said(rec.finish_session());
    if let Some((why, canceled)) = why {
        let why = format!("{why}; no model written; {}", session.0);
        tracing::warn!("calibration: {why}");
        let result = failed(why, Some(&rec));
        if canceled {
            handle.cancel(result);
        } else {
            handle.abort(result);
        }
        return;
    }
    // What the fit needs, taken out: the session writer the recording
    // holds may not be borrowed across an await.
    let recorded = failed(String::new(), Some(&rec));
    let records = rec.records().to_vec();
    match fit(recorded, records, estimator, model_path, session).await {
        Ok(r) => handle.succeed(r),
        Err(r) => handle.abort(r),
    }
}

/// The goal's files resolved in `models`, checked and the session opened,
/// then the calibration started, or why not (nothing left written): the
/// model file's path.
fn start(
    goal: &CalibrateGoal,
    models: &ModelsDir,
    shared: &Mutex<ForceControllerNode>,
    clock: &RosClock,
) -> Result<PathBuf, String> {
    let (model, session) = goal.outputs(models).map_err(|e| e.to_string())?;
    let writer = open_outputs(&model, &session).map_err(|e| e.to_string())?;
    if let Err(e) = lock(shared).start_calibration(goal, clock.now_s(), Some(writer)) {
        // Refused with the arm still: no session to keep.
        let _ = std::fs::remove_file(&session);
        return Err(e);
    }
    Ok(model)
}

/// The calibration's motion, its feedback each period, until the arm has
/// stopped: None when the pattern ended, else why not and whether the goal
/// was canceled.
async fn motion(
    handle: &mut GoalHandle<Calibrate::Action>,
    mut cancel: CancelWatch<impl futures::Stream<Item = CancelRequest> + Unpin>,
    shared: &Mutex<ForceControllerNode>,
    period: Duration,
    clock: &RosClock,
) -> Option<(String, bool)> {
    let mut ticker = tokio::time::interval(period);
    loop {
        ticker.tick().await;
        let now = clock.now_s();
        let mut n = lock(shared);
        // Stopped from outside the task, or the F/T wrench in the wrong
        // frame: before a cancel's withdrawal, which a stop ends.
        if let Some(why) = n.goal_end() {
            return Some((why.to_string(), false));
        }
        match cancel.poll(&mut n, now) {
            Canceling::No => {}
            Canceling::Withdrawing => continue,
            Canceling::Done(reason) => return Some((reason, true)),
        }
        match n.calibration_progress(now) {
            CalibrationProgress::Starting => {}
            CalibrationProgress::Ended(e) => {
                let canceled = e == Ended::Canceled;
                return e.failure().map(|why| (why, canceled));
            }
            CalibrationProgress::Running {
                push,
                pushes,
                phase,
                force_n,
            } => {
                let _ = handle.publish_feedback(Calibrate::Feedback {
                    push,
                    pushes,
                    phase: phase.name().into(),
                    force_n,
                });
            }
        }
    }
}
