//! A deep ensemble of the baseline network (Lakshminarayanan, Pritzel and
//! Blundell, "Simple and scalable predictive uncertainty estimation using
//! deep ensembles", NeurIPS 2017, whose experiments use 5 networks): the
//! same network ([`super::nn`]) trained once per contiguous block of the
//! rows as recorded, each on the other blocks, stopped early on its own
//! block and seeded apart (initial weights, batch order). The estimate is
//! the networks' mean; the model's own doubt is their spread, which grows
//! where the training data did not pin the networks down; a measured
//! target's standard deviation adds the networks' error on their held-out
//! blocks (every row is held out once: an error on a stretch of recording
//! a network did not see, as a new session's would be; the block also chose
//! the network's epoch, which flatters it a little). Its file (`file.rs`)
//! has a format of its own.

mod as_wrench_model;
mod family;
mod file;
#[cfg(test)]
mod tests;

use ndarray::{s, Array2, ArrayView2};
use rayon::prelude::*;

use super::nn::{Mlp, NnParams};
use super::provenance::{set_scales, Making};
use super::wrench_model::ModelError;
use super::wrench_model::{Estimate, TareSpec};
use super::Prediction;
use crate::learn::data::Dataset;
use crate::params::{Check, Checked};
use crate::sensor::SensorSpec;
use file::EnsembleFile;

pub use family::EnsembleFamily;
pub use file::{ENSEMBLE_FORMAT, ENSEMBLE_VERSION};

/// Networks in an ensemble unless asked otherwise (the paper's 5).
pub const DEFAULT_MEMBERS: usize = 5;

/// A trained ensemble.
#[derive(Debug, Clone)]
pub struct WrenchEnsemble {
    file: EnsembleFile,
}

impl WrenchEnsemble {
    /// Trains `members` (at least 2) networks with `params` on `data`
    /// (features tared; at least 2 rows per network), the k-th on every
    /// block of rows but the k-th and seeded `params.seed + k`, in parallel.
    pub fn train(
        data: &Dataset,
        tare: TareSpec,
        params: &Checked<NnParams>,
        members: usize,
    ) -> Result<Self, ModelError> {
        if members < 2 {
            return Err(ModelError::Members(members));
        }
        let blocks = blocks(data.len(), members);
        let nets = (0..members)
            .into_par_iter()
            .map(|k| -> Result<Mlp, ModelError> {
                let p = NnParams {
                    seed: params.seed.wrapping_add(k as u64),
                    ..NnParams::clone(params)
                };
                let train: Vec<usize> =
                    (0..data.len()).filter(|i| !blocks[k].contains(i)).collect();
                let held = blocks[k].clone().collect::<Vec<_>>();
                let (x, y) = (data.x.view(), data.y.view());
                Ok(Mlp::fit_on(&p.checked("nn")?, x, y, (&train, &held))?)
            })
            .collect::<Result<Vec<_>, _>>()?;
        let noise_std = held_out_std(&nets, data, &blocks);
        let file = EnsembleFile {
            format: ENSEMBLE_FORMAT.into(),
            version: ENSEMBLE_VERSION,
            features: data.features.clone(),
            axes: data.axes.clone(),
            tare,
            sensor: SensorSpec::biotac(crate::learn::data::layout_of(&data.features)),
            n_train: data.len(),
            members: nets,
            noise_std,
            std_scale: vec![1.0; data.axes.len()],
            selection: None,
            adapt_choice: None,
            calibration: None,
        };
        Ok(WrenchEnsemble { file })
    }

    /// [`DEFAULT_MEMBERS`] networks of the baseline for `sensor`
    /// ([`NnParams::for_sensor`]), the first seeded `seed`, recording that
    /// its features come from `sensor`: what `train --family ensemble`,
    /// `--select`, `adapt`, the calibration and `eval --ensemble` train.
    pub fn train_default(
        data: &Dataset,
        tare: TareSpec,
        sensor: SensorSpec,
        seed: u64,
    ) -> Result<Self, ModelError> {
        let params = NnParams {
            seed,
            ..NnParams::for_sensor(&sensor)
        };
        let mut model = Self::train(data, tare, &params.checked("nn")?, DEFAULT_MEMBERS)?;
        model.file.sensor = sensor;
        Ok(model)
    }

    /// Keeps `making` ([`crate::learn::models::wrench_model::WrenchModel::record`]);
    /// the data it was trained on are not kept: pooled retraining retrains a GP.
    pub(crate) fn record(&mut self, making: Making) {
        let f = &mut self.file;
        match making {
            Making::StdScales(scales) => set_scales(f.std_scale.iter_mut(), &scales),
            Making::TrainedOn(_) => {}
            Making::Selection(s) => f.selection = Some(*s),
            Making::AdaptChoice(c) => f.adapt_choice = Some(*c),
            Making::Calibration(r) => f.calibration = Some(*r),
        }
    }

    /// Networks in it.
    pub fn members(&self) -> usize {
        self.file.members.len()
    }

    /// Per axis, the standard deviation of a network's error on the rows it
    /// did not train on (N or Nm).
    pub fn noise_std(&self) -> &[f64] {
        &self.file.noise_std
    }

    /// [`crate::learn::models::wrench_model::WrenchModel::estimate`] once
    /// the feature count is checked: the networks' mean and the standard
    /// deviation of their estimates, each network's into `each` (networks
    /// x axes).
    fn estimate_row(&self, features: &[f64], each: &mut [f64], out: &mut [Estimate]) {
        let k = self.file.axes.len();
        for (net, s) in self.file.members.iter().zip(each.chunks_mut(k)) {
            net.predict_one(features, s);
        }
        let m = self.file.members.len() as f64;
        for (j, e) in out.iter_mut().enumerate() {
            let column = || each.iter().skip(j).step_by(k);
            let mean = column().sum::<f64>() / m;
            let var = column().map(|v| (v - mean).powi(2)).sum::<f64>() / (m - 1.0);
            *e = Estimate {
                mean,
                std: var.sqrt(),
            };
        }
    }

    /// Means and standard deviations of the networks' estimates (rows x
    /// axes) for rows of tared features.
    fn spread(&self, x: ArrayView2<f64>) -> (Array2<f64>, Array2<f64>) {
        let each: Vec<Array2<f64>> = self.file.members.iter().map(|n| n.predict(x)).collect();
        let m = each.len() as f64;
        let mean = each.iter().fold(Array2::zeros(each[0].dim()), |a, p| a + p) / m;
        let var = each.iter().fold(Array2::zeros(mean.dim()), |a, p| {
            a + (p - &mean).mapv(|d| d * d)
        }) / (m - 1.0);
        (mean, var.mapv(f64::sqrt))
    }

    /// [`crate::learn::models::wrench_model::WrenchModel::predict_observed`]
    /// once the feature count is checked.
    fn observed(&self, x: ArrayView2<f64>, with_std: bool) -> Prediction {
        let (mean, mut std) = self.spread(x);
        if !with_std {
            return Prediction { mean, std: None };
        }
        let f = &self.file;
        for ((mut col, noise), scale) in std
            .columns_mut()
            .into_iter()
            .zip(&f.noise_std)
            .zip(&f.std_scale)
        {
            col.mapv_inplace(|s| s.hypot(*noise) * scale);
        }
        Prediction {
            mean,
            std: Some(std),
        }
    }

    fn check_count(&self, found: usize) -> Result<(), ModelError> {
        let expected = self.file.features.len();
        if found != expected {
            return Err(ModelError::FeatureCount { expected, found });
        }
        Ok(())
    }
}

/// `n` rows cut into `k` contiguous blocks.
fn blocks(n: usize, k: usize) -> Vec<std::ops::Range<usize>> {
    (0..k).map(|j| j * n / k..(j + 1) * n / k).collect()
}

/// Per axis, the root mean square of each network's errors on its held-out
/// block, over every row.
fn held_out_std(nets: &[Mlp], data: &Dataset, blocks: &[std::ops::Range<usize>]) -> Vec<f64> {
    let mut sum = vec![0.0; data.axes.len()];
    for (net, block) in nets.iter().zip(blocks) {
        let x = data.x.slice(s![block.clone(), ..]);
        let error = net.predict(x) - data.y.slice(s![block.clone(), ..]);
        for (s, col) in sum.iter_mut().zip(error.columns()) {
            *s += col.iter().map(|e| e * e).sum::<f64>();
        }
    }
    sum.iter()
        .map(|s| (s / data.len().max(1) as f64).sqrt())
        .collect()
}
