//! The wrench estimator node: tares the BioTac on its first readings (out of
//! contact), then turns every reading into a wrench estimate with the GP.

use serde::Deserialize;

use crate::biotac::{BioTacReading, Tare};
use crate::learn::dataset::electrode_columns;
use crate::learn::default_model::Recipe;
use crate::learn::model::{Estimate, EstimatorWorkspace, ModelError, WrenchGp};
use crate::wrench::Wrench;

/// Readings used for the tare when the model does not say (its data were
/// tared before training).
const DEFAULT_TARE_SAMPLES: usize = 50;

/// One estimate (the `biotac/wrench` and `biotac/wrench_stddev` topics).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WrenchEstimate {
    /// Time of the reading it came from (s).
    pub stamp_s: f64,
    /// Sequence number of that reading.
    pub seq: u16,
    /// Posterior mean, BioTac frame (N, Nm); 0 on axes the model lacks.
    pub mean: Wrench,
    /// Posterior standard deviation (N, Nm); 0 on axes the model lacks.
    pub std: Wrench,
    /// Which axes (in [`crate::wrench::Axis::ALL`] order) the model estimates.
    pub estimated: [bool; 6],
    /// PDC above its tare (counts): a contact indicator.
    pub pdc_rise: f64,
}

impl WrenchEstimate {
    /// True when every number is finite.
    pub fn is_finite(&self) -> bool {
        let w = |w: &Wrench| w.force.iter().chain(w.torque.iter()).all(|v| v.is_finite());
        self.stamp_s.is_finite() && w(&self.mean) && w(&self.std) && self.pdc_rise.is_finite()
    }
}

/// Parameters of the estimator node (`wrench_estimator` in the scene files).
///
/// Unknown keys are not refused here: the world's `/**` parameters meant for
/// the other nodes reach this one too.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct EstimatorParams {
    /// Publish the posterior standard deviation, which the controller's
    /// out-of-range check reads; false: the mean only (cheaper, and that
    /// check then rests on PDC alone).
    pub with_std: bool,
    /// The model made when no model file is given.
    pub default_model: Recipe,
}

/// Errors building the node.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EstimatorError {
    /// The model was trained on other features than the 19 electrodes.
    #[error("the model's features are {found:?}; this node feeds the 19 electrodes e1..e19")]
    Features {
        /// The model's features.
        found: Vec<String>,
    },
    /// The model refused the input.
    #[error(transparent)]
    Model(#[from] ModelError),
}

/// The estimator node.
#[derive(Debug, Clone)]
pub struct EstimatorNode {
    model: WrenchGp,
    ws: EstimatorWorkspace,
    with_std: bool,
    tare_samples: usize,
    tare_readings: Vec<BioTacReading>,
    tare: Option<Tare>,
    out: Vec<Estimate>,
}

impl EstimatorNode {
    /// A node for `model`; `with_std = false` skips the variance (cheaper).
    pub fn new(model: WrenchGp, with_std: bool) -> Result<Self, EstimatorError> {
        if model.features() != electrode_columns().as_slice() {
            return Err(EstimatorError::Features {
                found: model.features().to_vec(),
            });
        }
        let tare_samples = match model.tare().samples {
            0 => DEFAULT_TARE_SAMPLES,
            n => n,
        };
        Ok(EstimatorNode {
            ws: model.workspace(),
            out: vec![Estimate::default(); model.axes().len()],
            model,
            with_std,
            tare_samples,
            tare_readings: Vec::with_capacity(tare_samples),
            tare: None,
        })
    }

    /// The model.
    pub fn model(&self) -> &WrenchGp {
        &self.model
    }

    /// True once the baseline is taken.
    pub fn is_tared(&self) -> bool {
        self.tare.is_some()
    }

    /// Readings the tare needs.
    pub fn tare_samples(&self) -> usize {
        self.tare_samples
    }

    /// Takes the reading: part of the tare at first, then an estimate.
    pub fn on_reading(
        &mut self,
        r: &BioTacReading,
    ) -> Result<Option<WrenchEstimate>, EstimatorError> {
        let Some(tare) = &self.tare else {
            self.tare_readings.push(*r);
            if self.tare_readings.len() == self.tare_samples {
                // Cannot fail: the buffer is not empty.
                self.tare = Tare::from_readings(&self.tare_readings).ok();
                self.tare_readings.clear();
            }
            return Ok(None);
        };
        let features = tare.tared(r);
        self.model
            .predict_one(&features, &mut self.ws, self.with_std, &mut self.out)?;
        let mut mean = Wrench::default();
        let mut std = Wrench::default();
        let mut estimated = [false; 6];
        for (axis, e) in self.model.axes().axes().iter().zip(&self.out) {
            mean.set(*axis, e.mean);
            std.set(*axis, e.std);
            estimated[axis.index()] = true;
        }
        Ok(Some(WrenchEstimate {
            stamp_s: r.stamp_s,
            seq: r.seq,
            mean,
            std,
            estimated,
            pdc_rise: tare.tared_pdc(r),
        }))
    }
}
