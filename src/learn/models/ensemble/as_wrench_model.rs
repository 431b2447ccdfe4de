//! The ensemble as a [`WrenchModel`]: what the estimator runs, and what
//! evaluations fit through its family.

use ndarray::ArrayView2;

use super::WrenchEnsemble;
use crate::learn::models::estimate_cost::ENSEMBLE_US;
use crate::learn::models::provenance::Making;
use crate::learn::models::wrench_model::ModelError;
use crate::learn::models::wrench_model::{Estimate, Workspace, WrenchModel};
use crate::learn::models::Prediction;
use crate::sensor::ModelInput;
use crate::wrench::AxisSet;

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
