//! The contact's stiffness on each axis, measured on the body the pad
//! touches: a person's fingertip is stiffer across the pad than along its
//! normal, or the reverse, and no fit along the normal tells the other.
//!
//! For [`PROBE_S`] the pad adds a small motion, `AMPLITUDE_M sin(2 pi f t)`,
//! on each axis, each at its own whole number of hertz ([`PROBE_HZ`]): over
//! the window the axes' sines are orthogonal, so all three are probed at
//! once. On each axis the force estimates and the pad's positions are
//! fitted by least squares with a cubic (the finger's own slow motion and
//! the arm following it) plus the sine and cosine of that axis's frequency.
//! Their ratio is the contact's dynamic stiffness there, `Z = -F / X` (the
//! force rises as the pad moves against the contact); its magnitude
//! includes the finger's damping and mass at a frequency near the loop's
//! crossover, which is what the gains must allow for.
//!
//! The stiffness taken is two standard errors above the measured one (the
//! gains' margin against noise: about 20 % on a 100 N/m contact with 7 mN
//! of noise on the estimate). A fit is refused when its force is within
//! five standard errors of zero (the pad slid, or the contact is too soft
//! to tell), when the pad moved less than 30 % of the probe (the arm did
//! not follow it), or when the force does not oppose the motion. Nothing
//! allocates.

use std::f64::consts::PI;

use nalgebra::{Matrix6, Vector3, Vector6};

/// Length of the probe (s): whole cycles of every frequency, short, as the
/// follow across the pad is slow until it is over.
pub const PROBE_S: f64 = 0.5;
/// Frequency of the probe on x, y, z (Hz): whole cycles in the window,
/// apart, above a person's pushes (about 1 Hz) and below the watchdog's top
/// band.
pub const PROBE_HZ: [f64; 3] = [6.0, 8.0, 4.0];
/// Amplitude of the probe's motion (m): 0.3 N across the skin's 1500 N/m
/// shear spring, under the friction of a 1 N hold (0.5 and up).
pub const AMPLITUDE_M: f64 = 2e-4;
/// Least share of the probe's amplitude the pad must have moved.
const MIN_MOTION_SHARE: f64 = 0.3;
/// Standard errors the force's swing must stand above its noise.
const MIN_STANDARD_ERRORS: f64 = 5.0;
/// Standard errors added to the force's swing: the stiffness the gains
/// take is an upper bound of what the probe measured.
const MARGIN_STANDARD_ERRORS: f64 = 2.0;
/// Fewest samples a fit takes.
const MIN_SAMPLES: usize = 20;

/// The probe's velocity (m/s) on each axis, `t` seconds in.
pub fn velocity(t: f64) -> Vector3<f64> {
    Vector3::from_fn(|j, _| {
        let w = 2.0 * PI * PROBE_HZ[j];
        AMPLITUDE_M * w * (w * t).cos()
    })
}

/// One series' least squares on the cubic and the sine and cosine of its
/// axis's frequency: the normal equations, built as samples come.
#[derive(Debug, Clone, PartialEq)]
struct SineFit {
    hz: f64,
    xtx: Matrix6<f64>,
    xty: Vector6<f64>,
    yty: f64,
    n: usize,
}

/// A fit's sine and cosine coefficients and the standard error of each.
struct Swing {
    sin: f64,
    cos: f64,
    se: f64,
}

impl Swing {
    fn amplitude(&self) -> f64 {
        self.sin.hypot(self.cos)
    }
}

impl SineFit {
    fn new(hz: f64) -> Self {
        SineFit {
            hz,
            xtx: Matrix6::zeros(),
            xty: Vector6::zeros(),
            yty: 0.0,
            n: 0,
        }
    }

    fn push(&mut self, t: f64, y: f64) {
        let u = t / PROBE_S - 0.5;
        let w = 2.0 * PI * self.hz * t;
        let r = Vector6::new(1.0, u, u * u, u * u * u, w.sin(), w.cos());
        self.xtx += r * r.transpose();
        self.xty += r * y;
        self.yty += y * y;
        self.n += 1;
    }

    fn swing(&self) -> Option<Swing> {
        if self.n < MIN_SAMPLES {
            return None;
        }
        let inverse = self.xtx.try_inverse()?;
        let b = inverse * self.xty;
        let variance = (self.yty - b.dot(&self.xty)).max(0.0) / (self.n - 6) as f64;
        Some(Swing {
            sin: b[4],
            cos: b[5],
            se: (variance * inverse[(4, 4)].max(inverse[(5, 5)])).sqrt(),
        })
    }
}

/// A probe under way: its clock and its fits.
#[derive(Debug, Clone, PartialEq)]
pub struct Probe {
    t: f64,
    forces: [SineFit; 3],
    positions: [SineFit; 3],
}

impl Default for Probe {
    fn default() -> Self {
        Probe {
            t: 0.0,
            forces: PROBE_HZ.map(SineFit::new),
            positions: PROBE_HZ.map(SineFit::new),
        }
    }
}

impl Probe {
    /// Time since the probe began (s).
    pub fn elapsed_s(&self) -> f64 {
        self.t
    }

    /// The probe's velocity now (m/s), then the clock moves on by `dt`.
    pub fn step(&mut self, dt: f64) -> Vector3<f64> {
        let v = velocity(self.t);
        self.t += dt;
        v
    }

    /// True once the window is over.
    pub fn done(&self) -> bool {
        self.t >= PROBE_S
    }

    /// Takes a force estimate (N, the pad's frame). Forces and positions
    /// are fitted apart, each on its own samples: a constant delay between
    /// them turns both swings alike and leaves their ratio's magnitude.
    pub fn push_force(&mut self, force: &Vector3<f64>) {
        for (fit, f) in self.forces.iter_mut().zip(force.iter()) {
            fit.push(self.t, *f);
        }
    }

    /// Takes the pad's position (m, the pad's frame).
    pub fn push_position(&mut self, position: &Vector3<f64>) {
        for (fit, x) in self.positions.iter_mut().zip(position.iter()) {
            fit.push(self.t, *x);
        }
    }

    /// The dynamic stiffness on each axis (N/m), two standard errors up,
    /// where the fits show it.
    pub fn stiffness(&self) -> [Option<f64>; 3] {
        std::array::from_fn(|j| {
            let (f, x) = (self.forces[j].swing()?, self.positions[j].swing()?);
            // The in-phase part of -F / X: positive when the force opposes.
            let opposes = -(f.sin * x.sin + f.cos * x.cos) > 0.0;
            let shown = f.amplitude() > MIN_STANDARD_ERRORS * f.se
                && x.amplitude() >= MIN_MOTION_SHARE * AMPLITUDE_M
                && opposes;
            shown.then(|| (f.amplitude() + MARGIN_STANDARD_ERRORS * f.se) / x.amplitude())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// Probes a contact of stiffness `k` per axis (N/m) with damping `c`
    /// (N s/m), the pad moving by the probe's share `share` on top of a
    /// slow slide (`slide_mps`, the finger moving with it) and noise of
    /// `sd` (N) on the force, at 100 readings a second.
    fn probe(k: [f64; 3], c: f64, share: f64, slide_mps: f64, sd: f64) -> [Option<f64>; 3] {
        let mut p = Probe::default();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let noise = Normal::new(0.0, sd.max(1e-12)).unwrap();
        let dt = 0.01;
        while !p.done() {
            let t = p.elapsed_s();
            let v = p.step(dt) * share;
            let x =
                Vector3::from_fn(|j, _| share * AMPLITUDE_M * (2.0 * PI * PROBE_HZ[j] * t).sin());
            let slide = Vector3::new(slide_mps * t, 0.0, 0.0);
            // A person's push of 0.3 N at 0.8 Hz along x.
            let push = Vector3::new(0.3 * (2.0 * PI * 0.8 * t).sin(), 0.0, 0.0);
            let force =
                Vector3::from_fn(|j, _| -k[j] * x[j] - c * v[j] + push[j] + noise.sample(&mut rng));
            p.push_force(&force);
            p.push_position(&(x + slide));
        }
        p.stiffness()
    }

    #[test]
    fn each_axis_is_measured_apart_from_the_others_and_the_slide() {
        let k = [600.0, 250.0, 90.0];
        let got = probe(k, 0.0, 0.7, 0.03, 0.007);
        for j in 0..3 {
            let z = got[j].unwrap_or_else(|| panic!("axis {j}: no fit"));
            assert!(
                (-0.1..0.3).contains(&(z / k[j] - 1.0)),
                "axis {j}: {z} N/m for {}",
                k[j]
            );
        }
    }

    #[test]
    fn damping_raises_what_the_gains_see() {
        // 10 N s/m at 6 Hz is 377 N/m in quadrature with 600 N/m.
        let z = probe([600.0; 3], 10.0, 1.0, 0.0, 0.0)[0].unwrap();
        let want = 600.0f64.hypot(10.0 * 2.0 * PI * 6.0);
        assert!((z / want - 1.0).abs() < 0.05, "{z} N/m, {want} N/m");
    }

    #[test]
    fn no_fit_from_noise_a_still_pad_or_a_force_that_helps() {
        assert_eq!(probe([2.0; 3], 0.0, 1.0, 0.0, 0.007), [None; 3], "noise");
        assert_eq!(probe([600.0; 3], 0.0, 0.1, 0.0, 0.007), [None; 3], "still");
        assert_eq!(probe([-600.0; 3], 0.0, 1.0, 0.0, 0.0), [None; 3], "helps");
    }
}
