//! The CNN behind the shared interface ([`crate::learn::models::Learner`]):
//! it reads a data set's images, not its features.

use super::{Cnn, CnnError, CnnParams};
use crate::learn::data::Dataset;
use crate::learn::models::gp::FitProgress;
use crate::learn::models::{Fitted, LearnError, Learner, Prediction};
use crate::params::Checked;
use crate::wrench::Axis;

/// The CNN with these options, on a data set's images.
#[derive(Debug, Clone)]
pub struct CnnLearner(pub Checked<CnnParams>);

/// The error for a data set without images.
fn no_images() -> LearnError {
    LearnError::new("cnn", CnnError::shape("images", "an image per row", "none"))
}

impl Learner for CnnLearner {
    fn name(&self) -> &'static str {
        "cnn"
    }

    fn takes(&self, data: &Dataset) -> bool {
        data.images.is_some()
    }

    fn fit(
        &self,
        train: &Dataset,
        _: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Box<dyn Fitted>, LearnError> {
        let images = train.images.as_ref().ok_or_else(no_images)?;
        let (net, _) = Cnn::fit(images.view(), train.y.view(), &self.0)
            .map_err(|e| LearnError::new("cnn", e))?;
        Ok(Box::new(net))
    }
}

impl Fitted for Cnn {
    fn predict(&self, data: &Dataset, _: bool) -> Result<Prediction, LearnError> {
        let images = data.images.as_ref().ok_or_else(no_images)?;
        let mean = Cnn::predict(self, images.view()).map_err(|e| LearnError::new("cnn", e))?;
        Ok(Prediction { mean, std: None })
    }

    fn predict_row(&mut self, _: &[f64], _: bool) -> Result<(), LearnError> {
        let e = CnnError::shape("input", "an image", "a row of features");
        Err(LearnError::new("cnn", e))
    }

    fn has_std(&self) -> bool {
        false
    }
}
