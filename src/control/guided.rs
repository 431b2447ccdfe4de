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
//! (src/contact.rs), the stiffest it can be. Once the first press holds,
//! the pad probes the contact on every axis for half a second (a 0.2 mm
//! dither, src/control/probe.rs), and the stiffness it shows sets each
//! axis's gain (along the normal, the larger of it and the fit; across the
//! pad, an axis the probe misses takes the other's): a fingertip may be far
//! stiffer across the pad than along it. Until then the follow across the
//! pad is slow.
//!
//! A sustained oscillation on an axis halves that axis's gain, up to three
//! times, a slower follow rather than a
//! stop; a fourth retracts the pad along its normal, naming the axis and
//! the frequency.
//!
//! Across the pad the arm adds most of the finger's velocity to its PD's:
//! the arm's measured velocity and the force's rate through the contact's
//! stiffness. That estimate comes from the arm's own motion, so it closes a
//! loop through the arm, and it holds for a massless finger only: a finger
//! with mass on its hand's spring (MuJoCo's, 20 g on 300 N/m) makes the
//! contact look about 2.5 times stiffer than fitted, with a 90 deg lead, at
//! 25 Hz, and on an arm without servo lag that loop rang at 25 Hz until the
//! watchdog stopped the move (docs/results.md). The estimate is low-passed
//! over the loop's delay and lag: at the frequency where the delay alone
//! turns 180 deg less than a third of it passes, a person's pushes (about
//! 1 Hz) pass nearly whole.
//!
//! Once an axis's contact is measured, and while in contact, the PD's
//! velocity is integrated too (a PI law whose integral's corner sits at a
//! fifth of the loop's crossover, `gain * stiffness / 5`, about 11 deg of
//! phase there): a push of steady speed is then followed with the error at
//! the deadband's edge instead of the speed over the gain, which at a 16 ms
//! cycle and 600 N/m across cost up to 0.39 N RMS over DDS on MuJoCo
//! (docs/results.md). The deadbanded error feeds it, so an estimate's bias
//! under the deadband moves nothing; a gain lowered by the watchdog empties
//! it.
//!
//! Without a finger to follow, the arm does not search for ever: nothing
//! touched for `contact_timeout_s` stops it (`timeout`), and it never moves
//! further than `max_travel_m` from where it started (`travel_limit`).

use nalgebra::Vector3;
use serde::{Deserialize, Serialize};

use super::identify::ContactStiffness;
use super::oscillation::OscillationDetector;
use super::pd::PdAxis;
use super::probe::Probe;
use super::task::{
    missing_axis, translation, ForceLaw, Task, TaskEnvelope, TaskFigures, TaskInput, TaskLoop,
    TaskSection,
};
use super::tuning::{LoopTiming, Margins};
use super::{Envelope, Phase, StopReason};
use crate::contact::{shear_stiffness, BodyParams};
use crate::kinematics::Twist;
use crate::params::reference::check_ranges;
use crate::params::{invalid, Check, Checked, ParamsError};
use crate::wrench::Axis;

/// The share of the finger's estimated velocity the arm adds to its PD's.
const FEEDFORWARD_SHARE: f64 = 0.8;
/// The finger's estimated speed below which the arm adds none (m/s).
const FEEDFORWARD_DEADBAND_MPS: f64 = 0.01;
/// Probes a contact may take before its gains stay those for the stiffest.
const PROBES: u32 = 3;
/// Times the watchdog may lower one axis's gain before the pad retracts.
const SOFTENINGS: u32 = 3;
/// The loop's crossover over the integral's corner frequency.
const INTEGRAL_RATIO: f64 = 5.0;

/// Guided-move settings (`force_controller.guided` in the scene files).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct GuidedParams {
    /// Force to hold along x, y, z of the BioTac frame (N).
    pub target_force_n: [f64; 3],
    /// Deadband on the force error (N).
    #[schemars(range(min = 0.0))]
    pub deadband_n: f64,
    /// Force magnitude above which the arm stops (N).
    pub force_limit_n: f64,
    /// Force magnitude that means a finger is there (N).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub contact_force_n: f64,
    /// Time without a finger after which the move stops (s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub contact_timeout_s: f64,
    /// Distance from the start after which the move stops (m).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_travel_m: f64,
    /// Speed of the retract after an oscillation (m/s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub retract_speed_mps: f64,
    /// Distance of that retract along the pad's normal (m).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub retract_distance_m: f64,
    /// The margins the gains keep: following a finger trades some of the
    /// hold's damping (`pd.margins`) for a smaller lag behind it.
    pub margins: Margins,
}

impl Check for GuidedParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        let t = Vector3::from(self.target_force_n);
        if !t.iter().all(|v| v.is_finite()) {
            let key = format!("{key}.target_force_n");
            return Err(invalid(&key, t.norm(), "finite values"));
        }
        check_ranges(&self, key)?;
        if self.force_limit_n.is_nan() || self.force_limit_n <= t.norm() {
            return Err(invalid(
                &format!("{key}.force_limit_n"),
                self.force_limit_n,
                "above the target force's magnitude",
            ));
        }
        self.margins.check(&format!("{key}.margins"))?;
        Ok(self)
    }
}

/// What the guided move sees each cycle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GuidedInput {
    /// Estimated force, BioTac frame (N).
    pub force: Vector3<f64>,
    /// True when the input is outside what the estimator knows.
    pub out_of_range: bool,
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
    watchdogs: [OscillationDetector; 3],
    /// The probe under way, the probes left and the dynamic stiffness each
    /// axis showed (N/m; src/control/probe.rs).
    probe: Option<Probe>,
    probes_left: u32,
    probed: [Option<f64>; 3],
    /// The times the watchdog lowered each axis's gain.
    lowered: [u32; 3],
    /// The factor the watchdog raised each axis's stiffness by.
    stiffer: [f64; 3],
    /// The finger's velocity across the pad, x and y, low-passed (m/s).
    finger: [f64; 2],
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
    retract_from_m: f64,
    phase: Phase,
    reason: Option<StopReason>,
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
        let watchdog = || OscillationDetector::new(law.oscillation.threshold_n);
        GuidedMove {
            pd: controlled.map(|c| c.then(axis)),
            // Each reading a sample: averaged over 40 ms, the x/y loop missed
            // off-axis (14.5 % at a 16 ms cycle, the embedded hold_sweep).
            stiffness: ContactStiffness::new(law.skin, 0.0),
            prior_body,
            watchdogs: [watchdog(), watchdog(), watchdog()],
            probe: None,
            probes_left: PROBES,
            probed: [None; 3],
            lowered: [0; 3],
            stiffer: [1.0; 3],
            finger: [0.0; 2],
            integral: [0.0; 3],
            arm: None,
            since_fresh_s: 0.0,
            without_contact_s: 0.0,
            pressed: false,
            retract_from_m: 0.0,
            law: *law,
            p: *p,
            phase: Phase::Follow,
            reason: None,
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
        self.phase = Phase::Stopped;
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
        let smooth_s = i.timing.dead_s() + i.timing.lag_s;
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
        let feeds = [0, 1, 2].map(|j| j < 2 && integrates[j]);
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
                // Across the pad, the finger's velocity: the arm's, and the
                // force's rate through the contact's stiffness
                // (F = k (x_finger - x_arm)), low-passed over the loop's
                // delay and lag (the module's doc).
                if let (Some(arm), true) = (self.arm, feeds[j]) {
                    let raw = arm[j] + pd.force_rate() / k[j];
                    self.finger[j] += (raw - self.finger[j]) * i.dt / (smooth_s + i.dt);
                    let finger = self.finger[j];
                    let along =
                        finger.signum() * (finger.abs() - FEEDFORWARD_DEADBAND_MPS).max(0.0);
                    v[j] += FEEDFORWARD_SHARE * along;
                }
                v[j] = v[j].clamp(-max_speed, max_speed);
            }
        }
        self.since_fresh_s += i.dt;
        match self.phase {
            Phase::Follow => self.follow(i, v),
            Phase::Retract if i.moved.z < self.retract_from_m + p.retract_distance_m => {
                Vector3::new(0.0, 0.0, p.retract_speed_mps)
            }
            Phase::Retract => {
                self.phase = Phase::Stopped;
                Vector3::zeros()
            }
            _ => Vector3::zeros(),
        }
    }

    /// Following: the limits, then the fit and the watchdogs on a new
    /// estimate; the PD's velocity `v` while none stops it.
    fn follow(&mut self, i: &GuidedInput, v: Vector3<f64>) -> Vector3<f64> {
        let p = self.p;
        // An estimate outside what the GP knows says nothing about the
        // force, so it is not read as over the limit.
        let stop = if i.out_of_range {
            Some(StopReason::OutOfRange)
        } else if i.force.norm() > p.force_limit_n {
            Some(StopReason::ForceLimit)
        } else if i.moved.norm() >= p.max_travel_m {
            Some(StopReason::TravelLimit)
        } else if self.without_contact_s >= p.contact_timeout_s {
            Some(StopReason::Timeout)
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
        if let (Some(x), true, false) = (i.position, i.force.z >= p.contact_force_n, self.pressed) {
            self.stiffness.push(dt, -x.z, i.force.z);
        }
        self.run_probe(i);
        if self.probe.is_some() {
            // The probe's swings are the pad's own: no watchdog counts them.
            return v + probing;
        }
        for j in 0..3 {
            if self.pd[j].is_none() || !self.watchdogs[j].step(i.force[j], dt) {
                continue;
            }
            if let Some(v) = self.on_oscillation(j, i.moved.z) {
                return v;
            }
        }
        v
    }

    /// Once the first press holds, probes the contact (src/control/probe.rs)
    /// until every controlled axis is measured or [`PROBES`] were tried; a
    /// probe that loses the contact is dropped.
    fn run_probe(&mut self, i: &GuidedInput) {
        let controlled = |j: usize| self.pd[j].is_some();
        let in_contact = i.force.z >= self.p.contact_force_n;
        let missing = (0..3).any(|j| controlled(j) && self.probed[j].is_none());
        let Some(probe) = self.probe.as_mut() else {
            if self.pressed && in_contact && missing && self.probes_left > 0 {
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
            if controlled(j) {
                self.probed[j] = self.probed[j].or(k);
            }
        }
        self.probe = None;
        self.watchdogs
            .iter_mut()
            .for_each(OscillationDetector::reset);
        let [x, y, z] = self.probed.map(|k| k.map(f64::round));
        tracing::info!("the contact measured (N/m; None: not measured): x {x:?}, y {y:?}, z {z:?}");
    }

    /// The watchdog saw axis `j` oscillate: the contact is stiffer than
    /// taken, so its stiffness is raised by the inverse of the gain factor
    /// (which lowers the gain by that factor, and the finger's velocity
    /// the feedforward reads from the force's rate), up to [`SOFTENINGS`]
    /// times; then the pad retracts along its normal from `normal_m`, the
    /// retract's velocity returned.
    fn on_oscillation(&mut self, j: usize, normal_m: f64) -> Option<Vector3<f64>> {
        let hz = self.watchdogs[j].frequency_hz();
        let axis = ["x", "y", "z"][j];
        if self.lowered[j] >= SOFTENINGS {
            tracing::warn!(
                "the force along {axis} oscillates at {hz:.1} Hz with its gain lowered \
                 {SOFTENINGS} times: retracting"
            );
            self.phase = Phase::Retract;
            self.reason = Some(StopReason::Oscillating);
            self.retract_from_m = normal_m;
            return Some(Vector3::new(0.0, 0.0, self.p.retract_speed_mps));
        }
        self.lowered[j] += 1;
        self.integral[j] = 0.0;
        let factor = self.law.oscillation.gain_factor;
        self.stiffer[j] /= factor;
        tracing::warn!(
            "the force along {axis} oscillates at {hz:.1} Hz: its gain lowered by a factor {factor}"
        );
        None
    }
}

impl TaskSection for GuidedParams {
    const NAME: &'static str = "guided";

    /// The gains for `body` (the stiffest the scene permits) until the
    /// finger is measured, on the controlled force axes.
    fn build(p: Checked<Self>, lp: &TaskLoop, body: &BodyParams) -> Box<dyn Task> {
        Box::new(GuidedMove::new(
            p,
            &lp.law(),
            lp.forces(),
            body.stiffness_n_per_m,
        ))
    }

    /// The controlled axis that allows the slowest motion towards `body`.
    /// On each axis the PD stops advancing past the target plus the
    /// deadband, and the axis may take what the force limit leaves beside
    /// the other axes' targets.
    fn envelope(
        p: &Checked<Self>,
        lp: &TaskLoop,
        body: &BodyParams,
        name: &str,
    ) -> Result<TaskEnvelope, ParamsError> {
        let forces = lp.forces();
        let t = p.target_force_n;
        let total: f64 = t.iter().map(|v| v * v).sum();
        let envelope = (0..3)
            .filter(|&i| forces[i])
            .map(|i| Envelope {
                skin: **lp.skin,
                stiffness_n_per_m: if i == 2 {
                    body.stiffness_n_per_m
                } else {
                    shear_stiffness(lp.skin, body)
                },
                shear: i != 2,
                trigger_n: t[i].abs() + p.deadband_n,
                target_n: t[i].abs(),
                limit_n: (p.force_limit_n.powi(2) - (total - t[i] * t[i])).sqrt(),
                reaction_s: lp.reaction_s(),
            })
            .min_by(|a, b| a.max_speed_mps().total_cmp(&b.max_speed_mps()))
            .ok_or_else(|| missing_axis(lp.axes, Axis::Fz))?;
        Ok(TaskEnvelope {
            envelope,
            body: name.into(),
            key: "pd.max_speed_mps",
            speed_mps: lp.pd.max_speed_mps,
        })
    }
}

/// The guided move as the controller runs it: in the BioTac's frame as it
/// turns, the orientation held.
impl Task for GuidedMove {
    fn step(&mut self, i: &TaskInput) -> Twist {
        let moved = i.pose.translation.vector - i.start.translation.vector;
        let input = GuidedInput {
            force: *i.force,
            out_of_range: i.out_of_range,
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
        self.finger = [0.0; 2];
        self.integral = [0.0; 3];
        self.arm = None;
        self.watchdogs
            .iter_mut()
            .for_each(OscillationDetector::reset);
        self.since_fresh_s = 0.0;
        self.probe = None;
    }

    fn stop(&mut self) {
        self.phase = Phase::Stopped;
    }

    fn stop_on(&mut self, reason: StopReason) {
        self.stop_with(reason);
    }

    fn figures(&self) -> TaskFigures {
        let k = self.stiffness();
        TaskFigures {
            stiffness_n_per_m: std::array::from_fn(|j| self.pd[j].as_ref().map(|_| k[j])),
            body_n_per_m: self.stiffness.body(),
            settled_sd_n: None,
            softened: self.lowered.iter().sum(),
        }
    }
}

#[cfg(test)]
mod tests;
