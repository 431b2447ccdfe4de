//! The model file: JSON with `format`, `version`, the feature names, the
//! axes, the input standardisation, how the data was tared, and per axis the
//! target standardisation, the GP's prior mean when it has one (`linear`:
//! weights, intercept and, for a cubic mean, its `bend`) and the GP
//! (`{"exact": ..}`: hyperparameters and training data; `{"sparse": ..}`:
//! hyperparameters, inducing inputs and their posterior); the network whose
//! estimate is every GP's prior mean, when it has one; an adapted model's
//! base, what made it and the data it was trained on, by reference
//! ([`crate::learn::models::provenance`]). The factorisations are
//! recomputed on load, which also re-checks the file's numbers.

use std::path::Path;

use ndarray::{Array2, ArrayView2};
use serde::{Deserialize, Serialize};

use super::{Estimate, EstimatorWorkspace, ModelError, TareSpec, WrenchGp};
use crate::biotac::reading::Column;
use crate::learn::models::gp::{FitInfo, Gp, GpData, GpWorkspace, LinearMean};
use crate::learn::models::nn::Mlp;
use crate::learn::models::provenance::{
    AdaptChoice, AdaptedFrom, CalibrationRecord, Selection, TrainedOn,
};
use crate::learn::models::scale::{InputScaling, Standardizer};
use crate::learn::models::wrench_model::{read_json, write_json};
use crate::sensor::SensorSpec;
use crate::wrench::{Axis, AxisSet};

/// The `format` field of every model file.
pub const MODEL_FORMAT: &str = "tactile_force/wrench_gp";
/// The model-file version this build writes (2: the GP of an axis is tagged
/// exact or sparse; 3: an adapted model holds the model it was adapted
/// from; 4: an axis may have a linear prior mean; 5: that mean may bend;
/// 6: how its options were selected on the data, `train --select`, and the
/// calibration on the robot that made it; 7: the data it was trained on, by
/// reference, and what `adapt` chose; 8: the network as the GPs' prior
/// mean; 9: `selection` holds each candidate's predicted cost, and no
/// clock reading; 10: the held-out scores per trial, and why the chooser
/// took a calibration's or `adapt`'s model). It reads versions 2 to 10.
pub const MODEL_VERSION: u32 = 10;

/// One output axis: the target's linear mean when it has one (in target
/// units), and the GP (fitted, or as stored) of what is left, standardised
/// by `target_mean` and `target_scale`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct AxisModel<G> {
    pub(super) axis: Axis,
    pub(super) target_mean: f64,
    pub(super) target_scale: f64,
    pub(super) fit: FitInfo,
    /// A linear prior mean (absent: zero).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) linear: Option<LinearMean>,
    pub(super) gp: G,
    /// What the standard deviation of a measured target (the GP's own with
    /// its noise) is multiplied by, so that held-out errors fall within two
    /// of it as often as they should ([`super::Making::StdScales`];
    /// absent: 1). The estimator's standard deviation, which the
    /// controller's doubt stop reads, is the GP's own.
    #[serde(default = "unit", skip_serializing_if = "is_unit")]
    pub(super) std_scale: f64,
}

fn unit() -> f64 {
    1.0
}

fn is_unit(x: &f64) -> bool {
    *x == 1.0
}

/// An adapted model's base: its estimate is the prior mean of the GPs.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Prior<G> {
    pub(super) from: AdaptedFrom,
    pub(super) base: Box<ModelFile<G>>,
}

/// The model file; `G` is [`Gp`] once checked, [`GpData`] as parsed.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct ModelFile<G> {
    pub(super) format: String,
    pub(super) version: u32,
    pub(super) features: Vec<String>,
    pub(super) axes: AxisSet,
    pub(super) tare: TareSpec,
    /// The sensor the features come from (absent in files before it: BioTac).
    #[serde(default)]
    pub(super) sensor: SensorSpec,
    /// How the tared features are presented (absent in files before it: standard).
    #[serde(default)]
    pub(super) scaling: InputScaling,
    pub(super) input: Standardizer,
    pub(super) n_train: usize,
    pub(super) outputs: Vec<AxisModel<G>>,
    /// The network whose estimate (from the GPs' inputs) is the prior mean
    /// of every axis's GP (absent: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) network: Option<Mlp>,
    #[serde(default = "no_prior", skip_serializing_if = "Option::is_none")]
    pub(super) prior: Option<Prior<G>>,
    /// How its options were chosen (`train --select`), with the CV table.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) selection: Option<Selection>,
    /// The calibration on the robot that made it, with its validation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) calibration: Option<CalibrationRecord>,
    /// The files it was trained on, by reference, and the base's options.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) trained_on: Option<TrainedOn>,
    /// What `adapt` chose: adapted or pooled, with both scores.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(super) adapt_choice: Option<AdaptChoice>,
    /// Which features are electrodes (for the pattern), from their names.
    #[serde(skip)]
    pub(super) electrode: Vec<bool>,
}

/// Which of `features` are electrodes.
pub(super) fn electrode_mask(features: &[String]) -> Vec<bool> {
    let is_electrode = |f: &String| matches!(Column::from_name(f), Some(Column::Electrode(_)));
    features.iter().map(is_electrode).collect()
}

fn no_prior<G>() -> Option<Prior<G>> {
    None
}

impl ModelFile<Gp> {
    pub(super) fn workspace(&self) -> EstimatorWorkspace {
        let largest = self.outputs.iter().max_by_key(|o| o.gp.size());
        EstimatorWorkspace {
            represented: vec![0.0; self.input.dim()],
            z: vec![0.0; self.input.dim()],
            gp: largest.map_or_else(|| GpWorkspace::new(0, 0), |o| o.gp.workspace()),
            network: vec![0.0; self.network.as_ref().map_or(0, Mlp::n_outputs)],
            prior: self.prior.as_ref().map(|p| {
                Box::new((
                    p.base.workspace(),
                    vec![Estimate::default(); p.base.outputs.len()],
                ))
            }),
        }
    }

    /// [`WrenchGp::predict_one`] once the feature count is checked.
    pub(super) fn predict_one(
        &self,
        features: &[f64],
        ws: &mut EstimatorWorkspace,
        with_std: bool,
        out: &mut [Estimate],
    ) {
        let row = ndarray::ArrayView1::from(features);
        self.scaling
            .represent_into(&self.electrode, row, &mut ws.represented);
        self.input
            .transform_into(ndarray::ArrayView1::from(&ws.represented), &mut ws.z);
        // Sequential on purpose: a thread pool would halve the latency of the
        // variance but allocates now and then (tests/predict_no_alloc.rs).
        for (o, e) in self.outputs.iter().zip(out.iter_mut()) {
            let (m, v) = o.gp.predict_one(&ws.z, &mut ws.gp, with_std);
            let prior = o.linear.as_ref().map_or(0.0, |l| l.at(&ws.z));
            e.mean = m * o.target_scale + o.target_mean + prior;
            e.std = v.sqrt() * o.target_scale;
        }
        if let Some(net) = &self.network {
            net.predict_one(&ws.z, &mut ws.network);
            for (e, n) in out.iter_mut().zip(&ws.network) {
                e.mean += n;
            }
        }
        // The prior mean: the base's estimate (same features and axes, checked
        // on load), into scratch allocated with the workspace.
        if let (Some(p), Some((pws, pout))) = (&self.prior, ws.prior.as_deref_mut()) {
            p.base.predict_one(features, pws, false, pout);
            for (e, b) in out.iter_mut().zip(pout.iter()) {
                e.mean += b.mean;
            }
        }
    }

    /// The GPs' standardised inputs of the rows of `x`, row after row.
    fn inputs(&self, x: ArrayView2<f64>) -> Vec<f64> {
        let represented = self.scaling.represent(&self.electrode, x);
        let z = self.input.transform(represented.view());
        z.iter().copied().collect()
    }

    /// The network mean's own estimate of the rows of `x` (None without one).
    pub(super) fn network_estimate(&self, x: ArrayView2<f64>) -> Option<Array2<f64>> {
        let net = self.network.as_ref()?;
        let z = self.inputs(x);
        let inputs = ArrayView2::from_shape((x.nrows(), self.input.dim()), &z).ok()?;
        Some(net.predict(inputs))
    }

    /// [`WrenchGp::predict`] once the feature count is checked.
    pub(super) fn predict(&self, x: ArrayView2<f64>, with_std: bool) -> (Array2<f64>, Array2<f64>) {
        let z = self.inputs(x);
        let (n, k) = (x.nrows(), self.outputs.len());
        let mut mean = Array2::zeros((n, k));
        let mut std = Array2::zeros((n, k));
        let gps: Vec<&Gp> = self.outputs.iter().map(|o| &o.gp).collect();
        let preds = Gp::predict_all(&gps, &z, with_std);
        for (j, (o, (m, v))) in self.outputs.iter().zip(preds).enumerate() {
            let prior = o.linear.as_ref().map(|l| l.at_rows(&z));
            for i in 0..n {
                mean[[i, j]] =
                    m[i] * o.target_scale + o.target_mean + prior.as_ref().map_or(0.0, |p| p[i]);
                std[[i, j]] = v[i].sqrt() * o.target_scale;
            }
        }
        if let Some(net) = &self.network {
            let inputs =
                ArrayView2::from_shape((n, self.input.dim()), &z).expect("n rows of inputs");
            mean += &net.predict(inputs);
        }
        if let Some(p) = &self.prior {
            mean += &p.base.predict(x, false).0;
        }
        (mean, std)
    }
}

impl WrenchGp {
    /// Writes the model file, whole or not at all
    /// ([`crate::outputs::write_whole`]).
    pub fn save(&self, path: &Path) -> Result<(), ModelError> {
        write_json(path, self)
    }

    /// Reads and validates a model file of the GP family.
    pub fn load(path: &Path) -> Result<Self, ModelError> {
        let (value, format) = read_json(path)?;
        if format != MODEL_FORMAT {
            return Err(ModelError::WrongFormat {
                path: path.display().to_string(),
                found: format,
                expected: MODEL_FORMAT.into(),
            });
        }
        Self::from_json(value, path)
    }

    /// Validates the JSON of a model file of the GP family read from `path`.
    pub(crate) fn from_json(value: serde_json::Value, path: &Path) -> Result<Self, ModelError> {
        let p = path.display().to_string();
        let version = value.get("version").and_then(|v| v.as_u64()).unwrap_or(0);
        if !(2..=u64::from(MODEL_VERSION)).contains(&version) {
            return Err(ModelError::UnsupportedVersion {
                path: p,
                found: version,
                first: 2,
                last: MODEL_VERSION,
            });
        }
        let file: ModelFile<GpData> =
            serde_json::from_value(value).map_err(|source| ModelError::Schema {
                path: p.clone(),
                source,
            })?;
        Ok(WrenchGp(checked(file, &p)?))
    }
}

/// The file's GPs rebuilt, and its parts checked against each other (an
/// adapted model's base too).
fn checked(mut file: ModelFile<GpData>, path: &str) -> Result<ModelFile<Gp>, ModelError> {
    let bad = |what: String| ModelError::Inconsistent {
        path: path.into(),
        what,
    };
    let electrode = electrode_mask(&file.features);
    let d = file.scaling.dim(&electrode);
    shape_problem(&file, d).map_or(Ok(()), |what| Err(bad(what)))?;
    let prior = match file.prior.take() {
        None => None,
        Some(Prior { from, base }) => {
            let base = checked(*base, path)?;
            if base.features != file.features
                || base.axes != file.axes
                || base.sensor != file.sensor
            {
                return Err(bad(format!(
                    "adapted from a model of features {:?} and axes {}, but has {:?} and {}",
                    base.features, base.axes, file.features, file.axes
                )));
            }
            Some(Prior {
                from,
                base: Box::new(base),
            })
        }
    };
    let outputs = std::mem::take(&mut file.outputs)
        .into_iter()
        .map(|o| {
            output_problem(&o, d).map_or(Ok(()), |what| Err(bad(what)))?;
            Ok(AxisModel {
                axis: o.axis,
                target_mean: o.target_mean,
                target_scale: o.target_scale,
                fit: o.fit,
                linear: o.linear,
                std_scale: o.std_scale,
                gp: Gp::try_from(o.gp).map_err(|source| ModelError::Stored {
                    path: path.into(),
                    axis: o.axis,
                    source,
                })?,
            })
        })
        .collect::<Result<_, ModelError>>()?;
    Ok(ModelFile {
        format: file.format,
        version: file.version,
        features: file.features,
        axes: file.axes,
        tare: file.tare,
        sensor: file.sensor,
        scaling: file.scaling,
        input: file.input,
        n_train: file.n_train,
        outputs,
        network: file.network,
        prior,
        selection: file.selection,
        calibration: file.calibration,
        trained_on: file.trained_on,
        adapt_choice: file.adapt_choice,
        electrode,
    })
}

/// What disagrees among a model file's features, inputs (`d` of them),
/// tare, sensor, axes and network mean; None when nothing does.
fn shape_problem(file: &ModelFile<GpData>, d: usize) -> Option<String> {
    if file.input.dim() != d
        || file.input.scale.len() != d
        || file.tare.mean_baseline.len() != file.features.len()
    {
        return Some(format!(
            "{} features ({d} inputs, {:?}), but {} input means, {} input scales and {} tare baselines",
            file.features.len(),
            file.scaling,
            file.input.dim(),
            file.input.scale.len(),
            file.tare.mean_baseline.len()
        ));
    }
    if let SensorSpec::Nail(spec) = &file.sensor {
        if let Err(e) = spec.check(file.features.len()) {
            return Some(e.to_string());
        }
    }
    let axes: Vec<Axis> = file.outputs.iter().map(|o| o.axis).collect();
    if axes != file.axes.axes() {
        return Some(format!("axes {} but outputs for {axes:?}", file.axes));
    }
    let net = file.network.as_ref();
    net.filter(|net| net.n_inputs() != d || net.n_outputs() != file.axes.len())
        .map(|net| {
            format!(
                "a network mean of {} inputs and {} outputs, but {d} inputs and {} axes",
                net.n_inputs(),
                net.n_outputs(),
                file.axes.len()
            )
        })
}

/// What is wrong with one axis's stored model of `d` inputs; None when
/// nothing is (its GP's own data are checked as it is built).
fn output_problem(o: &AxisModel<GpData>, d: usize) -> Option<String> {
    if o.gp.dim() != d {
        return Some(format!(
            "axis {}: GP of dimension {}, expected {d}",
            o.axis,
            o.gp.dim()
        ));
    }
    let positive = |v: f64| v > 0.0 && v.is_finite();
    if !(positive(o.target_scale) && positive(o.std_scale) && o.target_mean.is_finite()) {
        return Some(format!(
            "axis {}: target scale {} / mean {} / std scale {}",
            o.axis, o.target_scale, o.target_mean, o.std_scale
        ));
    }
    let l = o.linear.as_ref().filter(|l| !l.is_valid(d))?;
    Some(format!(
        "axis {}: linear mean of {} weights (expected {d}, all finite), intercept {}{}",
        o.axis,
        l.weights.len(),
        l.bias,
        l.bend.as_ref().map_or(String::new(), |b| format!(
            ", bend of {} lines (1 to 6, each of {d} weights) with scales {:?} (> 0), \
             ranges {:?} (ordered) and {} weights (one per term), all finite",
            b.along.len(),
            b.scale,
            b.range,
            b.coeffs.len()
        ))
    ))
}
