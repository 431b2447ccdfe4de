//! The wrench GP behind the shared interfaces: a [`Learner`] for
//! evaluations, and a [`WrenchModel`] for the estimator.

use ndarray::ArrayView2;

use super::{
    AdaptChoice, CalibrationRecord, Estimate, EstimatorWorkspace, Making, ModelError, Selection,
    TareSpec, WrenchGp,
};
use crate::learn::data::Dataset;
use crate::learn::models::gp::{FitProgress, GpParams, MeanKind};
use crate::learn::models::scale::InputScaling;
use crate::learn::models::wrench_model::{Workspace, WrenchModel};
use crate::learn::models::{Fitted, LearnError, Learner, Prediction};
use crate::params::Checked;
use crate::sensor::ModelInput;
use crate::wrench::{Axis, AxisSet};

/// A GP per axis with these options, its inputs presented as `scaling`
/// says and tared as `tare` says.
#[derive(Debug, Clone)]
pub struct GpLearner {
    /// The GP options.
    pub params: Checked<GpParams>,
    /// How the tared features reach the GP.
    pub scaling: InputScaling,
    /// How the training data were tared (recorded in the model).
    pub tare: TareSpec,
}

impl Learner for GpLearner {
    fn name(&self) -> &'static str {
        "gp"
    }

    fn every_row(&self) -> bool {
        self.params.mean != MeanKind::Zero
    }

    fn fit(
        &self,
        train: &Dataset,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Box<dyn Fitted>, LearnError> {
        let tare = self.tare.clone();
        let model = WrenchGp::train_scaled(train, tare, self.scaling, &self.params, progress)
            .map_err(|e| LearnError::new("gp", e))?;
        Ok(Box::new(FittedGp::from(model)))
    }
}

/// A trained wrench GP with scratch for single rows.
struct FittedGp {
    model: WrenchGp,
    ws: EstimatorWorkspace,
    out: Vec<Estimate>,
}

impl From<WrenchGp> for FittedGp {
    fn from(model: WrenchGp) -> Self {
        FittedGp {
            ws: model.workspace(),
            out: vec![Estimate::default(); model.axes().len()],
            model,
        }
    }
}

impl Fitted for FittedGp {
    fn predict(&self, data: &Dataset, with_std: bool) -> Result<Prediction, LearnError> {
        (self.model.predict_observed(data.x.view(), with_std)).map_err(|e| LearnError::new("gp", e))
    }

    fn predict_row(&mut self, features: &[f64], with_std: bool) -> Result<(), LearnError> {
        (self
            .model
            .predict_one(features, &mut self.ws, with_std, &mut self.out))
        .map_err(|e| LearnError::new("gp", e))
    }

    fn has_std(&self) -> bool {
        true
    }
}

impl WrenchModel for WrenchGp {
    fn family(&self) -> &'static str {
        "gp"
    }

    fn describe(&self) -> String {
        let gps: Vec<String> = self
            .fits()
            .map(|(a, gp, _)| format!("{a}: {}", gp.describe()))
            .collect();
        format!(
            "GP per axis ({}; prior mean {}; {} training samples), axes {}",
            gps.join(", "),
            self.prior_mean(),
            self.n_train(),
            self.axes()
        )
    }

    fn input(&self) -> ModelInput<'_> {
        self.input()
    }

    fn axes(&self) -> &AxisSet {
        self.axes()
    }

    fn n_train(&self) -> usize {
        self.n_train()
    }

    fn workspace(&self) -> Workspace {
        Workspace::new(self.workspace())
    }

    fn estimate(
        &self,
        features: &[f64],
        ws: &mut Workspace,
        with_std: bool,
        out: &mut [Estimate],
    ) -> Result<(), ModelError> {
        self.predict_one(features, ws.scratch()?, with_std, out)
    }

    fn std_scales(&self) -> Vec<f64> {
        self.std_scales()
    }

    fn predicted_estimate_us(&self) -> f64 {
        self.predicted_estimate_us()
    }

    fn save(&self, path: &std::path::Path) -> Result<(), ModelError> {
        self.save(path)
    }

    fn record(&mut self, making: Making) {
        self.record(making)
    }

    fn predict_observed(
        &self,
        x: ArrayView2<f64>,
        with_std: bool,
    ) -> Result<Prediction, ModelError> {
        self.predict_observed(x, with_std)
    }

    fn selection(&self) -> Option<&Selection> {
        self.selection()
    }

    fn adapt_choice(&self) -> Option<&AdaptChoice> {
        self.adapt_choice()
    }

    fn calibration(&self) -> Option<&CalibrationRecord> {
        self.calibration()
    }
}
