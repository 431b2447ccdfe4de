//! The simulated nail camera: a grey image of a fingernail whose colour
//! follows the fingertip force (config/nail_sim.yaml says what each value
//! models and where it comes from).
//!
//! The nail is an ellipse of half-axes `w` (across) and `l` (along the
//! finger) in the nail's own coordinates `a = x / w`, `b = y / l` (`b < 0`
//! towards the tip). At rest its grey is the person's level plus a texture
//! and a brighter lunula; four dark markers sit at `(±m_a, ±m_b)`. Under a
//! force `F` with the pad pressed at `p` (mm) and a twisting moment `τ_z`:
//!
//! ```text
//! s       = 1 - exp(-F_z / F_sat)                 (whitening, saturating)
//! (a0,b0) = (k_p p_y, -c - k_p p_x)                (follows the centre of pressure)
//! white   = G_n s exp(-(a-a0)²/2σa² - (b-b0)²/2σb²)
//! shear   = G_s (F_y a - F_x b) exp(-(a² + b²)/2σs²)   (one side whitens, the other darkens)
//! skew    = G_z τ_z a exp(-(b-b0)²/2σb²)
//! ```
//!
//! The camera sees the nail through the session's mount (shift and
//! rotation, a slip per trial), light (gain, left-right gradient, flicker)
//! and pixel noise. There is no blood-flow lag: the papers give none.

use nalgebra::{Rotation2, Vector2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Deserialize;

use super::frame::NailFrame;
use super::radial::RadialTest;
use crate::biotac::sim::{check_range, check_value, gaussian, uniform, ConfigError};
use crate::sim::collect::{check_sets, FtNoiseStd, PushTiming, SetSpecs};

/// The shipped `config/nail_sim.yaml`.
pub const NAIL_SIM_YAML: &str = include_str!("../../config/nail_sim.yaml");

/// `camera:` in the config.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraParams {
    /// Frame width (px).
    pub width_px: usize,
    /// Frame height (px).
    pub height_px: usize,
    /// Frame rate (Hz).
    pub rate_hz: f64,
    /// Pixel noise (std, grey levels).
    pub noise_grey: f64,
}

/// `nail:` in the config.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NailParams {
    /// Half-width (px).
    pub half_width_px: f64,
    /// Half-length (px).
    pub half_length_px: f64,
    /// Nail grey at rest.
    pub nail_grey: f64,
    /// Skin grey.
    pub skin_grey: f64,
    /// Texture bump amplitude (grey).
    pub texture_grey: f64,
    /// Texture bump width (px), range.
    pub texture_width_px: [f64; 2],
    /// Texture bumps per nail.
    pub texture_bumps: usize,
    /// Lunula rise (grey).
    pub lunula_grey: f64,
    /// Lunula extent (fraction of the half-length from the proximal edge).
    pub lunula_fraction: f64,
    /// Marker grey.
    pub marker_grey: f64,
    /// Marker radius (px).
    pub marker_radius_px: f64,
    /// Marker place (fractions of the half-axes).
    pub marker_at: [f64; 2],
}

/// `response:` in the config.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ResponseParams {
    /// Whitening at saturation (grey).
    pub normal_grey: f64,
    /// Force scale of the saturation (N).
    pub saturation_n: f64,
    /// Centre of the whitening (fraction of the half-length towards the tip).
    pub normal_centre: f64,
    /// Widths of the whitening (fractions of the half-axes).
    pub normal_width: [f64; 2],
    /// Whitening (and darkening opposite) per N of tangential force (grey).
    pub shear_grey_per_n: f64,
    /// Width of the shear pattern (fraction).
    pub shear_width: f64,
    /// Shift of the whitening per mm of the centre of pressure (fraction).
    pub pressure_shift_per_mm: f64,
    /// Skew per N·mm of twisting moment (grey).
    pub twist_grey_per_nmm: f64,
}

/// `person:` in the config: relative spreads drawn per person.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PersonSpread {
    /// Nail size.
    pub size_spread: f64,
    /// Response gains.
    pub response_spread: f64,
    /// Saturation force.
    pub saturation_spread: f64,
    /// Grey levels.
    pub grey_spread: f64,
}

/// `session:` in the config.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionSpread {
    /// Light gain, range.
    pub light_gain: [f64; 2],
    /// Left-right light gradient, range.
    pub light_gradient: [f64; 2],
    /// Camera shift (px), range.
    pub mount_shift_px: [f64; 2],
    /// Camera rotation (deg), range.
    pub mount_rotation_deg: [f64; 2],
    /// Camera slip per trial (px).
    pub slip_px_per_trial: f64,
    /// Light flicker per frame (std, fraction).
    pub flicker: f64,
}

/// `protocol:` in the config.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NailProtocol {
    /// Trials per set.
    pub trials_per_set: u32,
    /// Length of a trial (s).
    pub trial_duration_s: f64,
    /// Frame rate of the protocol (Hz): the camera's.
    pub rate_hz: f64,
    /// Frames out of contact at the start of a trial.
    pub tare_samples: u32,
    /// Shortest rest between pushes (s).
    pub min_rest_s: f64,
    /// Largest |tangential| / normal force.
    pub max_traction_ratio: f64,
    /// Centre of pressure per push (mm), range for x and y.
    pub pressure_centre_mm: [f64; 2],
    /// How far the centre of pressure rolls during a push (mm).
    pub pressure_roll_mm: f64,
    /// Twisting moment per push (N·mm), range.
    pub twist_nmm: [f64; 2],
    /// F/T reference noise.
    pub ft_noise_std: FtNoiseStd,
    /// The four sets.
    pub sets: SetSpecs,
    /// Watanabe's 360° test (`collect --protocol radial`).
    pub radial: RadialTest,
}

impl NailProtocol {
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
}

/// The whole config, checked ([`NailSimConfig::from_yaml_str`]).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NailSimConfig {
    /// The camera.
    pub camera: CameraParams,
    /// The nail at rest.
    pub nail: NailParams,
    /// How it responds to force.
    pub response: ResponseParams,
    /// How persons differ.
    pub person: PersonSpread,
    /// How sessions differ.
    pub session: SessionSpread,
    /// The data-collection protocol.
    pub protocol: NailProtocol,
}

impl NailSimConfig {
    /// Parses and checks a config text.
    pub fn from_yaml_str(yaml: &str) -> Result<Self, ConfigError> {
        let c: NailSimConfig = serde_yaml_ng::from_str(yaml)?;
        c.check()?;
        Ok(c)
    }

    /// Reads and checks a config file.
    pub fn from_file(path: &std::path::Path) -> Result<Self, ConfigError> {
        Self::from_yaml_str(&crate::biotac::sim::read_config(path)?)
    }

    /// The same config with `trials` trials per set.
    pub fn with_trials(&self, trials: u32) -> Result<Self, ConfigError> {
        let mut c = self.clone();
        c.protocol.trials_per_set = trials;
        c.check()?;
        Ok(c)
    }

    /// Each single value with its key and accepted bounds (min, max).
    #[rustfmt::skip]
    fn bounded_values(&self) -> Vec<(&'static str, f64, f64, f64)> {
        let (c, n, r) = (&self.camera, &self.nail, &self.response);
        let (p, s, q) = (&self.person, &self.session, &self.protocol);
        vec![
            ("camera.width_px", c.width_px as f64, 16.0, 4096.0),
            ("camera.height_px", c.height_px as f64, 16.0, 4096.0),
            ("camera.rate_hz", c.rate_hz, 1.0, 1000.0),
            ("camera.noise_grey", c.noise_grey, 0.0, 50.0),
            ("nail.half_width_px", n.half_width_px, 4.0, c.width_px as f64 / 2.0),
            ("nail.half_length_px", n.half_length_px, 4.0, c.height_px as f64 / 2.0),
            ("nail.nail_grey", n.nail_grey, 0.0, 255.0),
            ("nail.skin_grey", n.skin_grey, 0.0, 255.0),
            ("nail.texture_grey", n.texture_grey, 0.0, 100.0),
            ("nail.texture_bumps", n.texture_bumps as f64, 0.0, 100.0),
            ("nail.lunula_grey", n.lunula_grey, -100.0, 100.0),
            ("nail.lunula_fraction", n.lunula_fraction, 0.0, 1.0),
            ("nail.marker_grey", n.marker_grey, 0.0, 255.0),
            ("nail.marker_radius_px", n.marker_radius_px, 1.0, 10.0),
            ("nail.marker_at[0]", n.marker_at[0], 0.1, 0.9),
            ("nail.marker_at[1]", n.marker_at[1], 0.1, 0.9),
            ("response.normal_grey", r.normal_grey, 0.0, 255.0),
            ("response.saturation_n", r.saturation_n, 0.1, 1e3),
            ("response.normal_centre", r.normal_centre, -1.0, 1.0),
            ("response.normal_width[0]", r.normal_width[0], 0.01, 2.0),
            ("response.normal_width[1]", r.normal_width[1], 0.01, 2.0),
            ("response.shear_grey_per_n", r.shear_grey_per_n, 0.0, 100.0),
            ("response.shear_width", r.shear_width, 0.01, 2.0),
            ("response.pressure_shift_per_mm", r.pressure_shift_per_mm, 0.0, 1.0),
            ("response.twist_grey_per_nmm", r.twist_grey_per_nmm, 0.0, 10.0),
            ("person.size_spread", p.size_spread, 0.0, 0.5),
            ("person.response_spread", p.response_spread, 0.0, 0.9),
            ("person.saturation_spread", p.saturation_spread, 0.0, 0.9),
            ("person.grey_spread", p.grey_spread, 0.0, 0.5),
            ("session.slip_px_per_trial", s.slip_px_per_trial, 0.0, 10.0),
            ("session.flicker", s.flicker, 0.0, 0.5),
            ("protocol.trials_per_set", f64::from(q.trials_per_set), 1.0, 1e4),
            ("protocol.trial_duration_s", q.trial_duration_s, 0.1, 3600.0),
            ("protocol.rate_hz", q.rate_hz, 1.0, 1000.0),
            ("protocol.tare_samples", f64::from(q.tare_samples), 0.0, q.trial_duration_s * q.rate_hz - 1.0),
            ("protocol.min_rest_s", q.min_rest_s, 0.0, q.trial_duration_s),
            ("protocol.max_traction_ratio", q.max_traction_ratio, 1e-3, 2.0),
            ("protocol.pressure_roll_mm", q.pressure_roll_mm, 0.0, 20.0),
        ]
    }

    fn check(&self) -> Result<(), ConfigError> {
        let (c, n, s, q) = (&self.camera, &self.nail, &self.session, &self.protocol);
        let values = self.bounded_values();
        for (key, value, min, max) in values {
            check_value(key, value, min, max)?;
        }
        #[rustfmt::skip]
        let ranges = [
            ("nail.texture_width_px", n.texture_width_px, 0.5, 100.0),
            ("session.light_gain", s.light_gain, 0.1, 10.0),
            ("session.light_gradient", s.light_gradient, -0.5, 0.5),
            ("session.mount_shift_px", s.mount_shift_px, -20.0, 20.0),
            ("session.mount_rotation_deg", s.mount_rotation_deg, -30.0, 30.0),
            ("protocol.pressure_centre_mm", q.pressure_centre_mm, -20.0, 20.0),
            ("protocol.twist_nmm", q.twist_nmm, -1e3, 1e3),
        ];
        for (key, range, min, max) in ranges {
            check_range(key, range, min, max)?;
        }
        for (i, v) in q.ft_noise_std.force_n.iter().enumerate() {
            check_value(
                &format!("protocol.ft_noise_std.force_n[{i}]"),
                *v,
                0.0,
                100.0,
            )?;
        }
        for (i, v) in q.ft_noise_std.torque_nm.iter().enumerate() {
            check_value(
                &format!("protocol.ft_noise_std.torque_nm[{i}]"),
                *v,
                0.0,
                10.0,
            )?;
        }
        if (q.rate_hz - c.rate_hz).abs() > 1e-9 {
            return Err(ConfigError::Value {
                key: "protocol.rate_hz".into(),
                value: q.rate_hz,
                expected: format!("the camera's rate, camera.rate_hz = {}", c.rate_hz),
            });
        }
        check_sets(&q.sets, &q.timing())?;
        q.radial.check("protocol.radial")
    }
}

impl Default for NailSimConfig {
    /// The shipped `config/nail_sim.yaml`.
    fn default() -> Self {
        // Checked by the unit tests; fails only if the shipped file is broken.
        Self::from_yaml_str(NAIL_SIM_YAML)
            .expect("config/nail_sim.yaml shipped with the crate is valid")
    }
}

/// What presses on the finger at one frame.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Pressing {
    /// Force on the finger, finger frame (N): pressing is +z.
    pub force: [f64; 3],
    /// Centre of pressure on the pad (mm, x and y from the pad centre).
    pub centre_mm: [f64; 2],
    /// Twisting moment about z (N·mm).
    pub twist_nmm: f64,
}

/// A texture bump of the nail at rest.
#[derive(Debug, Clone, Copy)]
struct Bump {
    a: f64,
    b: f64,
    width_px: f64,
    grey: f64,
}

/// One person's nail: its shape and texture, and how it responds.
#[derive(Debug, Clone)]
pub struct Person {
    half_width_px: f64,
    half_length_px: f64,
    nail_grey: f64,
    skin_grey: f64,
    bumps: Vec<Bump>,
    response: ResponseParams,
}

impl Person {
    /// Person `person` of `config` (the same number gives the same person).
    pub fn new(config: &NailSimConfig, person: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(crate::sim::collect::unit_seed(person));
        let (n, p) = (&config.nail, &config.person);
        let mut spread = |s: f64| uniform(&mut rng, [1.0 - s, 1.0 + s]);
        let size = spread(p.size_spread);
        let (half_width_px, half_length_px) = (n.half_width_px * size, n.half_length_px * size);
        let nail_grey = n.nail_grey * spread(p.grey_spread);
        let skin_grey = n.skin_grey * spread(p.grey_spread);
        let r = &config.response;
        let response = ResponseParams {
            normal_grey: r.normal_grey * spread(p.response_spread),
            saturation_n: r.saturation_n * spread(p.saturation_spread),
            normal_centre: r.normal_centre * spread(p.response_spread),
            shear_grey_per_n: r.shear_grey_per_n * spread(p.response_spread),
            pressure_shift_per_mm: r.pressure_shift_per_mm * spread(p.response_spread),
            twist_grey_per_nmm: r.twist_grey_per_nmm * spread(p.response_spread),
            ..r.clone()
        };
        let bumps = (0..n.texture_bumps)
            .map(|_| Bump {
                a: uniform(&mut rng, [-0.9, 0.9]),
                b: uniform(&mut rng, [-0.9, 0.9]),
                width_px: uniform(&mut rng, n.texture_width_px),
                grey: uniform(&mut rng, [-n.texture_grey, n.texture_grey]),
            })
            .collect();
        Person {
            half_width_px,
            half_length_px,
            nail_grey,
            skin_grey,
            bumps,
            response,
        }
    }

    /// The nail's grey at nail coordinates (`x`, `y`) px from its centre
    /// (+y towards the base), under `pressing`; None outside the nail.
    fn nail_grey(&self, n: &NailParams, x: f64, y: f64, pressing: &Pressing) -> Option<f64> {
        let (a, b) = (x / self.half_width_px, y / self.half_length_px);
        if a * a + b * b > 1.0 {
            return None;
        }
        let [mx, my] = n.marker_at;
        let r2 = n.marker_radius_px * n.marker_radius_px;
        for (sa, sb) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)] {
            let dx = x - sa * mx * self.half_width_px;
            let dy = y - sb * my * self.half_length_px;
            if dx * dx + dy * dy <= r2 {
                return Some(n.marker_grey);
            }
        }
        let mut g = self.nail_grey;
        for bump in &self.bumps {
            let dx = x - bump.a * self.half_width_px;
            let dy = y - bump.b * self.half_length_px;
            g += bump.grey * (-(dx * dx + dy * dy) / (2.0 * bump.width_px.powi(2))).exp();
        }
        let lunula_start = 1.0 - 2.0 * n.lunula_fraction;
        if b > lunula_start {
            g += n.lunula_grey * ((b - lunula_start) / (1.0 - lunula_start)).min(1.0);
        }
        Some(g + self.response_grey(a, b, pressing))
    }

    /// What the force adds to the grey at (`a`, `b`).
    fn response_grey(&self, a: f64, b: f64, pressing: &Pressing) -> f64 {
        let r = &self.response;
        let [fx, fy, fz] = pressing.force;
        let [px, py] = pressing.centre_mm;
        let s = 1.0 - (-fz.max(0.0) / r.saturation_n).exp();
        let a0 = r.pressure_shift_per_mm * py;
        let b0 = -r.normal_centre - r.pressure_shift_per_mm * px;
        let [wa, wb] = r.normal_width;
        let along = (-(b - b0).powi(2) / (2.0 * wb * wb)).exp();
        let white = r.normal_grey * s * (-(a - a0).powi(2) / (2.0 * wa * wa)).exp() * along;
        let skew = r.twist_grey_per_nmm * pressing.twist_nmm * a * along;
        let spread = (-(a * a + b * b) / (2.0 * r.shear_width.powi(2))).exp();
        let shear = r.shear_grey_per_n * (fy * a - fx * b) * spread;
        white + skew + shear
    }
}

/// How the camera sits and the light falls in one session.
#[derive(Debug, Clone)]
pub struct Session {
    gain: f64,
    gradient: f64,
    shift: Vector2<f64>,
    rotation: Rotation2<f64>,
    slip: Vector2<f64>,
    slip_px_per_trial: f64,
    flicker: f64,
    noise_grey: f64,
    rng: ChaCha8Rng,
}

impl Session {
    /// Session `seed` of `config`: light, mount and every noise.
    pub fn new(config: &NailSimConfig, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let s = &config.session;
        Session {
            gain: uniform(&mut rng, s.light_gain),
            gradient: uniform(&mut rng, s.light_gradient),
            shift: Vector2::new(
                uniform(&mut rng, s.mount_shift_px),
                uniform(&mut rng, s.mount_shift_px),
            ),
            rotation: Rotation2::new(uniform(&mut rng, s.mount_rotation_deg).to_radians()),
            slip: Vector2::zeros(),
            slip_px_per_trial: s.slip_px_per_trial,
            flicker: s.flicker,
            noise_grey: config.camera.noise_grey,
            rng,
        }
    }

    /// The session's random numbers (pushes, noise), after its own draws.
    pub fn rng(&mut self) -> &mut ChaCha8Rng {
        &mut self.rng
    }

    /// A new trial: the camera slips a little.
    pub fn next_trial(&mut self) {
        let step = self.slip_px_per_trial;
        self.slip += Vector2::new(
            uniform(&mut self.rng, [-step, step]),
            uniform(&mut self.rng, [-step, step]),
        );
    }

    /// The frame the camera takes of `person`'s nail under `pressing`.
    pub fn render(
        &mut self,
        config: &NailSimConfig,
        person: &Person,
        pressing: &Pressing,
    ) -> NailFrame {
        let flicker = gaussian(&mut self.rng, self.flicker);
        let grey = self.expected_grey(config, person, pressing, flicker);
        let (noise, rng) = (self.noise_grey, &mut self.rng);
        let pixels = grey
            .iter()
            .map(|g| (g + gaussian(rng, noise)).round().clamp(0.0, 255.0) as u8)
            .collect();
        let (w, h) = (config.camera.width_px, config.camera.height_px);
        // The size comes from the checked config.
        NailFrame::new(w, h, pixels).expect("width x height pixels")
    }

    /// The grey of every pixel, row by row, before the camera's noise and
    /// rounding: what [`Session::render`] draws its frame around, the light
    /// flickering by the fraction `flicker` (0: not at all).
    pub fn expected_grey(
        &self,
        config: &NailSimConfig,
        person: &Person,
        pressing: &Pressing,
        flicker: f64,
    ) -> Vec<f64> {
        let (w, h) = (config.camera.width_px, config.camera.height_px);
        let centre = Vector2::new((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
        let to_nail = self.rotation.inverse();
        let light = self.gain * (1.0 + flicker);
        let mut grey = Vec::with_capacity(w * h);
        for v in 0..h {
            for u in 0..w {
                let q = Vector2::new(u as f64, v as f64) - centre - self.shift - self.slip;
                let p = to_nail * q;
                let g = person
                    .nail_grey(&config.nail, p.x, p.y, pressing)
                    .unwrap_or(person.skin_grey);
                let across = (u as f64 - centre.x) / w as f64;
                grey.push(g * light * (1.0 + self.gradient * across));
            }
        }
        grey
    }
}

#[cfg(test)]
mod tests;
