//! The wrench estimator node: turns every reading of a sensor into a
//! wrench estimate with its model (of any family, [`WrenchModel`]), the reading made into the model's features
//! by the sensor's input ([`SensorInput`]: the BioTac tares itself on its
//! first readings out of contact first). Over ROS, readings that arrive too
//! late are dropped and counted ([`EstimatorNode::on_received`]); input over
//! its bounds is refused before it reaches the node ([`EstimatorNode::guard`]).

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
#[derive(Debug, Clone, PartialEq, Deserialize)]
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

    /// Takes a reading that arrived at `now_s` (s, the clock of its stamp):
    /// None while taking the baseline, and for a reading older than the
    /// stale timeout (or with `now_s` unknown, NaN), of another electrode
    /// layout than the model's, or whose estimate is not finite; those are
    /// counted ([`EstimatorNode::dropped`]).
    pub fn on_received(&mut self, r: &S::Reading, now_s: f64) -> Option<WrenchEstimate> {
        if let Some(limit) = self.stale_timeout_s {
            let fresh = now_s - S::stamp(r).0 <= limit; // false for a NaN age
            if !fresh {
                self.dropped.stale += 1;
                return None;
            }
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
        next.dropped = self.dropped;
        next.estimates = self.estimates;
        *self = next;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::biotac::BioTacReading;
    use crate::learn::data::{electrode_columns, Dataset};
    use crate::learn::models::wrench_gp::TareSpec;
    use ndarray::Array2;

    /// One trial of features `features`, rows `x`, targets fz `y`.
    fn fz_data(features: Vec<String>, x: Array2<f64>, y: Array2<f64>) -> Dataset {
        let n = x.nrows();
        Dataset {
            features,
            x,
            axes: "fz".parse().unwrap(),
            y,
            set: vec![1; n],
            trial: vec![1; n],
            images: None,
        }
    }

    /// A model on the 19 electrodes, fz = minus the mean tared electrode.
    fn electrode_model() -> Box<dyn WrenchModel> {
        let n = 30;
        let x = Array2::from_shape_fn((n, 19), |(i, j)| -(((i * 7 + j * 3) % 11) as f64));
        let y = Array2::from_shape_fn((n, 1), |(i, _)| -x.row(i).sum() / 19.0);
        let data = fz_data(
            electrode_columns(crate::biotac::ElectrodeLayout::Biotac),
            x,
            y,
        );
        let tare = TareSpec {
            samples: 3,
            mean_baseline: vec![2000.0; 19],
        };
        Box::new(crate::learn::models::wrench_gp::quick_fit(&data, tare))
    }

    fn reading(stamp_s: f64, pressed: u16) -> BioTacReading {
        BioTacReading {
            seq: 0,
            stamp_s,
            electrodes: [2000 - pressed; 19].into(),
            pdc: 2000 + pressed,
            pac: [0; 22].into(),
            tdc: 0,
            tac: 0,
        }
    }

    #[test]
    fn late_readings_and_an_unknown_clock_are_dropped_and_counted() {
        let node = EstimatorNode::<BioTacInput>::new(electrode_model(), true).unwrap();
        assert!(matches!(
            node.clone().with_stale_timeout(0.0),
            Err(EstimatorError::StaleTimeout(_))
        ));
        let mut node = node.with_stale_timeout(0.03).unwrap();
        for i in 0..3 {
            assert_eq!(node.on_received(&reading(i as f64 * 0.01, 0), 0.03), None);
        }
        assert!(node.is_tared());
        assert!(node.on_received(&reading(1.0, 5), 1.02).is_some());
        assert_eq!(node.on_received(&reading(1.0, 5), 1.04), None);
        assert_eq!(node.on_received(&reading(1.0, 5), f64::NAN), None);
        node.count_unusable(true);
        node.count_unusable(false);
        let d = node.dropped();
        assert_eq!((d.stale, d.invalid, d.refused, d.non_finite), (2, 1, 1, 0));
        assert_eq!((d.total(), node.estimates()), (4, 1));
    }

    #[test]
    fn readings_of_another_layout_are_refused_by_name_and_counted() {
        let mut node = EstimatorNode::<BioTacInput>::new(electrode_model(), true).unwrap();
        assert_eq!(node.refusal(), None);
        let mut sp = reading(0.0, 0);
        sp.electrodes =
            crate::biotac::Electrodes::filled(crate::biotac::ElectrodeLayout::BiotacSp, 2000);
        for _ in 0..4 {
            assert_eq!(node.on_received(&sp, 0.0), None);
        }
        // Refused before the tare: none of them was taken into it.
        assert!(!node.is_tared());
        let d = node.dropped();
        assert_eq!((d.layout, d.non_finite, d.total()), (4, 0, 4));
        assert_eq!(
            node.refusal(),
            Some("model trained on 19 electrodes, readings have 24 electrodes")
        );
        let status = node.status();
        assert_eq!(status.level, Level::Error);
        assert_eq!(
            status.message,
            "taring; refusing readings: model trained on 19 electrodes, readings have 24 electrodes"
        );
        assert!(status
            .values
            .contains(&("dropped_layout".into(), "4".into())));
        let said = d.since(&Dropped::default()).unwrap();
        assert!(
            said.starts_with("dropped 4 readings: 0 undecodable"),
            "{said}"
        );
        assert!(said.contains("4 of another electrode layout"), "{said}");
        assert_eq!(d.since(&d), None);
    }

    #[test]
    fn the_status_says_loading_then_taring_then_estimating_then_what_was_dropped() {
        let has =
            |s: &Status, key: &str, value: &str| s.values.contains(&(key.into(), value.into()));
        let status = loading_status(12.4);
        assert_eq!(status.level, Level::Warn);
        assert!(status.message.contains("no estimate yet"), "{status:?}");
        assert!(has(&status, "model_ready", "false") && has(&status, "model_loading_s", "12"));
        let mut node = EstimatorNode::<BioTacInput>::new(electrode_model(), true)
            .unwrap()
            .with_ready_after(27.04);
        let status = node.status();
        assert_eq!(
            (status.level, status.message.as_str()),
            (Level::Warn, "taring")
        );
        assert!(has(&status, "model_ready", "true") && has(&status, "model_ready_after_s", "27.0"));
        for i in 0..4 {
            node.on_received(&reading(i as f64, 0), i as f64);
        }
        let status = node.status();
        assert_eq!(
            (status.level, status.message.as_str()),
            (Level::Ok, "estimating")
        );
        assert!(status.values.contains(&("estimates".into(), "1".into())));
        node.count_unusable(false);
        let status = node.status();
        assert_eq!(
            (status.level, status.message.as_str()),
            (Level::Warn, "estimating; 1 readings dropped so far")
        );
    }

    #[test]
    fn a_saved_tare_is_used_at_once_and_gives_the_same_estimate() {
        let mut first = EstimatorNode::<BioTacInput>::new(electrode_model(), false).unwrap();
        for i in 0..3 {
            first.on_received(&reading(i as f64, 0), i as f64);
        }
        let pressed = reading(5.0, 6);
        let before = first.on_received(&pressed, 5.0).unwrap();
        // A restart while pressed: taring on the press would read ~0 N.
        let mut restarted = EstimatorNode::<BioTacInput>::new(electrode_model(), false).unwrap();
        restarted.set_tare(first.tare().unwrap().clone());
        let after = restarted.on_received(&pressed, 5.0).unwrap();
        assert_eq!(after.mean, before.mean);
        assert!(before.mean.force.z > 3.0, "{:?}", before.mean);
    }

    /// A model on `features`, fz = the first feature / 100.
    fn model_on(features: &[&str]) -> Box<dyn WrenchModel> {
        let n = 30;
        let d = features.len();
        let x = Array2::from_shape_fn((n, d), |(i, j)| ((i * 7 + j * 3) % 11) as f64 * 10.0);
        let y = Array2::from_shape_fn((n, 1), |(i, _)| x[[i, 0]] / 100.0);
        let data = fz_data(features.iter().map(|f| f.to_string()).collect(), x, y);
        let tare = TareSpec {
            samples: 3,
            mean_baseline: vec![0.0; d],
        };
        Box::new(crate::learn::models::wrench_gp::quick_fit(&data, tare))
    }

    /// An ensemble of networks on the 19 electrodes: fz = the mean press
    /// (counts) / 50, trained on presses of 0 to 100 counts.
    fn electrode_ensemble() -> Box<dyn WrenchModel> {
        use crate::learn::models::ensemble::{WrenchEnsemble, DEFAULT_MEMBERS};
        use crate::learn::models::nn::NnParams;
        use crate::params::Check;
        let n = 500;
        let x = Array2::from_shape_fn((n, 19), |(i, j)| {
            -((i * 37 % 101) as f64) * (1.0 + 0.02 * ((i + j) % 5) as f64)
        });
        let y = Array2::from_shape_fn((n, 1), |(i, _)| -x.row(i).sum() / 19.0 / 50.0);
        let data = fz_data(
            electrode_columns(crate::biotac::ElectrodeLayout::Biotac),
            x,
            y,
        );
        let tare = TareSpec {
            samples: 3,
            mean_baseline: vec![2000.0; 19],
        };
        let params = NnParams::default().checked("nn").unwrap();
        Box::new(WrenchEnsemble::train(&data, tare, &params, DEFAULT_MEMBERS).unwrap())
    }

    #[test]
    fn an_ensemble_estimates_and_doubts_a_press_far_beyond_its_training() {
        let mut node = EstimatorNode::<BioTacInput>::new(electrode_ensemble(), true).unwrap();
        for i in 0..3 {
            node.on_received(&reading(i as f64, 0), i as f64);
        }
        let known = node.on_received(&reading(3.0, 50), 3.0).unwrap();
        assert!((known.mean.force.z - 1.0).abs() < 0.1, "{:?}", known.mean);
        // Ten times the deepest press it learnt: its networks disagree,
        // beyond the controller's out-of-range limit (config/world.yaml,
        // max_std_n 0.05 N), which they are well within on a known press.
        let beyond = node.on_received(&reading(4.0, 1000), 4.0).unwrap();
        let (inside, outside) = (known.std.force.z, beyond.std.force.z);
        assert!(
            inside < 0.02 && outside > 0.05,
            "std {inside} N, then {outside} N"
        );
    }

    #[test]
    fn models_on_other_channels_are_fed_those_channels_tared() {
        let mut node = EstimatorNode::<BioTacInput>::new(model_on(&["pdc", "e1"]), false).unwrap();
        for i in 0..3 {
            node.on_received(&reading(i as f64, 0), i as f64);
        }
        // PDC 50 counts above its tare: about 0.5 N.
        let e = node.on_received(&reading(5.0, 50), 5.0).unwrap();
        assert!((e.mean.force.z - 0.5).abs() < 0.1, "{:?}", e.mean);
        let err =
            EstimatorNode::<BioTacInput>::new(model_on(&["pdc", "pressure"]), false).unwrap_err();
        assert!(
            err.to_string().contains("\"pressure\"]; this node feeds"),
            "{err}"
        );
    }

    #[test]
    fn a_new_model_keeps_the_tare_and_is_refused_while_pressed() {
        let mut node = EstimatorNode::<BioTacInput>::new(model_on(&["pdc"]), false).unwrap();
        for i in 0..3 {
            node.on_received(&reading(i as f64, 0), i as f64);
        }
        // Pressed (PDC 60 counts up: about 0.6 N): refused, the model kept.
        let pressed = node.on_received(&reading(3.0, 60), 3.0).unwrap();
        let e = node.take_model(model_on(&["pdc", "e1"])).unwrap_err();
        let said = e.to_string();
        assert!(
            matches!(e, EstimatorError::Pressed { .. }) && said.contains("0.3 N"),
            "{said}"
        );
        assert_eq!(
            node.on_received(&reading(3.0, 60), 3.0).unwrap().mean,
            pressed.mean
        );
        assert_eq!(node.model().features(), ["pdc"]);
        // Out of contact: taken, on the same tare (no readings spent on a
        // new one), the counts kept.
        node.on_received(&reading(4.0, 0), 4.0).unwrap();
        node.take_model(model_on(&["pdc", "e1"])).unwrap();
        assert_eq!(node.model().features(), ["pdc", "e1"]);
        let e = node.on_received(&reading(5.0, 50), 5.0).unwrap();
        assert!((e.mean.force.z - 0.5).abs() < 0.1, "{:?}", e.mean);
        assert_eq!(node.estimates(), 4);
    }
}
