//! The simulated robot node: the arm plant, the object (fixed) or the
//! person's finger (moving on its path), the contact between them and the
//! BioTac pad, the F/T sensor and the BioTac simulator. Physics runs at
//! `physics_rate_hz` (1 kHz); sensing at the control period (100 Hz).
//!
//! Geometry: the body's surface is a plane facing the pad (its normal is +z
//! of the BioTac frame at the start), `object_gap_mm` below the pad point.
//! The pad point is the skin point at `contact_x_mm` that faces the body:
//! on the pad midline while the BioTac keeps its start orientation, around
//! the skin when it turns about its axis (the calibration's tilted presses).
//! The F/T sensor reports the wrench on the finger in the BioTac frame about
//! its origin, averaged over the physics steps of a period, each with
//! Gaussian noise.

use std::collections::BTreeMap;

use nalgebra::{Isometry3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::biotac::geometry::SurfacePoint;
use crate::biotac::sim::{gaussian, BioTacSim, BioTacSimConfig, Contact};
use crate::biotac::BioTacReading;
use crate::contact::{object_body, BodyParams, SkinParams};
use crate::control::JointState;
use crate::kinematics::{JointVector, Robot, RobotParams};
use crate::params::reference::check_ranges;
use crate::params::{invalid, Check, Checked, ParamsError};
use crate::sim::arm::ArmPlant;
use crate::sim::collect::unit_seed;
use crate::sim::contact::PlaneContact;
use crate::sim::finger::{FingerPath, FingerState, Segment};
use crate::wrench::Wrench;

/// The `sim_robot` parameters (world file + scene file).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SimRobotParams {
    /// Sensing and control period (s).
    #[schemars(range(min = 0.0001, max = 1.0))]
    pub control_period_s: f64,
    /// The BioTac skin law.
    pub skin: SkinParams,
    /// Objects the arm may touch, by name.
    pub objects: BTreeMap<String, BodyParams>,
    /// The object of this run (for the guided move: the person's fingertip).
    pub object: String,
    /// The arm: the links of its robot description, the BioTac's mount.
    pub robot: RobotParams,
    /// Physics rate (Hz); a multiple of the control rate.
    #[schemars(range(min = 1.0, max = 1e6))]
    pub physics_rate_hz: f64,
    /// The arm's command cycle (s): a command acts at the cycle after the
    /// one it arrives in (0: at once).
    #[schemars(range(min = 0.0))]
    pub command_cycle_s: f64,
    /// Delay before a joint velocity command acts, after its cycle (s).
    #[schemars(range(min = 0.0))]
    pub command_latency_s: f64,
    /// Time constant of the joints' velocity tracking (s).
    #[schemars(range(min = 0.0))]
    pub velocity_lag_s: f64,
    /// Joint positions at the start, one per joint of the chain (deg, or mm
    /// for a prismatic joint); absent: the middle of each joint's range.
    #[serde(default)]
    pub start_joints_deg: Option<Vec<f64>>,
    /// Where the pad touches, along the BioTac axis (mm).
    pub contact_x_mm: f64,
    /// Distance from the pad to the body's surface at the start (mm).
    pub object_gap_mm: f64,
    /// The body moves along this path (the guided move's finger); absent: fixed.
    #[schemars(with = "Option<Vec<String>>")]
    #[serde(skip_serializing)]
    pub finger_path: Option<Vec<Segment>>,
    /// F/T noise per physics step, forces (N, std).
    #[schemars(range(min = 0.0))]
    pub ft_noise_n: f64,
    /// F/T noise per physics step, torques (Nm, std).
    #[schemars(range(min = 0.0))]
    pub ft_noise_nm: f64,
    /// The simulated BioTac unit, numbered as `collect --unit` numbers them.
    pub sensor_unit: u64,
    /// Length of a run (s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub duration_s: f64,
    /// Jitter of the control period: each period lasts a uniformly drawn
    /// whole number of physics steps within +- this fraction (0: none).
    #[schemars(range(min = 0.0), extend("exclusiveMaximum" = 1.0))]
    pub period_jitter_fraction: f64,
    /// Embedded runtime only: delay of an estimate on its way to the
    /// controller (s), as over ROS 2.
    #[schemars(range(min = 0.0))]
    pub transport_delay_s: f64,
    /// Embedded runtime only: uniform jitter added to that delay (s).
    #[schemars(range(min = 0.0))]
    pub transport_jitter_s: f64,
}

/// What the simulated robot publishes each control period.
#[derive(Debug, Clone, PartialEq)]
pub struct SimSample {
    /// Simulated time (s).
    pub t: f64,
    /// The BioTac frame.
    pub reading: BioTacReading,
    /// Joint positions.
    pub joints: JointState,
    /// F/T measurement: wrench on the finger, BioTac frame (N, Nm).
    pub ft: Wrench,
    /// BioTac position relative to the start, in the start BioTac frame (m).
    pub offset: Vector3<f64>,
    /// BioTac velocity over the last period, start BioTac frame (m/s).
    pub velocity: Vector3<f64>,
    /// The finger, when the body moves.
    pub finger: Option<FingerState>,
}

/// The simulated robot node.
#[derive(Debug, Clone)]
pub struct SimRobot {
    robot: Robot,
    arm: ArmPlant,
    contact: PlaneContact,
    biotac: BioTacSim,
    path: Option<FingerPath>,
    /// When the finger's path began (s of simulated time); infinite while
    /// it waits ([`SimRobot::hold_finger`]).
    path_start_s: f64,
    contact_x_mm: f64,
    /// The contact point's angle about the BioTac's axis (rad), from its
    /// orientation to the body.
    contact_angle: f64,
    start: Isometry3<f64>,
    plane0: Vector3<f64>,
    normal: Vector3<f64>,
    dt: f64,
    steps_per_period: usize,
    jitter_steps: usize,
    period_s: f64,
    ft_noise: (f64, f64),
    rng: ChaCha8Rng,
    steps: u64,
    t: f64,
    force_sum: Vector3<f64>,
    noise_sum: Wrench,
    steps_in_period: usize,
    last_force: Vector3<f64>,
    last_offset: Vector3<f64>,
    duration_s: f64,
}

impl SimRobot {
    /// Checks the parameters and builds the world at rest around `robot`
    /// (built from the robot description with `p.robot`); `seed` drives
    /// every noise (F/T and BioTac), the BioTac is unit `sensor_unit` (as
    /// `collect --unit` numbers them).
    pub fn new(
        p: SimRobotParams,
        robot: Robot,
        sensor: &BioTacSimConfig,
        seed: u64,
    ) -> Result<Self, ParamsError> {
        let (skin, steps) = check(&p)?;
        let q0 = match &p.start_joints_deg {
            Some(values) => robot.positions_from_deg_mm("start_joints_deg", values)?,
            None => robot.middle(),
        };
        let body = object_body(&p.objects, &p.object)?;
        let path = p.finger_path.as_deref().map(FingerPath::new).transpose()?;
        if let Some(path) = &path {
            if path.duration_s() > p.duration_s {
                return Err(invalid(
                    "duration_s",
                    p.duration_s,
                    &format!("at least the finger path's {:.2} s", path.duration_s()),
                ));
            }
        }
        if !p.contact_x_mm.is_finite() || !p.object_gap_mm.is_finite() {
            return Err(invalid(
                "contact_x_mm/object_gap_mm",
                f64::NAN,
                "finite values",
            ));
        }

        let start = robot.chain.forward(&q0);
        let pad_tool = SurfacePoint::at(p.contact_x_mm, 0.0).point_mm * 1e-3;
        let normal = start.rotation * Vector3::z();
        let plane0 = start * nalgebra::Point3::from(pad_tool) - normal * p.object_gap_mm * 1e-3;
        let mut biotac = BioTacSim::new(sensor, unit_seed(p.sensor_unit));
        biotac.reseed_noise(seed);
        Ok(SimRobot {
            arm: ArmPlant::new(
                q0,
                &robot.limits,
                p.command_cycle_s,
                p.command_latency_s,
                p.velocity_lag_s,
            ),
            robot,
            contact: PlaneContact::new(skin, body),
            biotac,
            path,
            path_start_s: 0.0,
            contact_x_mm: p.contact_x_mm,
            contact_angle: 0.0,
            start,
            plane0: plane0.coords,
            normal,
            dt: 1.0 / p.physics_rate_hz,
            steps_per_period: steps,
            jitter_steps: (p.period_jitter_fraction * steps as f64).round() as usize,
            period_s: p.control_period_s,
            ft_noise: (p.ft_noise_n, p.ft_noise_nm),
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_f00d),
            steps: 0,
            t: 0.0,
            force_sum: Vector3::zeros(),
            noise_sum: Wrench::default(),
            steps_in_period: 0,
            last_force: Vector3::zeros(),
            last_offset: Vector3::zeros(),
            duration_s: p.duration_s,
        })
    }

    /// Keeps the finger at the start of its path until
    /// [`SimRobot::start_finger`] (the scene over ROS waits for estimates:
    /// a person pushes a finger that feels).
    pub fn hold_finger(&mut self) {
        self.path_start_s = f64::INFINITY;
    }

    /// Starts the finger's path now, if it was held; true when this call
    /// started it.
    pub fn start_finger(&mut self) -> bool {
        let held = self.path.is_some() && self.path_start_s.is_infinite();
        if held {
            self.path_start_s = self.t;
        }
        held
    }

    /// The finger at simulated time `t`.
    fn finger_at(&self, t: f64) -> Option<FingerState> {
        self.path.as_ref().map(|p| p.at(t - self.path_start_s))
    }

    /// Simulated time (s).
    pub fn time(&self) -> f64 {
        self.t
    }

    /// Length of the run (s).
    pub fn duration_s(&self) -> f64 {
        self.duration_s
    }

    /// The control period (s).
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// The contact body.
    pub fn body(&self) -> &BodyParams {
        self.contact.body()
    }

    /// The robot it simulates.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// The joint positions now (rad or m).
    pub fn joints(&self) -> &JointVector {
        self.arm.q()
    }

    /// Sends a joint velocity command now, one value per joint (the
    /// transports check the length).
    pub fn command(&mut self, qdot: &JointVector) {
        self.arm.command(self.t, qdot);
    }

    /// Runs the physics for one control period.
    pub fn advance(&mut self) {
        let j = self.jitter_steps;
        let steps = if j == 0 {
            self.steps_per_period
        } else {
            self.rng
                .random_range(self.steps_per_period - j..=self.steps_per_period + j)
        };
        for _ in 0..steps {
            self.arm.step(self.t, self.dt);
            // Counted, not summed, so the clock does not drift.
            self.steps += 1;
            self.t = self.steps as f64 * self.dt;
            let pose = self.robot.chain.forward(self.arm.q());
            // The skin point whose outward normal faces the body: the
            // body's normal n in the BioTac frame, the point's normal
            // (0, sin a, -cos a) = -n about the axis.
            let n = pose.rotation.inverse() * self.normal;
            self.contact_angle = (-n.y).atan2(n.z);
            let point = SurfacePoint::at(self.contact_x_mm, self.contact_angle).point_mm * 1e-3;
            let pad = (pose * nalgebra::Point3::from(point)).coords;
            let plane = match self.finger_at(self.t) {
                Some(finger) => self.plane0 + self.start.rotation * finger.offset,
                None => self.plane0,
            };
            let f_world = self.contact.step(&pad, &plane, &self.normal, self.dt);
            self.last_force = pose.rotation.inverse() * f_world;
            self.force_sum += self.last_force;
            let (sf, st) = self.ft_noise;
            self.noise_sum.force += Vector3::from_fn(|_, _| gaussian(&mut self.rng, sf));
            self.noise_sum.torque += Vector3::from_fn(|_, _| gaussian(&mut self.rng, st));
            self.steps_in_period += 1;
        }
    }

    /// Samples the sensors at the current time: the BioTac sees the force of
    /// the last physics step; the F/T sensor the period's average.
    pub fn sample(&mut self) -> SimSample {
        let contact = (self.last_force != Vector3::zeros()).then_some(Contact {
            x_mm: self.contact_x_mm,
            angle_rad: self.contact_angle,
            force: self.last_force,
        });
        let period_s = (self.steps_in_period.max(1) as f64 * self.dt).max(self.dt);
        let mut reading = self.biotac.step(contact.as_ref(), period_s);
        reading.stamp_s = self.t;
        let n = self.steps_in_period.max(1) as f64;
        let mean_force = if self.steps_in_period == 0 {
            self.last_force
        } else {
            self.force_sum / n
        };
        let truth = Contact {
            x_mm: self.contact_x_mm,
            angle_rad: self.contact_angle,
            force: mean_force,
        }
        .wrench();
        let ft = Wrench::new(
            truth.force + self.noise_sum.force / n,
            truth.torque + self.noise_sum.torque / n,
        );
        self.force_sum = Vector3::zeros();
        self.noise_sum = Wrench::default();
        self.steps_in_period = 0;
        let pose = self.robot.chain.forward(self.arm.q());
        let offset = self.start.rotation.inverse()
            * (pose.translation.vector - self.start.translation.vector);
        let velocity = (offset - self.last_offset) / period_s;
        self.last_offset = offset;
        SimSample {
            t: self.t,
            reading,
            joints: JointState {
                stamp_s: self.t,
                q: self.arm.q().clone(),
            },
            ft,
            offset,
            velocity,
            finger: self.finger_at(self.t),
        }
    }
}

/// `p` checked: its skin, and the physics steps per control period.
fn check(p: &SimRobotParams) -> Result<(Checked<SkinParams>, usize), ParamsError> {
    // Every range a field declares (the physics steps per period bounded).
    check_ranges(p, "")?;
    let skin = p.skin.checked("skin")?;
    let ratio = p.control_period_s * p.physics_rate_hz;
    if (ratio - ratio.round()).abs() > 1e-9 || ratio < 1.0 {
        return Err(invalid(
            "physics_rate_hz",
            p.physics_rate_hz,
            "a whole multiple of the control rate",
        ));
    }
    Ok((skin, ratio.round() as usize))
}
/// The fastest simulated time a node may run at: a period of 0.1 ms of
/// wall clock at 100 Hz.
pub const MAX_REAL_TIME_FACTOR: f64 = 100.0;

/// Refuses a real-time factor (simulated seconds per wall-clock second)
/// other than 1 without simulated time (`use_sim_time`), or outside
/// 1..=[`MAX_REAL_TIME_FACTOR`].
pub fn check_real_time_factor(speed: f64, sim_time: bool) -> Result<(), ParamsError> {
    if (1.0..=MAX_REAL_TIME_FACTOR).contains(&speed) && (sim_time || speed == 1.0) {
        return Ok(());
    }
    Err(ParamsError::Invalid {
        key: "real_time_factor".into(),
        value: speed.to_string(),
        expected: format!(
            "1, or up to {MAX_REAL_TIME_FACTOR} with use_sim_time:=true (stamps on the \
             system clock cannot run faster than it; slower than real time the \
             controller would take each estimate for late)"
        ),
    })
}

/// The joint velocities the simulated arm follows: the latest command,
/// held for ever as ros2_control's forward command controllers hold it
/// (`command_timeout_s` 0), or zero once none came for `command_timeout_s`.
#[derive(Debug, Clone)]
pub struct HeldCommand {
    timeout_s: f64,
    qdot: JointVector,
    zero: JointVector,
    at_s: f64,
}

impl HeldCommand {
    /// Zero for `dof` joints until a command comes; a timeout below 0 or
    /// not finite is refused.
    pub fn new(dof: usize, timeout_s: f64) -> Result<Self, ParamsError> {
        if !(timeout_s >= 0.0 && timeout_s.is_finite()) {
            return Err(ParamsError::Invalid {
                key: "command_timeout_s".into(),
                value: timeout_s.to_string(),
                expected: "0 (hold the last command) or a timeout in seconds".into(),
            });
        }
        Ok(HeldCommand {
            timeout_s,
            qdot: JointVector::zeros(dof),
            zero: JointVector::zeros(dof),
            at_s: f64::NEG_INFINITY,
        })
    }

    /// A command came at `now_s`.
    pub fn command(&mut self, qdot: JointVector, now_s: f64) {
        self.qdot = qdot;
        self.at_s = now_s;
    }

    /// What the arm does at `now_s`.
    pub fn at(&self, now_s: f64) -> &JointVector {
        match self.timeout_s > 0.0 && now_s - self.at_s > self.timeout_s {
            true => &self.zero,
            false => &self.qdot,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::TaskKind;
    use crate::runtime::scene::Scene;

    /// The guided scene's simulated robot after `held_s` of a held finger,
    /// then `run_s` from its start; the finger's offset at each end (m).
    fn finger_after(held_s: f64, run_s: f64) -> (f64, f64) {
        let scene = Scene::builtin(TaskKind::Guided).unwrap();
        let (_, mut sim, _) = scene
            .controller_and_sim(&BioTacSimConfig::default(), 0)
            .unwrap();
        let period_s = sim.period_s();
        let periods = |s: f64| (s / period_s).round() as usize;
        let moved = |sim: &mut SimRobot| sim.sample().finger.unwrap().offset.norm();
        sim.hold_finger();
        for _ in 0..periods(held_s) {
            sim.advance();
        }
        let held = moved(&mut sim);
        assert!(sim.start_finger() && !sim.start_finger());
        for _ in 0..periods(run_s) {
            sim.advance();
        }
        (held, moved(&mut sim))
    }

    #[test]
    fn a_held_finger_waits_and_then_runs_its_whole_path_from_its_start() {
        // The guided scene's path: waits 2 s, then pushes 30 mm along x.
        let (held, early) = finger_after(5.0, 1.9);
        assert_eq!((held, early), (0.0, 0.0));
        let (_, pushed) = finger_after(5.0, 3.2);
        assert!((pushed - 0.030).abs() < 1e-3, "{pushed} m");
    }

    #[test]
    fn a_real_time_factor_needs_simulated_time_and_stays_within_100() {
        check_real_time_factor(1.0, false).unwrap();
        assert!(HeldCommand::new(6, -1.0).is_err());
        check_real_time_factor(20.0, true).unwrap();
        for (speed, sim_time) in [(2.0, false), (0.5, true), (101.0, true), (f64::NAN, true)] {
            let e = check_real_time_factor(speed, sim_time)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains("real_time_factor") && e.contains("use_sim_time"),
                "{e}"
            );
        }
    }

    #[test]
    fn a_command_is_held_for_ever_or_until_its_timeout() {
        let v = JointVector::from_element(2, 0.1);
        let mut held = HeldCommand::new(2, 0.0).unwrap();
        assert_eq!(held.at(0.0).norm(), 0.0, "zero until a command");
        held.command(v.clone(), 1.0);
        assert_eq!(held.at(1000.0), &v, "a forward command controller holds it");
        let mut timed = HeldCommand::new(2, 0.1).unwrap();
        timed.command(v.clone(), 1.0);
        assert_eq!(timed.at(1.05), &v);
        assert_eq!(timed.at(1.15).norm(), 0.0);
    }
}
