//! `wrench_estimator`: `biotac/readings` (tactile_force_msgs/BioTac,
//! untyped) -> [`EstimatorNode`] -> `biotac/wrench` and
//! `biotac/wrench_stddev` (geometry_msgs/WrenchStamped, frame_id = the
//! BioTac frame) and `biotac/pdc_rise` (sensor_msgs/FluidPressure, counts).
//! Nothing is published for a refused message, a reading with invalid
//! channels, a reading older than `stale_timeout_s`, or a non-finite estimate.

use futures::StreamExt;
use r2r::geometry_msgs::msg::WrenchStamped;
use r2r::sensor_msgs::msg::FluidPressure;
use r2r::QosProfile;

use super::biotac_msg::{self, BIOTAC_MSG_TYPE};
use super::{convert, RosError};
use crate::kinematics::robot::PA10_YAML;
use crate::learn::model::WrenchGp;
use crate::nodes::estimator::EstimatorParams;
use crate::nodes::EstimatorNode;
use crate::runtime::scene::{GUARDED_YAML, WORLD_YAML};

/// Counters of dropped input (logged every 1000 drops).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Dropped {
    /// Messages refused by [`biotac_msg::from_json`].
    pub refused: u64,
    /// Readings with invalid channels.
    pub invalid: u64,
    /// Readings older than the stale timeout.
    pub stale: u64,
    /// Estimates with NaN or infinity.
    pub non_finite: u64,
}

/// Runs the node until the process ends.
pub async fn run() -> Result<(), RosError> {
    let mut node = super::create_node("wrench_estimator")?;
    let model_file = super::own_string(
        &node,
        "model_file",
        "",
        "GP model file from `tactile_force train`; empty: the demos' default model (trained on first use, cached).",
    )?;
    let frame_id = super::own_string(
        &node,
        "frame_id",
        "biotac",
        "Frame of the published wrenches (the BioTac frame).",
    )?;
    let stale_s = super::own_f64(
        &node,
        "stale_timeout_s",
        0.03,
        "Readings older than this are not estimated (s).",
    )?;
    if stale_s <= 0.0 {
        return Err(RosError::Setup(format!(
            "stale_timeout_s = {stale_s}: expected > 0"
        )));
    }
    let skip = ["model_file", "frame_id", "stale_timeout_s"];
    let params: EstimatorParams = super::node_params(
        &node,
        "wrench_estimator",
        &[PA10_YAML, WORLD_YAML, GUARDED_YAML],
        &skip,
        super::describe_shared,
    )?;
    let model = if model_file.is_empty() {
        let recipe = &params.default_model;
        crate::learn::default_model::load_or_train(recipe, &mut || {
            tracing::info!(
                "training the default model ({}, about 10 s)",
                recipe.describe()
            )
        })
        .map_err(|e| RosError::Setup(e.to_string()))?
        .0
    } else {
        WrenchGp::load(std::path::Path::new(&model_file))
            .map_err(|e| RosError::Setup(format!("{model_file}: {e}")))?
    };
    let gps: Vec<String> = model
        .fits()
        .map(|(a, gp, _)| format!("{a}: {}", gp.describe()))
        .collect();
    tracing::info!(
        "wrench_estimator: model {} ({}; {} training samples), axes {}, with_std {}, stale after {stale_s} s",
        if model_file.is_empty() { "default" } else { &model_file },
        gps.join(", "),
        model.n_train(),
        model.axes(),
        params.with_std,
    );
    let mut estimator =
        EstimatorNode::new(model, params.with_std).map_err(|e| RosError::Setup(e.to_string()))?;

    let mut readings = node.subscribe_untyped(
        "biotac/readings",
        BIOTAC_MSG_TYPE,
        QosProfile::sensor_data(),
    )?;
    let wrench = node.create_publisher::<WrenchStamped>("biotac/wrench", QosProfile::default())?;
    let stddev =
        node.create_publisher::<WrenchStamped>("biotac/wrench_stddev", QosProfile::default())?;
    let pdc = node.create_publisher::<FluidPressure>("biotac/pdc_rise", QosProfile::default())?;
    let mut clock = r2r::Clock::create(r2r::ClockType::RosTime)?;
    let (handler, _events) = node.make_parameter_handler()?;
    tokio::spawn(handler);
    super::spin(node);

    let mut dropped = Dropped::default();
    while let Some(msg) = readings.next().await {
        let reading = match msg
            .map_err(|e| e.to_string())
            .and_then(|v| biotac_msg::from_json(&v).map_err(|e| e.to_string()))
        {
            Ok((r, meta)) if meta.invalid_channels.is_empty() => r,
            Ok(_) => {
                dropped.invalid += 1;
                continue;
            }
            Err(e) => {
                dropped.refused += 1;
                tracing::debug!("biotac/readings: {e}");
                continue;
            }
        };
        if super::now_s(&mut clock) - reading.stamp_s > stale_s {
            dropped.stale += 1;
            continue;
        }
        let estimate = match estimator.on_reading(&reading) {
            Ok(Some(e)) => e,
            Ok(None) => continue, // still taking the tare
            Err(e) => {
                dropped.non_finite += 1;
                tracing::debug!("estimate: {e}");
                continue;
            }
        };
        let Some((mean, std)) = convert::estimate_msgs(&estimate, &frame_id) else {
            dropped.non_finite += 1;
            continue;
        };
        // The mean last: the controller steps when the mean and std of a
        // reading are both in (the std is zeros without `with_std`).
        let sent = pdc
            .publish(&convert::pdc_rise_msg(&estimate, &frame_id))
            .and_then(|()| stddev.publish(&std))
            .and_then(|()| wrench.publish(&mean));
        if let Err(e) = sent {
            tracing::warn!("publish: {e}");
        }
        let total = dropped.refused + dropped.invalid + dropped.stale + dropped.non_finite;
        if total > 0 && total % 1000 == 0 {
            tracing::warn!("dropped input so far: {dropped:?}");
        }
    }
    Ok(())
}
