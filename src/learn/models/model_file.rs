//! A model file of any family, read by its `format`: the estimator node,
//! `demo --model` and `eval --model` take either.

use std::path::Path;

use super::ensemble::{WrenchEnsemble, ENSEMBLE_FORMAT};
use super::wrench_gp::{WrenchGp, MODEL_FORMAT};
use super::wrench_model::{read_json, ModelError, WrenchModel};

/// Reads and validates a model file of any family.
pub fn load(path: &Path) -> Result<Box<dyn WrenchModel>, ModelError> {
    let (value, format) = read_json(path)?;
    match format.as_str() {
        MODEL_FORMAT => Ok(Box::new(WrenchGp::from_json(value, path)?)),
        ENSEMBLE_FORMAT => Ok(Box::new(WrenchEnsemble::from_json(value, path)?)),
        _ => Err(ModelError::WrongFormat {
            path: path.display().to_string(),
            found: format,
            expected: ANY_FORMAT,
        }),
    }
}

/// The formats [`load`] reads, for its error.
const ANY_FORMAT: &str = "tactile_force/wrench_gp or tactile_force/wrench_ensemble";
