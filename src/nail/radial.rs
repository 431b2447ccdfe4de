//! Watanabe et al. 2023's 360° test (§ 3.2, Eqs. 3 and 4), as a second
//! nail protocol: the tangential force keeps one direction per trial, the
//! directions evenly spaced around the pad. In every direction the normal
//! force runs `cycles` cycles `Fz = Fmax / 2 (1 - cos 2π t / T)` and the
//! tangential force follows it, `Fr = μ Fz (i - 1) / (n_c - 1)` in cycle
//! `i = 1..=n_c`: its peaks step up to `μ Fmax`. Watanabe read their
//! direction error "at the peak points of the applied force" of this test.

use serde::Deserialize;

use crate::biotac::sim::{check_value, ConfigError};
use crate::sim::collect::PadForce;

/// `protocol.radial:` in the nail config.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RadialTest {
    /// Directions of the tangential force, evenly spaced over 360° (one
    /// trial each).
    pub directions: u32,
    /// Load cycles per direction, `n_c`.
    pub cycles: u32,
    /// Length of one cycle (s), `1 / f_s`.
    pub cycle_s: f64,
    /// Normal force at the top of every cycle (N), `Fz_max`.
    pub normal_peak_n: f64,
}

impl RadialTest {
    /// Checks the values; `key` names the section in messages.
    pub(crate) fn check(&self, key: &str) -> Result<(), ConfigError> {
        let values = [
            ("directions", f64::from(self.directions), 1.0, 360.0),
            ("cycles", f64::from(self.cycles), 2.0, 100.0),
            ("cycle_s", self.cycle_s, 1.0, 3600.0),
            ("normal_peak_n", self.normal_peak_n, 0.1, 100.0),
        ];
        for (field, value, min, max) in values {
            check_value(&format!("{key}.{field}"), value, min, max)?;
        }
        Ok(())
    }

    /// The direction of the `index`-th trial (0-based) in radians: 0,
    /// 360° / directions, ...
    pub fn direction_rad(&self, index: u32) -> f64 {
        std::f64::consts::TAU * f64::from(index) / f64::from(self.directions)
    }

    /// How long the cycles of one direction last (s).
    pub fn duration_s(&self) -> f64 {
        f64::from(self.cycles) * self.cycle_s
    }

    /// The force `t` seconds into the cycles of a trial in direction
    /// `direction_rad`, with `traction_ratio` as `μ`, and the cycle's index
    /// (0-based); None outside the cycles.
    pub(crate) fn force_at(
        &self,
        direction_rad: f64,
        traction_ratio: f64,
        t: f64,
    ) -> Option<(usize, PadForce)> {
        if !(t > 0.0 && t < self.duration_s()) {
            return None;
        }
        let cycle = (t / self.cycle_s).floor() as usize;
        let phase = std::f64::consts::TAU * t / self.cycle_s;
        let normal_n = self.normal_peak_n / 2.0 * (1.0 - phase.cos());
        let step = cycle as f64 / f64::from(self.cycles - 1);
        Some((
            cycle,
            PadForce {
                normal_n,
                tangential_n: traction_ratio * normal_n * step,
                direction_rad,
            },
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn watanabe() -> RadialTest {
        // § 3.2: n_c = 5, f_s = 0.025 Hz, Fz_max = 10 N, 12 directions.
        RadialTest {
            directions: 12,
            cycles: 5,
            cycle_s: 40.0,
            normal_peak_n: 10.0,
        }
    }

    #[test]
    fn the_tangential_peaks_step_up_to_mu_fmax_in_one_direction() {
        let r = watanabe();
        assert_eq!(r.duration_s(), 200.0);
        assert!((r.direction_rad(3) - 90f64.to_radians()).abs() < 1e-12);
        // Tops of the cycles at 20, 60, ... s: Fz = 10 N, Fr = 0, 1.25, ..., 5 N.
        for (i, fr) in [0.0, 1.25, 2.5, 3.75, 5.0].iter().enumerate() {
            let (cycle, f) = r.force_at(1.0, 0.5, 20.0 + 40.0 * i as f64).unwrap();
            assert_eq!(cycle, i);
            assert!((f.normal_n - 10.0).abs() < 1e-9, "{f:?}");
            assert!((f.tangential_n - fr).abs() < 1e-9, "{f:?}");
            assert_eq!(f.direction_rad, 1.0);
        }
        // Fz rises at most π Fmax f_s = 0.79 N/s (Watanabe: |dFz/dt| <= 1 N/s).
        let (_, a) = r.force_at(0.0, 0.5, 10.0).unwrap();
        let (_, b) = r.force_at(0.0, 0.5, 10.01).unwrap();
        assert!(((b.normal_n - a.normal_n) / 0.01 - 0.785).abs() < 0.01);
        assert!(r.force_at(0.0, 0.5, 0.0).is_none());
        assert!(r.force_at(0.0, 0.5, 200.0).is_none());
    }

    #[test]
    fn a_bad_value_is_named() {
        let mut r = watanabe();
        assert!(r.check("protocol.radial").is_ok());
        r.cycles = 1;
        let e = r.check("protocol.radial").unwrap_err().to_string();
        assert!(e.contains("protocol.radial.cycles"), "{e}");
    }
}
