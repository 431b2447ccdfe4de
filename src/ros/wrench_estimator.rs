//! `wrench_estimator`: `biotac/readings` (tactile_force_msgs/BioTac, taken
//! as CDR bytes and decoded here) -> [`EstimatorNode`] -> `biotac/wrench` and
//! `biotac/wrench_stddev` (geometry_msgs/WrenchStamped, frame_id = the
//! BioTac frame) and `biotac/pdc_rise` (sensor_msgs/FluidPressure, counts).
//! Nothing is published for a message that does not decode, a reading with
//! invalid channels, a reading older than `stale_timeout_s`, or a non-finite
//! estimate: each is counted, on `/diagnostics` once a second.
//!
//! The tare is saved (`tare_file`): restarted within `tare_max_age_s`, for
//! the same sensor serial, the node takes it up rather than taring again,
//! since the finger may be pressed (a hold) when it comes back.

use std::path::PathBuf;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use futures::StreamExt;
use r2r::diagnostic_msgs::msg::DiagnosticArray;
use r2r::geometry_msgs::msg::WrenchStamped;
use r2r::sensor_msgs::msg::FluidPressure;
use r2r::QosProfile;

use super::convert::level::{OK, WARN};
use super::params::RuntimeParams;
use super::{convert, RosError};
use crate::biotac::msg::{self as biotac_msg, BIOTAC_MSG_TYPE};
use crate::biotac::tare::SavedTare;
use crate::control::TaskKind;
use crate::learn::model::WrenchGp;
use crate::nodes::estimator::EstimatorParams;
use crate::nodes::EstimatorNode;
use crate::params::layered_flat_params;
use crate::sensor::biotac::BioTacInput;

fn unix_s() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
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
    let tare_file = super::own_string(
        &node,
        "tare_file",
        "",
        "Where the tare is saved; empty: wrench_estimator_tare.json in the model cache folder.",
    )?;
    let tare_max_age_s = super::own_f64(
        &node,
        "tare_max_age_s",
        60.0,
        "A saved tare younger than this is taken up at start (s); 0: always tare anew.",
    )?;
    let skip = [
        "model_file",
        "frame_id",
        "stale_timeout_s",
        "tare_file",
        "tare_max_age_s",
    ];
    let params: EstimatorParams = super::node_params(
        &node,
        "wrench_estimator",
        layered_flat_params(&TaskKind::Guarded.shipped_layers(), "wrench_estimator")?,
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
        })?
        .0
    } else {
        WrenchGp::load(std::path::Path::new(&model_file))?
    };
    let gps: Vec<String> = model
        .fits()
        .map(|(a, gp, _)| format!("{a}: {}", gp.describe()))
        .collect();
    tracing::info!(
        "model {} ({}; {} training samples), axes {}, with_std {}, stale after {stale_s} s",
        if model_file.is_empty() {
            "default"
        } else {
            &model_file
        },
        gps.join(", "),
        model.n_train(),
        model.axes(),
        params.with_std,
    );
    let mut estimator = EstimatorNode::<BioTacInput>::new(model, params.with_std)
        .and_then(|e| e.with_stale_timeout(stale_s))?;
    let tare_path = match tare_file.as_str() {
        "" => {
            crate::learn::default_model::cache_dir().map(|d| d.join("wrench_estimator_tare.json"))
        }
        f => Some(PathBuf::from(f)),
    };
    if tare_path.is_none() {
        tracing::info!("no cache folder ($HOME unset) and no tare_file: the tare is not saved");
    }
    let mut saved = match tare_path.as_deref().map(SavedTare::load) {
        Some(Ok(s)) => s.filter(|s| (0.0..=tare_max_age_s).contains(&(unix_s() - s.taken_unix_s))),
        Some(Err(e)) => {
            tracing::warn!("{e}; taking a new tare");
            None
        }
        None => None,
    };

    let mut readings = node.subscribe_raw(
        "biotac/readings",
        BIOTAC_MSG_TYPE,
        QosProfile::sensor_data(),
    )?;
    let wrench = node.create_publisher::<WrenchStamped>("biotac/wrench", QosProfile::default())?;
    let stddev =
        node.create_publisher::<WrenchStamped>("biotac/wrench_stddev", QosProfile::default())?;
    let pdc = node.create_publisher::<FluidPressure>("biotac/pdc_rise", QosProfile::default())?;
    let diagnostics =
        node.create_publisher::<DiagnosticArray>("/diagnostics", QosProfile::default())?;
    let clock = super::serve_parameters(&mut node, RuntimeParams::none())?;
    super::spin(node);

    let mut report = tokio::time::interval(Duration::from_secs(1));
    let mut reported = estimator.dropped();
    loop {
        let msg = tokio::select! {
            m = readings.next() => match m {
                Some(m) => m,
                None => return Ok(()),
            },
            _ = report.tick() => {
                let d = estimator.dropped();
                if d.total() > reported.total() {
                    tracing::warn!(
                        "dropped {} readings in the last second: {} undecodable, {} with \
                         invalid channels, {} stale, {} non-finite",
                        d.total() - reported.total(),
                        d.refused - reported.refused,
                        d.invalid - reported.invalid,
                        d.stale - reported.stale,
                        d.non_finite - reported.non_finite,
                    );
                }
                reported = d;
                let (level, message) = match (estimator.is_tared(), d.total()) {
                    (false, _) => (WARN, "taring".to_string()),
                    (true, 0) => (OK, "estimating".to_string()),
                    (true, n) => (WARN, format!("estimating; {n} readings dropped so far")),
                };
                let values = vec![
                    ("estimates", estimator.estimates().to_string()),
                    ("dropped_refused", d.refused.to_string()),
                    ("dropped_invalid_channels", d.invalid.to_string()),
                    ("dropped_stale", d.stale.to_string()),
                    ("dropped_non_finite", d.non_finite.to_string()),
                ];
                let name = "wrench_estimator";
                let msg = convert::diagnostics_msg(clock.now_s(), level, name, message, "", values);
                if let Err(e) = diagnostics.publish(&msg) {
                    tracing::warn!("diagnostics: {e}");
                }
                continue;
            }
        };
        let (reading, meta) = match biotac_msg::from_cdr(&msg) {
            Ok((r, meta)) if meta.invalid_channels.is_empty() => (r, meta),
            Ok(_) => {
                estimator.count_unusable(true);
                continue;
            }
            Err(e) => {
                estimator.count_unusable(false);
                tracing::debug!("biotac/readings: {e}");
                continue;
            }
        };
        if let Some(s) = saved.take() {
            if s.serial == meta.serial && !estimator.is_tared() {
                tracing::info!(
                    "taking up the tare saved {:.0} s ago (same sensor, \"{}\"): \
                     the skin may be pressed now; tare_max_age_s:=0 tares anew",
                    unix_s() - s.taken_unix_s,
                    s.serial,
                );
                estimator.set_tare(s.tare);
            }
        }
        let was_tared = estimator.is_tared();
        let estimate = estimator.on_received(&reading, clock.now_s());
        if !was_tared && estimator.is_tared() {
            tracing::info!("tared on {} readings", estimator.tare_samples());
            if let (Some(tare), Some(path)) = (estimator.tare(), &tare_path) {
                let s = SavedTare {
                    serial: meta.serial.clone(),
                    taken_unix_s: unix_s(),
                    tare: tare.clone(),
                };
                if let Err(e) = s.save(path) {
                    tracing::warn!("tare not saved: {e}");
                }
            }
        }
        let Some(e) = estimate else { continue };
        let Some((mean, std)) = convert::estimate_msgs(&e, &frame_id) else {
            continue; // on_received has checked that every number is finite
        };
        // The mean last: the controller steps when the mean and std of a
        // reading are both in (the std is zeros without `with_std`).
        let sent = pdc
            .publish(&convert::pdc_rise_msg(&e, &frame_id))
            .and_then(|()| stddev.publish(&std))
            .and_then(|()| wrench.publish(&mean));
        if let Err(e) = sent {
            tracing::warn!("publish: {e}");
        }
    }
}
