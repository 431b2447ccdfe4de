//! The BioTac's loop: the readings of the `input` parameter (CDR bytes:
//! `biotac` reads `biotac/readings`, `biotac_all` sensor `finger` of a
//! Shadow hand's `/rh/tactile`, [`ReadingSource`]) -> estimates; the tare
//! is saved (`tare_file`): restarted within `tare_max_age_s`, for the same
//! sensor serial, the node takes it up rather than taring again, since the
//! finger may be pressed (a hold) when it comes back.
//!
//! `model_file` may be set while the node runs (the calibration action
//! does): a file in `models_dir` (a path outside it, `..` or a symlink
//! leading out is refused), loaded and checked, and estimates come from it from
//! the next reading on, on the same tare; refused, with the reason, when it
//! does not load or fit the BioTac, and while the finger is pressed
//! ([`crate::nodes::wrench_estimator::PRESSED_N`]).

use std::sync::{Arc, Mutex};

mod tare_store;

use futures::StreamExt;
use r2r::QosProfile;

use super::{describe_model, load_model, Outputs, Settings, REPORT};
use crate::learn::models::model_file::ModelId;
use crate::learn::models::wrench_model::WrenchModel;
use crate::nodes::bounds::MESSAGE_MAX_BYTES;
use crate::nodes::own_params;
use crate::nodes::wrench_estimator::reading_source::{ReadingSource, SourceError, Unusable};
use crate::nodes::EstimatorNode;
use crate::outputs::models_dir::ModelsDir;
use crate::ros::inputs::Inputs;
use crate::ros::params::RuntimeParams;
use crate::ros::{bounded, lock, RosError};
use crate::sensor::biotac::BioTacInput;
use tare_store::TareStore;

/// Checks (or, `apply`, takes) the model of a new `model_file` value: a
/// file in `models` ([`ModelsDir::input`]), or "" for the default model.
fn take_model(
    estimator: &Mutex<EstimatorNode<BioTacInput>>,
    id: &Mutex<ModelId>,
    recipe: &crate::learn::default_model::Recipe,
    models: &ModelsDir,
    value: &r2r::ParameterValue,
    apply: bool,
) -> Result<(), String> {
    let r2r::ParameterValue::String(file) = value else {
        return Err(format!(
            "{value:?}: expected a model file's path (a string)"
        ));
    };
    let path = match file.as_str() {
        "" => String::new(),
        f => models
            .input("model_file", f)
            .map_err(|e| e.to_string())?
            .display()
            .to_string(),
    };
    let (model, kept) = load_model(&path, recipe).map_err(|e| e.to_string())?;
    let said = describe_model(file, model.as_ref());
    // Read before the estimator is locked: its readings wait for nothing.
    let new_id = if apply {
        ModelId::of(kept.as_deref())
    } else {
        ModelId::default()
    };
    let mut e = lock(estimator);
    if !apply {
        return e.check_model(model.as_ref()).map_err(|e| e.to_string());
    }
    e.take_model(model).map_err(|e| e.to_string())?;
    *lock(id) = new_id;
    tracing::info!("{said}: estimating with it from the next reading, on the same tare");
    Ok(())
}

/// Runs the BioTac estimator until the process ends: its input declared,
/// the saved tare looked up, the readings and `model_file` wired, then one
/// estimate per reading.
pub(super) async fn run(
    mut node: r2r::Node,
    model: Box<dyn WrenchModel>,
    s: Settings,
    mut out: Outputs,
) -> Result<(), RosError> {
    let source = declare_source(&node)?;
    let estimator = EstimatorNode::<BioTacInput>::new(model, s.with_std)
        .and_then(|e| e.with_stale_timeout(s.stale_s))?
        .with_ready_after(s.ready_after_s);
    let mut tares = TareStore::open(&s.tare_file, s.tare_max_age_s);
    let (qos, guard) = (QosProfile::sensor_data(), estimator.guard().clone());
    let (topic, kind) = (source.topic(), source.type_name());
    let readings = match bounded::raw(
        &mut node,
        topic,
        kind,
        qos.clone(),
        MESSAGE_MAX_BYTES,
        &guard,
    ) {
        Err(RosError::R2r(r2r::Error::InvalidMessageType { .. })) => {
            return Err(SourceError::NotBuilt(source.type_name()).into())
        }
        subscribed => subscribed?,
    };
    tracing::info!("reading {} on {}", source.type_name(), source.topic());
    let inputs = Inputs::new(&[(topic, &qos)], s.silent_after_s);
    let mut readings = inputs.watched(topic, readings);
    let estimator = Arc::new(Mutex::new(estimator));
    let (shared, id) = (estimator.clone(), out.model.clone());
    let (recipe, models) = (s.default_model, s.models);
    let live = RuntimeParams::new(
        &[own_params::MODEL_FILE.name],
        Box::new(move |_, value, apply| {
            take_model(&shared, &id, &recipe, &models, value, apply)
                .inspect_err(|e| tracing::warn!("model_file refused: {e}"))
        }),
        &guard,
    );
    let clock = crate::ros::serve_parameters(&mut node, live)?;
    let spinning = crate::ros::spin(node);
    let graph = spinning.graph();

    let mut report = tokio::time::interval(REPORT);
    loop {
        let msg = tokio::select! {
            m = readings.next() => match m {
                Some(m) => m,
                None => return Ok(()),
            },
            _ = report.tick() => {
                let status = out.status(&lock(&estimator));
                out.report(status, &clock, (&inputs, &graph)).await;
                continue;
            }
        };
        let mut estimator = lock(&estimator);
        let (reading, serial) = match source.decode(&msg) {
            Ok(decoded) => decoded,
            Err(e) => {
                estimator.count_unusable(e == Unusable::InvalidChannels);
                tracing::debug!("{}: {e:?}", source.topic());
                continue;
            }
        };
        tares.take_up(&mut estimator, &serial);
        let was_tared = estimator.is_tared();
        let estimate = estimator.on_received(&reading, clock.now_s());
        if !was_tared && estimator.is_tared() {
            tracing::info!("tared on {} readings", estimator.tare_samples());
            tares.save(&estimator, serial);
        }
        if let Some(e) = estimate {
            out.publish(&e, clock.now_s());
        }
    }
}

/// Declares where the readings come from.
fn declare_source(node: &r2r::Node) -> Result<ReadingSource, RosError> {
    let input = crate::ros::own_string(node, &own_params::INPUT)?;
    let finger = crate::ros::own_f64(node, &own_params::FINGER)?;
    Ok(ReadingSource::from_params(&input, finger)?)
}
