//! The guided move (joystick): keep a set force against a person's fingertip
//! along each controlled axis (1 N along z, 0 N along x and y by default), so
//! that the arm follows the finger's pushes. A deadband (0.2 N in the thesis)
//! ignores small forces. Above the force limit, or on an input outside what
//! the estimator knows, the arm stops.
//!
//! Per axis the PD law gives `u` ("raise the force"); the BioTac moves by
//! `v = -u`: along -z to press harder on a finger under the pad, along +x to
//! give way to a finger pushing the skin towards +x.
//!
//! The gains come from the contact as measured and the loop's measured
//! timing. Along the normal, the finger's stiffness is fitted from the
//! force against the pad's position while the pad first presses it (until
//! then the stiffest body the scene permits); across the pad, until
//! measured, the contact is taken as stiff as the skin's shear spring alone
//! (src/contact.rs), the stiffest it can be. Once the first press holds
//! (the normal force within two deadbands of its target for half a period
//! at the watchdog's lowest frequency, 0.17 s: a press that rings is the
//! watchdog's to answer first), the pad probes the contact on every axis
//! for half a second (a 0.2 mm dither, src/control/probe.rs), and the
//! stiffness it shows sets each axis's gain (along the normal, the larger
//! of it and the fit; across the pad, an axis the probe misses takes the
//! other's): a fingertip may be far stiffer across the pad than along it.
//! Until then the follow across the pad is slow.
//!
//! A sustained oscillation on an axis halves that axis's gain, up to three
//! times, a slower follow rather than a stop; a fourth retracts the pad
//! along its normal, naming the axis and the frequency. A gain lowered
//! before the probe measured its axis was lowered on a guess: the probe's
//! measure replaces it.
//!
//! On each axis whose contact is measured the arm adds most of the finger's
//! velocity to its PD's: the arm's measured velocity and the force's rate
//! through the contact's stiffness, along the normal too (without it a
//! fingertip of 1000 N/m on the embedded plant of guided/tests.rs missed 0.3
//! N along the normal at a 16 ms cycle). That estimate comes from the
//! arm's own motion, so it closes a loop through the arm, and it holds for a
//! massless finger only: a finger with mass on its hand's spring (MuJoCo's, 20
//! g on 300 N/m) makes the contact look about 2.5 times stiffer than fitted,
//! with a 90 deg lead, at 25 Hz, and on an arm without servo lag that loop rang
//! at 25 Hz until the watchdog stopped the move (docs/results.md). The estimate
//! is low-passed twice over the loop's delay and lag and carried forward by
//! its own rate to when the command acts (guided/finger.rs): a person's
//! pushes (about 1 Hz) are met when they come, a ring at 25 Hz passes less
//! than a third.
//!
//! Once an axis's contact is measured, and while in contact, the PD's velocity
//! is integrated too (a PI law whose integral's corner sits at half the loop's
//! crossover, `gain * stiffness / 2`, about 27 deg of phase there): a push of
//! steady speed is then followed with the error at the deadband's edge instead
//! of the speed over the gain, which at a 16 ms cycle and 600 N/m across cost
//! up to 0.39 N RMS over DDS on MuJoCo (docs/results.md). With the corner at
//! a fifth of the crossover (11 deg) and the finger's velocity added across
//! the pad only, 79 of issue 48's 90 MuJoCo runs kept 0.3 N; at half, 85,
//! none stopped (docs/results.md). The deadbanded error feeds it, so an
//! estimate's bias under the deadband moves nothing; a gain lowered by the
//! watchdog empties it.
//!
//! Without a finger to follow, the arm does not search for ever: nothing
//! touched for `contact_timeout_s` stops it (`timeout`), and it never moves
//! further than `max_travel_m` from where it started (`travel_limit`).

mod finger;
mod section;
pub use section::GuidedParams;

use std::any::Any;

use nalgebra::Vector3;

use super::identify::ContactStiffness;
use super::oscillation::LOW_HZ;
use super::pd::PdAxis;
use super::probe::Probe;
use super::rules::{ForceLimit, Watch};
use super::task::{translation, ForceLaw, Task, TaskFigures, TaskInput};
use super::tuning::LoopTiming;
use super::{Phase, StopReason};
use crate::kinematics::Twist;
use crate::params::Checked;
use crate::wrench::Axis;
use finger::FingerVelocity;

/// The guided move's own phase (with [`Phase::RETRACT`] and
/// [`Phase::STOPPED`]).
impl Phase {
    /// Following a person's finger.
    pub const FOLLOW: Phase = Phase::named("follow");
}

/// The share of the finger's estimated velocity the arm adds to its PD's.
const FEEDFORWARD_SHARE: f64 = 0.8;
/// The finger's estimated speed below which the arm adds none (m/s).
const FEEDFORWARD_DEADBAND_MPS: f64 = 0.01;
/// Probes a contact may take before its gains stay those for the stiffest.
const PROBES: u32 = 3;
/// Times the watchdog may lower one axis's gain before the pad retracts.
const SOFTENINGS: u32 = 3;
/// The loop's crossover over the integral's corner frequency.
const INTEGRAL_RATIO: f64 = 2.0;
/// Time the normal force must stay within [`HOLD_BAND`] deadbands of its
/// target before the probe (s): half a period at the watchdog's lowest
/// frequency, which a ring beyond that band never stays within it for, so
/// that a first press that rings is the watchdog's to answer.
const HOLD_BEFORE_PROBE_S: f64 = 0.5 / LOW_HZ;
/// The band of a held press, in deadbands: the force rests at the
/// deadband's edge, where its noise crosses it.
const HOLD_BAND: f64 = 2.0;

/// What the guided move sees each cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuidedInput {
    /// Estimated force, BioTac frame (N).
    pub force: Vector3<f64>,
    /// Time since the previous cycle (s).
    pub dt: f64,
    /// True when the force is a new estimate.
    pub fresh: bool,
    /// The pad's position when the force's reading was taken, BioTac frame
    /// (m), when known.
    pub position: Option<Vector3<f64>>,
    /// The pad's displacement from the start now, in the BioTac frame at
    /// the start (m): z along the pad's normal.
    pub moved: Vector3<f64>,
    /// The BioTac's velocity when the force's reading was taken, BioTac
    /// frame (m/s), when known.
    pub arm_velocity: Option<Vector3<f64>>,
    /// The loop's timing as measured.
    pub timing: LoopTiming,
}

/// The guided-move controller.
#[derive(Debug, Clone, PartialEq)]
pub struct GuidedMove {
    p: GuidedParams,
    law: ForceLaw,
    pd: [Option<PdAxis>; 3],
    stiffness: ContactStiffness,
    /// The finger's stiffness assumed until fitted (N/m).
    prior_body: f64,
    /// The probe under way, the probes left and the dynamic stiffness each
    /// axis showed (N/m; src/control/probe.rs).
    probe: Option<Probe>,
    probes_left: u32,
    probed: [Option<f64>; 3],
    /// The times the watchdog lowered each axis's gain.
    lowered: [u32; 3],
    /// The factor the watchdog raised each axis's stiffness by (reset by
    /// the probe's first measure of the axis).
    stiffer: [f64; 3],
    /// The finger's velocity per axis (guided/finger.rs).
    finger: [FingerVelocity; 3],
    /// Each axis's integral term: the PD's velocity integrated at the
    /// integral's corner (m/s).
    integral: [f64; 3],
    /// The arm's velocity last measured, BioTac frame (m/s).
    arm: Option<Vector3<f64>>,
    since_fresh_s: f64,
    without_contact_s: f64,
    /// True once the first press reached the normal target: the finger
    /// moves by itself from then on, so the stiffness fit stops.
    pressed: bool,
    /// Time the normal force has stayed within [`HOLD_BAND`] deadbands of
    /// its target (s): the probe waits for a hold.
    held_s: f64,
    retract_from_m: f64,
    phase: Phase,
    reason: Option<StopReason>,
    /// A stability rule's stop, taken at the next cycle.
    aborted: Option<StopReason>,
}

impl GuidedMove {
    /// A guided move controlling the force axes `controlled` (x, y, z) in
    /// the loop of `law`, assuming a finger of stiffness `prior_body`
    /// (N/m) until it has fitted the one it presses.
    pub fn new(
        p: Checked<GuidedParams>,
        law: &ForceLaw,
        controlled: [bool; 3],
        prior_body: f64,
    ) -> Self {
        let axis = || PdAxis::new(&law.pd, p.margins, p.deadband_n);
        GuidedMove {
            pd: controlled.map(|c| c.then(axis)),
            // Each reading a sample: averaged over 40 ms, the x/y loop missed
            // off-axis (14.5 % at a 16 ms cycle, the embedded hold_sweep).
            stiffness: ContactStiffness::new(law.skin, 0.0),
            prior_body,
            probe: None,
            probes_left: PROBES,
            probed: [None; 3],
            lowered: [0; 3],
            stiffer: [1.0; 3],
            finger: Default::default(),
            integral: [0.0; 3],
            arm: None,
            since_fresh_s: 0.0,
            without_contact_s: 0.0,
            pressed: false,
            held_s: 0.0,
            retract_from_m: 0.0,
            law: *law,
            p: *p,
            phase: Phase::FOLLOW,
            reason: None,
            aborted: None,
        }
    }

    /// The contact's stiffness per axis (N/m): across the pad what the
    /// probe measured on that axis, or on the other one while this one's
    /// fails (the same skin and fingertip both ways; the watchdog lowers a
    /// gain that proves too high), until then the stiffest the contact can
    /// be, the skin's shear spring alone; along the normal the skin in
    /// series with the finger fitted on the first press, or the probe's if
    /// larger; times what the watchdog added.
    fn stiffness(&self) -> [f64; 3] {
        let normal = self
            .stiffness
            .effective(self.p.target_force_n[2], self.prior_body);
        let across = self.law.skin.shear_stiffness_n_per_m;
        let [x, y, z] = self.measured();
        let taken = [
            x.unwrap_or(across),
            y.unwrap_or(across),
            z.map_or(normal, |k| k.max(normal)),
        ];
        std::array::from_fn(|j| taken[j] * self.stiffer[j])
    }

    /// The stiffness the probe measured per axis (N/m), across the pad the
    /// other axis's where one's is missing.
    fn measured(&self) -> [Option<f64>; 3] {
        let [x, y, z] = self.probed;
        [x.or(y), y.or(x), z]
    }

    fn stop_with(&mut self, reason: StopReason) {
        self.phase = Phase::STOPPED;
        self.reason = Some(reason);
    }

    /// One cycle: BioTac velocity (m/s, BioTac frame).
    pub fn velocity(&mut self, i: &GuidedInput) -> Vector3<f64> {
        let p = self.p;
        let k = self.stiffness();
        for (axis, k) in self.pd.iter_mut().zip(k) {
            if let Some(axis) = axis {
                axis.tune(k, k, &i.timing);
            }
        }
        let delay_s = i.timing.dead_s() + i.timing.lag_s;
        // A reading whose joint state has not come yet (a 16 ms stream):
        // the arm's last velocity stands, so the feedforward does not
        // switch off and on.
        self.arm = i.arm_velocity.or(self.arm);
        // Only in contact, on an axis whose contact is measured: with no
        // contact or a stiffness taken too high, the force's rate leaves
        // the arm's own velocity in the finger's.
        let touched = i.force.norm() >= p.contact_force_n;
        let known = self.measured();
        let integrates = [0, 1, 2].map(|j| touched && self.probe.is_none() && known[j].is_some());
        let max_speed = self.law.pd.max_speed_mps;
        let mut v = Vector3::zeros();
        for (j, pd) in self.pd.iter_mut().enumerate() {
            if let Some(pd) = pd {
                let u = -pd.step(p.target_force_n[j], i.force[j], i.dt);
                self.integral[j] = if integrates[j] {
                    let corner = pd.gain() * k[j] / INTEGRAL_RATIO;
                    (self.integral[j] + corner * u * i.dt).clamp(-max_speed, max_speed)
                } else {
                    0.0
                };
                v[j] = u + self.integral[j];
                // The finger's velocity: the arm's, and the force's rate
                // through the contact's stiffness (F = k (x_finger -
                // x_arm)), as it will be when the command acts (the
                // module's doc).
                if let (Some(arm), true) = (self.arm, integrates[j]) {
                    let measured = arm[j] + pd.force_rate() / k[j];
                    let finger = self.finger[j].step(measured, i.dt, delay_s);
                    let along =
                        finger.signum() * (finger.abs() - FEEDFORWARD_DEADBAND_MPS).max(0.0);
                    v[j] += FEEDFORWARD_SHARE * along;
                }
                v[j] = v[j].clamp(-max_speed, max_speed);
            }
        }
        self.since_fresh_s += i.dt;
        let aborted = self.aborted.take();
        match self.phase {
            Phase::FOLLOW => self.follow(i, v, aborted),
            Phase::RETRACT if i.moved.z < self.retract_from_m + p.retract_distance_m => {
                Vector3::new(0.0, 0.0, p.retract_speed_mps)
            }
            Phase::RETRACT => {
                self.phase = Phase::STOPPED;
                Vector3::zeros()
            }
            _ => Vector3::zeros(),
        }
    }

    /// Following: a stability rule's stop (`aborted`: an oscillation
    /// retracts) and the limits, then the fit and the probe on a new
    /// estimate; the PD's velocity `v` while none stops it.
    fn follow(
        &mut self,
        i: &GuidedInput,
        v: Vector3<f64>,
        aborted: Option<StopReason>,
    ) -> Vector3<f64> {
        let p = self.p;
        if aborted == Some(StopReason::OSCILLATING) {
            self.phase = Phase::RETRACT;
            self.reason = aborted;
            self.retract_from_m = i.moved.z;
            return Vector3::new(0.0, 0.0, p.retract_speed_mps);
        }
        let stop = if aborted.is_some() {
            aborted
        } else if i.moved.norm() >= p.max_travel_m {
            Some(StopReason::TRAVEL_LIMIT)
        } else if self.without_contact_s >= p.contact_timeout_s {
            Some(StopReason::TIMEOUT)
        } else {
            None
        };
        if let Some(reason) = stop {
            self.stop_with(reason);
            return Vector3::zeros();
        }
        let touched = i.force.norm() >= p.contact_force_n;
        self.without_contact_s = if touched {
            0.0
        } else {
            self.without_contact_s + i.dt
        };
        let controlled = Vector3::from_fn(|j, _| f64::from(u8::from(self.pd[j].is_some())));
        let probing = self.probe.as_mut().map_or(Vector3::zeros(), |probe| {
            probe.push_position(&i.moved);
            probe.step(i.dt).component_mul(&controlled)
        });
        if !i.fresh {
            return v + probing;
        }
        self.pressed |= i.force.z >= p.target_force_n[2] - p.deadband_n;
        let dt = std::mem::take(&mut self.since_fresh_s);
        let holds = (i.force.z - p.target_force_n[2]).abs() <= HOLD_BAND * p.deadband_n;
        self.held_s = if holds { self.held_s + dt } else { 0.0 };
        if let (Some(x), true, false) = (i.position, i.force.z >= p.contact_force_n, self.pressed) {
            self.stiffness.push(dt, -x.z, i.force.z);
        }
        self.run_probe(i);
        if self.probe.is_some() {
            v + probing
        } else {
            v
        }
    }

    /// Once the first press holds ([`HOLD_BEFORE_PROBE_S`]), probes the
    /// contact (src/control/probe.rs) until every controlled axis is
    /// measured or [`PROBES`] were tried; a probe that loses the contact is
    /// dropped. An axis's first measure replaces what the watchdog raised
    /// its stiffness by.
    fn run_probe(&mut self, i: &GuidedInput) {
        let controlled = |j: usize| self.pd[j].is_some();
        let in_contact = i.force.z >= self.p.contact_force_n;
        let missing = (0..3).any(|j| controlled(j) && self.probed[j].is_none());
        let Some(probe) = self.probe.as_mut() else {
            let held = self.held_s >= HOLD_BEFORE_PROBE_S;
            if held && in_contact && missing && self.probes_left > 0 {
                self.probes_left -= 1;
                self.probe = Some(Probe::default());
            }
            return;
        };
        if !in_contact {
            tracing::warn!("the contact was lost while probing it");
            self.probe = None;
            return;
        }
        probe.push_force(&i.force);
        if !probe.done() {
            return;
        }
        for (j, k) in probe.stiffness().into_iter().enumerate() {
            if controlled(j) && self.probed[j].is_none() && k.is_some() {
                self.probed[j] = k;
                self.stiffer[j] = 1.0;
            }
        }
        self.probe = None;
        let [x, y, z] = self.probed.map(|k| k.map(f64::round));
        tracing::info!("the contact measured (N/m; None: not measured): x {x:?}, y {y:?}, z {z:?}");
    }

    /// The watchdog saw axis `j` oscillate at `hz`: the contact is stiffer
    /// than taken, so its stiffness is raised by the inverse of the gain
    /// factor (which lowers the gain by that factor, and the finger's
    /// velocity the feedforward reads from the force's rate), up to
    /// [`SOFTENINGS`] times; then false.
    fn lower(&mut self, j: usize, hz: f64) -> bool {
        let axis = ["x", "y", "z"][j];
        if self.lowered[j] >= SOFTENINGS {
            tracing::warn!(
                "the force along {axis} oscillates at {hz:.1} Hz with its gain lowered \
                 {SOFTENINGS} times: retracting"
            );
            return false;
        }
        self.lowered[j] += 1;
        self.integral[j] = 0.0;
        let factor = self.law.oscillation.gain_factor;
        self.stiffer[j] /= factor;
        tracing::warn!(
            "the force along {axis} oscillates at {hz:.1} Hz: its gain lowered by a factor {factor}"
        );
        true
    }
}

/// The guided move as the controller runs it: in the BioTac's frame as it
/// turns, the orientation held.
impl Task for GuidedMove {
    fn step(&mut self, i: &TaskInput) -> Twist {
        let moved = i.pose.translation.vector - i.start.translation.vector;
        let input = GuidedInput {
            force: *i.force,
            dt: i.dt,
            fresh: i.fresh,
            position: i.force_position.map(|x| i.pose.rotation.inverse() * x),
            moved: i.start.rotation.inverse() * moved,
            arm_velocity: i.force_velocity.map(|v| i.pose.rotation.inverse() * v),
            timing: *i.timing,
        };
        translation(i.pose.rotation * self.velocity(&input))
    }

    /// Follow; Retract after a second oscillation; Stopped.
    fn phase(&self) -> Phase {
        self.phase
    }

    fn reason(&self) -> Option<StopReason> {
        self.reason
    }

    fn targets(&self) -> [Option<f64>; 3] {
        std::array::from_fn(|i| self.pd[i].as_ref().map(|_| self.p.target_force_n[i]))
    }

    fn gains(&self) -> [Option<f64>; 3] {
        self.pd.each_ref().map(|p| p.as_ref().map(PdAxis::gain))
    }

    fn directions(&self) -> Vec<(String, Vector3<f64>)> {
        ["x", "y", "z"]
            .iter()
            .enumerate()
            .filter(|(i, _)| self.pd[*i].is_some())
            .map(|(i, name)| (format!("{name} of the BioTac frame"), Vector3::ith(i, 1.0)))
            .collect()
    }

    fn force_axes(&self) -> Vec<Axis> {
        [Axis::Fx, Axis::Fy, Axis::Fz]
            .into_iter()
            .enumerate()
            .filter_map(|(i, a)| self.pd[i].as_ref().map(|_| a))
            .collect()
    }

    fn pause(&mut self) {
        self.pd.iter_mut().flatten().for_each(PdAxis::reset);
        self.finger = Default::default();
        self.integral = [0.0; 3];
        self.arm = None;
        self.since_fresh_s = 0.0;
        self.probe = None;
    }

    fn stop(&mut self) {
        self.phase = Phase::STOPPED;
    }

    fn stop_on(&mut self, reason: StopReason) {
        self.stop_with(reason);
    }

    /// Stops in this cycle while following (a retract goes on as it was).
    fn abort(&mut self, reason: StopReason) {
        self.aborted = Some(reason);
    }

    /// The force's magnitude.
    fn force_limit(&self) -> Option<ForceLimit> {
        Some(ForceLimit {
            limit_n: self.p.force_limit_n,
            along: None,
        })
    }

    /// Following, each controlled axis; probing (the probe's swings are the
    /// pad's own) or retracting, none.
    fn watch(&self) -> Watch {
        if self.phase != Phase::FOLLOW || self.probe.is_some() {
            return Watch::Nothing;
        }
        let axes = [Vector3::x(), Vector3::y(), Vector3::z()];
        Watch::Regulating(std::array::from_fn(|j| {
            self.pd[j].as_ref().map(|_| axes[j])
        }))
    }

    /// Lowers each oscillating axis's gain; an axis already lowered as
    /// often as it may be (`SOFTENINGS`) retracts the pad along its normal.
    fn soften(&mut self, hz: [Option<f64>; 3]) {
        for (j, hz) in hz.into_iter().enumerate() {
            if hz.is_some_and(|hz| !self.lower(j, hz)) {
                self.abort(StopReason::OSCILLATING);
                return;
            }
        }
    }

    fn figures(&self) -> TaskFigures {
        let k = self.stiffness();
        TaskFigures {
            stiffness_n_per_m: std::array::from_fn(|j| self.pd[j].as_ref().map(|_| k[j])),
            body_n_per_m: self.stiffness.body(),
            settled_sd_n: None,
            softened: self.lowered.iter().sum(),
            own: Vec::new(),
        }
    }

    /// Every setting at once: the person's finger meets the new deadband,
    /// target and limits from the next cycle; the start, the travel, the
    /// measured stiffness and what the watchdog lowered stay.
    fn retune(&mut self, fresh: &dyn Task) -> bool {
        let Some(fresh) = (fresh as &dyn Any).downcast_ref::<GuidedMove>() else {
            return false;
        };
        for (pd, new) in self.pd.iter_mut().zip(&fresh.pd) {
            if let (Some(pd), Some(new)) = (pd, new) {
                pd.take_settings(new);
            }
        }
        self.p = fresh.p;
        self.law = fresh.law;
        true
    }
}

#[cfg(test)]
mod tests;
