//! The guarded move: approach along a direction at a set speed until
//! contact, then regulate the force to the target and hold it; retract and
//! stop above the force limit, on an input outside what the estimator
//! knows, or on an oscillation the lowered gain did not end; stop when
//! nothing is touched within the travel or the time of the approach.
//!
//! ```text
//!  Approach --F >= contact or PDC rise--> Regulate <--settled--> Hold
//!     |  |  \--travelled > max distance (any phase)--> Stopped(travel_limit)
//!     |  \--approaching for max_approach_s--> Stopped(timeout)
//!     \-- F > limit, out of range, oscillating --> Retract --retracted--> Stopped(reason)
//! ```
//!
//! Nothing is declared: the gain is set for the contact as it is measured
//! (the body behind the skin fitted from force against position in the
//! first tens of milliseconds of contact, [`ContactStiffness`]) and for the
//! loop's measured timing ([`PdAxis::tune`]); until then, for the stiffest
//! body the scene permits and the delays' bounds. An approach in a loop
//! slower than the safety envelope assumed slows by the same share. A
//! sustained oscillation (the stability rules' watchdog, src/control/rules.rs)
//! halves the gain; a second one retracts.
//!
//! On a soft body the force rises slowly under the gain the skin's margin
//! allows (src/control/tuning.rs): once the body is fitted (at least twice
//! as compliant as the skin at the target), a feedforward
//! drives the BioTac to where the fitted line puts the target force, on
//! its own position (a loop through the arm, not the force, so the skin
//! sets no margin on it) at `1 / (3 R)` per second of the distance left,
//! `R` the measured reaction time, no faster than the skin's travel to the
//! force limit in `R` (a rigid body under a soft layer still stops
//! within it). It ends for good once the force is within half the band of
//! the target; the PD trims throughout.
//!
//! Settled is the pressing force within `settle_band_n` of the target for
//! `settle_time_s` of estimates, with a standard deviation of at most
//! `settle_sd_n` over them: `hold` is true of the force, not of a moment.
//!
//! Sign convention: the task works on the pressing force (the force along
//! minus the approach direction) and returns a speed along the approach
//! direction (positive = towards the object).

mod section;
pub use section::GuardedParams;

use nalgebra::Vector3;

use super::identify::{ContactStiffness, SAMPLE_SPAN_S};
use super::pd::PdAxis;
use super::rules::{ForceLimit, Watch};
use super::task::{translation, ForceLaw, Task, TaskFigures, TaskInput};
use super::tuning::LoopTiming;
use super::{Envelope, Phase, StopReason};
use crate::kinematics::Twist;
use crate::params::Checked;
use crate::wrench::Axis;

/// The guarded move's own phases (with [`Phase::HOLD`], [`Phase::RETRACT`]
/// and [`Phase::STOPPED`]).
impl Phase {
    /// Moving towards the object at the approach speed.
    pub const APPROACH: Phase = Phase::named("approach");
    /// In contact, regulating the force.
    pub const REGULATE: Phase = Phase::named("regulate");
}

/// What the guarded move sees each cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuardedInput {
    /// Estimated pressing force (N).
    pub force_n: f64,
    /// PDC rise above its tare (counts).
    pub pdc_rise: f64,
    /// Distance travelled along the approach direction since the start (m).
    pub travelled_m: f64,
    /// Time since the previous cycle (s).
    pub dt: f64,
    /// True when the force is a new estimate.
    pub fresh: bool,
    /// Position along the approach when the force's reading was taken (m),
    /// when known.
    pub position_m: Option<f64>,
    /// The loop's timing as measured.
    pub timing: LoopTiming,
}

/// The forces of the last settling time (estimates, one a period).
#[derive(Debug, Clone, PartialEq)]
pub struct SettleWindow {
    forces: Vec<f64>,
    next: usize,
    full: bool,
}

impl SettleWindow {
    /// A window of `n` forces (at least one), allocated once.
    pub fn new(n: usize) -> Self {
        SettleWindow {
            forces: vec![0.0; n.max(1)],
            next: 0,
            full: false,
        }
    }

    /// Adds the newest force.
    pub fn push(&mut self, f: f64) {
        self.forces[self.next] = f;
        self.next = (self.next + 1) % self.forces.len();
        self.full |= self.next == 0;
    }

    /// Forgets the forces.
    pub fn clear(&mut self) {
        self.next = 0;
        self.full = false;
    }

    /// The standard deviation of the window's forces, once full (N).
    pub fn sd(&self) -> Option<f64> {
        if !self.full {
            return None;
        }
        let n = self.forces.len() as f64;
        let mean = self.forces.iter().sum::<f64>() / n;
        let var = self.forces.iter().map(|f| (f - mean).powi(2)).sum::<f64>() / n;
        Some(var.sqrt())
    }

    /// True when the window is full and every force is within `band` of
    /// `target`.
    pub fn within(&self, target: f64, band: f64) -> bool {
        self.full && self.forces.iter().all(|f| (f - target).abs() <= band)
    }
}

/// The guarded-move state machine.
#[derive(Debug, Clone, PartialEq)]
pub struct GuardedMove {
    p: GuardedParams,
    law: ForceLaw,
    pd: PdAxis,
    stiffness: ContactStiffness,
    /// The body's stiffness assumed until fitted (N/m).
    prior_body: f64,
    softened: u32,
    settle: SettleWindow,
    /// Time since the last fresh estimate (s).
    since_fresh_s: f64,
    phase: Phase,
    reason: Option<StopReason>,
    approach_s: f64,
    retract_from_m: f64,
    /// True once the feedforward has brought the force near the target.
    pressed: bool,
    /// Where along the approach contact was first felt (m).
    touched_m: Option<f64>,
    /// A withdrawal asked for, begun at the next cycle.
    withdrawing: bool,
    /// A stability rule's stop, taken at the next cycle.
    aborted: Option<StopReason>,
}

/// The feedforward's time constant, in reaction times.
const FEEDFORWARD_REACTIONS: f64 = 3.0;
/// The feedforward acts on a body at least this many times as compliant
/// as the skin at the target.
const FEEDFORWARD_SOFTNESS: f64 = 2.0;

impl GuardedMove {
    /// A move with checked parameters in the loop of `law`, assuming a
    /// body of stiffness `prior_body` (N/m) until it has fitted the one it
    /// touches.
    pub fn new(p: Checked<GuardedParams>, law: &ForceLaw, prior_body: f64) -> Self {
        let window = (p.settle_time_s / law.period_s).round() as usize;
        GuardedMove {
            pd: PdAxis::new(&law.pd, law.pd.margins, 0.0),
            stiffness: ContactStiffness::new(law.skin, SAMPLE_SPAN_S),
            prior_body,
            softened: 0,
            settle: SettleWindow::new(window),
            since_fresh_s: 0.0,
            law: *law,
            p: *p,
            phase: Phase::APPROACH,
            reason: None,
            approach_s: 0.0,
            retract_from_m: 0.0,
            pressed: false,
            touched_m: None,
            withdrawing: false,
            aborted: None,
        }
    }

    /// Unit approach direction in the BioTac frame.
    pub fn direction(&self) -> Vector3<f64> {
        Vector3::from(self.p.direction)
    }

    /// The force being held (N).
    pub fn target_force_n(&self) -> f64 {
        self.p.target_force_n
    }

    /// The PD law (for its gain).
    pub fn pd(&self) -> &PdAxis {
        &self.pd
    }

    /// The body's stiffness fitted so far (N/m; infinite: rigid).
    pub fn body(&self) -> Option<f64> {
        self.stiffness.body()
    }

    /// The approach speed in a loop whose measured reaction time is
    /// `reaction_s`: slower by the share it exceeds what the safety
    /// envelope assumed, so that the force still peaks within its limit.
    fn approach_speed(&self, reaction_s: f64) -> f64 {
        self.p.approach_speed_mps * (self.law.reaction_s / reaction_s).min(1.0)
    }

    fn retract(&mut self, reason: StopReason, travelled_m: f64) {
        self.phase = Phase::RETRACT;
        self.reason = Some(reason);
        self.retract_from_m = travelled_m;
    }

    /// A withdrawal: pressed along the approach (the object ahead, the
    /// force at least `contact_force_n`), it retracts to
    /// `retract_distance_m` short of where contact was first felt, then
    /// stops; otherwise (still approaching, or an object behind the pad,
    /// which a retract would drive it into) it stops where it is.
    fn withdraw_from(&mut self, i: &GuardedInput) -> f64 {
        if i.force_n < self.p.contact_force_n {
            self.phase = Phase::STOPPED;
            return 0.0;
        }
        self.phase = Phase::RETRACT;
        self.retract_from_m = self.touched_m.unwrap_or(i.travelled_m).min(i.travelled_m);
        -self.p.retract_speed_mps
    }

    fn stop_with(&mut self, reason: StopReason) -> f64 {
        self.phase = Phase::STOPPED;
        self.reason = Some(reason);
        0.0
    }

    /// One cycle: the speed along the approach direction (m/s).
    pub fn speed(&mut self, i: &GuardedInput) -> f64 {
        let p = self.p;
        let k = self.stiffness.effective(p.target_force_n, self.prior_body);
        // A body with mass leaves the skin alone at the loop's crossover.
        self.pd
            .tune(k, self.law.skin.stiffness_at(p.target_force_n), &i.timing);
        let u = self.pd.step(p.target_force_n, i.force_n, i.dt);
        self.since_fresh_s += i.dt;
        let active = matches!(self.phase, Phase::APPROACH | Phase::REGULATE | Phase::HOLD);
        if std::mem::take(&mut self.withdrawing) && active {
            return self.withdraw_from(i);
        }
        if let (true, Some(reason)) = (active, self.aborted.take()) {
            self.retract(reason, i.travelled_m);
        }
        let reaction_s = i.timing.period_s + i.timing.transport_s + i.timing.arm_s();
        match self.phase {
            Phase::APPROACH => {
                self.approach_s += i.dt;
                if i.force_n >= p.contact_force_n || i.pdc_rise >= p.contact_pdc_counts {
                    self.phase = Phase::REGULATE;
                    self.touched_m = Some(i.travelled_m);
                    return self.regulate(u, i, reaction_s);
                }
                if i.travelled_m >= p.max_distance_m {
                    return self.stop_with(StopReason::TRAVEL_LIMIT);
                }
                if self.approach_s >= p.max_approach_s {
                    return self.stop_with(StopReason::TIMEOUT);
                }
                self.approach_speed(reaction_s)
            }
            // Never further than the approach distance, even in contact
            // (a PDC rise can mean a touch away from the approach direction).
            Phase::REGULATE | Phase::HOLD if i.travelled_m >= p.max_distance_m => {
                self.stop_with(StopReason::TRAVEL_LIMIT)
            }
            Phase::REGULATE | Phase::HOLD => self.regulate(u, i, reaction_s),
            Phase::RETRACT => {
                if i.travelled_m <= self.retract_from_m - p.retract_distance_m {
                    self.phase = Phase::STOPPED;
                    return 0.0;
                }
                -p.retract_speed_mps
            }
            _ => 0.0,
        }
    }

    /// In contact: the stiffness fit and the settling window take each new
    /// estimate; the speed is the PD's, never towards the
    /// object faster than the approach.
    fn regulate(&mut self, u: f64, i: &GuardedInput, reaction_s: f64) -> f64 {
        let p = self.p;
        if i.fresh {
            let dt = std::mem::take(&mut self.since_fresh_s);
            if let (Some(x), true) = (i.position_m, i.force_n >= p.contact_force_n) {
                self.stiffness.push(dt, x, i.force_n);
            }
            self.settle.push(i.force_n);
        }
        let settled = self.settle.within(p.target_force_n, p.settle_band_n)
            && self.settle.sd().is_some_and(|sd| sd <= p.settle_sd_n);
        self.phase = if settled {
            Phase::HOLD
        } else {
            Phase::REGULATE
        };
        let approach = self.approach_speed(reaction_s);
        match self.feedforward(i, reaction_s) {
            Some((v, cap)) => (u + v).min(cap.max(approach)),
            None => u.min(approach),
        }
    }

    /// The feedforward's speed towards the position of the target force
    /// and the speed it may reach at the measured force (m/s); None once
    /// the force is near the target, or before a fit.
    fn feedforward(&mut self, i: &GuardedInput, reaction_s: f64) -> Option<(f64, f64)> {
        let p = self.p;
        self.pressed |= i.force_n >= p.target_force_n - 0.5 * p.settle_band_n;
        if self.pressed {
            return None;
        }
        // Only where the body gives most: on a stiff one the skin's law
        // is most of the distance left, and a skin not quite its law puts
        // the target past where it is.
        let skin = self.law.skin.stiffness_at(p.target_force_n);
        if self.stiffness.body()? * FEEDFORWARD_SOFTNESS > skin {
            return None;
        }
        let left = self.stiffness.position_of(p.target_force_n)? - i.travelled_m;
        let rigid = Envelope {
            skin: self.law.skin,
            stiffness_n_per_m: f64::INFINITY,
            shear: false,
            trigger_n: i.force_n.max(0.0),
            target_n: p.target_force_n,
            limit_n: p.force_limit_n,
            reaction_s,
        };
        let cap = rigid.max_speed_mps().min(self.law.pd.max_speed_mps);
        let v = (left / (FEEDFORWARD_REACTIONS * reaction_s)).clamp(0.0, cap);
        Some((v, cap))
    }
}

/// The guarded move as the controller runs it: along its direction in the
/// BioTac frame at the start, the orientation held.
impl Task for GuardedMove {
    fn step(&mut self, i: &TaskInput) -> Twist {
        let d_tool = self.direction();
        let d_world = i.start.rotation * d_tool;
        let along = |p: &Vector3<f64>| (p - i.start.translation.vector).dot(&d_world);
        let input = GuardedInput {
            force_n: -d_tool.dot(i.force),
            pdc_rise: i.pdc_rise,
            travelled_m: along(&i.pose.translation.vector),
            dt: i.dt,
            fresh: i.fresh,
            position_m: i.force_position.as_ref().map(along),
            timing: *i.timing,
        };
        translation(d_world * self.speed(&input))
    }

    fn phase(&self) -> Phase {
        self.phase
    }

    fn reason(&self) -> Option<StopReason> {
        self.reason
    }

    /// The target on the axis the direction mostly points along.
    fn targets(&self) -> [Option<f64>; 3] {
        let d = self.direction();
        let mut t = [None; 3];
        t[d.iamax()] = Some(self.p.target_force_n * -d[d.iamax()]);
        t
    }

    /// The gain along the direction, on the axis it mostly points along.
    fn gains(&self) -> [Option<f64>; 3] {
        let mut out = [None; 3];
        out[self.direction().iamax()] = Some(self.pd.gain());
        out
    }

    fn directions(&self) -> Vec<(String, Vector3<f64>)> {
        let d = self.direction();
        let name = format!("the approach direction [{}, {}, {}]", d.x, d.y, d.z);
        vec![(name, d)]
    }

    fn force_axes(&self) -> Vec<Axis> {
        let d = self.direction();
        [Axis::Fx, Axis::Fy, Axis::Fz]
            .into_iter()
            .filter(|a| d[a.index()] != 0.0)
            .collect()
    }

    fn pause(&mut self) {
        self.pd.reset();
        self.settle.clear();
        self.since_fresh_s = 0.0;
    }

    fn stop(&mut self) {
        self.phase = Phase::STOPPED;
    }

    /// Out of contact: at the next cycle, a retract from where contact was
    /// first felt, or a stop (`GuardedMove::withdraw_from`).
    fn withdraw(&mut self) {
        self.withdrawing = true;
    }

    fn stop_on(&mut self, reason: StopReason) {
        self.phase = Phase::STOPPED;
        self.reason = Some(reason);
    }

    /// Retracts in this cycle, from wherever it is in contact or
    /// approaching (a retract or a stop goes on as it was).
    fn abort(&mut self, reason: StopReason) {
        self.aborted = Some(reason);
    }

    /// The pressing force, along minus the approach direction.
    fn force_limit(&self) -> Option<ForceLimit> {
        Some(ForceLimit {
            limit_n: self.p.force_limit_n,
            along: Some(-self.direction()),
        })
    }

    /// Approaching, the estimate's noise out of contact (below half the
    /// contact force: not the first rise) sets the watchdog's floor; in
    /// contact, the pressing force.
    fn watch(&self) -> Watch {
        let along = -self.direction();
        match self.phase {
            Phase::APPROACH => Watch::Rest {
                along,
                below_n: 0.5 * self.p.contact_force_n,
            },
            Phase::REGULATE | Phase::HOLD => Watch::Regulating([Some(along), None, None]),
            _ => Watch::Nothing,
        }
    }

    /// The first oscillation halves the gain (by `oscillation.gain_factor`)
    /// and restarts the settling; the next retracts.
    fn soften(&mut self, hz: [Option<f64>; 3]) {
        let Some(hz) = hz[0] else { return };
        if self.softened > 0 {
            tracing::warn!(
                "the force oscillates again at {hz:.1} Hz with the gain lowered: retracting"
            );
            self.abort(StopReason::OSCILLATING);
            return;
        }
        self.softened += 1;
        self.pd.soften(self.law.oscillation.gain_factor);
        self.settle.clear();
        tracing::warn!(
            "the force oscillates at {hz:.1} Hz: gain lowered by a factor {}",
            self.law.oscillation.gain_factor
        );
    }

    fn figures(&self) -> TaskFigures {
        let mut stiffness = [None; 3];
        stiffness[self.direction().iamax()] = Some(
            self.stiffness
                .effective(self.p.target_force_n, self.prior_body),
        );
        TaskFigures {
            stiffness_n_per_m: stiffness,
            body_n_per_m: self.stiffness.body(),
            settled_sd_n: self.settle.sd(),
            softened: self.softened,
            own: Vec::new(),
        }
    }
}

#[cfg(test)]
pub(crate) mod tests;
