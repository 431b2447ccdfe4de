//! The wrench estimator: one GP per axis (exact, or sparse with inducing
//! points) on standardised, tared electrode features, and its versioned model
//! file.
//!
//! The model file is JSON: `format`, `version`, the feature names, the axes,
//! the input standardisation, how the data was tared, and per axis the target
//! standardisation, the GP's prior mean when it has one (`linear`: weights,
//! intercept and, for a cubic mean, its `bend`) and the GP (`{"exact": ..}`:
//! hyperparameters and training data; `{"sparse": ..}`: hyperparameters,
//! inducing inputs and their posterior). The factorisations are recomputed on load, which also
//! re-checks the file's numbers.

use std::path::Path;

use ndarray::{Array2, ArrayView2};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::sync::Mutex;

use super::calibration::CalibrationRecord;
use super::choice::Selection;
use super::dataset::Dataset;
use super::gp::fit::FitProgress;
use super::gp::{FitInfo, Gp, GpData, GpError, GpWorkspace, LinearMean, ValidGpParams};
use super::scale::{InputScaling, Standardizer};
use crate::biotac::reading::Column;
use crate::sensor::{ModelInput, SensorSpec};
use crate::wrench::{Axis, AxisSet};

/// The `format` field of every model file.
pub const MODEL_FORMAT: &str = "tactile_force/wrench_gp";
/// The model-file version this build writes (2: the GP of an axis is tagged
/// exact or sparse; 3: an adapted model holds the model it was adapted
/// from; 4: an axis may have a linear prior mean; 5: that mean may bend;
/// 6: how its options were selected on the data, `train --select`, and the
/// calibration on the robot that made it).
/// It reads versions 2 to 6.
pub const MODEL_VERSION: u32 = 6;

/// Errors saving, loading or using a model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// File path.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The file could not be written.
    #[error("{path}: cannot write: {source}")]
    Write {
        /// File path.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// Not JSON: truncated or corrupt.
    #[error("{path}: not a model file (truncated or corrupt JSON: {source})")]
    Corrupt {
        /// File path.
        path: String,
        /// Parser error, with line and column.
        source: serde_json::Error,
    },
    /// JSON, but not a tactile_force wrench model.
    #[error("{path}: format is {found:?}, expected {MODEL_FORMAT:?}")]
    WrongFormat {
        /// File path.
        path: String,
        /// The `format` field found.
        found: String,
    },
    /// A model-file version this build cannot read.
    #[error("{path}: model file version {found}, this build reads versions 2 to {MODEL_VERSION}")]
    UnsupportedVersion {
        /// File path.
        path: String,
        /// Version found.
        found: u64,
    },
    /// The right format and version, but fields missing or of the wrong type.
    #[error("{path}: invalid model file: {source}")]
    Schema {
        /// File path.
        path: String,
        /// Parser error naming the field.
        source: serde_json::Error,
    },
    /// Parts of the file disagree (feature counts, axes, sizes).
    #[error("{path}: inconsistent model file: {what}")]
    Inconsistent {
        /// File path.
        path: String,
        /// What disagrees, with the numbers.
        what: String,
    },
    /// Features given to the model do not match the ones it was trained on.
    #[error("model expects {expected} features, got {found}")]
    FeatureCount {
        /// Features the model uses.
        expected: usize,
        /// Features given.
        found: usize,
    },
    /// Adaptation data whose features or axes are not the base model's.
    #[error("cannot adapt: the base model has features {base:?}, the data {data:?}")]
    AdaptMismatch {
        /// The base model's features and axes.
        base: String,
        /// The data's.
        data: String,
    },
    /// Training or rebuilding a GP failed.
    #[error(transparent)]
    Gp(#[from] GpError),
}

/// How the training features were tared.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TareSpec {
    /// Out-of-contact samples at the start of each trial that gave its baseline.
    pub samples: usize,
    /// Baseline of each feature, averaged over the training trials (counts).
    pub mean_baseline: Vec<f64>,
}

/// Estimate of one wrench component: mean and 1-sigma of the latent force.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Estimate {
    /// Posterior mean (N or Nm).
    pub mean: f64,
    /// Posterior standard deviation of the mean (N or Nm).
    pub std: f64,
}

/// One output axis: the target's linear mean when it has one (in target
/// units), and the GP (fitted, or as stored) of what is left, standardised
/// by `target_mean` and `target_scale`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct AxisModel<G> {
    axis: Axis,
    target_mean: f64,
    target_scale: f64,
    fit: FitInfo,
    /// A linear prior mean (absent: zero).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    linear: Option<LinearMean>,
    gp: G,
}

/// Where an adapted model came from (`adapt`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdaptedFrom {
    /// The base model file, as given.
    pub model: String,
    /// The recordings it was adapted with, as given.
    pub data: Vec<String>,
    /// Seconds of adaptation data (rows times the sensor's sample period).
    pub seconds: f64,
}

/// An adapted model's base: its estimate is the prior mean of the GPs.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Prior<G> {
    from: AdaptedFrom,
    base: Box<ModelFile<G>>,
}

/// The model file; `G` is [`Gp`] once checked, [`GpData`] as parsed.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelFile<G> {
    format: String,
    version: u32,
    features: Vec<String>,
    axes: AxisSet,
    tare: TareSpec,
    /// The sensor the features come from (absent in files before it: BioTac).
    #[serde(default)]
    sensor: SensorSpec,
    /// How the tared features are presented (absent in files before it: standard).
    #[serde(default)]
    scaling: InputScaling,
    input: Standardizer,
    n_train: usize,
    outputs: Vec<AxisModel<G>>,
    #[serde(default = "no_prior", skip_serializing_if = "Option::is_none")]
    prior: Option<Prior<G>>,
    /// How its options were chosen (`train --select`), with the CV table.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    selection: Option<Selection>,
    /// The calibration on the robot that made it, with its validation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    calibration: Option<CalibrationRecord>,
    /// Which features are electrodes (for the pattern), from their names.
    #[serde(skip)]
    electrode: Vec<bool>,
}

/// Which of `features` are electrodes.
fn electrode_mask(features: &[String]) -> Vec<bool> {
    let is_electrode = |f: &String| matches!(Column::from_name(f), Some(Column::Electrode(_)));
    features.iter().map(is_electrode).collect()
}

fn no_prior<G>() -> Option<Prior<G>> {
    None
}

impl ModelFile<Gp> {
    fn workspace(&self) -> EstimatorWorkspace {
        let largest = self.outputs.iter().max_by_key(|o| o.gp.size());
        EstimatorWorkspace {
            represented: vec![0.0; self.input.dim()],
            z: vec![0.0; self.input.dim()],
            gp: largest.map_or_else(|| GpWorkspace::new(0, 0), |o| o.gp.workspace()),
            prior: self.prior.as_ref().map(|p| {
                Box::new((
                    p.base.workspace(),
                    vec![Estimate::default(); p.base.outputs.len()],
                ))
            }),
        }
    }

    /// [`WrenchGp::predict_one`] once the feature count is checked.
    fn predict_one(
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
        // The prior mean: the base's estimate (same features and axes, checked
        // on load), into scratch allocated with the workspace.
        if let (Some(p), Some((pws, pout))) = (&self.prior, ws.prior.as_deref_mut()) {
            p.base.predict_one(features, pws, false, pout);
            for (e, b) in out.iter_mut().zip(pout.iter()) {
                e.mean += b.mean;
            }
        }
    }

    /// [`WrenchGp::predict`] once the feature count is checked.
    fn predict(&self, x: ArrayView2<f64>, with_std: bool) -> (Array2<f64>, Array2<f64>) {
        let represented = self.scaling.represent(&self.electrode, x);
        let z: Vec<f64> = self
            .input
            .transform(represented.view())
            .iter()
            .copied()
            .collect();
        let (n, k) = (x.nrows(), self.outputs.len());
        let mut mean = Array2::zeros((n, k));
        let mut std = Array2::zeros((n, k));
        for (j, o) in self.outputs.iter().enumerate() {
            let (m, v) = o.gp.predict(&z, with_std);
            let prior = o.linear.as_ref().map(|l| l.at_rows(&z));
            for i in 0..n {
                mean[[i, j]] =
                    m[i] * o.target_scale + o.target_mean + prior.as_ref().map_or(0.0, |p| p[i]);
                std[[i, j]] = v[i].sqrt() * o.target_scale;
            }
        }
        if let Some(p) = &self.prior {
            mean += &p.base.predict(x, false).0;
        }
        (mean, std)
    }
}

/// A trained wrench estimator.
#[derive(Debug, Clone, Serialize)]
#[serde(transparent)]
pub struct WrenchGp(ModelFile<Gp>);

/// Scratch for [`WrenchGp::predict_one`], allocated once per estimator.
#[derive(Debug, Clone)]
pub struct EstimatorWorkspace {
    represented: Vec<f64>,
    z: Vec<f64>,
    gp: GpWorkspace,
    prior: Option<Box<(EstimatorWorkspace, Vec<Estimate>)>>,
}

impl WrenchGp {
    /// Trains one GP per axis of `data` (features already tared, presented
    /// standardised), the axes in parallel. `progress` is told the axis and
    /// the fit's progress after every evaluation.
    pub fn train(
        data: &Dataset,
        tare: TareSpec,
        params: &ValidGpParams,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Self, ModelError> {
        Self::train_scaled(data, tare, InputScaling::Standard, params, progress)
    }

    /// [`WrenchGp::train`] with the features presented as `scaling` says.
    pub fn train_scaled(
        data: &Dataset,
        tare: TareSpec,
        scaling: InputScaling,
        params: &ValidGpParams,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Self, ModelError> {
        // Check before standardising: one infinity would spoil every row.
        let d = data.features.len();
        for (name, m) in [("features", &data.x), ("targets", &data.y)] {
            if let Some(i) = m.iter().position(|v| !v.is_finite()) {
                let cols = m.ncols();
                return Err(GpError::NonFinite {
                    row: i / cols,
                    column: if name == "features" {
                        i % cols
                    } else {
                        d + i % cols
                    },
                }
                .into());
            }
        }
        let electrode = electrode_mask(&data.features);
        let represented = scaling.represent(&electrode, data.x.view());
        let input = scaling.fit(represented.view());
        let z = input.transform(represented.view());
        let x: Vec<f64> = z.iter().copied().collect();
        let d = input.dim();
        let means = params.get().mean.fit(&x, d, data.y.view())?;
        let progress = Mutex::new(progress);
        let outputs = data
            .axes
            .axes()
            .par_iter()
            .enumerate()
            .map(|(j, &axis)| {
                // What the GP models: the target less its prior mean,
                // standardised (so that the fit's starts and bounds hold).
                let mut y = data.y.column(j).to_owned();
                let linear = means[j].clone();
                if let Some(l) = &linear {
                    y.iter_mut().zip(l.at_rows(&x)).for_each(|(y, p)| *y -= p);
                }
                let targets = Standardizer::fit(y.view().insert_axis(ndarray::Axis(1)));
                let (m, s) = (targets.mean[0], targets.scale[0]);
                let y: Vec<f64> = y.iter().map(|v| (v - m) / s).collect();
                let mut report = |p| {
                    if let Ok(mut f) = progress.lock() {
                        f(axis, p)
                    }
                };
                let (gp, fit) = Gp::fit(&x, d, &y, params, &mut report)?;
                Ok(AxisModel {
                    axis,
                    target_mean: m,
                    target_scale: s,
                    fit,
                    linear,
                    gp,
                })
            })
            .collect::<Result<Vec<_>, GpError>>()?;
        Ok(WrenchGp(ModelFile {
            format: MODEL_FORMAT.into(),
            version: MODEL_VERSION,
            features: data.features.clone(),
            axes: data.axes.clone(),
            tare,
            sensor: SensorSpec::Biotac,
            scaling,
            input,
            n_train: data.len(),
            outputs,
            prior: None,
            selection: None,
            calibration: None,
            electrode,
        }))
    }

    /// Adapts `self` to another sensor unit, session or person from a short
    /// recording `data` (features tared as `tare` says): GPs on what the
    /// recording's reference differs from this model's estimate, with this
    /// model's estimate as their prior mean. Where the recording says
    /// nothing new, the adapted model estimates as this one does.
    pub fn adapt(
        &self,
        data: &Dataset,
        tare: TareSpec,
        from: AdaptedFrom,
        params: &ValidGpParams,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Self, ModelError> {
        if data.features != self.0.features || data.axes != self.0.axes {
            return Err(ModelError::AdaptMismatch {
                base: format!("{:?}, axes {}", self.0.features, self.0.axes),
                data: format!("{:?}, axes {}", data.features, data.axes),
            });
        }
        let (base_mean, _) = self.predict(data.x.view(), false)?;
        let residual = Dataset {
            y: &data.y - &base_mean,
            ..data.clone()
        };
        let mut adapted = Self::train_scaled(&residual, tare, self.0.scaling, params, progress)?;
        adapted.0.sensor = self.0.sensor.clone();
        adapted.0.prior = Some(Prior {
            from,
            base: Box::new(self.0.clone()),
        });
        Ok(adapted)
    }

    /// The model, recording how its options were chosen.
    pub fn with_selection(mut self, selection: Selection) -> Self {
        self.0.selection = Some(selection);
        self
    }

    /// The model, recording the calibration that made it.
    pub fn with_calibration(mut self, record: CalibrationRecord) -> Self {
        self.0.calibration = Some(record);
        self
    }

    /// The calibration that made it, when one did.
    pub fn calibration(&self) -> Option<&CalibrationRecord> {
        self.0.calibration.as_ref()
    }

    /// How its options were chosen, when `train --select` chose them.
    pub fn selection(&self) -> Option<&Selection> {
        self.0.selection.as_ref()
    }

    /// What the model was adapted from, when it was (`adapt`).
    pub fn adapted_from(&self) -> Option<&AdaptedFrom> {
        self.0.prior.as_ref().map(|p| &p.from)
    }

    /// Feature names, in input order.
    pub fn features(&self) -> &[String] {
        &self.0.features
    }

    /// Estimated axes, in output order.
    pub fn axes(&self) -> &AxisSet {
        &self.0.axes
    }

    /// How the training data was tared.
    pub fn tare(&self) -> &TareSpec {
        &self.0.tare
    }

    /// The sensor the model reads.
    pub fn sensor(&self) -> &SensorSpec {
        &self.0.sensor
    }

    /// The model, recording that its features come from `sensor` (`train`
    /// on nail frames records their preprocessing).
    pub fn with_sensor(mut self, sensor: SensorSpec) -> Self {
        self.0.sensor = sensor;
        self
    }

    /// What the model says of its input, for the sensor that feeds it.
    pub fn input(&self) -> ModelInput<'_> {
        ModelInput {
            features: &self.0.features,
            sensor: &self.0.sensor,
            tare_samples: self.0.tare.samples,
        }
    }

    /// Rows the model was trained on (an exact GP keeps a subset of them,
    /// see [`Gp::size`]).
    pub fn n_train(&self) -> usize {
        self.0.n_train
    }

    /// Per axis: the fitted GP and what its fit did.
    pub fn fits(&self) -> impl Iterator<Item = (Axis, &Gp, &FitInfo)> {
        self.0.outputs.iter().map(|o| (o.axis, &o.gp, &o.fit))
    }

    /// Scratch for [`WrenchGp::predict_one`].
    pub fn workspace(&self) -> EstimatorWorkspace {
        self.0.workspace()
    }

    /// Estimates every axis from one row of tared features, without
    /// allocating. `with_std = false` skips the variance (std = 0), which
    /// costs O(n^2) per axis for the exact GP and O(m^2) for the sparse one.
    /// An adapted model's std is that of its own GPs: how far the row is
    /// from what the adaptation recording covered.
    pub fn predict_one(
        &self,
        features: &[f64],
        ws: &mut EstimatorWorkspace,
        with_std: bool,
        out: &mut [Estimate],
    ) -> Result<(), ModelError> {
        if features.len() != self.0.features.len() {
            return Err(ModelError::FeatureCount {
                expected: self.0.features.len(),
                found: features.len(),
            });
        }
        self.0.predict_one(features, ws, with_std, out);
        Ok(())
    }

    /// Means and standard deviations (samples x axes) for rows of tared features.
    pub fn predict(
        &self,
        x: ArrayView2<f64>,
        with_std: bool,
    ) -> Result<(Array2<f64>, Array2<f64>), ModelError> {
        if x.ncols() != self.0.features.len() {
            return Err(ModelError::FeatureCount {
                expected: self.0.features.len(),
                found: x.ncols(),
            });
        }
        Ok(self.0.predict(x, with_std))
    }

    /// Writes the model file.
    pub fn save(&self, path: &Path) -> Result<(), ModelError> {
        let io = |source| ModelError::Write {
            path: path.display().to_string(),
            source,
        };
        let json = serde_json::to_vec(self).map_err(|e| io(e.into()))?;
        std::fs::write(path, json).map_err(io)
    }

    /// Reads and validates a model file.
    pub fn load(path: &Path) -> Result<Self, ModelError> {
        let p = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| ModelError::Io {
            path: p.clone(),
            source,
        })?;
        let value: serde_json::Value =
            serde_json::from_slice(&bytes).map_err(|source| ModelError::Corrupt {
                path: p.clone(),
                source,
            })?;
        let format = value.get("format").and_then(|f| f.as_str()).unwrap_or("");
        if format != MODEL_FORMAT {
            return Err(ModelError::WrongFormat {
                path: p,
                found: format.into(),
            });
        }
        let version = value.get("version").and_then(|v| v.as_u64()).unwrap_or(0);
        if !(2..=u64::from(MODEL_VERSION)).contains(&version) {
            return Err(ModelError::UnsupportedVersion {
                path: p,
                found: version,
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
    let bad = |what: String| {
        Err(ModelError::Inconsistent {
            path: path.into(),
            what,
        })
    };
    let electrode = electrode_mask(&file.features);
    let d = file.scaling.dim(&electrode);
    if file.input.dim() != d
        || file.input.scale.len() != d
        || file.tare.mean_baseline.len() != file.features.len()
    {
        return bad(format!(
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
            return bad(e.to_string());
        }
    }
    let axes: Vec<Axis> = file.outputs.iter().map(|o| o.axis).collect();
    if axes != file.axes.axes() {
        return bad(format!("axes {} but outputs for {axes:?}", file.axes));
    }
    let prior = match file.prior.take() {
        None => None,
        Some(Prior { from, base }) => {
            let base = checked(*base, path)?;
            if base.features != file.features
                || base.axes != file.axes
                || base.sensor != file.sensor
            {
                return bad(format!(
                    "adapted from a model of features {:?} and axes {}, but has {:?} and {}",
                    base.features, base.axes, file.features, file.axes
                ));
            }
            Some(Prior {
                from,
                base: Box::new(base),
            })
        }
    };
    let mut outputs = Vec::with_capacity(file.outputs.len());
    for o in std::mem::take(&mut file.outputs) {
        if o.gp.dim() != d {
            return bad(format!(
                "axis {}: GP of dimension {}, expected {d}",
                o.axis,
                o.gp.dim()
            ));
        }
        if !(o.target_scale > 0.0 && o.target_scale.is_finite() && o.target_mean.is_finite()) {
            return bad(format!(
                "axis {}: target scale {} / mean {}",
                o.axis, o.target_scale, o.target_mean
            ));
        }
        if let Some(l) = o.linear.as_ref().filter(|l| !l.is_valid(d)) {
            return bad(format!(
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
            ));
        }
        outputs.push(AxisModel {
            axis: o.axis,
            target_mean: o.target_mean,
            target_scale: o.target_scale,
            fit: o.fit,
            linear: o.linear,
            gp: Gp::try_from(o.gp)?,
        });
    }
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
        prior,
        selection: file.selection,
        calibration: file.calibration,
        electrode,
    })
}

/// The default settings with one restart (quick), for tests.
#[cfg(test)]
pub(crate) fn quick_params() -> ValidGpParams {
    super::gp::GpParams {
        restarts: 1,
        ..Default::default()
    }
    .validate()
    .expect("default GP parameters")
}

/// A model fitted with [`quick_params`], for tests.
#[cfg(test)]
pub(crate) fn quick_fit(data: &Dataset, tare: TareSpec) -> WrenchGp {
    WrenchGp::train(data, tare, &quick_params(), &mut |_, _| {}).expect("a small test model fits")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::gp::MeanKind;
    use ndarray::Array2;

    fn small_model_data() -> Dataset {
        let n = 40;
        let x = Array2::from_shape_fn((n, 3), |(i, j)| ((i * 7 + j * 3) % 11) as f64 - 5.0);
        let y = Array2::from_shape_fn((n, 2), |(i, j)| x[[i, 0]] * (j as f64 + 1.0) + x[[i, 1]]);
        Dataset {
            features: vec!["e1".into(), "e2".into(), "e3".into()],
            x,
            axes: "fx,fz".parse().unwrap(),
            y,
            set: vec![1; n],
            trial: vec![1; n],
            images: None,
        }
    }

    fn small_model() -> WrenchGp {
        let tare = TareSpec {
            samples: 5,
            mean_baseline: vec![1.0, 2.0, 3.0],
        };
        quick_fit(&small_model_data(), tare)
    }

    fn load_text(text: &str) -> Result<WrenchGp, ModelError> {
        let f = tempfile::NamedTempFile::new().unwrap();
        std::fs::write(f.path(), text).unwrap();
        WrenchGp::load(f.path())
    }

    #[test]
    fn saved_model_loads_and_predicts_the_same() {
        let model = small_model();
        let f = tempfile::NamedTempFile::new().unwrap();
        model.save(f.path()).unwrap();
        let back = WrenchGp::load(f.path()).unwrap();
        let (mut a, mut b) = ([Estimate::default(); 2], [Estimate::default(); 2]);
        let x = [0.5, -1.0, 2.0];
        model
            .predict_one(&x, &mut model.workspace(), true, &mut a)
            .unwrap();
        back.predict_one(&x, &mut back.workspace(), true, &mut b)
            .unwrap();
        assert_eq!(a, b);
        assert!(a.iter().all(|e| e.mean.is_finite() && e.std > 0.0));
        assert_eq!(back.tare().mean_baseline, vec![1.0, 2.0, 3.0]);
        let err = model.predict_one(&x[..2], &mut model.workspace(), true, &mut a);
        assert!(matches!(
            err,
            Err(ModelError::FeatureCount {
                expected: 3,
                found: 2
            })
        ));
    }

    #[test]
    fn an_adapted_model_adds_a_correction_to_its_base_and_loads_back() {
        let base = small_model();
        let mut data = Dataset {
            // Another unit: the base's targets plus an offset growing with e1.
            y: base.predict(small_model_data().x.view(), false).unwrap().0,
            ..small_model_data()
        };
        for (i, mut row) in data.y.rows_mut().into_iter().enumerate() {
            row += 0.5 * data.x[[i, 0]];
        }
        let from = AdaptedFrom {
            model: "base.json".into(),
            data: vec!["new.csv".into()],
            seconds: 0.4,
        };
        let tare = base.tare().clone();
        let adapted = base
            .adapt(
                &data,
                tare.clone(),
                from.clone(),
                &quick_params(),
                &mut |_, _| {},
            )
            .unwrap();
        assert_eq!(adapted.adapted_from(), Some(&from));
        let x = [2.0, -1.0, 1.0];
        let (mut b, mut a) = ([Estimate::default(); 2], [Estimate::default(); 2]);
        base.predict_one(&x, &mut base.workspace(), true, &mut b)
            .unwrap();
        adapted
            .predict_one(&x, &mut adapted.workspace(), true, &mut a)
            .unwrap();
        for (a, b) in a.iter().zip(&b) {
            assert!((a.mean - b.mean - 0.5 * x[0]).abs() < 0.1, "{a:?} {b:?}");
        }
        // The batch prediction agrees with the single one.
        let (batch, _) = adapted.predict(ndarray::aview2(&[x]), false).unwrap();
        assert!((batch[[0, 1]] - a[1].mean).abs() < 1e-9);
        let f = tempfile::NamedTempFile::new().unwrap();
        adapted.save(f.path()).unwrap();
        let back = WrenchGp::load(f.path()).unwrap();
        let mut c = [Estimate::default(); 2];
        back.predict_one(&x, &mut back.workspace(), true, &mut c)
            .unwrap();
        assert_eq!(a, c);
        assert_eq!(back.adapted_from(), Some(&from));

        let other = Dataset {
            features: vec!["e1".into(), "e2".into(), "pdc".into()],
            ..data
        };
        let err = base
            .adapt(&other, tare, from, &quick_params(), &mut |_, _| {})
            .unwrap_err();
        assert!(matches!(err, ModelError::AdaptMismatch { .. }), "{err}");
    }

    #[test]
    fn a_pattern_model_predicts_the_same_after_loading_and_checks_its_inputs() {
        let data = small_model_data();
        let tare = TareSpec {
            samples: 5,
            mean_baseline: vec![0.0; 3],
        };
        let model = WrenchGp::train_scaled(
            &data,
            tare,
            InputScaling::Pattern,
            &quick_params(),
            &mut |_, _| {},
        )
        .unwrap();
        // Three electrodes: the pattern and its magnitude, four inputs.
        assert!(model.fits().all(|(_, gp, _)| gp.dim() == 4));
        let f = tempfile::NamedTempFile::new().unwrap();
        model.save(f.path()).unwrap();
        let back = WrenchGp::load(f.path()).unwrap();
        let x = [3.0, -2.0, 1.0];
        let (mut a, mut b) = ([Estimate::default(); 2], [Estimate::default(); 2]);
        model
            .predict_one(&x, &mut model.workspace(), true, &mut a)
            .unwrap();
        back.predict_one(&x, &mut back.workspace(), true, &mut b)
            .unwrap();
        assert_eq!(a, b);
        let (batch, _) = back.predict(ndarray::aview2(&[x]), false).unwrap();
        assert!((batch[[0, 0]] - a[0].mean).abs() < 1e-9);
        // The same file said to be standardised: three features, four inputs.
        let json = std::fs::read_to_string(f.path()).unwrap();
        let err = load_text(&json.replace("\"scaling\":\"pattern\"", "\"scaling\":\"standard\""));
        let err = err.unwrap_err().to_string();
        assert!(
            err.contains("3 features (3 inputs, Standard), but 4 input means"),
            "{err}"
        );
    }

    /// A one-start model of `data` with the prior mean `mean`.
    fn train_with_mean(data: &Dataset, mean: MeanKind) -> WrenchGp {
        let params = super::super::gp::GpParams {
            restarts: 1,
            mean,
            ..Default::default()
        };
        let tare = TareSpec {
            samples: 5,
            mean_baseline: vec![0.0; 3],
        };
        WrenchGp::train(data, tare, &params.validate().unwrap(), &mut |_, _| {}).unwrap()
    }

    #[test]
    fn a_linear_mean_extrapolates_loads_back_and_is_checked() {
        // y = 2 x0 - x1 + 0.5 on inputs in [-5, 5], asked at x0 = 1000: the
        // line goes on (2010.5); without it the GP of what the line left (0)
        // says 0.
        let mut data = small_model_data();
        data.y = Array2::from_shape_fn((data.len(), 2), |(i, _)| {
            2.0 * data.x[[i, 0]] - data.x[[i, 1]] + 0.5
        });
        let model = train_with_mean(&data, MeanKind::Linear);
        let far = ndarray::aview2(&[[1000.0, -10.0, 0.0]]);
        let at = |m: &WrenchGp| m.predict(far, false).unwrap().0[[0, 0]];
        assert!((at(&model) - 2010.5).abs() < 1e-3, "{}", at(&model));
        let f = tempfile::NamedTempFile::new().unwrap();
        model.save(f.path()).unwrap();
        assert_eq!(at(&WrenchGp::load(f.path()).unwrap()), at(&model));
        let mut value: serde_json::Value =
            serde_json::from_slice(&std::fs::read(f.path()).unwrap()).unwrap();
        for o in value["outputs"].as_array_mut().unwrap() {
            o.as_object_mut().unwrap().remove("linear");
        }
        let without = load_text(&value.to_string()).unwrap();
        assert!(at(&without).abs() < 1.0, "{}", at(&without));
        let json = std::fs::read_to_string(f.path()).unwrap();
        let err = load_text(&json.replacen("\"weights\":[", "\"weights\":[1.0,", 1));
        let err = err.unwrap_err().to_string();
        assert!(
            err.contains("linear mean of 4 weights (expected 3"),
            "{err}"
        );
    }

    #[test]
    fn a_cubic_mean_round_trips_and_a_bad_bend_is_refused() {
        // y = x0 + 0.3 x0^3 - x1: the bent mean carries it, the file keeps it.
        let mut data = small_model_data();
        data.y = Array2::from_shape_fn((data.len(), 2), |(i, _)| {
            let (a, b) = (data.x[[i, 0]], data.x[[i, 1]]);
            a + 0.3 * a.powi(3) - b
        });
        let model = train_with_mean(&data, MeanKind::Cubic);
        let fitted = model.predict(data.x.view(), false).unwrap().0;
        let worst = (&fitted - &data.y)
            .iter()
            .fold(0.0f64, |m, e| m.max(e.abs()));
        assert!(worst < 0.05, "{worst}");
        let row = data.x.slice(ndarray::s![3..4, ..]);
        let at = |m: &WrenchGp| m.predict(row, false).unwrap().0[[0, 0]];
        let f = tempfile::NamedTempFile::new().unwrap();
        model.save(f.path()).unwrap();
        assert_eq!(at(&WrenchGp::load(f.path()).unwrap()), at(&model));
        let json = std::fs::read_to_string(f.path()).unwrap();
        assert!(json.contains("\"bend\":{\"along\":["), "{json}");
        let bend = json.find("\"bend\"").unwrap();
        let broken = format!(
            "{}{}",
            &json[..bend],
            json[bend..].replacen("\"scale\":[", "\"scale\":[-", 1)
        );
        let err = load_text(&broken);
        let err = err.unwrap_err().to_string();
        assert!(
            err.contains("bend of 2 lines") && err.contains("scales [-"),
            "{err}"
        );
    }

    #[test]
    fn broken_model_files_give_clear_errors() {
        let json = serde_json::to_string(&small_model()).unwrap();
        let err = load_text(&json[..json.len() / 2]).unwrap_err();
        assert!(matches!(err, ModelError::Corrupt { .. }), "{err}");
        assert!(err.to_string().contains("truncated or corrupt"));

        let err = load_text("{\"format\": \"something else\"}").unwrap_err();
        assert!(matches!(err, ModelError::WrongFormat { .. }), "{err}");

        let v1 = json.replace(&format!("\"version\":{MODEL_VERSION}"), "\"version\":1");
        let err = load_text(&v1).unwrap_err();
        assert!(
            matches!(err, ModelError::UnsupportedVersion { found: 1, .. }),
            "{err}"
        );

        let four = json.replace("[\"e1\",\"e2\",\"e3\"]", "[\"e1\",\"e2\",\"e3\",\"e4\"]");
        let err = load_text(&four).unwrap_err();
        assert!(matches!(err, ModelError::Inconsistent { .. }), "{err}");
        assert!(err.to_string().contains("4 features"), "{err}");

        let missing = json.replace("\"n_train\":40,", "");
        let err = load_text(&missing).unwrap_err();
        assert!(err.to_string().contains("n_train"), "{err}");

        let nan_hyper = json.replacen("\"signal_var\":", "\"signal_var\":-", 1);
        let err = load_text(&nan_hyper).unwrap_err();
        assert!(
            matches!(err, ModelError::Gp(GpError::InvalidHyper { .. })),
            "{err}"
        );
    }
}
