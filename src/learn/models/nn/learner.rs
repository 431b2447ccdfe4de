//! The network behind the shared interface ([`crate::learn::models::Learner`]).

use super::{Mlp, NnParams};
use crate::learn::data::Dataset;
use crate::learn::models::gp::FitProgress;
use crate::learn::models::{Fitted, LearnError, Learner, Prediction};
use crate::params::Checked;
use crate::wrench::Axis;

/// The network with these options, on the features as they are.
#[derive(Debug, Clone)]
pub struct NnLearner(pub Checked<NnParams>);

impl Learner for NnLearner {
    fn name(&self) -> &'static str {
        "nn"
    }

    fn fit(
        &self,
        train: &Dataset,
        _: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Box<dyn Fitted>, LearnError> {
        let net = Mlp::fit(&self.0, train.x.view(), train.y.view())
            .map_err(|e| LearnError::new("nn", e))?;
        let out = vec![0.0; net.n_outputs()];
        Ok(Box::new(FittedNn { net, out }))
    }
}

/// A trained network with scratch for single rows.
struct FittedNn {
    net: Mlp,
    out: Vec<f64>,
}

impl Fitted for FittedNn {
    fn predict(&self, data: &Dataset, _: bool) -> Result<Prediction, LearnError> {
        Ok(Prediction {
            mean: self.net.predict(data.x.view()),
            std: None,
        })
    }

    fn predict_row(&mut self, features: &[f64], _: bool) -> Result<(), LearnError> {
        self.net.predict_one(features, &mut self.out);
        Ok(())
    }

    fn has_std(&self) -> bool {
        false
    }
}
