//! The ensemble behind the shared interfaces: a [`Learner`] for
//! evaluations, and a [`WrenchModel`] for the estimator.

use ndarray::ArrayView2;

use super::WrenchEnsemble;
use crate::learn::data::Dataset;
use crate::learn::models::estimate_cost::ENSEMBLE_US;
use crate::learn::models::gp::FitProgress;
use crate::learn::models::nn::NnParams;
use crate::learn::models::provenance::Making;
use crate::learn::models::wrench_model::ModelError;
use crate::learn::models::wrench_model::{Estimate, TareSpec, Workspace, WrenchModel};
use crate::learn::models::{Fitted, LearnError, Learner, Prediction};
use crate::params::Checked;
use crate::sensor::ModelInput;
use crate::wrench::{Axis, AxisSet};

/// An ensemble of `members` networks with these options.
#[derive(Debug, Clone)]
pub struct EnsembleLearner {
    /// Each network's options (its seed: the first network's).
    pub params: Checked<NnParams>,
    /// Networks in the ensemble.
    pub members: usize,
    /// How the training data were tared (recorded in the model).
    pub tare: TareSpec,
}

impl Learner for EnsembleLearner {
    fn name(&self) -> &'static str {
        "ensemble"
    }

    fn fit(
        &self,
        train: &Dataset,
        _: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Box<dyn Fitted>, LearnError> {
        let model = WrenchEnsemble::train(train, self.tare.clone(), &self.params, self.members)
            .map_err(|e| LearnError::new("ensemble", e))?;
        let out = vec![Estimate::default(); model.file.axes.len()];
        let ws = model.workspace();
        Ok(Box::new(FittedEnsemble { model, ws, out }))
    }
}

/// A trained ensemble with scratch for one row.
struct FittedEnsemble {
    model: WrenchEnsemble,
    ws: Workspace,
    out: Vec<Estimate>,
}

impl Fitted for FittedEnsemble {
    fn predict(&self, data: &Dataset, with_std: bool) -> Result<Prediction, LearnError> {
        (self.model.predict_observed(data.x.view(), with_std))
            .map_err(|e| LearnError::new("ensemble", e))
    }

    fn predict_row(&mut self, features: &[f64], with_std: bool) -> Result<(), LearnError> {
        (self
            .model
            .estimate(features, &mut self.ws, with_std, &mut self.out))
        .map_err(|e| LearnError::new("ensemble", e))
    }

    fn has_std(&self) -> bool {
        true
    }
}

impl WrenchModel for WrenchEnsemble {
    fn family(&self) -> &'static str {
        "ensemble"
    }

    fn describe(&self) -> String {
        let f = &self.file;
        let net = &f.members[0];
        format!(
            "ensemble of {} networks ({}-{}-{}; {} training samples), axes {}",
            f.members.len(),
            net.n_inputs(),
            net.n_hidden(),
            net.n_outputs(),
            f.n_train,
            f.axes
        )
    }

    fn input(&self) -> ModelInput<'_> {
        ModelInput {
            features: &self.file.features,
            sensor: &self.file.sensor,
            tare_samples: self.file.tare.samples,
        }
    }

    fn axes(&self) -> &AxisSet {
        &self.file.axes
    }

    fn n_train(&self) -> usize {
        self.file.n_train
    }

    /// Room for each network's estimate of a row.
    fn workspace(&self) -> Workspace {
        Workspace::new(vec![0.0; self.file.members.len() * self.file.axes.len()])
    }

    /// The networks' spread costs nothing beyond their estimates: computed
    /// whatever `with_std` says.
    fn estimate(
        &self,
        features: &[f64],
        ws: &mut Workspace,
        _: bool,
        out: &mut [Estimate],
    ) -> Result<(), ModelError> {
        self.check_count(features.len())?;
        let each = ws.scratch::<Vec<f64>>()?;
        if each.len() != self.file.members.len() * self.file.axes.len() {
            return Err(ModelError::ForeignWorkspace);
        }
        self.estimate_row(features, each, out);
        Ok(())
    }

    fn std_scales(&self) -> Vec<f64> {
        self.file.std_scale.clone()
    }

    fn predicted_estimate_us(&self) -> f64 {
        ENSEMBLE_US
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
        self.check_count(x.ncols())?;
        Ok(self.observed(x, with_std))
    }

    fn selection(&self) -> Option<&crate::learn::models::provenance::Selection> {
        self.file.selection.as_ref()
    }

    fn adapt_choice(&self) -> Option<&crate::learn::models::provenance::AdaptChoice> {
        self.file.adapt_choice.as_ref()
    }

    fn calibration(&self) -> Option<&crate::learn::models::provenance::CalibrationRecord> {
        self.file.calibration.as_ref()
    }
}
