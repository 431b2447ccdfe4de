//! The ensemble of networks as a model family ([`ModelFamily`]).

use std::path::Path;

use super::{WrenchEnsemble, ENSEMBLE_FORMAT};
use crate::learn::models::estimate_cost::ENSEMBLE_US;
use crate::learn::models::family::{Fit, Form, ModelFamily, Shape};
use crate::learn::models::provenance::{Choice, Cost};
use crate::learn::models::wrench_model::{ModelError, WrenchModel};

/// The baseline network, [`super::DEFAULT_MEMBERS`] of it seeded apart.
pub struct EnsembleFamily;

/// Seconds of one fold's ensemble in `train --select`, per 1000 rows,
/// measured on 2 idle cores (docs/results.md, "`train --select` within its
/// budget").
const ENSEMBLE_PER_1000_ROWS_S: f64 = 0.068;

impl ModelFamily for EnsembleFamily {
    fn name(&self) -> &'static str {
        "ensemble"
    }

    fn format(&self) -> &'static str {
        ENSEMBLE_FORMAT
    }

    fn load(
        &self,
        file: serde_json::Value,
        path: &Path,
    ) -> Result<Box<dyn WrenchModel>, ModelError> {
        Ok(Box::new(WrenchEnsemble::from_json(file, path)?))
    }

    /// Its networks standardise their inputs themselves: the GP's options
    /// but the seed do not apply; the networks' shape is the sensor's
    /// baseline.
    fn fit(&self, fit: Fit) -> Result<Box<dyn WrenchModel>, ModelError> {
        let model = WrenchEnsemble::train_default(fit.data, fit.tare, fit.sensor, fit.params.seed)?;
        Ok(Box::new(model))
    }

    fn form(&self, _: &Choice) -> Form {
        Form {
            name: "the ensemble",
            flexibility: 3,
            points: 0,
        }
    }

    fn cost(&self, _: &Choice, shape: &Shape) -> Cost {
        Cost {
            fit_s: shape.folds as f64 * ENSEMBLE_PER_1000_ROWS_S * shape.train_rows as f64 / 1000.0,
            estimate_us: ENSEMBLE_US,
        }
    }
}
