//! The calibration task: the arm presses the BioTac on a known surface (a
//! calibration block) in the pattern ([`mod@super::pattern`]), with the F/T
//! sensor, not the BioTac, as its force feedback, so that a model can be
//! trained on what the BioTac reads. Each push is a trial of the recording,
//! and starts with a rest out of contact (its tare).
//!
//! Every press is a guarded move ([`GuardedMove`]) along the block's
//! normal: approach, regulate, hold; over the force limit it retracts and
//! the calibration stops; nothing touched within `max_distance_m` stops it
//! with a timeout (no contact found); a force above `contact_force_n`
//! during a rest (the push's tare) stops it in contact. Between pushes the
//! pad backs off to `clearance_m` above where it touched. Slides and turns
//! follow the pattern.
//!
//! ```text
//!  per push: Rest -> (Tilt) -> Approach -> Regulate -> Hold -> (Shear) -> Retract
//!  after the last: (Tilt back) -> Stopped
//! ```

use std::any::Any;

use nalgebra::{Isometry3, Rotation3, Vector3};

use super::pattern::{pattern, CalibrateParams, Push, PushKind};
use super::CalibrateGoal;
use crate::contact::BodyParams;
use crate::control::guarded::{GuardedInput, GuardedMove, GuardedParams};
use crate::control::rules::Watch;
use crate::control::task::{
    ForceLaw, OffAxis, Task, TaskEnvelope, TaskInput, TaskLoop, TaskReport, TaskSection,
};
use crate::control::{ControllerParams, ForceLimit, Goal, OutsideGoal, Phase, StopReason};
use crate::kinematics::Twist;
use crate::params::{Check, Checked, ParamsError};
use crate::wrench::Axis;

/// The calibration's own phases (with the guarded move's while it presses).
impl Phase {
    /// Out of contact, still (a push's tare).
    pub const REST: Phase = Phase::named("rest");
    /// Turning the BioTac about its axis.
    pub const TILT: Phase = Phase::named("tilt");
    /// Pressed, sliding along the block.
    pub const SHEAR: Phase = Phase::named("shear");
}

/// The calibration's own stop reason.
impl StopReason {
    /// The pad touched something during a rest, which must be out of
    /// contact (its tare).
    pub const IN_CONTACT: StopReason = StopReason::named("in_contact");
}

/// Where a push is.
#[derive(Debug, Clone, PartialEq)]
enum Stage {
    /// Out of contact, still (s left).
    Rest(f64),
    /// Turning about the BioTac's axis to a roll (rad) from the start.
    Tilt(f64),
    /// The guarded move: approach, regulate; then holding (s left once settled).
    Press(Box<GuardedMove>, Option<f64>),
    /// Sliding along a tangent (unit, base frame), from a point (base frame).
    Shear(Box<GuardedMove>, Vector3<f64>, Vector3<f64>),
    /// Backing off to this distance along the normal from the push's start.
    Retract(f64),
    /// Turning back after the last push.
    Untilt,
    /// Finished.
    Done,
}

/// A twist with a linear velocity only.
fn linear(v: Vector3<f64>) -> Twist {
    Twist::new(v.x, v.y, v.z, 0.0, 0.0, 0.0)
}

/// The calibration's state machine.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrateMove {
    p: CalibrateParams,
    law: ForceLaw,
    /// The block's stiffness: the prior, then each press's fit (N/m).
    block_n_per_m: f64,
    pushes: Vec<Push>,
    /// The push running (index into `pushes`).
    push: usize,
    stage: Stage,
    /// Where the push started (base frame).
    from: Option<Vector3<f64>>,
    /// Distance along the normal from the push's start where it touched.
    touched_m: f64,
    elapsed_s: f64,
    stage_s: f64,
    stopped: Option<Option<StopReason>>,
    /// Canceled: the retract running is the last, then the turn back.
    withdrawn: bool,
}

/// Tolerance of a turn (rad): 0.2 deg.
const TILT_TOLERANCE_RAD: f64 = 0.2 * std::f64::consts::PI / 180.0;

impl CalibrateMove {
    /// The calibration of checked parameters in the loop of `law`, the
    /// block assumed `block_n_per_m` stiff until a press has fitted it.
    pub fn new(p: Checked<CalibrateParams>, law: ForceLaw, block_n_per_m: f64) -> Self {
        let p = (*p).clone();
        let pushes = pattern(&p);
        let rest = p.rest_s;
        CalibrateMove {
            p,
            law,
            block_n_per_m,
            pushes,
            push: 0,
            stage: Stage::Rest(rest),
            from: None,
            touched_m: 0.0,
            elapsed_s: 0.0,
            stage_s: 0.0,
            stopped: None,
            withdrawn: false,
        }
    }

    /// The pushes of the pattern.
    pub fn pushes(&self) -> &[Push] {
        &self.pushes
    }

    /// The push running, 0-based, and what it does; None once finished.
    pub fn current(&self) -> Option<(usize, Push)> {
        (self.stopped.is_none()).then(|| (self.push, self.pushes[self.push]))
    }

    /// The calibration that `task` is, if it is one.
    pub fn of(task: &dyn Task) -> Option<&CalibrateMove> {
        (task as &dyn Any).downcast_ref()
    }

    /// The push running (0-based) and the set its rows are labelled with;
    /// None once finished.
    pub fn label(&self) -> Option<(usize, u32)> {
        self.current().map(|(i, p)| (i, p.kind.set()))
    }

    /// The normal force of the push pressing now (N).
    pub fn target_n(&self) -> Option<f64> {
        match &self.stage {
            Stage::Press(..) | Stage::Shear(..) => Some(self.pushes[self.push].target_n),
            _ => None,
        }
    }

    /// The gain of the press running (m/s per N).
    pub fn gain(&self) -> Option<f64> {
        match &self.stage {
            Stage::Press(g, _) | Stage::Shear(g, ..) => Some(g.pd().gain()),
            _ => None,
        }
    }

    /// Stops for good with `reason` (None: the pattern's end, or stopped
    /// from outside).
    fn finish(&mut self, reason: Option<StopReason>) {
        self.stopped.get_or_insert(reason);
    }

    /// The guarded move of push `i` along `into` (base frame) at `pose`.
    fn press(
        &self,
        i: usize,
        pose: &Isometry3<f64>,
        into: &Vector3<f64>,
    ) -> Result<GuardedMove, ParamsError> {
        let target = self.pushes[i].target_n;
        let direction = pose.rotation.inverse() * into;
        let g = GuardedParams {
            direction: direction.into(),
            approach_speed_mps: self.p.approach_speed_mps,
            target_force_n: target,
            contact_force_n: self.p.contact_force_n,
            // Contact on the F/T force alone: PDC is what is calibrated.
            contact_pdc_counts: f64::MAX,
            force_limit_n: self.p.force_limit_n,
            max_distance_m: self.p.max_distance_m,
            max_approach_s: 2.0 * self.p.max_distance_m / self.p.approach_speed_mps,
            retract_speed_mps: self.p.approach_speed_mps,
            retract_distance_m: self.p.clearance_m,
            settle_band_n: (0.05 * target).max(0.05),
            settle_time_s: 0.1,
            settle_sd_n: (0.025 * target).max(0.02),
        }
        .checked("calibrate")?;
        Ok(GuardedMove::new(g, &self.law, self.block_n_per_m))
    }

    /// Turns about the BioTac's axis to the roll `to` (rad, from the
    /// start); once there, presses (or, `last`, finishes).
    fn turn(
        &mut self,
        to: f64,
        i: &TaskInput,
        into: &Vector3<f64>,
        here: Vector3<f64>,
        last: bool,
    ) -> (Stage, Twist) {
        let rel = Rotation3::from(i.start.rotation.inverse() * i.pose.rotation);
        let left = to - rel[(2, 1)].atan2(rel[(2, 2)]);
        let rate = self.p.roll_rate_deg_s.to_radians();
        let same = if last { Stage::Untilt } else { Stage::Tilt(to) };
        if left.abs() <= TILT_TOLERANCE_RAD {
            if last {
                self.finish(None);
                return (Stage::Done, Twist::zeros());
            }
            self.from = Some(here);
            return match self.press(self.push, i.pose, into) {
                Ok(g) => (Stage::Press(Box::new(g), None), Twist::zeros()),
                Err(_) => {
                    self.finish(Some(StopReason::UNREALISABLE));
                    (Stage::Done, Twist::zeros())
                }
            };
        }
        if self.stage_s > 3.0 * left.abs() / rate + 2.0 {
            // The arm does not turn as asked (fewer joints, a limit).
            self.finish(Some(StopReason::UNREALISABLE));
            return (Stage::Done, Twist::zeros());
        }
        let w =
            i.pose.rotation * Vector3::x() * left.signum() * rate.min(left.abs() / i.dt.max(1e-3));
        (same, Twist::new(0.0, 0.0, 0.0, w.x, w.y, w.z))
    }

    /// A press: the guarded move until it holds, then the hold; then the
    /// shear or the retract.
    fn pressing(
        &mut self,
        mut g: Box<GuardedMove>,
        hold: Option<f64>,
        i: &TaskInput,
        travelled: f64,
        into: &Vector3<f64>,
        here: Vector3<f64>,
    ) -> (Stage, Twist) {
        let before = g.phase();
        let speed = g.speed(&self.guarded_input(&g, i, travelled));
        let v = linear(into * speed);
        if let Some(block) = g.body() {
            self.block_n_per_m = block;
        }
        if before == Phase::APPROACH && g.phase() != Phase::APPROACH {
            self.touched_m = travelled;
        }
        match g.phase() {
            // No contact within the approach distance, or retracted from
            // the force limit.
            Phase::STOPPED => {
                self.finish(Some(g.reason().unwrap_or(StopReason::TIMEOUT)));
                return (Stage::Done, Twist::zeros());
            }
            Phase::RETRACT => return (Stage::Press(g, hold), v),
            _ => {}
        }
        let hold = match hold {
            None if g.phase() == Phase::HOLD => Some(self.p.hold_s),
            None => None,
            Some(left) => Some(left - i.dt),
        };
        if !hold.is_some_and(|left| left <= i.dt / 2.0) {
            return (Stage::Press(g, hold), v);
        }
        let PushKind::Shear(a) = self.pushes[self.push].kind else {
            return (Stage::Retract(self.touched_m - self.p.clearance_m), v);
        };
        // Along the block: the tangent's part across the normal.
        let t = i.pose.rotation * Vector3::new(a.cos(), a.sin(), 0.0);
        let t = (t - into * t.dot(into)).normalize();
        (Stage::Shear(g, t, here), v)
    }

    /// The guarded move's input: the F/T force along its direction.
    fn guarded_input(&self, g: &GuardedMove, i: &TaskInput, travelled: f64) -> GuardedInput {
        // The block's normal, into it, and where the push started.
        let into = i.start.rotation * -Vector3::z();
        let from = self.from.unwrap_or(i.pose.translation.vector);
        GuardedInput {
            force_n: -g.direction().dot(i.force),
            pdc_rise: i.pdc_rise,
            travelled_m: travelled,
            dt: i.dt,
            fresh: i.fresh,
            position_m: i.force_position.map(|p| (p - from).dot(&into)),
            timing: *i.timing,
        }
    }
}

impl TaskSection for CalibrateParams {
    const NAME: &'static str = "calibrate";

    /// Each press's gains for `body`, the calibration block, until a press
    /// has fitted it.
    fn build(p: Checked<Self>, lp: &TaskLoop, body: &BodyParams) -> Box<dyn Task> {
        Box::new(CalibrateMove::new(p, lp.law(), body.stiffness_n_per_m))
    }

    /// The approach of a press to the pattern's largest force.
    fn envelope(
        p: &Checked<Self>,
        lp: &TaskLoop,
        body: &BodyParams,
        name: &str,
    ) -> Result<TaskEnvelope, ParamsError> {
        let top = p
            .ladder_n
            .iter()
            .chain(&p.shear_force_n)
            .copied()
            .fold(0.0, f64::max);
        Ok(TaskEnvelope {
            envelope: lp.press_envelope(body, p.contact_force_n, top, p.force_limit_n),
            body: name.into(),
            key: "calibrate.approach_speed_mps",
            speed_mps: p.approach_speed_mps,
        })
    }

    /// It slides and turns on purpose: nothing is off-axis.
    fn report(p: &Checked<Self>) -> TaskReport {
        TaskReport {
            approach_speed_mps: Some(p.approach_speed_mps),
            off_axis: OffAxis::Nothing,
        }
    }

    /// Outside a goal it waits, the arm still, for a `calibrate` goal (the
    /// default goal's surface and axes).
    fn outside_goal(p: ControllerParams) -> Result<OutsideGoal, ParamsError> {
        Ok(OutsideGoal {
            params: CalibrateGoal::default().apply(&p)?,
            waits: true,
        })
    }
}

impl Task for CalibrateMove {
    fn step(&mut self, i: &TaskInput) -> Twist {
        if self.stopped.is_some() {
            return Twist::zeros();
        }
        self.elapsed_s += i.dt;
        self.stage_s += i.dt;
        if self.elapsed_s > self.p.max_duration_s {
            self.finish(Some(StopReason::TIMEOUT));
            return Twist::zeros();
        }
        // The block's normal, into it: the pad's -z at the start.
        let into = i.start.rotation * -Vector3::z();
        let here = i.pose.translation.vector;
        let from = *self.from.get_or_insert(here);
        let travelled = (here - from).dot(&into);
        let stage = std::mem::replace(&mut self.stage, Stage::Done);
        let kind = std::mem::discriminant(&stage);
        let (next, twist) = match stage {
            // A rest is the push's tare: out of contact, or no calibration.
            Stage::Rest(_) if i.force.norm() > self.p.contact_force_n => {
                self.finish(Some(StopReason::IN_CONTACT));
                (Stage::Done, Twist::zeros())
            }
            Stage::Rest(left) if left > i.dt / 2.0 => (Stage::Rest(left - i.dt), Twist::zeros()),
            Stage::Rest(_) => (Stage::Tilt(self.pushes[self.push].roll_rad), Twist::zeros()),
            Stage::Tilt(to) => self.turn(to, i, &into, here, false),
            Stage::Untilt => self.turn(0.0, i, &into, here, true),
            Stage::Press(g, hold) => self.pressing(g, hold, i, travelled, &into, here),
            Stage::Shear(mut g, t, start) => {
                let speed = g.speed(&self.guarded_input(&g, i, travelled));
                match g.phase() {
                    Phase::STOPPED => {
                        self.finish(Some(g.reason().unwrap_or(StopReason::FORCE_LIMIT)));
                        (Stage::Done, Twist::zeros())
                    }
                    Phase::RETRACT => (Stage::Shear(g, t, start), linear(into * speed)),
                    _ if (here - start).dot(&t) >= self.p.shear_distance_m => (
                        Stage::Retract(self.touched_m - self.p.clearance_m),
                        linear(into * speed),
                    ),
                    _ => (
                        Stage::Shear(g, t, start),
                        linear(into * speed + t * self.p.shear_speed_mps),
                    ),
                }
            }
            Stage::Retract(to) if travelled > to => (
                Stage::Retract(to),
                linear(-into * self.p.approach_speed_mps),
            ),
            Stage::Retract(_) if !self.withdrawn && self.push + 1 < self.pushes.len() => {
                self.push += 1;
                self.from = Some(here);
                (Stage::Rest(self.p.rest_s), Twist::zeros())
            }
            Stage::Retract(_) => (Stage::Untilt, Twist::zeros()),
            Stage::Done => (Stage::Done, Twist::zeros()),
        };
        if std::mem::discriminant(&next) != kind {
            self.stage_s = 0.0;
        }
        self.stage = next;
        twist
    }

    fn phase(&self) -> Phase {
        if self.stopped.is_some() {
            return Phase::STOPPED;
        }
        match &self.stage {
            Stage::Rest(_) => Phase::REST,
            Stage::Tilt(_) | Stage::Untilt => Phase::TILT,
            Stage::Press(g, None) => g.phase(),
            Stage::Press(_, Some(_)) => Phase::HOLD,
            Stage::Shear(..) => Phase::SHEAR,
            Stage::Retract(_) => Phase::RETRACT,
            Stage::Done => Phase::STOPPED,
        }
    }

    /// Why it stopped, when it stopped before the end of the pattern.
    fn reason(&self) -> Option<StopReason> {
        self.stopped.flatten()
    }

    /// The press's normal force, on z.
    fn targets(&self) -> [Option<f64>; 3] {
        [None, None, self.target_n()]
    }

    fn gains(&self) -> [Option<f64>; 3] {
        [None, None, self.gain()]
    }

    fn directions(&self) -> Vec<(String, Vector3<f64>)> {
        vec![
            ("-z of the BioTac frame (its presses)".into(), -Vector3::z()),
            ("x of the BioTac frame (its slides)".into(), Vector3::x()),
            ("y of the BioTac frame (its slides)".into(), Vector3::y()),
        ]
    }

    fn force_axes(&self) -> Vec<Axis> {
        vec![Axis::Fz]
    }

    fn pause(&mut self) {
        if let Stage::Press(g, _) | Stage::Shear(g, ..) = &mut self.stage {
            g.pause();
        }
    }

    fn stop(&mut self) {
        self.finish(None);
    }

    /// Pressed (past the approach, or sliding): backs off to `clearance_m`
    /// short of where it touched; then, as when out of contact, turns back
    /// to the start's roll and finishes, no push after.
    fn withdraw(&mut self) {
        if self.stopped.is_some() {
            return;
        }
        self.withdrawn = true;
        let back = Stage::Retract(self.touched_m - self.p.clearance_m);
        self.stage = match std::mem::replace(&mut self.stage, Stage::Done) {
            Stage::Press(g, _) if g.phase() == Phase::APPROACH => Stage::Untilt,
            Stage::Press(..) | Stage::Shear(..) => back,
            Stage::Rest(_) | Stage::Tilt(_) => Stage::Untilt,
            s @ (Stage::Retract(_) | Stage::Untilt | Stage::Done) => s,
        };
        self.stage_s = 0.0;
    }

    fn stop_on(&mut self, reason: StopReason) {
        self.finish(Some(reason));
    }

    /// Pressing or sliding, the press's guarded move retracts; out of
    /// contact (resting, turning, backing off) there is nothing to leave.
    fn abort(&mut self, reason: StopReason) {
        if let Stage::Press(g, _) | Stage::Shear(g, ..) = &mut self.stage {
            g.abort(reason);
        }
    }

    /// The press's limit while pressing or sliding; none out of contact.
    fn force_limit(&self) -> Option<ForceLimit> {
        match &self.stage {
            Stage::Press(g, _) | Stage::Shear(g, ..) => g.force_limit(),
            _ => None,
        }
    }

    /// The press's while pressing or sliding; nowhere out of contact.
    fn watch(&self) -> Watch {
        match &self.stage {
            Stage::Press(g, _) | Stage::Shear(g, ..) => g.watch(),
            _ => Watch::Nothing,
        }
    }

    /// The press's guarded move lowers its gain, or retracts.
    fn soften(&mut self, hz: [Option<f64>; 3]) {
        if let Stage::Press(g, _) | Stage::Shear(g, ..) = &mut self.stage {
            g.soften(hz);
        }
    }
}
