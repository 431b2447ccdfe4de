//! The stability rules: checks the controller runs each cycle before the
//! task steps, whatever the task. A rule may halt the arm for the cycle (a
//! stale estimate) or stop the task for good; a stopped task leaves the
//! contact its own way (`Task::abort`, src/control/task.rs). The chain of the shipped rules is
//! [`RuleChain::shipped`]: a new rule is its type and one line there, or
//! [`RuleChain::with`] for a rule defined outside the crate.
//!
//! The oscillation watchdog is not a rule of the chain: its answer lowers
//! the task's own gains, on the axes and in the phases the task regulates
//! (guarded.rs, guided.rs).

use std::fmt;

use nalgebra::Vector3;

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
}

/// One stability rule.
pub trait Rule: fmt::Debug + Send + Sync + BoxedRule {
    /// One cycle: the verdict, if the rule objects.
    fn check(&mut self, i: &RuleInput) -> Option<Verdict>;
}

/// Clones a rule behind its trait: implemented for every `Rule + Clone`.
pub trait BoxedRule {
    /// A copy, boxed.
    fn boxed_clone(&self) -> Box<dyn Rule>;
}

impl<T: Rule + Clone + 'static> BoxedRule for T {
    fn boxed_clone(&self) -> Box<dyn Rule> {
        Box::new(self.clone())
    }
}

impl Clone for Box<dyn Rule> {
    fn clone(&self) -> Self {
        self.boxed_clone()
    }
}

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

/// The rules a controller runs, in order; the first that objects answers.
#[derive(Debug, Clone)]
pub struct RuleChain {
    rules: Vec<Box<dyn Rule>>,
}

impl RuleChain {
    /// The shipped rules: a stale estimate halts; an input out of range,
    /// then a force over the limit, stops the task.
    pub fn shipped() -> Self {
        RuleChain {
            rules: vec![Box::new(Stale), Box::new(OutOfRange), Box::new(OverForce)],
        }
    }

    /// The chain with `rule` last.
    pub fn with(mut self, rule: impl Rule + Clone + 'static) -> Self {
        self.rules.push(Box::new(rule));
        self
    }

    /// Runs the rules on `i`: the first objection, if any.
    pub fn check(&mut self, i: &RuleInput) -> Option<Verdict> {
        self.rules.iter_mut().find_map(|rule| rule.check(i))
    }
}

/// Chains of the same rules with the same settings (as they print) are
/// equal.
impl PartialEq for RuleChain {
    fn eq(&self, other: &Self) -> bool {
        format!("{self:?}") == format!("{other:?}")
    }
}

impl Default for RuleChain {
    fn default() -> Self {
        Self::shipped()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input(force: &Vector3<f64>, limit: Option<ForceLimit>) -> RuleInput<'_> {
        RuleInput {
            force,
            out_of_range: false,
            estimate_age_s: 0.004,
            stale_after_s: 0.005,
            limit,
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
        let mut chain = RuleChain::shipped();
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
}
