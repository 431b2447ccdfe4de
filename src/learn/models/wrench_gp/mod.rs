//! The wrench estimator: one GP per axis (exact, or sparse with inducing
//! points) on standardised, tared electrode features, and its versioned model
//! file (its format, saving and loading: `file.rs`), which records what made
//! the model in types of its own ([`super::provenance`]).

mod as_wrench_model;
mod axis_fits;
mod family;
mod file;
mod network;
mod observed;

use ndarray::{Array2, ArrayView2};
use serde::Serialize;

use super::estimate_cost::{exact_us, sparse_us, NETWORK_US};
use super::gp::fit::FitProgress;
use super::gp::{FitInfo, Gp, GpError, GpParams, GpWorkspace, MeanKind, SeHyper};
use super::scale::{InputScaling, Standardizer};
use crate::learn::data::Dataset;
use crate::params::Checked;
use crate::sensor::{ModelInput, SensorSpec};
use crate::wrench::{Axis, AxisSet};
use axis_fits::{floors, gp_targets, AxisFits};
use file::{electrode_mask, AxisModel, ModelFile, Prior};
use network::network_mean;

pub use super::family::WarmStart;
use super::provenance::set_scales;
pub use super::provenance::{
    AdaptChoice, AdaptedFrom, AloneScore, CalibrationRecord, Choice, CvRow, DataFile, GpChoice,
    Making, Selection, TrainedOn, Validation,
};
pub use super::wrench_model::{Estimate, ModelError, TareSpec};
pub use family::GpFamily;
pub use file::{MODEL_FORMAT, MODEL_VERSION};
pub use observed::{std_scale, std_scale_over_folds};

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
    network: Vec<f64>,
    prior: Option<Box<(EstimatorWorkspace, Vec<Estimate>)>>,
}

impl WrenchGp {
    /// Trains one GP per axis of `data` (features already tared, presented
    /// standardised), the axes in parallel. `progress` is told the axis and
    /// the fit's progress after every evaluation.
    pub fn train(
        data: &Dataset,
        tare: TareSpec,
        params: &Checked<GpParams>,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Self, ModelError> {
        Self::train_scaled(data, tare, InputScaling::Standard, params, progress)
    }

    /// [`WrenchGp::train`] with the features presented as `scaling` says.
    pub fn train_scaled(
        data: &Dataset,
        tare: TareSpec,
        scaling: InputScaling,
        params: &Checked<GpParams>,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Self, ModelError> {
        Self::train_from(data, tare, scaling, params, WarmStart::default(), progress)
    }

    /// [`WrenchGp::train_scaled`], started from what `warm` gives.
    pub fn train_from(
        data: &Dataset,
        tare: TareSpec,
        scaling: InputScaling,
        params: &Checked<GpParams>,
        warm: WarmStart,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Self, ModelError> {
        let (electrode, input, x) = standardised_inputs(data, scaling)?;
        let d = input.dim();
        let means = params.mean.fit(&x, d, data.y.view())?;
        let inputs = ArrayView2::from_shape((data.len(), d), &x).expect("n rows of d inputs");
        let network = match warm.network {
            Some(net) if params.mean == MeanKind::Network && net.n_inputs() == d => {
                Some(net.clone())
            }
            _ => network_mean(inputs, data.y.view(), params)?,
        };
        let mut residual = data.y.clone();
        if let Some(net) = &network {
            residual -= &net.predict(inputs);
        }
        let axes = data.axes.axes();
        let targets = gp_targets(&residual, &means, &x);
        let floors = floors(data, &targets, network.is_some(), params)?;
        let fits = AxisFits {
            x: &x,
            d,
            axes,
            targets: &targets,
            floors: &floors,
            warm: &warm,
        }
        .fit(params, progress)?;
        let outputs = fits
            .into_iter()
            .zip(targets)
            .zip(means)
            .zip(axes)
            .map(|((((gp, fit), (t, _)), linear), &axis)| AxisModel {
                axis,
                target_mean: t.mean[0],
                target_scale: t.scale[0],
                fit,
                linear,
                gp,
                std_scale: 1.0,
            })
            .collect();
        Ok(WrenchGp(ModelFile {
            format: MODEL_FORMAT.into(),
            version: MODEL_VERSION,
            features: data.features.clone(),
            axes: data.axes.clone(),
            tare,
            // A BioTac's or a BioTac SP's, as the features say; `train`
            // records the nail camera's with `with_sensor`.
            sensor: SensorSpec::biotac(crate::learn::data::layout_of(&data.features)),
            scaling,
            input,
            n_train: data.len(),
            outputs,
            network,
            prior: None,
            selection: None,
            calibration: None,
            trained_on: None,
            adapt_choice: None,
            electrode,
        }))
    }

    /// How its features are presented to its GPs.
    pub fn scaling(&self) -> InputScaling {
        self.0.scaling
    }

    /// The model, with `base`'s estimate as the prior mean of its GPs and
    /// `base`'s sensor: what [`WrenchGp::adapt`] makes.
    pub(crate) fn on_top_of(mut self, base: &WrenchGp, from: AdaptedFrom) -> Self {
        self.0.sensor = base.0.sensor.clone();
        self.0.prior = Some(Prior {
            from,
            base: Box::new(base.0.clone()),
        });
        self
    }

    /// The model, recording the data it was trained on (None: not known).
    pub fn with_trained_on(mut self, trained_on: Option<TrainedOn>) -> Self {
        self.0.trained_on = trained_on;
        self
    }

    /// Keeps `making` ([`WrenchModel::record`]).
    pub(crate) fn record(&mut self, making: Making) {
        let f = &mut self.0;
        match making {
            Making::StdScales(scales) => {
                set_scales(f.outputs.iter_mut().map(|o| &mut o.std_scale), &scales)
            }
            Making::TrainedOn(on) => f.trained_on = on,
            Making::Selection(s) => f.selection = Some(*s),
            Making::AdaptChoice(c) => f.adapt_choice = Some(*c),
            Making::Calibration(r) => f.calibration = Some(*r),
        }
    }

    /// The GPs' prior mean, for messages: `network`, `base model` (an
    /// adapted model), `cubic`, `linear` (on some axis) or `zero`.
    pub fn prior_mean(&self) -> &'static str {
        let f = &self.0;
        let linear = || f.outputs.iter().filter_map(|o| o.linear.as_ref());
        if f.network.is_some() {
            "network"
        } else if f.prior.is_some() {
            "base model"
        } else if linear().any(|l| l.bend.is_some()) {
            "cubic"
        } else if linear().next().is_some() {
            "linear"
        } else {
            "zero"
        }
    }

    /// The data it was trained on, by reference, when recorded.
    pub fn trained_on(&self) -> Option<&TrainedOn> {
        self.0.trained_on.as_ref()
    }

    /// What `adapt` chose, when `adapt` made it.
    pub fn adapt_choice(&self) -> Option<&AdaptChoice> {
        self.0.adapt_choice.as_ref()
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

    /// Per axis, in output order: the GP's hyperparameters (a warm start
    /// for [`WrenchGp::train_from`]).
    pub fn hypers(&self) -> Vec<SeHyper> {
        self.0
            .outputs
            .iter()
            .map(|o| o.gp.hyper().clone())
            .collect()
    }

    /// Per axis: the fitted GP and what its fit did.
    pub fn fits(&self) -> impl Iterator<Item = (Axis, &Gp, &FitInfo)> {
        self.0.outputs.iter().map(|o| (o.axis, &o.gp, &o.fit))
    }

    /// Scratch for [`WrenchGp::predict_one`].
    pub fn workspace(&self) -> EstimatorWorkspace {
        self.0.workspace()
    }

    /// [`WrenchGp::predict_one`]'s time with the standard deviation (µs)
    /// predicted from its GPs' kinds and sizes, its network mean and an
    /// adapted model's base ([`super::estimate_cost`]).
    pub fn predicted_estimate_us(&self) -> f64 {
        predicted_us(&self.0)
    }

    /// Estimates every axis from one row of tared features, without
    /// allocating. `with_std = false` skips the variance (std = 0), which
    /// costs O(m^2) per axis: the exact GP's m training rows near the input
    /// (at most 1000), the sparse GP's m inducing points.
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
        self.check_features(x)?;
        Ok(self.0.predict(x, with_std))
    }

    fn check_features(&self, x: ArrayView2<f64>) -> Result<(), ModelError> {
        if x.ncols() != self.0.features.len() {
            return Err(ModelError::FeatureCount {
                expected: self.0.features.len(),
                found: x.ncols(),
            });
        }
        Ok(())
    }
}

/// The data's electrode mask, the standardiser of its inputs as `scaling`
/// represents them, and the standardised inputs row after row; refused when
/// a feature or target is not finite (one would spoil every row).
fn standardised_inputs(
    data: &Dataset,
    scaling: InputScaling,
) -> Result<(Vec<bool>, Standardizer, Vec<f64>), ModelError> {
    let d = data.features.len();
    for (name, m) in [("features", &data.x), ("targets", &data.y)] {
        if let Some(i) = m.iter().position(|v| !v.is_finite()) {
            let cols = m.ncols();
            let column = if name == "features" {
                i % cols
            } else {
                d + i % cols
            };
            return Err(GpError::NonFinite {
                row: i / cols,
                column,
            }
            .into());
        }
    }
    let electrode = electrode_mask(&data.features);
    let represented = scaling.represent(&electrode, data.x.view());
    let input = scaling.fit(represented.view());
    let z = input.transform(represented.view());
    Ok((electrode, input, z.iter().copied().collect()))
}

/// [`WrenchGp::predicted_estimate_us`] of a model file.
fn predicted_us(file: &ModelFile<Gp>) -> f64 {
    let axis = |gp: &Gp| match gp {
        Gp::Exact(g) => exact_us(g.n_train(), g.dim()),
        Gp::Sparse(g) => sparse_us(g.n_inducing(), g.dim()),
    };
    let gps: f64 = file.outputs.iter().map(|o| axis(&o.gp)).sum();
    let network = file.network.as_ref().map_or(0.0, |_| NETWORK_US);
    gps + network + file.prior.as_ref().map_or(0.0, |p| predicted_us(&p.base))
}

#[cfg(test)]
pub(crate) fn quick_params() -> Checked<GpParams> {
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
mod tests;
