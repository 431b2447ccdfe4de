//! BioTac forward model: a contact on the skin -> one [`BioTacReading`].
//!
//! Frames and signs: the BioTac core frame (+x towards the tip, -z is the pad),
//! positions in mm, forces in N. [`Contact::force`] is the force the object
//! applies to the finger, so pressing into the pad pushes the finger towards +z.
//!
//! The model, per electrode `i` with skin point `s_i` (the electrode projected
//! onto the capsule) and a contact at skin point `c` with outward normal `n`:
//!
//! ```text
//! Fn  = max(0, -F.n)                      normal (compressive) force, N
//! Ft  = F - (F.n) n                       tangential force, N
//! u_i = Fn exp(-|s_i-c|^2 / 2 wp^2)                        pressure footprint
//!     + k_s Ft.(s_i-c)/ws exp(-|s_i-c|^2 / 2 ws^2)         skin shift
//! dZ_i = g_i Zc tanh(u_i / uc)                  u_i >= 0: compression, bottoms out
//!      = -r Z0_i tanh(g_i Zc |u_i| / (uc r Z0_i)) u_i < 0: skin lifts off
//! E0_i = a_i (1 - exp(c_i (TDC + b_i))) + d_i   thermal baseline
//! Z0_i = 10 kOhm (4095 / E0_i - 1)              baseline impedance
//! E_i  = 4095 / (1 + (Z0_i + dZ_i) / 10 kOhm) + noise
//! ```
//!
//! Facts (docs/ARCHITECTURE.md, "Reference facts / BioTac"): the value law
//! `E = 4095 / (1 + Z / 10 kOhm)` (compression raises Z, so values drop), the
//! thermal baseline formula and its coefficient ranges, PDC rising with force
//! and saturating, tangential force sliding the skin so side electrodes
//! respond. The footprint and shift kernels are modelling choices: the shift
//! term is the first-order change of a footprint that slides along `Ft`, so
//! electrodes ahead of the shift see more compression and those behind less.
//! All parameters are in `config/biotac_sim.yaml`.

use nalgebra::Vector3;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

mod config;

use config::ADC;
pub(crate) use config::{check_range, check_value, gaussian, read_config, uniform};
pub use config::{
    BioTacSimConfig, ConfigError, ElectrodeParams, PacParams, PdcParams, SensorParams, TacParams,
    TdcParams, ThermalRanges,
};

use super::geometry::{electrodes, SurfacePoint};
use super::{BioTacReading, Electrodes, Pac};
use crate::wrench::Wrench;

/// The simulator configuration shipped with the crate (sensor and protocol).
pub const DEFAULT_CONFIG_YAML: &str = include_str!("../../config/biotac_sim.yaml");

/// Series resistance of the electrode readout (kOhm): `E = 4095 / (1 + Z / 10 kOhm)`.
/// Architecture page, "Reference facts / BioTac".
const READOUT_KOHM: f64 = 10.0;

/// A contact between an object and the skin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Contact {
    /// Contact point along the axis (mm, core frame); clamped to the tip.
    pub x_mm: f64,
    /// Contact point angle about +x (rad): 0 = pad midline (-z), + towards +y.
    pub angle_rad: f64,
    /// Force the object applies to the finger (N, core frame); pressing into
    /// the pad is +z.
    pub force: Vector3<f64>,
}

impl Contact {
    /// The contact point on the skin capsule and its outward normal.
    pub fn surface(&self) -> SurfacePoint {
        SurfacePoint::at(self.x_mm, self.angle_rad)
    }

    /// Compressive normal force `max(0, -F.n)` (N).
    pub fn normal_force(&self) -> f64 {
        (-self.force.dot(&self.surface().normal)).max(0.0)
    }

    /// The wrench on the finger about the core-frame origin: force (N) and
    /// torque `r x F` (Nm) with `r` the contact point in metres. This is what
    /// an ideal F/T reference reports, expressed in the BioTac frame.
    pub fn wrench(&self) -> Wrench {
        let r_m = self.surface().point_mm * 1e-3;
        Wrench::new(self.force, r_m.cross(&self.force))
    }
}

/// Thermal baseline coefficients of one electrode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ThermalCoeffs {
    /// Amplitude (counts).
    pub a: f64,
    /// Temperature offset (TDC counts).
    pub b: f64,
    /// Rate (1 / TDC count).
    pub c: f64,
    /// Offset (counts).
    pub d: f64,
}

impl ThermalCoeffs {
    /// Out-of-contact electrode value at temperature `tdc` (counts):
    /// `E0 = a (1 - exp(c (TDC + b))) + d` (architecture page).
    pub fn baseline(&self, tdc: f64) -> f64 {
        self.a * (1.0 - (self.c * (tdc + self.b)).exp()) + self.d
    }
}

/// Per-electrode constants fixed for a simulated unit.
#[derive(Debug, Clone, Copy)]
struct ElectrodeUnit {
    thermal: ThermalCoeffs,
    gain: f64,
    skin_point_mm: Vector3<f64>,
}

/// A simulated BioTac unit: per-unit baselines drawn from the config with
/// `unit_seed`, its own noise stream, a temperature and a frame clock.
#[derive(Debug, Clone)]
pub struct BioTacSim {
    params: SensorParams,
    electrodes: Vec<ElectrodeUnit>,
    pdc_baseline: f64,
    pac_baseline: f64,
    tac_baseline: f64,
    tdc: f64,
    sensitivity: f64,
    last_normal_n: f64,
    last_rate_n_per_s: f64,
    seq: u16,
    stamp_s: f64,
    rng: ChaCha8Rng,
}

impl BioTacSim {
    /// A unit with baselines drawn from `config` using `unit_seed`; the same
    /// seed gives the same unit and the same noise sequence.
    pub fn new(config: &BioTacSimConfig, unit_seed: u64) -> Self {
        let p = config.params().clone();
        let mut rng = ChaCha8Rng::seed_from_u64(unit_seed);
        let t = &p.electrodes.thermal;
        let spread = p.electrodes.gain_spread;
        let electrodes = electrodes(p.layout)
            .map(|e| {
                let thermal = ThermalCoeffs {
                    a: uniform(&mut rng, t.a_counts),
                    b: uniform(&mut rng, t.b_counts),
                    c: uniform(&mut rng, t.c_per_count),
                    d: uniform(&mut rng, t.d_counts),
                };
                let skin_point_mm = SurfacePoint::project(&e.position()).point_mm;
                ElectrodeUnit {
                    thermal,
                    gain: uniform(&mut rng, [1.0 - spread, 1.0 + spread]),
                    skin_point_mm,
                }
            })
            .collect();
        BioTacSim {
            pdc_baseline: uniform(&mut rng, p.pdc.baseline_counts),
            pac_baseline: uniform(&mut rng, p.pac.baseline_counts),
            tac_baseline: uniform(&mut rng, p.tac.baseline_counts),
            tdc: uniform(&mut rng, p.tdc.initial_counts),
            electrodes,
            params: p,
            sensitivity: 1.0,
            last_normal_n: 0.0,
            last_rate_n_per_s: 0.0,
            seq: 0,
            stamp_s: 0.0,
            rng,
        }
    }

    /// Restarts the noise stream from `seed`, keeping the unit: the same
    /// sensor in another run.
    pub fn reseed_noise(&mut self, seed: u64) {
        self.rng = ChaCha8Rng::seed_from_u64(seed);
    }

    /// Current temperature (TDC counts, noise-free).
    pub fn temperature(&self) -> f64 {
        self.tdc
    }

    /// Sets the temperature (TDC counts); electrode baselines follow the
    /// thermal formula.
    pub fn set_temperature(&mut self, tdc_counts: f64) {
        self.tdc = tdc_counts;
    }

    /// Scales every electrode's impedance change with contact (1 = as the
    /// unit was drawn): how a session's mounting and fluid fill change what
    /// the electrodes see for the same force.
    pub fn set_sensitivity(&mut self, factor: f64) {
        self.sensitivity = factor;
    }

    /// Thermal coefficients of this unit's electrodes, E1 first.
    pub fn thermal(&self) -> Vec<ThermalCoeffs> {
        self.electrodes.iter().map(|e| e.thermal).collect()
    }

    /// Noise-free out-of-contact electrode values at the current temperature
    /// (counts), kept inside the ADC range.
    pub fn electrode_baselines(&self) -> Vec<f64> {
        self.electrodes.iter().map(|e| self.baseline(e)).collect()
    }

    fn baseline(&self, e: &ElectrodeUnit) -> f64 {
        // Keep the baseline strictly inside the ADC range so Z0 is finite and positive.
        e.thermal.baseline(self.tdc).clamp(1.0, ADC - 1.0)
    }

    /// Noise-free electrode values (counts) for `contact` at the current
    /// temperature, before rounding and clamping.
    pub fn electrode_values(&self, contact: Option<&Contact>) -> Vec<f64> {
        let ep = &self.params.electrodes;
        let load = contact.map(|c| {
            let s = c.surface();
            let f_dot_n = c.force.dot(&s.normal);
            (
                s.point_mm,
                (-f_dot_n).max(0.0),
                c.force - s.normal * f_dot_n,
            )
        });
        let slope = ep.compression_max_kohm / ep.compression_sat_n;
        let value = |e: &ElectrodeUnit| {
            let gain = e.gain * self.sensitivity;
            let e0 = self.baseline(e);
            let z0 = READOUT_KOHM * (ADC / e0 - 1.0);
            let Some((c, normal_n, tangential_n)) = load else {
                return e0;
            };
            let d = e.skin_point_mm - c;
            let d2 = d.norm_squared();
            let wp = ep.pressure_width_mm;
            let ws = ep.shear_width_mm;
            let u = normal_n * (-d2 / (2.0 * wp * wp)).exp()
                + ep.shear_gain * tangential_n.dot(&d) / ws * (-d2 / (2.0 * ws * ws)).exp();
            let dz = if u >= 0.0 {
                gain * ep.compression_max_kohm * (u / ep.compression_sat_n).tanh()
            } else {
                // Same slope at u = 0, but the impedance can only fall by a
                // fraction of its baseline (the skin lifts off, fluid fills in).
                let floor = ep.release_max_fraction * z0;
                -floor * (gain * slope * -u / floor).tanh()
            };
            ADC / (1.0 + (z0 + dz) / READOUT_KOHM)
        };
        self.electrodes.iter().map(value).collect()
    }

    /// Samples one frame for `contact` (None = out of contact), advancing the
    /// frame clock by `dt_s` seconds (the frame period, 0.01 s at 100 Hz).
    pub fn step(&mut self, contact: Option<&Contact>, dt_s: f64) -> BioTacReading {
        let values = self.electrode_values(contact);
        let p = &self.params;
        let mut electrodes = Electrodes::filled(p.layout, 0);
        for (out, v) in electrodes.iter_mut().zip(values) {
            *out = to_counts(v + gaussian(&mut self.rng, p.electrodes.noise_counts));
        }

        let normal_n = contact.map_or(0.0, Contact::normal_force);
        let pdc_rise = p.pdc.rise_max_counts * (1.0 - (-normal_n / p.pdc.sat_n).exp());
        let pdc =
            to_counts(self.pdc_baseline + pdc_rise + gaussian(&mut self.rng, p.pdc.noise_counts));

        // PAC sees the rate of change of the fluid pressure: ramp the rate
        // linearly over the frame's samples (22; 27 on a BioTac SP) from the
        // previous frame's to this one's.
        let rate = if dt_s > 0.0 {
            (normal_n - self.last_normal_n) / dt_s
        } else {
            0.0
        };
        let mut pac = Pac::filled(p.layout.pac_per_frame(), 0);
        let n_pac = pac.len() as f64;
        for (k, out) in pac.iter_mut().enumerate() {
            let frac = (k + 1) as f64 / n_pac;
            let r = self.last_rate_n_per_s + (rate - self.last_rate_n_per_s) * frac;
            let v = self.pac_baseline
                + p.pac.rate_gain_counts_per_n_per_s * r
                + gaussian(&mut self.rng, p.pac.noise_counts);
            *out = to_counts(v);
        }
        self.last_normal_n = normal_n;
        self.last_rate_n_per_s = rate;

        let tdc = to_counts(self.tdc + gaussian(&mut self.rng, p.tdc.noise_counts));
        let tac = to_counts(self.tac_baseline + gaussian(&mut self.rng, p.tac.noise_counts));

        let reading = BioTacReading {
            seq: self.seq,
            stamp_s: self.stamp_s,
            electrodes,
            pdc,
            pac,
            tdc,
            tac,
        };
        self.seq = self.seq.wrapping_add(1);
        self.stamp_s += dt_s;
        reading
    }
}

/// Rounds to an ADC count and clamps to 0..=4095 (NaN -> 0).
fn to_counts(v: f64) -> u16 {
    v.round().clamp(0.0, ADC) as u16
}

#[cfg(test)]
mod tests;
