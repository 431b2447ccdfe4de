//! `wrench_estimator`: the readings of the model's sensor -> [`EstimatorNode`]
//! -> `biotac/wrench_estimate` (tactile_force_msgs/WrenchEstimate: mean,
//! standard deviation, the axes estimated, the model's file and SHA-256,
//! the reading's age, the PDC rise in counts), and its mean on
//! `biotac/wrench` (geometry_msgs/WrenchStamped, for RViz and tools); the
//! standard deviation also on `biotac/wrench_stddev` (deprecated: it goes
//! in the next release). frame_id = the sensor's frame. The model file
//! says which sensor ([`crate::sensor::SensorSpec`]):
//!
//! - a BioTac model reads `biotac/readings` (tactile_force_msgs/BioTac), or
//!   with `input: biotac_all` one `finger` of a Shadow hand's `/rh/tactile`
//!   (sr_robot_msgs/BiotacAll), taken as CDR bytes:
//!   `wrench_estimator/biotac.rs`;
//! - a nail-camera model reads `camera/image` (sensor_msgs/Image, mono8,
//!   rgb8 or bgr8): `wrench_estimator/nail.rs`.
//!
//! `model_file` may be set while the node runs, to a file in `models_dir`
//! (default: the model cache folder): see `wrench_estimator/biotac.rs`; a
//! `model_file` given at launch may be anywhere. With none
//! given the node estimates with the default model and sets `model_file` to
//! its cache file, so that `ros2 param get` (and the calibration) read which.
//!
//! Nothing is published for a message that does not decode, a reading with
//! invalid channels, a reading older than `stale_timeout_s`, or a non-finite
//! estimate: each is counted, on `/diagnostics` once a second, with its
//! input named when silent for `silent_input_s` ([`super::inputs`]).
//! SIGINT and SIGTERM end it (exit code 0).

mod biotac;
mod nail;

use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use r2r::diagnostic_msgs::msg::DiagnosticArray;
use r2r::geometry_msgs::msg::WrenchStamped;
use r2r::QosProfile;

use super::ending::Endings;
use super::inputs::Inputs;
use super::{convert, lock, Graph, RosClock, RosError};
use crate::learn::default_model::{Origin, Recipe};
use crate::learn::models::model_file::{self, ModelId};
use crate::learn::models::wrench_model::WrenchModel;
use crate::nodes::estimate_msg::{self as msg, ESTIMATE_MSG_TYPE};
use crate::nodes::own_params;
use crate::nodes::param_reference::RosNode;
use crate::nodes::status::{Level, Status};
use crate::nodes::tasks;
use crate::nodes::wrench_estimator::drop_log::DropLog;
use crate::nodes::wrench_estimator::{loading_status, EstimatorParams};
use crate::nodes::EstimatorNode;
use crate::sensor::{SensorInput, SensorSpec};
use crate::wrench::WrenchEstimate;

/// Runs the node until a signal ends it.
pub async fn run(mut endings: Endings) -> Result<(), RosError> {
    endings.until(estimate()).await
}

async fn estimate() -> Result<(), RosError> {
    let mut node = super::create_node("wrench_estimator")?;
    let model_file = super::own_string(&node, &own_params::MODEL_FILE)?;
    let frame_id = super::own_string(&node, &own_params::ESTIMATE_FRAME)?;
    let stale_s = super::own_f64(&node, &own_params::STALE_TIMEOUT)?;
    let tare_file = super::own_string(&node, &own_params::TARE_FILE)?;
    let tare_max_age_s = super::own_f64(&node, &own_params::TARE_MAX_AGE)?;
    let silent_after_s = super::own_f64(&node, &own_params::SILENT_INPUT)?;
    let models = super::models_dir(&node)?;
    let params: EstimatorParams =
        super::node_params(&node, RosNode::WrenchEstimator, &tasks::shipped())?;
    let out = Outputs::new(&mut node, frame_id, params.with_std)?;
    let loading = std::time::Instant::now();
    let (model, file) = load_reporting(&model_file, &params.default_model, &out, &node).await?;
    let ready_after_s = loading.elapsed().as_secs_f64();
    *lock(&out.model) = ModelId::of(file.as_deref());
    if let (true, Some(file)) = (model_file.is_empty(), &file) {
        // Says which file it estimates with (the calibration adapts it).
        super::set_own_string(
            &node,
            own_params::MODEL_FILE.name,
            &file.display().to_string(),
        );
    }
    tracing::info!(
        "{}: ready after {ready_after_s:.1} s; with_std {}, stale after {stale_s} s",
        describe_model(&model_file, model.as_ref()),
        params.with_std,
    );
    let settings = Settings {
        default_model: params.default_model.clone(),
        with_std: params.with_std,
        stale_s,
        ready_after_s,
        tare_file,
        tare_max_age_s,
        silent_after_s,
        models,
    };
    match model.input().sensor {
        SensorSpec::Biotac { .. } => biotac::run(node, model, settings, out).await,
        SensorSpec::Nail(_) => nail::run(node, model, settings, out).await,
    }
}

/// [`load_model`] on a blocking thread, saying on `/diagnostics` once a
/// second that no estimate comes yet (training the default model takes
/// tens of seconds on first use).
async fn load_reporting(
    model_file: &str,
    recipe: &Recipe,
    out: &Outputs,
    node: &r2r::Node,
) -> Result<(Box<dyn WrenchModel>, Option<PathBuf>), RosError> {
    let clock = RosClock::of(node);
    let (file, recipe) = (model_file.to_string(), recipe.clone());
    let start = std::time::Instant::now();
    let mut loading = tokio::task::spawn_blocking(move || load_model(&file, &recipe));
    let mut report = tokio::time::interval(REPORT);
    loop {
        tokio::select! {
            loaded = &mut loading => return loaded?,
            _ = report.tick() => out.publish_status(loading_status(start.elapsed().as_secs_f64()), &clock),
        }
    }
}

/// The model of `model_file`, or with none the demos' default model of
/// `recipe` (trained on first use, cached), and the file it is in (none for
/// a default model the cache could not keep).
fn load_model(
    model_file: &str,
    recipe: &Recipe,
) -> Result<(Box<dyn WrenchModel>, Option<PathBuf>), RosError> {
    if !model_file.is_empty() {
        let path = PathBuf::from(model_file);
        return Ok((model_file::load(&path)?, Some(path)));
    }
    let mut said = || {
        tracing::info!(
            "training the default model ({}): no estimate until it is ready",
            recipe.describe()
        )
    };
    let (model, origin) = crate::learn::default_model::load_or_train(recipe, &mut said)?;
    let path = match origin {
        Origin::Cached(p) | Origin::TrainedAndCached(p) => Some(p),
        Origin::TrainedNotCached(_) => None,
    };
    Ok((Box::new(model), path))
}

/// One line on the model of `file` (empty: the default model).
fn describe_model(file: &str, model: &dyn WrenchModel) -> String {
    let name = if file.is_empty() { "default" } else { file };
    format!("model {name}: {}", model.describe())
}

/// The node's own parameters that the sensor loops read.
struct Settings {
    /// The model made for an empty `model_file`.
    default_model: Recipe,
    with_std: bool,
    stale_s: f64,
    /// Seconds from the start to the model's being ready.
    ready_after_s: f64,
    tare_file: String,
    tare_max_age_s: f64,
    /// Its input silent this long is named (s).
    silent_after_s: f64,
    /// Where a `model_file` set while running must be.
    models: crate::outputs::models_dir::ModelsDir,
}

/// The estimator's topics and its once-a-second report.
struct Outputs {
    /// tactile_force_msgs/WrenchEstimate as CDR ([`crate::nodes::estimate_msg`]).
    estimate: r2r::PublisherUntyped,
    wrench: r2r::Publisher<WrenchStamped>,
    /// Deprecated: the std is in `estimate`.
    stddev: r2r::Publisher<WrenchStamped>,
    diagnostics: r2r::Publisher<DiagnosticArray>,
    /// The node's name, its status's (`nail_estimator` when renamed so).
    name: String,
    frame_id: String,
    with_std: bool,
    /// The model estimating: set when `model_file` changes.
    model: Arc<Mutex<ModelId>>,
    /// What the log said of dropped readings.
    drops: DropLog,
}

impl Outputs {
    fn new(node: &mut r2r::Node, frame_id: String, with_std: bool) -> Result<Self, RosError> {
        let qos = QosProfile::default;
        Ok(Outputs {
            estimate: node.create_publisher_untyped(
                "biotac/wrench_estimate",
                ESTIMATE_MSG_TYPE,
                qos(),
            )?,
            wrench: node.create_publisher("biotac/wrench", qos())?,
            stddev: node.create_publisher("biotac/wrench_stddev", qos())?,
            diagnostics: node.create_publisher("/diagnostics", qos())?,
            name: node.name()?,
            frame_id,
            with_std,
            model: Arc::default(),
            drops: DropLog::default(),
        })
    }

    /// Publishes an estimate at `now_s`: the whole estimate, then its
    /// mean and std as wrenches (the std zeros without `with_std`).
    fn publish(&self, e: &WrenchEstimate, now_s: f64) {
        let model = lock(&self.model).clone();
        let age_s = now_s - e.stamp_s;
        let msgs = msg::to_cdr(e, &self.frame_id, self.with_std, &model, age_s)
            .zip(convert::estimate_msgs(e, &self.frame_id));
        let Some((estimate, (mean, std))) = msgs else {
            return; // on_received has checked that every number is finite
        };
        let sent = self
            .estimate
            .publish_raw(&estimate)
            .and_then(|()| self.stddev.publish(&std))
            .and_then(|()| self.wrench.publish(&mean));
        if let Err(e) = sent {
            tracing::warn!("publish: {e}");
        }
    }

    /// The once-a-second report's status: what was dropped (logged when
    /// it grew, as [`DropLog`] says) and the node's status; [`Outputs::report`]
    /// sends it.
    fn status<S: SensorInput>(&mut self, estimator: &EstimatorNode<S>) -> Status {
        match self.drops.line(estimator) {
            Some((Level::Error, line)) => tracing::error!("{line}"),
            Some((_, line)) => tracing::warn!("{line}"),
            None => {}
        }
        estimator.status()
    }

    /// Sends `status` on `/diagnostics`, its input named if silent.
    async fn report(
        &self,
        mut status: Status,
        clock: &RosClock,
        (inputs, graph): (&Inputs, &Graph),
    ) {
        inputs.report(&mut status, graph, |_| true).await;
        self.publish_status(status, clock);
    }

    /// Publishes the node's status on `/diagnostics`.
    fn publish_status(&self, status: Status, clock: &RosClock) {
        let msg = convert::status_msg(clock.now_s(), &self.name, "", status);
        if let Err(e) = self.diagnostics.publish(&msg) {
            tracing::warn!("diagnostics: {e}");
        }
    }
}

/// The report's period.
const REPORT: Duration = Duration::from_secs(1);
