//! The stability rules: checks the controller runs each cycle before the
//! task steps, whatever the task. A rule may halt the arm for the cycle (a
//! stale estimate), stop the task for good (it leaves the contact its own
//! way: `Task::abort`, src/control/task.rs), or tell it that the force
//! oscillates where it regulates it (it lowers that gain, or stops:
//! `Task::soften`). The chain of the shipped rules is
//! [`RuleChain::shipped`]: a new rule is its type and one line there; a
//! rule defined outside the crate joins with [`RuleChain::with`] (a scene's
//! `with_rule`).

use std::fmt;

use dyn_clone::DynClone;
use nalgebra::Vector3;

use super::oscillation::{OscillationDetector, OscillationParams};
use super::safety::{Halt, Watchdog};
use super::StopReason;

/// What a rule sees each cycle.
#[derive(Debug, Clone, Copy)]
pub struct RuleInput<'a> {
    /// Estimated force on the BioTac, BioTac frame (N).
    pub force: &'a Vector3<f64>,
    /// True when the input is outside what the estimator knows.
    pub out_of_range: bool,
    /// The estimate's age (s).
    pub estimate_age_s: f64,
    /// The age an estimate may reach (s).
    pub stale_after_s: f64,
    /// The force the task holds to a limit; None when it presses nothing.
    pub limit: Option<ForceLimit>,
    /// Where the task regulates the force now.
    pub watch: Watch,
    /// Time since the previous cycle (s).
    pub dt: f64,
    /// True when the force is a new estimate, not the last one again.
    pub fresh: bool,
}

/// Where a task regulates the force now, for the oscillation watchdog.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum Watch {
    /// Nowhere (retracting, stopped, probing the contact).
    #[default]
    Nothing,
    /// Out of contact: the force along `along` (BioTac frame), while below
    /// `below_n` (N) in magnitude, is the estimate's noise at rest.
    Rest {
        /// The unit direction.
        along: Vector3<f64>,
        /// The force below which it is at rest (N).
        below_n: f64,
    },
    /// Regulating the force along each of these unit directions (BioTac
    /// frame), in the task's order.
    Regulating([Option<Vector3<f64>>; 3]),
}

/// A limit on the force a task presses with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForceLimit {
    /// The limit (N).
    pub limit_n: f64,
    /// The unit direction (BioTac frame) the force is measured along; None:
    /// its magnitude.
    pub along: Option<Vector3<f64>>,
}

impl ForceLimit {
    /// The force `f` as the limit measures it (N).
    pub fn force_n(&self, f: &Vector3<f64>) -> f64 {
        self.along.map_or_else(|| f.norm(), |d| d.dot(f))
    }
}

/// A rule's answer.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// Zero velocity this cycle, the task paused.
    Halt(Halt),
    /// The task stops for good, leaving the contact.
    Stop(StopReason),
    /// The force oscillates along the task's watched directions that have
    /// a frequency here (Hz): the task lowers those gains, or stops.
    Oscillating([Option<f64>; 3]),
}

/// One stability rule.
pub trait Rule: fmt::Debug + Send + Sync + DynClone {
    /// One cycle: the verdict, if the rule objects.
    fn check(&mut self, i: &RuleInput) -> Option<Verdict>;

    /// Forgets the force's history after a pause in the inputs.
    fn pause(&mut self) {}

    /// Takes new stability settings while the task runs; by default the
    /// rule has none.
    fn retune(&mut self, oscillation: &OscillationParams) {
        let _ = oscillation;
    }
}

dyn_clone::clone_trait_object!(Rule);

/// An estimate older than its stream allows halts the arm (MoveIt Servo
/// halts on a stale command: architecture page, "anchors' safety habits").
#[derive(Debug, Clone, Copy)]
pub struct Stale;

impl Rule for Stale {
    fn check(&mut self, i: &RuleInput) -> Option<Verdict> {
        Watchdog::seconds(i.stale_after_s)
            .check_age("wrench estimate", i.estimate_age_s)
            .err()
            .map(Verdict::Halt)
    }
}

/// An input outside what the estimator knows says nothing about the force:
/// the task stops, whatever the force.
#[derive(Debug, Clone, Copy)]
pub struct OutOfRange;

impl Rule for OutOfRange {
    fn check(&mut self, i: &RuleInput) -> Option<Verdict> {
        i.out_of_range
            .then_some(Verdict::Stop(StopReason::OUT_OF_RANGE))
    }
}

/// A force past the task's limit stops it.
#[derive(Debug, Clone, Copy)]
pub struct OverForce;

impl Rule for OverForce {
    fn check(&mut self, i: &RuleInput) -> Option<Verdict> {
        let limit = i.limit?;
        (limit.force_n(i.force) > limit.limit_n).then_some(Verdict::Stop(StopReason::FORCE_LIMIT))
    }
}

/// The force oscillating in 3-30 Hz where the task regulates it
/// (control/oscillation.rs), on each new estimate; out of contact, the
/// estimate's noise raises the threshold.
#[derive(Debug, Clone)]
pub struct Oscillation {
    detectors: [OscillationDetector; 3],
    /// Which directions were watched at the last new estimate.
    watched: [bool; 3],
    /// Time since the last new estimate (s).
    since_fresh_s: f64,
}

impl Oscillation {
    /// The watchdog with the settings `p`.
    pub fn new(p: &OscillationParams) -> Self {
        Oscillation {
            detectors: std::array::from_fn(|_| OscillationDetector::new(p.threshold_n)),
            watched: [false; 3],
            since_fresh_s: 0.0,
        }
    }
}

impl Rule for Oscillation {
    fn check(&mut self, i: &RuleInput) -> Option<Verdict> {
        self.since_fresh_s += i.dt;
        if !i.fresh {
            return None;
        }
        let dt = std::mem::take(&mut self.since_fresh_s);
        let along = match i.watch {
            Watch::Regulating(along) => along,
            Watch::Rest { along, below_n } => {
                let f = along.dot(i.force);
                if f.abs() < below_n {
                    self.detectors[0].rest(f, dt);
                }
                [None; 3]
            }
            Watch::Nothing => [None; 3],
        };
        let mut hz = [None; 3];
        for (k, d) in along.iter().enumerate() {
            let watched = std::mem::replace(&mut self.watched[k], d.is_some());
            let Some(d) = d else { continue };
            // A direction watched anew starts counting afresh.
            if !watched {
                self.detectors[k].reset();
            }
            if self.detectors[k].step(d.dot(i.force), dt) {
                hz[k] = Some(self.detectors[k].frequency_hz());
            }
        }
        hz.iter()
            .any(Option::is_some)
            .then_some(Verdict::Oscillating(hz))
    }

    fn pause(&mut self) {
        self.detectors
            .iter_mut()
            .for_each(OscillationDetector::reset);
        self.since_fresh_s = 0.0;
    }

    fn retune(&mut self, oscillation: &OscillationParams) {
        for d in &mut self.detectors {
            d.set_threshold_n(oscillation.threshold_n);
        }
    }
}

/// The rules a controller runs, in order; the first that objects answers.
#[derive(Debug, Clone, Default)]
pub struct RuleChain {
    rules: Vec<Box<dyn Rule>>,
}

impl RuleChain {
    /// The shipped rules: a stale estimate halts; an input out of range,
    /// then a force over the limit, stops the task; then the oscillation
    /// watchdog with the settings `oscillation`.
    pub fn shipped(oscillation: &OscillationParams) -> Self {
        RuleChain {
            rules: vec![
                Box::new(Stale),
                Box::new(OutOfRange),
                Box::new(OverForce),
                Box::new(Oscillation::new(oscillation)),
            ],
        }
    }

    /// The chain with `rule` last.
    pub fn with(mut self, rule: impl Rule + 'static) -> Self {
        self.rules.push(Box::new(rule));
        self
    }

    /// Adds the rules of `other` last.
    pub fn extend(&mut self, other: &RuleChain) {
        self.rules.extend(other.rules.iter().cloned());
    }

    /// Runs the rules on `i`: the first objection, if any.
    pub fn check(&mut self, i: &RuleInput) -> Option<Verdict> {
        self.rules.iter_mut().find_map(|rule| rule.check(i))
    }

    /// Every rule forgets the force's history (a pause in the inputs).
    pub fn pause(&mut self) {
        self.rules.iter_mut().for_each(|rule| rule.pause());
    }

    /// Every rule takes new stability settings.
    pub fn retune(&mut self, oscillation: &OscillationParams) {
        self.rules
            .iter_mut()
            .for_each(|rule| rule.retune(oscillation));
    }
}

/// Chains of the same rules with the same settings (as they print) are
/// equal.
impl PartialEq for RuleChain {
    fn eq(&self, other: &Self) -> bool {
        format!("{self:?}") == format!("{other:?}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const OSCILLATION: OscillationParams = OscillationParams {
        threshold_n: 0.02,
        gain_factor: 0.5,
    };

    fn input(force: &Vector3<f64>, limit: Option<ForceLimit>) -> RuleInput<'_> {
        RuleInput {
            force,
            out_of_range: false,
            estimate_age_s: 0.004,
            stale_after_s: 0.005,
            limit,
            watch: Watch::Nothing,
            dt: 0.01,
            fresh: true,
        }
    }

    #[test]
    fn a_force_is_held_to_its_limit_along_a_direction_or_in_magnitude() {
        let f = Vector3::new(0.0, 2.0, -2.5);
        let along = ForceLimit {
            limit_n: 2.4,
            along: Some(-Vector3::z()),
        };
        let stop = Some(Verdict::Stop(StopReason::FORCE_LIMIT));
        assert_eq!(OverForce.check(&input(&f, Some(along))), stop);
        let lateral = ForceLimit {
            along: Some(Vector3::x()),
            ..along
        };
        assert_eq!(OverForce.check(&input(&f, Some(lateral))), None);
        let magnitude = ForceLimit {
            limit_n: 3.3,
            along: None,
        };
        assert_eq!(OverForce.check(&input(&f, Some(magnitude))), None);
        let magnitude = ForceLimit {
            limit_n: 3.1,
            ..magnitude
        };
        assert_eq!(OverForce.check(&input(&f, Some(magnitude))), stop);
        // A task that presses nothing has no limit.
        assert_eq!(OverForce.check(&input(&f, None)), None);
    }

    #[test]
    fn a_stale_estimate_halts_before_any_stop_and_out_of_range_comes_before_the_limit() {
        let f = Vector3::new(0.0, 0.0, 9.0);
        let limit = Some(ForceLimit {
            limit_n: 3.0,
            along: None,
        });
        let mut i = input(&f, limit);
        i.out_of_range = true;
        let mut chain = RuleChain::shipped(&OSCILLATION);
        let verdicts: Vec<_> = chain.rules.iter_mut().filter_map(|r| r.check(&i)).collect();
        assert_eq!(
            verdicts,
            [
                Verdict::Stop(StopReason::OUT_OF_RANGE),
                Verdict::Stop(StopReason::FORCE_LIMIT)
            ]
        );
        assert_eq!(chain.check(&i), Some(verdicts[0].clone()));
        i.estimate_age_s = 0.0051;
        let first = chain.check(&i);
        assert!(
            matches!(first, Some(Verdict::Halt(Halt::Stale { .. }))),
            "{first:?}"
        );
        // NaN ages halt too.
        i.estimate_age_s = f64::NAN;
        assert!(Stale.check(&i).is_some());
    }

    #[test]
    fn an_oscillation_where_the_task_regulates_is_told_with_its_frequency() {
        // 12.5 Hz swings of +-0.04 N about 1 N along -z, on the second of
        // the task's directions; the first watches x, which holds still.
        let along = [Some(Vector3::x()), Some(-Vector3::z()), None];
        let mut rule = Oscillation::new(&OSCILLATION);
        let mut told = None;
        for k in 0..100 {
            let f = Vector3::new(0.0, 0.0, -1.0 - if k % 8 < 4 { 0.04 } else { -0.04 });
            let mut i = input(&f, None);
            i.watch = Watch::Regulating(along);
            if let Some(v) = rule.check(&i) {
                told = Some((k, v));
                break;
            }
        }
        let (k, verdict) = told.expect("never told");
        assert!(k <= 40, "three cycles and the filter's settling: {k}");
        let Verdict::Oscillating([None, Some(hz), None]) = verdict else {
            panic!("{verdict:?}");
        };
        assert!((hz - 12.5).abs() < 0.5, "{hz} Hz");
        // The same swings where the task regulates nothing, or on estimates
        // seen before, are nobody's.
        let mut rule = Oscillation::new(&OSCILLATION);
        for k in 0..200 {
            let f = Vector3::new(0.0, 0.0, -1.0 - if k % 8 < 4 { 0.04 } else { -0.04 });
            let mut i = input(&f, None);
            i.watch = if k % 2 == 0 {
                Watch::Nothing
            } else {
                Watch::Regulating(along)
            };
            i.fresh = k % 4 < 2;
            assert_eq!(rule.check(&i), None, "{k}");
        }
    }
}
