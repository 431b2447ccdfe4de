//! The ensemble's model file: JSON with `format`
//! ([`ENSEMBLE_FORMAT`]), `version`, the feature names, the axes, how the
//! data was tared, the sensor, the networks (each with its standardisers)
//! and per axis the networks' held-out error and the scale of a measured
//! target's standard deviation. Checked against itself on load.

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::WrenchEnsemble;
use crate::learn::models::nn::Mlp;
use crate::learn::models::provenance::{AdaptChoice, CalibrationRecord, Selection};
use crate::learn::models::wrench_model::ModelError;
use crate::learn::models::wrench_model::{write_json, TareSpec};
use crate::sensor::SensorSpec;
use crate::wrench::AxisSet;

/// The `format` field of an ensemble's model file.
pub const ENSEMBLE_FORMAT: &str = "tactile_force/wrench_ensemble";
/// The version this build writes (2: `selection`, `adapt_choice` and
/// `calibration` added; 3: `selection` holds each candidate's predicted
/// cost, and no clock reading; 4: the held-out scores per trial, and why
/// the chooser took a calibration's or `adapt`'s model).
pub const ENSEMBLE_VERSION: u32 = 4;
/// The oldest version it reads.
const FIRST_VERSION: u32 = 1;

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct EnsembleFile {
    pub(super) format: String,
    pub(super) version: u32,
    pub(super) features: Vec<String>,
    pub(super) axes: AxisSet,
    pub(super) tare: TareSpec,
    pub(super) sensor: SensorSpec,
    pub(super) n_train: usize,
    pub(super) members: Vec<Mlp>,
    /// Per axis: the networks' error on rows they did not train on (N or Nm).
    pub(super) noise_std: Vec<f64>,
    /// Per axis: what a measured target's standard deviation is multiplied by.
    pub(super) std_scale: Vec<f64>,
    /// How `train --select` chose it (absent when it did not).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) selection: Option<Selection>,
    /// What `adapt` chose it over (absent when `adapt` did not make it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) adapt_choice: Option<AdaptChoice>,
    /// The calibration on the robot that made it (absent when none did).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) calibration: Option<CalibrationRecord>,
}

impl WrenchEnsemble {
    /// Writes the model file, whole or not at all.
    pub fn save(&self, path: &Path) -> Result<(), ModelError> {
        write_json(path, &self.file)
    }

    /// Validates the JSON of an ensemble's model file read from `path`.
    pub(crate) fn from_json(value: serde_json::Value, path: &Path) -> Result<Self, ModelError> {
        let p = path.display().to_string();
        let version = value.get("version").and_then(|v| v.as_u64()).unwrap_or(0);
        if !(u64::from(FIRST_VERSION)..=u64::from(ENSEMBLE_VERSION)).contains(&version) {
            return Err(ModelError::UnsupportedVersion {
                path: p,
                found: version,
                first: FIRST_VERSION,
                last: ENSEMBLE_VERSION,
            });
        }
        let file: EnsembleFile =
            serde_json::from_value(value).map_err(|source| ModelError::Schema {
                path: p.clone(),
                source,
            })?;
        match inconsistency(&file) {
            Some(what) => Err(ModelError::Inconsistent { path: p, what }),
            None => Ok(WrenchEnsemble { file }),
        }
    }
}

/// What disagrees in `file`, if anything.
fn inconsistency(f: &EnsembleFile) -> Option<String> {
    let (d, k) = (f.features.len(), f.axes.len());
    if f.members.len() < 2 {
        return Some(format!("{} networks, at least 2 needed", f.members.len()));
    }
    if let Some(i) = f
        .members
        .iter()
        .position(|n| n.n_inputs() != d || n.n_outputs() != k)
    {
        let n = &f.members[i];
        return Some(format!(
            "network {i} maps {} inputs to {} outputs, the file has {d} features and {k} axes",
            n.n_inputs(),
            n.n_outputs()
        ));
    }
    let per_axis = |v: &[f64], ok: fn(f64) -> bool| v.len() == k && v.iter().all(|x| ok(*x));
    if !per_axis(&f.noise_std, |x| x.is_finite() && x >= 0.0)
        || !per_axis(&f.std_scale, |x| x.is_finite() && x > 0.0)
    {
        return Some(format!(
            "{k} axes, but noise_std {:?} and std_scale {:?} (one finite value per axis, the \
             noise >= 0, the scale > 0)",
            f.noise_std, f.std_scale
        ));
    }
    if f.tare.mean_baseline.len() != d {
        return Some(format!(
            "{d} features, {} tare baselines",
            f.tare.mean_baseline.len()
        ));
    }
    match &f.sensor {
        SensorSpec::Nail(spec) => spec.check(d).err().map(|e| e.to_string()),
        SensorSpec::Biotac { .. } => None,
    }
}
