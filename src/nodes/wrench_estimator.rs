//! The wrench estimator node: turns every reading of a sensor into a
//! wrench estimate with its model (of any family, [`WrenchModel`]), the reading made into the model's features
//! by the sensor's input ([`SensorInput`]: the BioTac tares itself on its
//! first readings out of contact first). Over ROS, readings that arrive too
//! late are dropped and counted ([`EstimatorNode::on_received`]); input over
//! its bounds is refused before it reaches the node ([`EstimatorNode::guard`]).

pub mod drop_log;
pub mod reading_source;

use std::sync::Arc;

use serde::Deserialize;

use super::bounds::InputGuard;
use super::status::{Level, Status};
use crate::biotac::Tare;
use crate::exit::{Classify, ExitClass};
use crate::learn::default_model::Recipe;
use crate::learn::models::wrench_gp::ModelError;
use crate::learn::models::wrench_model::{Estimate, Workspace, WrenchModel};
use crate::sensor::biotac::BioTacInput;
use crate::sensor::{SensorError, SensorInput};
use crate::wrench::{Wrench, WrenchEstimate};

/// Parameters of the estimator node (`wrench_estimator` in the scene files).
///
/// Unknown keys are not refused here: the world's `/**` parameters meant for
/// the other nodes reach this one too.
#[derive(Debug, Clone, PartialEq, Deserialize, schemars::JsonSchema)]
pub struct EstimatorParams {
    /// Publish the posterior standard deviation, which the controller's
    /// out-of-range check reads; false: the mean only (cheaper, and that
    /// check then rests on PDC alone).
    pub with_std: bool,
    /// The model made when no model file is given.
    pub default_model: Recipe,
}

/// Readings that gave no estimate, by reason (the node's diagnostics).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Dropped {
    /// Messages that could not be decoded (wrong lengths, wrong type).
    pub refused: u64,
    /// Readings with channels the driver flagged invalid.
    pub invalid: u64,
    /// Readings older than the stale timeout on arrival.
    pub stale: u64,
    /// Readings of another electrode layout than the model's
    /// ([`EstimatorNode::refusal`] says which).
    pub layout: u64,
    /// Readings the model refused or turned into NaN or infinity.
    pub non_finite: u64,
}

impl Dropped {
    /// All of them.
    pub fn total(&self) -> u64 {
        self.refused + self.invalid + self.stale + self.layout + self.non_finite
    }

    /// What was dropped since `before`, in words; None if nothing was.
    pub fn since(&self, before: &Dropped) -> Option<String> {
        let n = self.total() - before.total();
        (n > 0).then(|| {
            format!(
                "dropped {n} readings: {} undecodable, {} with invalid channels, {} stale, \
                 {} of another electrode layout, {} non-finite",
                self.refused - before.refused,
                self.invalid - before.invalid,
                self.stale - before.stale,
                self.layout - before.layout,
                self.non_finite - before.non_finite,
            )
        })
    }
}

/// Errors building the node.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EstimatorError {
    /// The model does not fit the node's sensor, or a reading gives no features.
    #[error(transparent)]
    Sensor(#[from] SensorError),
    /// The model refused the input.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The stale timeout is not a positive number of seconds.
    #[error("stale_timeout_s = {0}: expected a time > 0 s")]
    StaleTimeout(f64),
    /// A new model while the finger is pressed.
    #[error("the finger is pressed (estimated |F| = {force_n:.2} N, above {PRESSED_N} N): a new model now would step the force a hold sees; take it out of contact")]
    Pressed {
        /// The last estimate's force (N).
        force_n: f64,
    },
}

/// A model or setting the estimator cannot take: refused input.
impl Classify for EstimatorError {
    fn class(&self) -> ExitClass {
        match self {
            EstimatorError::Sensor(e) => e.class(),
            EstimatorError::Model(e) => e.class(),
            _ => ExitClass::Refused,
        }
    }
}

/// A reading this much older than the node's clock (s) is not late: its
/// stamp is of another clock ([`EstimatorNode::stale_hint`]).
pub const ANOTHER_CLOCK_S: f64 = 1.0;

/// Above this estimated force (N) the finger counts as pressed: no new
/// model is taken ([`EstimatorNode::take_model`]).
pub const PRESSED_N: f64 = 0.3;

/// The estimator node, for the sensor `S` (the BioTac by default).
#[derive(Debug)]
pub struct EstimatorNode<S: SensorInput = BioTacInput> {
    model: Box<dyn WrenchModel>,
    sensor: S,
    features: Vec<f64>,
    ws: Workspace,
    with_std: bool,
    out: Vec<Estimate>,
    stale_timeout_s: Option<f64>,
    dropped: Dropped,
    /// The age of the last stale reading (s): None before one, NaN when
    /// the node's clock read no time then.
    stale_age_s: Option<f64>,
    /// Why readings of another layout are refused, once one was.
    refusal: Option<String>,
    estimates: u64,
    /// The last estimate's force magnitude (N).
    force_n: f64,
    /// Seconds from the node's start to its model's being ready.
    ready_after_s: Option<f64>,
    /// The bounds of its input, shared with the adapter that asks them.
    guard: Arc<InputGuard>,
}

/// A copy with scratch of its own.
impl<S: SensorInput + Clone> Clone for EstimatorNode<S> {
    fn clone(&self) -> Self {
        EstimatorNode {
            model: self.model.clone(),
            sensor: self.sensor.clone(),
            features: self.features.clone(),
            ws: self.model.workspace(),
            with_std: self.with_std,
            out: self.out.clone(),
            stale_timeout_s: self.stale_timeout_s,
            dropped: self.dropped,
            stale_age_s: self.stale_age_s,
            refusal: self.refusal.clone(),
            estimates: self.estimates,
            force_n: self.force_n,
            ready_after_s: self.ready_after_s,
            guard: self.guard.clone(),
        }
    }
}

/// The status while the model loads (the default model trains on first
/// use): a warning, no estimate yet, and the seconds so far.
pub fn loading_status(elapsed_s: f64) -> Status {
    let mut status = Status::ok("loading the model: no estimate yet");
    status.raise(Level::Warn, "");
    status.value("model_ready", false);
    status.value("model_loading_s", format!("{elapsed_s:.0}"));
    status
}

impl<S: SensorInput> EstimatorNode<S> {
    /// A node for `model`; `with_std = false` skips the variance (cheaper).
    pub fn new(model: Box<dyn WrenchModel>, with_std: bool) -> Result<Self, EstimatorError> {
        let sensor = S::for_model(model.input())?;
        Ok(EstimatorNode {
            sensor,
            features: vec![0.0; model.features().len()],
            ws: model.workspace(),
            out: vec![Estimate::default(); model.axes().len()],
            model,
            with_std,
            stale_timeout_s: None,
            dropped: Dropped::default(),
            stale_age_s: None,
            refusal: None,
            estimates: 0,
            ready_after_s: None,
            force_n: 0.0,
            guard: Arc::new(InputGuard::new()),
        })
    }

    /// Readings older than `seconds` on arrival are dropped
    /// ([`EstimatorNode::on_received`]).
    pub fn with_stale_timeout(mut self, seconds: f64) -> Result<Self, EstimatorError> {
        if !(seconds > 0.0 && seconds.is_finite()) {
            return Err(EstimatorError::StaleTimeout(seconds));
        }
        self.stale_timeout_s = Some(seconds);
        Ok(self)
    }

    /// Says on its status that its model was ready `seconds` after the node
    /// started (loaded, or trained on first use).
    pub fn with_ready_after(mut self, seconds: f64) -> Self {
        self.ready_after_s = Some(seconds);
        self
    }

    /// The bounds of its input: what a transport asks before it hands the
    /// node a message or a parameter set.
    pub fn guard(&self) -> &Arc<InputGuard> {
        &self.guard
    }

    /// The sensor's input (its baseline).
    pub fn sensor(&self) -> &S {
        &self.sensor
    }

    /// What was dropped so far.
    pub fn dropped(&self) -> Dropped {
        self.dropped
    }

    /// Why readings were refused by the model's sensor, naming both
    /// layouts ("model trained on 19 electrodes, readings have 24
    /// electrodes"), once one was.
    pub fn refusal(&self) -> Option<&str> {
        self.refusal.as_deref()
    }

    /// Counts a message that never became a reading: undecodable (`invalid`
    /// false) or with channels the driver flagged invalid (`invalid` true).
    pub fn count_unusable(&mut self, invalid: bool) {
        if invalid {
            self.dropped.invalid += 1;
        } else {
            self.dropped.refused += 1;
        }
    }

    /// Estimates made so far.
    pub fn estimates(&self) -> u64 {
        self.estimates
    }

    /// The node's status: taring, estimating, with readings dropped so far
    /// (a warning), refusing readings of another layout than the model's
    /// (an error, saying both); the counts as figures.
    pub fn status(&self) -> Status {
        let (d, tared) = (self.dropped, self.is_tared());
        let mut status = Status::ok(if tared { "estimating" } else { "taring" });
        if !tared {
            status.raise(Level::Warn, "");
        }
        if let Some(why) = &self.refusal {
            status.raise(Level::Error, &format!("; refusing readings: {why}"));
        } else if tared && d.total() > 0 {
            status.raise(
                Level::Warn,
                &format!("; {} readings dropped so far", d.total()),
            );
        }
        if let Some(hint) = self.stale_hint() {
            status.raise(
                Level::Warn,
                &format!("; {} readings dropped as stale: {hint}", d.stale),
            );
        }
        status.value("model_ready", true);
        if let Some(s) = self.ready_after_s {
            status.value("model_ready_after_s", format!("{s:.1}"));
        }
        status.value("estimates", self.estimates);
        status.value("dropped_refused", d.refused);
        status.value("dropped_invalid_channels", d.invalid);
        status.value("dropped_stale", d.stale);
        status.value("dropped_layout", d.layout);
        status.value("dropped_non_finite", d.non_finite);
        self.guard.report(&mut status);
        status
    }

    /// Why the last stale reading was stale, when it says that its stamp
    /// and the node's clock are not of one clock: more than
    /// [`ANOTHER_CLOCK_S`] old (a recording played back without simulated
    /// time, or another machine's clock), or come while the node's clock
    /// read no time (under `use_sim_time`, before any `/clock`: a
    /// recording played without `--clock`). Both name the fix.
    pub fn stale_hint(&self) -> Option<String> {
        let age = self.stale_age_s?;
        if age.is_nan() {
            return Some(
                "the last stale reading came while this node's clock read no time: with \
                 use_sim_time:=true it follows /clock, and none had come. A recording played \
                 back: play it with `ros2 bag play --clock`"
                    .into(),
            );
        }
        (age > ANOTHER_CLOCK_S).then(|| {
            format!(
                "the last stale reading was {age:.1} s old: its stamp is not of this node's \
                 clock. A recording played back: start the estimator with use_sim_time:=true \
                 and play it with `ros2 bag play --clock`; a sensor on another machine: \
                 synchronise the clocks"
            )
        })
    }

    /// Takes a reading that arrived at `now_s` (s, the clock of its stamp):
    /// None while taking the baseline, and for a reading older than the
    /// stale timeout (or with `now_s` unknown, NaN), of another electrode
    /// layout than the model's, or whose estimate is not finite; those are
    /// counted ([`EstimatorNode::dropped`]).
    pub fn on_received(&mut self, r: &S::Reading, now_s: f64) -> Option<WrenchEstimate> {
        if let Some(limit) = self.stale_timeout_s {
            let age_s = now_s - S::stamp(r).0;
            let fresh = age_s <= limit; // false for a NaN age
            if !fresh {
                self.dropped.stale += 1;
                self.stale_age_s = Some(age_s);
                return None;
            }
            // Fresh again: the hint of the last stale one no longer holds.
            self.stale_age_s = None;
        }
        match self.on_reading(r) {
            Ok(Some(e)) if e.is_finite() => {
                self.estimates += 1;
                Some(e)
            }
            Ok(None) => None,
            Err(EstimatorError::Sensor(e @ SensorError::Layout { .. })) => {
                self.dropped.layout += 1;
                if self.refusal.is_none() {
                    self.refusal = Some(e.to_string());
                }
                None
            }
            Ok(Some(_)) | Err(_) => {
                self.dropped.non_finite += 1;
                None
            }
        }
    }

    /// The model.
    pub fn model(&self) -> &dyn WrenchModel {
        self.model.as_ref()
    }

    /// True once the baseline is taken.
    pub fn is_tared(&self) -> bool {
        self.sensor.is_ready()
    }

    /// Readings the baseline takes.
    pub fn tare_samples(&self) -> usize {
        self.sensor.baseline_samples()
    }

    /// Takes the reading: part of the baseline at first, then an estimate.
    pub fn on_reading(&mut self, r: &S::Reading) -> Result<Option<WrenchEstimate>, EstimatorError> {
        let Some(cue) = self.sensor.features(r, &mut self.features)? else {
            return Ok(None);
        };
        self.model
            .estimate(&self.features, &mut self.ws, self.with_std, &mut self.out)?;
        let mut mean = Wrench::default();
        let mut std = Wrench::default();
        let mut estimated = [false; 6];
        for (axis, e) in self.model.axes().axes().iter().zip(&self.out) {
            mean.set(*axis, e.mean);
            std.set(*axis, e.std);
            estimated[axis.index()] = true;
        }
        self.force_n = mean.force.norm();
        let (stamp_s, seq) = S::stamp(r);
        Ok(Some(WrenchEstimate {
            stamp_s,
            seq,
            mean,
            std,
            estimated,
            pdc_rise: cue,
        }))
    }
}

impl EstimatorNode<BioTacInput> {
    /// The BioTac's tare, once taken.
    pub fn tare(&self) -> Option<&Tare> {
        self.sensor.tare()
    }

    /// Takes `tare` as the BioTac's baseline (a saved one): no readings are
    /// spent on it.
    pub fn set_tare(&mut self, tare: Tare) {
        self.sensor.set_tare(tare);
    }

    /// Takes `reference`, a tare of this BioTac too old to take up, as the
    /// one a new tare is checked against: none is taken while the finger
    /// is pressed ([`BioTacInput::set_reference`]).
    pub fn set_tare_reference(&mut self, reference: Tare) {
        self.sensor.set_reference(reference);
    }

    /// Why [`EstimatorNode::take_model`] would refuse `model` now, if it
    /// would: not a model of this BioTac's readings, or the finger pressed.
    pub fn check_model(&self, model: &dyn WrenchModel) -> Result<(), EstimatorError> {
        if self.force_n > PRESSED_N {
            return Err(EstimatorError::Pressed {
                force_n: self.force_n,
            });
        }
        BioTacInput::for_model(model.input())?;
        Ok(())
    }

    /// Estimates with `model` from the next reading on, keeping the tare
    /// (it holds every channel, so it serves a model of other channels)
    /// and the counts; refused when `model` is not a BioTac model, and
    /// while the last estimate says the finger is pressed ([`PRESSED_N`]).
    pub fn take_model(&mut self, model: Box<dyn WrenchModel>) -> Result<(), EstimatorError> {
        self.check_model(model.as_ref())?;
        let mut next = EstimatorNode::new(model, self.with_std)?;
        if let Some(tare) = self.tare() {
            next.set_tare(tare.clone());
        }
        next.stale_timeout_s = self.stale_timeout_s;
        next.stale_age_s = self.stale_age_s;
        next.dropped = self.dropped;
        next.estimates = self.estimates;
        *self = next;
        Ok(())
    }
}

#[cfg(test)]
mod tests;
