//! The `~/calibrate` action server of `force_controller` (needs r2r's
//! generated types for tactile_force_msgs, so a real ROS build only).
//!
//! A goal starts the calibration task on its surface
//! ([`CalibrateGoal`]); while it runs the loop steps on the F/T wrench and
//! records it with the BioTac's readings ([`CalibrationRecorder`]). When the
//! arm has stopped: the recording is written (MCAP), the estimator's model
//! (its `model_file` parameter, asked through its parameter service) is
//! adapted or a model trained from scratch, whichever validates better
//! ([`fit_and_save`], on a blocking thread: the loop keeps commanding zero
//! velocity), and the estimator is given the new model file. A calibration
//! that cannot succeed ends aborted with the reason, the arm stopped, and no
//! model written or handed on.

use std::path::PathBuf;
use std::time::{SystemTime, UNIX_EPOCH};

use r2r::rcl_interfaces::msg::{
    Parameter as ParameterMsg, ParameterType, ParameterValue as ValueMsg,
};
use r2r::rcl_interfaces::srv::{GetParameters, SetParameters};
use r2r::tactile_force_msgs::action::Calibrate;

use super::*;
use crate::learn::calibration::{fit_and_save, CalibrationRecord};
use crate::learn::models::wrench_gp::WrenchGp;
use crate::nodes::calibration::Ended;
use crate::ros::RosClock;

/// How long the estimator's parameter service may take to answer.
const ESTIMATOR_TIMEOUT: Duration = Duration::from_secs(10);

/// The estimator's parameter services: its model file, asked and set.
pub(super) struct EstimatorLink {
    name: String,
    get: r2r::Client<GetParameters::Service>,
    set: r2r::Client<SetParameters::Service>,
}

impl EstimatorLink {
    /// Clients of the parameter services of the node `name`.
    pub(super) fn new(node: &mut r2r::Node, name: &str) -> Result<Self, RosError> {
        let qos = QosProfile::default;
        Ok(EstimatorLink {
            name: name.to_string(),
            get: node.create_client(&format!("{name}/get_parameters"), qos())?,
            set: node.create_client(&format!("{name}/set_parameters"), qos())?,
        })
    }

    /// The estimator's `model_file`: the model file it estimates with.
    async fn model_file(&self) -> Result<String, String> {
        let req = GetParameters::Request {
            names: vec!["model_file".into()],
        };
        let answer = self.call(self.get.request(&req)).await?;
        match answer.values.first() {
            Some(v) if v.type_ == ParameterType::PARAMETER_STRING as u8 => {
                Ok(v.string_value.clone())
            }
            _ => Err(format!("{} has no model_file parameter", self.name)),
        }
    }

    /// Sets the estimator's `model_file`: (taken, its answer).
    async fn set_model_file(&self, path: &str) -> Result<(bool, String), String> {
        let req = SetParameters::Request {
            parameters: vec![ParameterMsg {
                name: "model_file".into(),
                value: ValueMsg {
                    type_: ParameterType::PARAMETER_STRING as u8,
                    string_value: path.into(),
                    ..Default::default()
                },
            }],
        };
        let answer = self.call(self.set.request(&req)).await?;
        let r = answer.results.first().ok_or("no answer")?;
        Ok((r.successful, r.reason.clone()))
    }

    async fn call<T>(
        &self,
        request: r2r::Result<impl std::future::Future<Output = r2r::Result<T>>>,
    ) -> Result<T, String> {
        let failed = |e: String| format!("{}'s parameter service: {e}", self.name);
        let answer = request.map_err(|e| failed(e.to_string()))?;
        tokio::time::timeout(ESTIMATOR_TIMEOUT, answer)
            .await
            .map_err(|_| failed(format!("no answer within {ESTIMATOR_TIMEOUT:?}")))?
            .map_err(|e| failed(e.to_string()))
    }
}

/// Where a goal writes the model and the recording.
fn outputs(goal: &Calibrate::Goal) -> Result<(PathBuf, PathBuf), String> {
    let model = match goal.model_file.as_str() {
        "" => {
            let dir = crate::learn::default_model::cache_dir()
                .ok_or("no model cache folder ($HOME unset): give model_file")?;
            let unix = SystemTime::now()
                .duration_since(UNIX_EPOCH)
                .map_or(0, |d| d.as_secs());
            dir.join(format!("calibration_{unix}.json"))
        }
        f => PathBuf::from(f),
    };
    let session = match goal.session_file.as_str() {
        "" => model.with_extension("mcap"),
        f => PathBuf::from(f),
    };
    Ok((model, session))
}

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

/// The RMSE of fx, fy, fz of the validation row `name`.
fn rmse(r: &CalibrationRecord, name: &str) -> Vec<f64> {
    r.validation
        .iter()
        .find(|v| v.model == name)
        .map(|v| v.rmse.values().copied().collect())
        .unwrap_or_default()
}

pub(super) async fn serve(
    mut goals: impl futures::Stream<Item = r2r::ActionServerGoalRequest<Calibrate::Action>> + Unpin,
    shared: Arc<Mutex<Shared>>,
    period: Duration,
    clock: RosClock,
    estimator: EstimatorLink,
) {
    while let Some(req) = goals.next().await {
        let goal = CalibrateGoal {
            surface: req.goal.surface.clone(),
        };
        let started = outputs(&req.goal).and_then(|paths| {
            let mut g = lock(&shared);
            if g.goal_active {
                return Err("a goal is running: cancel it first".into());
            }
            let robot = g.robot.clone().ok_or("no robot description yet")?;
            let c = goal.start(&g.base, robot).map_err(|e| e.to_string())?;
            g.controller = Some(c);
            g.task = TaskKind::Calibrate;
            g.goal_active = true;
            g.calibration = Some(CalibrationRecorder::new(clock.now_s()));
            g.last = None;
            Ok(paths)
        });
        let Ok((mut handle, mut cancel)) = req.accept() else {
            if started.is_ok() {
                end_goal(&shared);
            }
            continue;
        };
        let (model_path, session_path) = match started {
            Ok(paths) => paths,
            Err(e) => {
                tracing::warn!("calibrate goal refused: {e}");
                let _ = handle.abort(failed(format!("refused: {e}"), None));
                continue;
            }
        };
        tracing::info!("calibrating: pressing the {}", lock(&shared).base.object);
        let mut ticker = tokio::time::interval(period);
        let ended = loop {
            ticker.tick().await;
            let mut g = lock(&shared);
            let g = &mut *g;
            let canceled = futures::FutureExt::now_or_never(cancel.next()).flatten();
            let (Some(c), Some(rec)) = (g.controller.as_mut(), g.calibration.as_ref()) else {
                break Ended::Canceled;
            };
            if let Some(request) = canceled {
                c.stop();
                request.accept();
                break Ended::Canceled;
            }
            let now = clock.now_s();
            if rec.ft_stale(now) {
                c.stop();
                break Ended::FtStale(rec.motion_s());
            }
            let Some(out) = &g.last else { continue };
            if out.phase == Phase::Stopped {
                break Ended::from_stop(out.reason);
            }
            let _ = handle.publish_feedback(Calibrate::Feedback {
                push: c.push().map_or(0, |(i, _)| i as u32 + 1),
                pushes: c.pushes().unwrap_or(0) as u32,
                phase: out.phase.name().into(),
                force_n: rec.last_force().force.norm(),
            });
        };
        let rec = lock(&shared).calibration.take();
        let Some(rec) = rec else {
            end_goal(&shared);
            continue;
        };
        if let Some(why) = ended.failure() {
            tracing::warn!("calibration: {why}; no model written");
            let result = failed(why, Some(&rec));
            let _ = if ended == Ended::Canceled {
                handle.cancel(result)
            } else {
                handle.abort(result)
            };
            end_goal(&shared);
            continue;
        }
        let result = fit(&rec, &estimator, model_path, session_path).await;
        let _ = match result {
            Ok(r) => handle.succeed(r),
            Err(r) => handle.abort(r),
        };
        end_goal(&shared);
    }
}

/// The goal is over: a task switch or a new goal may come.
fn end_goal(shared: &Mutex<Shared>) {
    let mut g = lock(shared);
    g.goal_active = false;
    g.calibration = None;
}

/// The fit once the arm has stopped, and the estimator given the model.
async fn fit(
    rec: &CalibrationRecorder,
    estimator: &EstimatorLink,
    model_path: PathBuf,
    session_path: PathBuf,
) -> Result<Calibrate::Result, Calibrate::Result> {
    let refuse = |why: String| {
        tracing::warn!("calibration: {why}");
        failed(why, Some(rec))
    };
    let current_file = estimator.model_file().await.map_err(refuse)?;
    if current_file.is_empty() {
        return Err(refuse(format!(
            "{} does not say its model file (model_file is empty)",
            estimator.name
        )));
    }
    tracing::info!(
        "calibration: {} pushes recorded; fitting (the estimator's model {current_file}, adapted, or a new one)",
        rec.records().last().map_or(0, |r| r.trial)
    );
    let records = rec.records().to_vec();
    let (motion_s, peak) = (rec.motion_s(), rec.peak_force_n());
    let (model, session) = (model_path.clone(), session_path.clone());
    let fitted = tokio::task::spawn_blocking(move || {
        let current =
            WrenchGp::load(std::path::Path::new(&current_file)).map_err(|e| e.to_string())?;
        fit_and_save(&records, &current, motion_s, peak, &session, &model)
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
        Ok((true, _)) => (true, format!("{} estimates with {path}", estimator.name)),
        Ok((false, why)) => (false, why),
        Err(e) => (false, e),
    };
    tracing::info!(
        "calibration: chose the model {}, {:.1} s of compute, written to {path}; {message}",
        fitted.chosen,
        fitted.compute_s
    );
    Ok(Calibrate::Result {
        reason: "calibrated".into(),
        model_file: path,
        session_file: session_path.display().to_string(),
        current_rmse_n: rmse(&fitted, "current"),
        chosen_rmse_n: rmse(&fitted, &fitted.chosen),
        chosen: fitted.chosen,
        pushes: fitted.pushes,
        motion_s: fitted.motion_s,
        compute_s: fitted.compute_s,
        peak_force_n: fitted.peak_force_n,
        estimator_updated: updated,
        estimator_message: message,
    })
}
