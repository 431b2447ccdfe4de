//! Any model family as a [`Learner`]: what `eval` and `tradeoff` compare,
//! fitted through the family's own [`ModelFamily::fit`], so that a family
//! the estimator can run is evaluated as it would be trained.

use super::family::{Fit, ModelFamily, WarmStart};
use super::gp::{FitProgress, GpParams};
use super::scale::InputScaling;
use super::wrench_model::{Estimate, TareSpec, Workspace, WrenchModel};
use super::{Fitted, LearnError, Learner, Prediction};
use crate::learn::data::Dataset;
use crate::params::Checked;
use crate::sensor::SensorSpec;
use crate::wrench::Axis;

/// A family with its options, its inputs presented as `input` says.
pub struct FamilyLearner {
    /// The family.
    pub family: &'static dyn ModelFamily,
    /// Its options (every family takes the seed).
    pub params: Checked<GpParams>,
    /// How the tared features reach a GP.
    pub input: InputScaling,
    /// How the training data were tared (recorded in the model).
    pub tare: TareSpec,
    /// The sensor the features come from.
    pub sensor: SensorSpec,
}

impl Learner for FamilyLearner {
    fn name(&self) -> &'static str {
        self.family.name()
    }

    fn every_row(&self) -> bool {
        self.family.every_row(&self.params)
    }

    fn fit(
        &self,
        train: &Dataset,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Box<dyn Fitted>, LearnError> {
        let model = self.family.fit(Fit {
            data: train,
            tare: self.tare.clone(),
            sensor: self.sensor.clone(),
            input: self.input,
            params: &self.params,
            warm: WarmStart::default(),
            progress,
        });
        let model = model.map_err(|e| LearnError::new(self.name(), e))?;
        Ok(Box::new(FittedModel::from(model)))
    }
}

/// A fitted wrench model with scratch for one row.
struct FittedModel {
    model: Box<dyn WrenchModel>,
    ws: Workspace,
    out: Vec<Estimate>,
}

impl From<Box<dyn WrenchModel>> for FittedModel {
    fn from(model: Box<dyn WrenchModel>) -> Self {
        FittedModel {
            ws: model.workspace(),
            out: vec![Estimate::default(); model.axes().len()],
            model,
        }
    }
}

impl Fitted for FittedModel {
    /// The standard deviation of a measured target (the model's own doubt
    /// and its data's noise): what held-out errors are judged against.
    fn predict(&self, data: &Dataset, with_std: bool) -> Result<Prediction, LearnError> {
        (self.model.predict_observed(data.x.view(), with_std))
            .map_err(|e| LearnError::new(self.model.family(), e))
    }

    fn predict_row(&mut self, features: &[f64], with_std: bool) -> Result<(), LearnError> {
        (self
            .model
            .estimate(features, &mut self.ws, with_std, &mut self.out))
        .map_err(|e| LearnError::new(self.model.family(), e))
    }

    fn has_std(&self) -> bool {
        true
    }
}

#[cfg(test)]
mod tests {
    use ndarray::Array2;

    use super::*;
    use crate::learn::models::ensemble::EnsembleFamily;
    use crate::learn::models::gp::MeanKind;
    use crate::learn::models::wrench_gp::{quick_params, GpFamily};

    /// 300 rows of 3 features, fx and fz smooth in them, 3 trials.
    fn data() -> Dataset {
        let n = 300;
        let x = Array2::from_shape_fn((n, 3), |(i, j)| ((i * (j + 3)) % 17) as f64 / 4.0 - 2.0);
        let y = Array2::from_shape_fn((n, 2), |(i, j)| {
            (x[[i, 0]] * (j as f64 + 1.0)).sin() + 0.5 * x[[i, 2]]
        });
        Dataset {
            features: vec!["e1".into(), "e2".into(), "e3".into()],
            x,
            axes: "fx,fz".parse().unwrap(),
            y,
            set: vec![1; n],
            trial: (0..n).map(|i| 1 + i as u32 / 100).collect(),
            images: None,
        }
    }

    fn learner(family: &'static dyn ModelFamily, mean: MeanKind) -> FamilyLearner {
        let params = GpParams {
            mean,
            ..(*quick_params()).clone()
        };
        FamilyLearner {
            family,
            params: params.validate().unwrap(),
            input: InputScaling::Standard,
            tare: TareSpec {
                samples: 0,
                mean_baseline: vec![0.0; 3],
            },
            sensor: SensorSpec::default(),
        }
    }

    #[test]
    fn a_family_fits_through_its_seam_and_predicts_with_its_doubt() {
        let data = data();
        for family in [&GpFamily as &dyn ModelFamily, &EnsembleFamily] {
            let l = learner(family, MeanKind::Zero);
            assert_eq!(l.name(), family.name());
            let mut fitted = l.fit(&data, &mut |_, _| {}).unwrap();
            let pred = fitted.predict(&data, true).unwrap();
            let std = pred.std.expect("a standard deviation");
            assert_eq!((pred.mean.dim(), std.dim()), ((300, 2), (300, 2)));
            assert!(
                std.iter().all(|s| s.is_finite() && *s > 0.0),
                "{}",
                family.name()
            );
            // It learnt the targets: RMSE well below their spread.
            let err = (&pred.mean - &data.y)
                .mapv(|e| e * e)
                .mean()
                .unwrap()
                .sqrt();
            let sd = data.y.std(0.0);
            assert!(err < 0.6 * sd, "{}: RMSE {err}, sd {sd}", family.name());
            fitted.predict_row(&[0.1, 0.2, 0.3], true).unwrap();
            assert!(fitted.predict_row(&[0.1, 0.2], true).is_err());
        }
    }

    #[test]
    fn only_a_gp_with_a_prior_mean_takes_every_row() {
        assert!(!learner(&GpFamily, MeanKind::Zero).every_row());
        assert!(learner(&GpFamily, MeanKind::Linear).every_row());
        assert!(!learner(&EnsembleFamily, MeanKind::Linear).every_row());
    }
}
