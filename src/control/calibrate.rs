//! The calibration task: the arm presses the BioTac on a known surface (a
//! calibration block) in a scripted pattern, with the F/T sensor, not the
//! BioTac, as its force feedback, so that a model can be trained on what
//! the BioTac reads. Each press is a push, a trial of the recording, and
//! starts with a rest out of contact (its tare):
//!
//! - normal presses up a force ladder (`ladder_n`);
//! - shear pushes: pressed at `shear_force_n`, the pad slides
//!   `shear_distance_m` along each of `shear_directions_deg` in the pad's
//!   plane (0 = +x of the BioTac frame, 90 = +y);
//! - every push with the BioTac turned about its axis to the next of
//!   `roll_deg` (in turn), so that the block touches other points of the
//!   pad.
//!
//! Every press is a guarded move ([`GuardedMove`]) along the block's
//! normal: approach, regulate, hold; over the force limit it retracts and
//! the calibration stops; nothing touched within `max_distance_m` stops it
//! with a timeout (no contact found); a force above `contact_force_n`
//! during a rest (the push's tare) stops it in contact. Between pushes the pad backs off to
//! `clearance_m` above where it touched.
//!
//! ```text
//!  per push: Rest -> (Tilt) -> Approach -> Regulate -> Hold -> (Shear) -> Retract
//!  after the last: (Tilt back) -> Stopped
//! ```

use nalgebra::{Isometry3, Rotation3, Vector3};
use serde::Deserialize;

use super::guarded::{GuardedInput, GuardedMove, GuardedParams};
use super::pd::{LoopDelays, PdParams};
use super::task::TaskInput;
use super::{Phase, StopReason};
use crate::contact::{series_stiffness, BodyParams, SkinParams};
use crate::kinematics::Twist;
use crate::params::{invalid, positive, Check, Checked, ParamsError};

/// Calibration settings (`force_controller.calibrate` in the scene files).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrateParams {
    /// Normal forces of the ladder's presses (N), in order.
    pub ladder_n: Vec<f64>,
    /// Normal forces held while the pad slides, one round of slides each (N).
    pub shear_force_n: Vec<f64>,
    /// Directions of the slides in the pad's plane (deg; 0 = +x, 90 = +y).
    pub shear_directions_deg: Vec<f64>,
    /// How far the pad slides along the block in a shear push (m).
    pub shear_distance_m: f64,
    /// How fast it slides (m/s).
    pub shear_speed_mps: f64,
    /// Turns of the BioTac about its axis from the start, one per push in
    /// turn (deg).
    pub roll_deg: Vec<f64>,
    /// How fast it turns (deg/s).
    pub roll_rate_deg_s: f64,
    /// Approach and retract speed (m/s).
    pub approach_speed_mps: f64,
    /// Force that means contact (N).
    pub contact_force_n: f64,
    /// Time each press holds its force once settled (s).
    pub hold_s: f64,
    /// Time out of contact before each press: its tare (s).
    pub rest_s: f64,
    /// How far above where it touched the pad backs off between pushes (m).
    pub clearance_m: f64,
    /// Force above which the calibration retracts and stops (N).
    pub force_limit_n: f64,
    /// Approach distance of a press with no contact: the calibration stops (m).
    pub max_distance_m: f64,
    /// The longest the calibration may move the arm (s).
    pub max_duration_s: f64,
}

impl Check for CalibrateParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        let name = |field: &str| format!("{key}.{field}");
        positive(&name("contact_force_n"), self.contact_force_n)?;
        if self.ladder_n.is_empty() {
            return Err(invalid(&name("ladder_n"), 0.0, "at least one force"));
        }
        let forces = self
            .ladder_n
            .iter()
            .map(|f| ("ladder_n", *f))
            .chain(self.shear_force_n.iter().map(|f| ("shear_force_n", *f)));
        for (field, f) in forces {
            if !(f > self.contact_force_n && f < self.force_limit_n) {
                return Err(invalid(
                    &name(field),
                    f,
                    &format!(
                        "between the contact force {} N and the force limit {} N",
                        self.contact_force_n, self.force_limit_n
                    ),
                ));
            }
        }
        for (field, v) in [
            ("shear_distance_m", self.shear_distance_m),
            ("shear_speed_mps", self.shear_speed_mps),
            ("roll_rate_deg_s", self.roll_rate_deg_s),
            ("approach_speed_mps", self.approach_speed_mps),
            ("hold_s", self.hold_s),
            ("rest_s", self.rest_s),
            ("clearance_m", self.clearance_m),
            ("max_distance_m", self.max_distance_m),
            ("max_duration_s", self.max_duration_s),
        ] {
            positive(&name(field), v)?;
        }
        if let Some(d) = self.shear_directions_deg.iter().find(|d| !d.is_finite()) {
            return Err(invalid(&name("shear_directions_deg"), *d, "a finite angle"));
        }
        if self.roll_deg.is_empty() {
            return Err(invalid(
                &name("roll_deg"),
                0.0,
                "at least one turn (0: none)",
            ));
        }
        if let Some(t) = self.roll_deg.iter().find(|t| t.is_nan() || t.abs() > 30.0) {
            return Err(invalid(&name("roll_deg"), *t, "turns within +-30 deg"));
        }
        Ok(self)
    }
}

/// What a push does, and the set it is labelled with in the recording (the
/// thesis' sets: 1 mainly x, 2 mainly y, 3 mainly z, 4 combined).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PushKind {
    /// A normal press.
    Normal,
    /// A press that slides in the pad's plane along a direction (rad; 0 =
    /// +x of the BioTac frame, pi/2 = +y).
    Shear(f64),
}

impl PushKind {
    /// The set number of its rows: a slide within 22.5 deg of x is set 1,
    /// of y set 2, between them set 4; a press set 3.
    pub fn set(self) -> u32 {
        match self {
            PushKind::Shear(a) => {
                let (s, c) = a.sin_cos();
                let axis = std::f64::consts::FRAC_PI_8.cos();
                if c.abs() >= axis {
                    1
                } else if s.abs() >= axis {
                    2
                } else {
                    4
                }
            }
            PushKind::Normal => 3,
        }
    }
}

/// One push of the pattern.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Push {
    /// What it does.
    pub kind: PushKind,
    /// Its normal force (N).
    pub target_n: f64,
    /// The BioTac's turn about its axis from the start (rad).
    pub roll_rad: f64,
}

/// The pattern: the ladder's presses and the slides (every direction, each
/// at every shear force), spread evenly among each other, each push at the
/// next turn of `roll_deg`.
pub fn pattern(p: &CalibrateParams) -> Vec<Push> {
    let presses = p.ladder_n.iter().map(|&f| (PushKind::Normal, f));
    // Direction by direction, each at every shear force: the pushes held
    // out for validation (every fourth) leave a twin of each in training.
    let slides = p.shear_directions_deg.iter().flat_map(|&d| {
        p.shear_force_n
            .iter()
            .map(move |&f| (PushKind::Shear(d.to_radians()), f))
    });
    // Each kind's pushes at (i + 1/2) / n of the way through: merged in
    // that order, neither kind bunches at one end.
    let spread = |n: usize| move |(i, push)| ((i as f64 + 0.5) / n as f64, push);
    let (np, ns) = (
        p.ladder_n.len(),
        p.shear_force_n.len() * p.shear_directions_deg.len(),
    );
    let mut order: Vec<(f64, (PushKind, f64))> = presses
        .enumerate()
        .map(spread(np))
        .chain(slides.enumerate().map(spread(ns)))
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    order
        .into_iter()
        .zip(p.roll_deg.iter().cycle())
        .map(|((_, (kind, target_n)), roll)| Push {
            kind,
            target_n,
            roll_rad: roll.to_radians(),
        })
        .collect()
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

/// What the calibration needs of the loop to build each press's guarded move.
#[derive(Debug, Clone, PartialEq)]
pub struct PressLoop {
    /// The BioTac skin law.
    pub skin: Checked<SkinParams>,
    /// The calibration block.
    pub body: BodyParams,
    /// The PD law.
    pub pd: Checked<PdParams>,
    /// The loop's delays.
    pub delays: Checked<LoopDelays>,
    /// The control period (s).
    pub period_s: f64,
}

/// The calibration's state machine.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrateMove {
    p: CalibrateParams,
    press: PressLoop,
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
}

/// Tolerance of a turn (rad): 0.2 deg.
const TILT_TOLERANCE_RAD: f64 = 0.2 * std::f64::consts::PI / 180.0;

impl CalibrateMove {
    /// The calibration of checked parameters on the loop `press`.
    pub fn new(p: Checked<CalibrateParams>, press: PressLoop) -> Self {
        let p = (*p).clone();
        let pushes = pattern(&p);
        let rest = p.rest_s;
        CalibrateMove {
            p,
            press,
            pushes,
            push: 0,
            stage: Stage::Rest(rest),
            from: None,
            touched_m: 0.0,
            elapsed_s: 0.0,
            stage_s: 0.0,
            stopped: None,
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

    /// The task's phase.
    pub fn phase(&self) -> Phase {
        if self.stopped.is_some() {
            return Phase::Stopped;
        }
        match &self.stage {
            Stage::Rest(_) => Phase::Rest,
            Stage::Tilt(_) | Stage::Untilt => Phase::Tilt,
            Stage::Press(g, None) => g.phase(),
            Stage::Press(_, Some(_)) => Phase::Hold,
            Stage::Shear(..) => Phase::Shear,
            Stage::Retract(_) => Phase::Retract,
            Stage::Done => Phase::Stopped,
        }
    }

    /// Why it stopped, when it stopped before the end of the pattern.
    pub fn reason(&self) -> Option<StopReason> {
        self.stopped.flatten()
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

    /// Stops where it is.
    pub fn stop(&mut self) {
        self.stop_on(None);
    }

    /// Stops for good with `reason` (None: stopped from outside).
    pub fn stop_on(&mut self, reason: Option<StopReason>) {
        self.stopped.get_or_insert(reason);
    }

    /// Forgets the force history after a pause in the inputs.
    pub fn pause(&mut self) {
        if let Stage::Press(g, _) | Stage::Shear(g, ..) = &mut self.stage {
            g.pause();
        }
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
            retract_speed_mps: self.p.approach_speed_mps,
            retract_distance_m: self.p.clearance_m,
            settle_band_n: (0.05 * target).max(0.05),
            settle_time_s: 0.1,
        }
        .checked("calibrate")?;
        let l = &self.press;
        let k = series_stiffness(&l.skin, &l.body, target);
        Ok(GuardedMove::new(g, &l.pd, k, l.period_s, &l.delays))
    }

    /// One cycle: the BioTac's twist (base frame).
    pub fn step(&mut self, i: &TaskInput) -> Twist {
        if self.stopped.is_some() {
            return Twist::zeros();
        }
        self.elapsed_s += i.dt;
        self.stage_s += i.dt;
        if self.elapsed_s > self.p.max_duration_s {
            self.stop_on(Some(StopReason::Timeout));
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
                self.stop_on(Some(StopReason::InContact));
                (Stage::Done, Twist::zeros())
            }
            Stage::Rest(left) if left > i.dt / 2.0 => (Stage::Rest(left - i.dt), Twist::zeros()),
            Stage::Rest(_) => (Stage::Tilt(self.pushes[self.push].roll_rad), Twist::zeros()),
            Stage::Tilt(to) => self.turn(to, i, &into, here, false),
            Stage::Untilt => self.turn(0.0, i, &into, here, true),
            Stage::Press(g, hold) => self.pressing(g, hold, i, travelled, &into, here),
            Stage::Shear(mut g, t, start) => {
                let speed = g.step(&self.guarded_input(&g, i, travelled));
                match g.phase() {
                    Phase::Stopped => {
                        self.stop_on(Some(g.reason().unwrap_or(StopReason::ForceLimit)));
                        (Stage::Done, Twist::zeros())
                    }
                    Phase::Retract => (Stage::Shear(g, t, start), linear(into * speed)),
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
            Stage::Retract(_) if self.push + 1 < self.pushes.len() => {
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
                self.stop_on(None);
                return (Stage::Done, Twist::zeros());
            }
            self.from = Some(here);
            return match self.press(self.push, i.pose, into) {
                Ok(g) => (Stage::Press(Box::new(g), None), Twist::zeros()),
                Err(_) => {
                    self.stop_on(Some(StopReason::Unrealisable));
                    (Stage::Done, Twist::zeros())
                }
            };
        }
        if self.stage_s > 3.0 * left.abs() / rate + 2.0 {
            // The arm does not turn as asked (fewer joints, a limit).
            self.stop_on(Some(StopReason::Unrealisable));
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
        let speed = g.step(&self.guarded_input(&g, i, travelled));
        let v = linear(into * speed);
        if before == Phase::Approach && g.phase() != Phase::Approach {
            self.touched_m = travelled;
        }
        match g.phase() {
            // No contact within the approach distance, or retracted from
            // the force limit.
            Phase::Stopped => {
                self.stop_on(Some(g.reason().unwrap_or(StopReason::Timeout)));
                return (Stage::Done, Twist::zeros());
            }
            Phase::Retract => return (Stage::Press(g, hold), v),
            _ => {}
        }
        let hold = match hold {
            None if g.phase() == Phase::Hold => Some(self.p.hold_s),
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
        GuardedInput {
            force_n: -g.direction().dot(i.force),
            pdc_rise: i.pdc_rise,
            travelled_m: travelled,
            out_of_range: i.out_of_range,
            dt: i.dt,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{node_params, CALIBRATE_YAML};

    fn shipped() -> CalibrateParams {
        #[derive(Deserialize)]
        struct Section {
            calibrate: CalibrateParams,
        }
        node_params::<Section>(CALIBRATE_YAML, "force_controller")
            .unwrap()
            .calibrate
    }

    #[test]
    fn the_pattern_interleaves_every_kind_and_labels_it_with_the_thesis_sets() {
        let p = shipped().checked("calibrate").unwrap();
        let pushes = pattern(&p);
        let n = p.ladder_n.len() + p.shear_force_n.len() * p.shear_directions_deg.len();
        assert_eq!(pushes.len(), n);
        // Presses and slides spread among each other: in every window of
        // four pushes, both kinds.
        for w in pushes.windows(4) {
            assert!(w.iter().any(|p| p.kind == PushKind::Normal), "{w:?}");
            assert!(w.iter().any(|p| p.kind != PushKind::Normal), "{w:?}");
        }
        // Each push at the next turn, in order.
        for (push, roll) in pushes.iter().zip(p.roll_deg.iter().cycle()) {
            assert_eq!(push.roll_rad, roll.to_radians());
        }
        // Every slide direction at each of its forces.
        for f in &p.shear_force_n {
            for d in &p.shear_directions_deg {
                let kind = PushKind::Shear(d.to_radians());
                assert!(pushes.iter().any(|p| p.kind == kind && p.target_n == *f));
            }
        }
        // Every push held out for validation has a twin in training: a
        // press, or a slide the same way at another force.
        let every = crate::learn::calibration::HELD_OUT_EVERY as usize;
        let (out, kept): (Vec<_>, Vec<_>) = pushes
            .iter()
            .enumerate()
            .partition(|(i, _)| (i + 1) % every == 0);
        for (i, push) in out {
            assert!(
                kept.iter().any(|(_, k)| k.kind == push.kind),
                "push {}",
                i + 1
            );
        }
        // Labelled as the thesis' sets: along x 1, along y 2, between 4, presses 3.
        let set = |deg: f64| PushKind::Shear(f64::to_radians(deg)).set();
        assert_eq!([set(0.0), set(180.0), set(-20.0)], [1, 1, 1]);
        assert_eq!([set(90.0), set(270.0), set(110.0)], [2, 2, 2]);
        assert_eq!([set(45.0), set(135.0), set(-45.0)], [4, 4, 4]);
        assert_eq!(PushKind::Normal.set(), 3);
        // The ladder in order, up to its top.
        let ladder: Vec<f64> = pushes
            .iter()
            .filter(|p| p.kind == PushKind::Normal)
            .map(|p| p.target_n)
            .collect();
        assert_eq!(ladder, p.ladder_n);
    }

    #[test]
    fn forces_at_or_beyond_the_limit_and_wild_turns_are_refused_by_name() {
        let mut p = shipped();
        p.ladder_n.push(12.0);
        let e = p.checked("calibrate").unwrap_err().to_string();
        assert!(
            e.contains("calibrate.ladder_n = 12") && e.contains("force limit 12"),
            "{e}"
        );
        let mut p = shipped();
        p.shear_force_n = vec![0.1];
        let e = p.checked("calibrate").unwrap_err().to_string();
        assert!(e.contains("calibrate.shear_force_n"), "{e}");
        let mut p = shipped();
        p.roll_deg = vec![45.0];
        let e = p.checked("calibrate").unwrap_err().to_string();
        assert!(e.contains("calibrate.roll_deg = 45"), "{e}");
        let mut p = shipped();
        p.rest_s = 0.0;
        assert!(p.checked("calibrate").is_err());
    }
}
