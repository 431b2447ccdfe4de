//! How well one frame of the simulated nail camera can tell the direction
//! of the tangential force at all, whatever the model: the Cramér-Rao
//! bound. The camera's noise is Gaussian (`camera.noise_grey`) about
//! [`Session::expected_grey`], so the Fisher information of a frame is
//! `JᵀJ / σ²`, `J` the pixels' slopes in the unknowns; its inverse bounds
//! the covariance of any unbiased estimate from that frame (Kay 1993,
//! "Fundamentals of Statistical Signal Processing: Estimation Theory",
//! section 3.9, the general Gaussian case). The bound takes the frame as
//! the camera gives it: registration and the person's nail are known.

use nalgebra::{DMatrix, Vector2};

use super::sim::{NailSimConfig, Person, Pressing, Session};

/// What a frame has to tell, beside the force.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Unknown {
    /// Force on the finger along x, y, z (N).
    Force(usize),
    /// Centre of pressure on the pad along x, y (mm).
    Centre(usize),
    /// Twisting moment about z (N·mm).
    Twist,
    /// The light's frame-to-frame flicker (fraction).
    Flicker,
}

/// The unknowns of a frame, fx and fy first; the pad's centre and twist
/// only when they are not given.
fn unknowns(pad_known: bool) -> Vec<Unknown> {
    let mut u = vec![Unknown::Force(0), Unknown::Force(1), Unknown::Force(2)];
    if !pad_known {
        u.extend([Unknown::Centre(0), Unknown::Centre(1), Unknown::Twist]);
    }
    u.push(Unknown::Flicker);
    u
}

/// Step of the central differences, in each unknown's unit: small against
/// the widths of the nail's response (fractions of a 30 px half-width).
const STEP: f64 = 1e-4;

/// The slope of every pixel's expected grey in each of `unknowns`, at
/// `pressing` and no flicker (grey per unit).
fn slopes(
    config: &NailSimConfig,
    person: &Person,
    session: &Session,
    pressing: &Pressing,
    unknowns: &[Unknown],
) -> Vec<Vec<f64>> {
    let moved = |u: Unknown, h: f64| {
        let (mut p, mut flicker) = (*pressing, 0.0);
        match u {
            Unknown::Force(i) => p.force[i] += h,
            Unknown::Centre(i) => p.centre_mm[i] += h,
            Unknown::Twist => p.twist_nmm += h,
            Unknown::Flicker => flicker += h,
        }
        session.expected_grey(config, person, &p, flicker)
    };
    unknowns
        .iter()
        .map(|&u| {
            let (up, down) = (moved(u, STEP), moved(u, -STEP));
            up.iter()
                .zip(&down)
                .map(|(a, b)| (a - b) / (2.0 * STEP))
                .collect()
        })
        .collect()
}

/// The smallest covariance of an unbiased estimate of the unknowns whose
/// slopes are `slopes`, under pixel noise of `noise_grey`; None when the
/// frame cannot tell them apart (singular information).
fn covariance(slopes: &[Vec<f64>], noise_grey: f64) -> Option<DMatrix<f64>> {
    let n = slopes.len();
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let gram = DMatrix::from_fn(n, n, |i, j| dot(&slopes[i], &slopes[j]));
    Some(gram.try_inverse()? * noise_grey.powi(2))
}

/// The standard deviation (deg) of the tangential force's direction that
/// no unbiased estimate from one frame of `person` in `session` under
/// `pressing` can beat: with the pad's centre of pressure and twist
/// unknown as well (`pad_known` false), or given. None without a
/// tangential force, with a value that is not finite, or when the frame
/// cannot tell the unknowns apart.
pub fn direction_bound_deg(
    config: &NailSimConfig,
    person: &Person,
    session: &Session,
    pressing: &Pressing,
    pad_known: bool,
) -> Option<f64> {
    let [fx, fy, _] = pressing.force;
    let ft = fx.hypot(fy);
    let values = pressing.force.iter().chain(&pressing.centre_mm);
    if ft <= 0.0 || !values.chain([&pressing.twist_nmm]).all(|v| v.is_finite()) {
        return None;
    }
    let s = slopes(config, person, session, pressing, &unknowns(pad_known));
    let cov = covariance(&s, config.camera.noise_grey)?;
    let across = Vector2::new(-fy / ft, fx / ft);
    let var = (across.transpose() * cov.fixed_view::<2, 2>(0, 0) * across)[0];
    Some((var.sqrt() / ft).to_degrees())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at_peak(ft: f64, direction_deg: f64) -> Pressing {
        let (s, c) = direction_deg.to_radians().sin_cos();
        Pressing {
            force: [ft * c, ft * s, 10.0],
            centre_mm: [2.0, -1.5],
            twist_nmm: 8.0,
        }
    }

    fn bound(config: &NailSimConfig, pressing: &Pressing, pad_known: bool) -> f64 {
        let (person, session) = (Person::new(config, 1), Session::new(config, 3));
        direction_bound_deg(config, &person, &session, pressing, pad_known).unwrap()
    }

    #[test]
    fn the_bound_falls_as_the_shear_grows_and_rises_with_the_noise() {
        let c = NailSimConfig::default();
        let b = bound(&c, &at_peak(1.25, 60.0), false);
        assert!(b > 0.1 && b < 10.0, "{b}");
        // Shear adds a pattern in proportion to fx and fy: the information
        // does not depend on them, and the angle is the error across over |Ft|.
        let twice = bound(&c, &at_peak(2.5, 60.0), false);
        assert!((b / twice - 2.0).abs() < 1e-6, "{b} / {twice}");
        let mut noisy = c.clone();
        noisy.camera.noise_grey *= 2.0;
        assert!((bound(&noisy, &at_peak(1.25, 60.0), false) / b - 2.0).abs() < 1e-9);
        // Knowing where the pad presses can only help.
        let known = bound(&c, &at_peak(1.25, 60.0), true);
        assert!(known < b, "{known} vs {b}");
        let (person, session) = (Person::new(&c, 1), Session::new(&c, 3));
        let none = at_peak(0.0, 0.0);
        assert_eq!(
            direction_bound_deg(&c, &person, &session, &none, false),
            None
        );
        let mut nan = at_peak(1.25, 60.0);
        nan.centre_mm[0] = f64::NAN;
        assert_eq!(
            direction_bound_deg(&c, &person, &session, &nan, false),
            None
        );
    }

    #[test]
    fn least_squares_on_rendered_frames_reaches_the_bound() {
        // The frames `render` draws (noise, flicker, rounding) scatter a
        // least-squares estimate, linearised at the truth, as the bound says:
        // the bound's noise model is the camera's.
        let c = NailSimConfig::default();
        let (person, mut session) = (Person::new(&c, 1), Session::new(&c, 3));
        let pressing = at_peak(1.25, 60.0);
        let u = unknowns(false);
        let s = slopes(&c, &person, &session, &pressing, &u);
        let cov = covariance(&s, 1.0).unwrap();
        let mean = session.expected_grey(&c, &person, &pressing, 0.0);
        let across = Vector2::new(-60f64.to_radians().sin(), 60f64.to_radians().cos());
        let errors: Vec<f64> = (0..300)
            .map(|_| {
                let frame = session.render(&c, &person, &pressing);
                let residual: Vec<f64> = frame
                    .pixels()
                    .iter()
                    .zip(&mean)
                    .map(|(&g, m)| f64::from(g) - m)
                    .collect();
                let jr = DMatrix::from_fn(u.len(), 1, |i, _| {
                    s[i].iter().zip(&residual).map(|(a, b)| a * b).sum::<f64>()
                });
                let d = &cov * jr;
                across.x * d[0] + across.y * d[1]
            })
            .collect();
        let n = errors.len() as f64;
        let mean_error = errors.iter().sum::<f64>() / n;
        let sd = (errors.iter().map(|e| (e - mean_error).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let sd_deg = (sd / 1.25).to_degrees();
        let b = bound(&c, &pressing, false);
        // 300 frames hold the standard deviation to about 4 %; rounding adds
        // 1 % to the noise.
        assert!(
            (sd_deg / b - 1.0).abs() < 0.15,
            "{sd_deg} deg against the bound {b} deg"
        );
        assert!(
            mean_error.abs() < 3.0 * sd / n.sqrt(),
            "bias {mean_error} N"
        );
    }
}
