//! The wrench GP as a [`WrenchModel`]: what the estimator runs, and what
//! evaluations fit through its family.

use ndarray::ArrayView2;

use super::{AdaptChoice, CalibrationRecord, Estimate, Making, ModelError, Selection, WrenchGp};
use crate::learn::models::wrench_model::{Workspace, WrenchModel};
use crate::learn::models::Prediction;
use crate::sensor::ModelInput;
use crate::wrench::AxisSet;

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
