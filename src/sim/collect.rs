//! The thesis data-collection protocol (Huhnstock 2014, section 3.2).
//!
//! Four sets of trials: pushes mainly in x, mainly in y, mainly in z, and
//! combined (the force rotates in the x-y plane while z varies); 10 trials of
//! ~20 s per set at 100 Hz; the BioTac and the F/T reference are recorded
//! together. Here a plate presses on the pad of a simulated BioTac
//! ([`crate::biotac::sim`]) and the reference is the true contact wrench plus
//! Gaussian noise.
//!
//! Frames and signs: BioTac core frame (+x tip, -z pad); forces are those the
//! plate applies to the finger, so pressing into the pad is +z.
//!
//! A trial: `tare_samples` out of contact (for the tare), then `pushes`
//! raised-cosine pulses separated by rests of at least `min_rest_s`, ending
//! out of contact. Within a push of duration `D` started at `t0`,
//!
//! ```text
//! w(t)  = (1 - cos(2 pi (t - t0) / D)) / 2      in [0, 1]
//! Fn(t) = N w(t)                                 normal, into the skin
//! Ft(t) = T w(t)^2 (cos th(t) t1 + sin th(t) t2) tangential, th(t) = th0 + omega (t - t0)
//! ```
//!
//! with `N >= T / max_traction_ratio`, so `|Ft| / Fn = (T / N) w <= max_traction_ratio`
//! at every instant: the plate sticks (friction coefficient ~1).

use std::path::Path;

use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::biotac::geometry::SKIN_RADIUS_MM;
use crate::biotac::sim::{
    check_range, check_value, gaussian, read_config, uniform, BioTacSim, BioTacSimConfig,
    ConfigError, Contact, DEFAULT_CONFIG_YAML,
};
use crate::record::Record;
use crate::wrench::Wrench;

/// One set of trials (`protocol.sets.<name>`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetSpec {
    /// Pushes per trial.
    pub pushes: u32,
    /// Duration of one push (s), range.
    pub push_duration_s: [f64; 2],
    /// Peak normal force of a push (N), range; raised to
    /// tangential peak / `max_traction_ratio` when lower.
    pub normal_peak_n: [f64; 2],
    /// Peak tangential force of a push (N), range.
    pub tangential_peak_n: [f64; 2],
    /// Base tangential directions (deg, 0 = +x, 90 = +y on the pad), used in
    /// turn from a random start.
    pub directions_deg: Vec<f64>,
    /// Uniform jitter added to each push's base direction (+- deg).
    pub direction_jitter_deg: f64,
    /// Rotation rate of the direction during a push (deg/s), range; random sign.
    pub rotation_deg_per_s: [f64; 2],
}

impl SetSpec {
    /// Largest normal force a push of this set can reach (N).
    pub fn max_normal_n(&self, max_traction_ratio: f64) -> f64 {
        self.normal_peak_n[1].max(self.tangential_peak_n[1] / max_traction_ratio)
    }
}

/// The four sets, in set-number order 1..=4 (`protocol.sets`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetSpecs {
    /// Set 1: pushes mainly in x.
    pub x: SetSpec,
    /// Set 2: pushes mainly in y.
    pub y: SetSpec,
    /// Set 3: pushes mainly in z.
    pub z: SetSpec,
    /// Set 4: force rotating in the x-y plane with varying z.
    pub combined: SetSpec,
}

impl SetSpecs {
    /// `(set number, key, spec)` for sets 1..=4.
    pub fn numbered(&self) -> [(u32, &'static str, &SetSpec); 4] {
        [
            (1, "x", &self.x),
            (2, "y", &self.y),
            (3, "z", &self.z),
            (4, "combined", &self.combined),
        ]
    }
}

/// Standard deviation of the F/T reference noise per axis (`protocol.ft_noise_std`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FtNoiseStd {
    /// Forces fx, fy, fz (N).
    pub force_n: [f64; 3],
    /// Torques tx, ty, tz (Nm).
    pub torque_nm: [f64; 3],
}

/// What changes between two sessions of the same unit (`protocol.session`):
/// each drawn once per session.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionParams {
    /// Shift of every contact along the axis after re-mounting (mm), range.
    pub mount_offset_x_mm: [f64; 2],
    /// Rotation of every contact about +x after re-mounting (deg), range.
    pub mount_offset_angle_deg: [f64; 2],
    /// Relative change of the electrodes' response to contact (1 +- this).
    pub sensitivity_spread: f64,
}

/// The protocol parameters as written in the `protocol:` section.
/// Validate them with [`ProtocolParams::validate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ProtocolParams {
    /// Trials per set.
    pub trials_per_set: u32,
    /// Length of one trial (s).
    pub trial_duration_s: f64,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Samples out of contact at the start of every trial, for the tare.
    pub tare_samples: u32,
    /// Shortest rest out of contact after the tare, between pushes and at the end (s).
    pub min_rest_s: f64,
    /// Largest |tangential| / normal force applied (below the friction coefficient).
    pub max_traction_ratio: f64,
    /// Contact position along the axis, drawn per trial (mm), range.
    pub contact_x_mm: [f64; 2],
    /// Contact angle about +x, drawn per trial (deg, 0 = pad midline), range.
    pub contact_angle_deg: [f64; 2],
    /// TDC rise per trial (counts).
    pub tdc_drift_per_trial_counts: f64,
    /// Std of the F/T reference noise per axis.
    pub ft_noise_std: FtNoiseStd,
    /// What differs between sessions of one unit.
    pub session: SessionParams,
    /// The four sets.
    pub sets: SetSpecs,
}

/// The shape of the simulator file as the protocol reads it: the `sensor:`
/// section belongs to [`BioTacSimConfig`].
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ProtocolFile {
    #[serde(default, rename = "sensor")]
    _sensor: serde::de::IgnoredAny,
    protocol: ProtocolParams,
}

impl ProtocolParams {
    /// The timing the push schedule reads.
    pub(crate) fn timing(&self) -> PushTiming {
        PushTiming {
            trial_duration_s: self.trial_duration_s,
            rate_hz: self.rate_hz,
            tare_samples: self.tare_samples,
            min_rest_s: self.min_rest_s,
            max_traction_ratio: self.max_traction_ratio,
        }
    }

    /// Checks every value (finite, in range, pushes fit the trial) and
    /// returns the checked config.
    pub fn validate(self) -> Result<CollectConfig, ConfigError> {
        let (f, t) = (&self.ft_noise_std.force_n, &self.ft_noise_std.torque_nm);
        let samples = self.trial_duration_s * self.rate_hz;
        // Key, value, allowed [min, max]; the order matters where a bound uses
        // an earlier value.
        #[rustfmt::skip]
        let values = [
            ("protocol.trials_per_set", f64::from(self.trials_per_set), 1.0, 1e4),
            ("protocol.trial_duration_s", self.trial_duration_s, 0.01, 3600.0),
            ("protocol.rate_hz", self.rate_hz, 1.0, 1e4),
            ("protocol.tare_samples", f64::from(self.tare_samples), 1.0, samples - 1.0),
            ("protocol.min_rest_s", self.min_rest_s, 0.0, self.trial_duration_s),
            ("protocol.max_traction_ratio", self.max_traction_ratio, 1e-3, 2.0),
            ("protocol.tdc_drift_per_trial_counts", self.tdc_drift_per_trial_counts, -100.0, 100.0),
            ("protocol.ft_noise_std.force_n[0]", f[0], 0.0, 100.0),
            ("protocol.ft_noise_std.force_n[1]", f[1], 0.0, 100.0),
            ("protocol.ft_noise_std.force_n[2]", f[2], 0.0, 100.0),
            ("protocol.ft_noise_std.torque_nm[0]", t[0], 0.0, 10.0),
            ("protocol.ft_noise_std.torque_nm[1]", t[1], 0.0, 10.0),
            ("protocol.ft_noise_std.torque_nm[2]", t[2], 0.0, 10.0),
            ("protocol.session.sensitivity_spread", self.session.sensitivity_spread, 0.0, 0.5),
        ];
        for (key, value, min, max) in values {
            check_value(key, value, min, max)?;
        }
        // Key, [low, high], allowed [min, max] for both ends.
        #[rustfmt::skip]
        let ranges = [
            ("protocol.contact_x_mm", self.contact_x_mm, -30.0, SKIN_RADIUS_MM),
            ("protocol.contact_angle_deg", self.contact_angle_deg, -90.0, 90.0),
            ("protocol.session.mount_offset_x_mm", self.session.mount_offset_x_mm, -10.0, 10.0),
            ("protocol.session.mount_offset_angle_deg", self.session.mount_offset_angle_deg, -45.0, 45.0),
        ];
        for (key, range, min, max) in ranges {
            check_range(key, range, min, max)?;
        }
        check_sets(&self.sets, &self.timing())?;
        Ok(CollectConfig { params: self })
    }
}

/// Checks the sets of a protocol: counts and ranges, and that the longest
/// pushes and their rests fit in a trial after the tare window.
pub(crate) fn check_sets(sets: &SetSpecs, timing: &PushTiming) -> Result<(), ConfigError> {
    let tare_s = f64::from(timing.tare_samples) / timing.rate_hz;
    for (_, name, s) in sets.numbered() {
        let key = |field: &str| format!("protocol.sets.{name}.{field}");
        check_value(&key("pushes"), f64::from(s.pushes), 1.0, 1e3)?;
        check_range(&key("push_duration_s"), s.push_duration_s, 1e-2, 3600.0)?;
        check_range(&key("normal_peak_n"), s.normal_peak_n, 0.0, 1e3)?;
        check_range(&key("tangential_peak_n"), s.tangential_peak_n, 0.0, 1e3)?;
        check_value(
            &key("direction_jitter_deg"),
            s.direction_jitter_deg,
            0.0,
            180.0,
        )?;
        check_range(
            &key("rotation_deg_per_s"),
            s.rotation_deg_per_s,
            0.0,
            3600.0,
        )?;
        if s.directions_deg.is_empty() {
            return Err(ConfigError::Empty {
                key: key("directions_deg"),
            });
        }
        for (i, &d) in s.directions_deg.iter().enumerate() {
            check_value(&key(&format!("directions_deg[{i}]")), d, -360.0, 360.0)?;
        }
        // The longest pushes and the rests must fit after the tare window.
        let pushes = f64::from(s.pushes);
        let room = timing.trial_duration_s - tare_s - (pushes + 1.0) * timing.min_rest_s;
        if s.push_duration_s[1] * pushes > room {
            return Err(ConfigError::Value {
                key: key("push_duration_s[1]"),
                value: s.push_duration_s[1],
                expected: format!(
                    "at most {:.3} s, so that {} pushes and {} rests of protocol.min_rest_s \
                     fit in protocol.trial_duration_s after the tare",
                    room / pushes,
                    s.pushes,
                    s.pushes + 1
                ),
            });
        }
    }
    Ok(())
}

/// Checked protocol parameters; build with [`CollectConfig::from_yaml_str`],
/// [`CollectConfig::from_file`] or `Default` (the shipped `config/biotac_sim.yaml`).
#[derive(Debug, Clone, PartialEq)]
pub struct CollectConfig {
    params: ProtocolParams,
}

impl CollectConfig {
    /// Parses the `protocol:` section of a simulator YAML file and validates it.
    pub fn from_yaml_str(yaml: &str) -> Result<Self, ConfigError> {
        let file: ProtocolFile = serde_yaml_ng::from_str(yaml)?;
        file.protocol.validate()
    }

    /// Reads and validates a simulator YAML file.
    pub fn from_file(path: &Path) -> Result<Self, ConfigError> {
        Self::from_yaml_str(&read_config(path)?)
    }

    /// The validated parameters.
    pub fn params(&self) -> &ProtocolParams {
        &self.params
    }

    /// The same protocol with `trials` trials per set (at least 1).
    pub fn with_trials(&self, trials: u32) -> Result<Self, ConfigError> {
        ProtocolParams {
            trials_per_set: trials,
            ..self.params.clone()
        }
        .validate()
    }

    /// The same protocol with the finger mounted as the simulated arm holds
    /// it (`demo`): no mount offset and nominal sensitivity in every session.
    pub fn on_the_arm(&self) -> Self {
        let mut params = self.params.clone();
        params.session.mount_offset_x_mm = [0.0, 0.0];
        params.session.mount_offset_angle_deg = [0.0, 0.0];
        params.session.sensitivity_spread = 0.0;
        CollectConfig { params }
    }

    /// Samples per trial: `round(trial_duration_s * rate_hz)`.
    pub fn samples_per_trial(&self) -> usize {
        (self.params.trial_duration_s * self.params.rate_hz).round() as usize
    }

    /// Standard deviation of the F/T reference noise per axis (N, Nm): the
    /// noise floor of any estimate checked against the reference.
    pub fn ft_noise_std(&self) -> Wrench {
        Wrench::new(
            Vector3::from(self.params.ft_noise_std.force_n),
            Vector3::from(self.params.ft_noise_std.torque_nm),
        )
    }
}

impl Default for CollectConfig {
    /// The shipped `config/biotac_sim.yaml`.
    fn default() -> Self {
        // Checked by the unit tests; fails only if the shipped file is broken.
        Self::from_yaml_str(DEFAULT_CONFIG_YAML)
            .expect("config/biotac_sim.yaml shipped with the crate is valid")
    }
}

/// When a trial's pushes may happen and how hard they may pull sideways:
/// the part of a protocol that the push schedule reads.
#[derive(Debug, Clone, Copy)]
pub(crate) struct PushTiming {
    /// Length of one trial (s).
    pub trial_duration_s: f64,
    /// Sampling rate (Hz).
    pub rate_hz: f64,
    /// Samples out of contact at the start of every trial.
    pub tare_samples: u32,
    /// Shortest rest out of contact between pushes (s).
    pub min_rest_s: f64,
    /// Largest |tangential| / normal force.
    pub max_traction_ratio: f64,
}

/// One push of a trial.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Push {
    start_s: f64,
    duration_s: f64,
    normal_peak_n: f64,
    tangential_peak_n: f64,
    direction_rad: f64,
    rotation_rad_per_s: f64,
}

/// The force of a push at one instant, in the pad's frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PadForce {
    /// Into the pad (N).
    pub normal_n: f64,
    /// Along the pad (N).
    pub tangential_n: f64,
    /// Direction of the tangential force (rad, 0 = first pad tangent).
    pub direction_rad: f64,
}

impl Push {
    /// The push's force at `t` seconds into the trial, None outside it.
    fn at(&self, t: f64) -> Option<PadForce> {
        if !(t > self.start_s && t < self.start_s + self.duration_s) {
            return None;
        }
        let tau = t - self.start_s;
        let w = 0.5 * (1.0 - (std::f64::consts::TAU * tau / self.duration_s).cos());
        Some(PadForce {
            normal_n: self.normal_peak_n * w,
            tangential_n: self.tangential_peak_n * w * w,
            direction_rad: self.direction_rad + self.rotation_rad_per_s * tau,
        })
    }
}

/// The pushes of one trial of `set`, after the tare window, separated by
/// rests of at least `timing.min_rest_s` (the module's raised-cosine pulses).
pub(crate) fn sample_pushes(timing: &PushTiming, set: &SetSpec, rng: &mut impl Rng) -> Vec<Push> {
    let n = set.pushes as usize;
    let durations: Vec<f64> = (0..n).map(|_| uniform(rng, set.push_duration_s)).collect();
    // n + 1 rests (after the tare, between pushes, at the end) share the slack.
    let tare_s = f64::from(timing.tare_samples) / timing.rate_hz;
    let slack = (timing.trial_duration_s
        - tare_s
        - durations.iter().sum::<f64>()
        - (n + 1) as f64 * timing.min_rest_s)
        .max(0.0);
    let weights: Vec<f64> = (0..=n).map(|_| rng.random::<f64>() + 1e-3).collect();
    let total: f64 = weights.iter().sum();
    let first_direction = rng.random_range(0..set.directions_deg.len());
    let mut t = tare_s;
    durations
        .iter()
        .enumerate()
        .map(|(k, &duration_s)| {
            t += timing.min_rest_s + slack * weights[k] / total;
            let start_s = t;
            t += duration_s;
            let tangential_peak_n = uniform(rng, set.tangential_peak_n);
            let normal_peak_n =
                uniform(rng, set.normal_peak_n).max(tangential_peak_n / timing.max_traction_ratio);
            let base = set.directions_deg[(first_direction + k) % set.directions_deg.len()];
            let jitter = set.direction_jitter_deg * (2.0 * rng.random::<f64>() - 1.0);
            let sign = if rng.random::<bool>() { 1.0 } else { -1.0 };
            Push {
                start_s,
                duration_s,
                normal_peak_n,
                tangential_peak_n,
                direction_rad: (base + jitter).to_radians(),
                rotation_rad_per_s: sign * uniform(rng, set.rotation_deg_per_s).to_radians(),
            }
        })
        .collect()
}

/// The force of the push under way at `t` seconds into the trial, and the
/// push's index; None between pushes.
pub(crate) fn force_at(pushes: &[Push], t: f64) -> Option<(usize, PadForce)> {
    pushes
        .iter()
        .enumerate()
        .find_map(|(i, p)| p.at(t).map(|f| (i, f)))
}

/// Where and when the plate touches the finger during one trial.
#[derive(Debug, Clone)]
struct TrialPlan {
    x_mm: f64,
    angle_rad: f64,
    pushes: Vec<Push>,
}

impl TrialPlan {
    fn sample(p: &ProtocolParams, set: &SetSpec, mount: &Mount, rng: &mut impl Rng) -> Self {
        let x_mm = uniform(rng, p.contact_x_mm) + mount.x_mm;
        let angle_rad = (uniform(rng, p.contact_angle_deg) + mount.angle_deg).to_radians();
        let pushes = sample_pushes(&p.timing(), set, rng);
        TrialPlan {
            x_mm,
            angle_rad,
            pushes,
        }
    }

    /// The contact at `t` seconds into the trial, None between pushes.
    fn contact_at(&self, t: f64) -> Option<Contact> {
        let (_, f) = force_at(&self.pushes, t)?;
        let mut contact = Contact {
            x_mm: self.x_mm,
            angle_rad: self.angle_rad,
            force: Vector3::zeros(),
        };
        let surface = contact.surface();
        let (t1, t2) = surface.tangents();
        let (s, c) = f.direction_rad.sin_cos();
        contact.force = -surface.normal * f.normal_n + (t1 * c + t2 * s) * f.tangential_n;
        Some(contact)
    }
}

/// How the finger sits in its mount in one session.
#[derive(Debug, Clone, Copy)]
struct Mount {
    x_mm: f64,
    angle_deg: f64,
}

/// The seed of simulated BioTac unit `unit`: `collect(.., unit, ..)`
/// records `BioTacSim::new(config, unit_seed(unit))`.
pub fn unit_seed(unit: u64) -> u64 {
    ChaCha8Rng::seed_from_u64(unit).random()
}

/// Runs the protocol on simulated BioTac unit `unit` in session `session`:
/// sets 1..=4, trials 1..=`trials_per_set`, `samples_per_trial` rows each,
/// in that order.
///
/// The unit fixes the sensor's constants (per-electrode gains and thermal
/// baselines, PDC/PAC/TAC baselines: `sensor:` in the config). The session
/// draws, once, the temperature at its start, the mount (every contact
/// shifted and rotated by `protocol.session`'s offsets) and the electrodes'
/// sensitivity; then the pushes of every trial and all noise.
///
/// Each record holds the time since the trial start, the reading, and the
/// F/T reference: the true contact wrench ([`Contact::wrench`], about the
/// BioTac origin, in the BioTac frame) plus per-axis Gaussian noise of
/// [`CollectConfig::ft_noise_std`]. The temperature rises by
/// `tdc_drift_per_trial_counts` per trial, linearly within a trial.
pub fn collect(
    config: &CollectConfig,
    sim_config: &BioTacSimConfig,
    unit: u64,
    session: u64,
) -> Vec<Record> {
    let p = &config.params;
    let mut sim = BioTacSim::new(sim_config, unit_seed(unit));
    let mut rng = ChaCha8Rng::seed_from_u64(session);
    sim.reseed_noise(rng.random());
    let tdc0 = uniform(&mut rng, sim_config.params().tdc.initial_counts);
    let spread = p.session.sensitivity_spread;
    sim.set_sensitivity(uniform(&mut rng, [1.0 - spread, 1.0 + spread]));
    let mount = Mount {
        x_mm: uniform(&mut rng, p.session.mount_offset_x_mm),
        angle_deg: uniform(&mut rng, p.session.mount_offset_angle_deg),
    };
    let dt = 1.0 / p.rate_hz;
    let n = config.samples_per_trial();
    let noise = config.ft_noise_std();
    let mut records = Vec::with_capacity(4 * p.trials_per_set as usize * n);
    let mut trial_index = 0.0;
    for (set, _, spec) in p.sets.numbered() {
        for trial in 1..=p.trials_per_set {
            let plan = TrialPlan::sample(p, spec, &mount, &mut rng);
            for k in 0..n {
                let t = k as f64 * dt;
                let progress = trial_index + t / p.trial_duration_s;
                sim.set_temperature(tdc0 + p.tdc_drift_per_trial_counts * progress);
                let contact = plan.contact_at(t);
                let reading = sim.step(contact.as_ref(), dt);
                let truth = contact.map(|c| c.wrench()).unwrap_or_default();
                let wrench = Wrench::new(
                    truth.force + noise.force.map(|s| gaussian(&mut rng, s)),
                    truth.torque + noise.torque.map(|s| gaussian(&mut rng, s)),
                );
                records.push(Record {
                    t,
                    set,
                    trial,
                    reading,
                    wrench,
                });
            }
            trial_index += 1.0;
        }
    }
    records
}

#[cfg(test)]
mod tests;
