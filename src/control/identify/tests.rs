use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::*;

fn skin() -> SkinParams {
    SkinParams {
        force_scale_n: 0.5,
        length_scale_mm: 1.2,
        shear_stiffness_n_per_m: 1500.0,
    }
}

/// An arm with latency `l` and lag `tau`, commanded every 10 ms along x by
/// `speed(t)`, its positions measured every `every` s: the track.
fn track(l: f64, tau: f64, every: f64, speed: impl Fn(f64) -> f64) -> ArmTrack {
    let mut track = ArmTrack::default();
    let (dt, mut v, mut x) = (1e-4, 0.0, 0.0);
    let mut sent: Vec<(f64, f64)> = Vec::new();
    let mut next_sample = 0.0;
    for k in 0..12_000 {
        let t = k as f64 * dt;
        if k % 100 == 0 {
            sent.push((t, speed(t)));
            track.on_command(t, Vector3::new(speed(t), 0.0, 0.0));
        }
        let u = sent
            .iter()
            .rev()
            .find(|(ts, _)| *ts + l <= t + 1e-12)
            .map_or(0.0, |(_, u)| *u);
        v += if tau > 0.0 { (u - v) * dt / tau } else { u - v };
        x += v * dt;
        if t >= next_sample - 1e-12 {
            track.on_position(t, Vector3::new(x, 0.0, 0.0));
            next_sample += every;
        }
    }
    track
}

#[test]
fn the_fit_finds_the_latency_and_lag_of_an_arm_it_did_not_see() {
    // Speed steps and a ramp within the last 0.4 s.
    let speed = |t: f64| match t {
        t if t < 0.85 => 0.0,
        t if t < 1.0 => 0.01,
        t => 0.01 - 0.02 * (t - 1.0),
    };
    for (l, tau, every) in [
        (0.024, 0.02, 0.01),
        (0.008, 0.0, 0.002),
        (0.04, 0.03, 0.008),
    ] {
        let fit = track(l, tau, every, speed).fit().expect("moved enough");
        assert!(
            (fit.latency_s - l).abs() <= 0.0025 && (fit.lag_s - tau).abs() <= 0.0035,
            "{l} {tau}: {fit:?}"
        );
        assert!(fit.r2 > 0.99, "{fit:?}");
    }
}

#[test]
fn without_motion_or_with_a_steady_one_there_is_no_fit() {
    assert!(track(0.02, 0.02, 0.01, |_| 0.0).fit().is_none());
    assert!(ArmTrack::default().fit().is_none());
    // A steady speed shows neither latency nor lag.
    assert!(track(0.02, 0.02, 0.01, |_| 0.01).fit().is_none());
}

#[test]
fn a_position_is_read_at_any_recent_time() {
    let mut t = ArmTrack::default();
    t.on_position(1.0, Vector3::new(0.0, 0.0, 0.0));
    t.on_position(1.001, Vector3::new(9.0, 0.0, 0.0)); // too close: dropped
    t.on_position(1.01, Vector3::new(1.0, 0.0, 0.0));
    assert!((t.position_at(1.005).unwrap().x - 0.5).abs() < 1e-9);
    assert_eq!(t.position_at(1.012).unwrap().x, 1.0, "just after the last");
    assert!(t.position_at(1.1).is_none() && t.position_at(0.9).is_none());
}

#[test]
fn the_body_behind_the_skin_is_found_from_force_against_position() {
    let skin = skin();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for body in [50.0, 300.0, 1e4, f64::INFINITY] {
        let mut s = ContactStiffness::new(skin, SAMPLE_SPAN_S);
        assert_eq!(s.body(), None);
        let mut fitted = None;
        // Pressing from 0.15 N to 1 N, the estimate noisy (5 mN).
        for i in 0..30 {
            let f = 0.15 + 0.03 * i as f64;
            let x = 0.02 + 1.2e-3 * (f / 0.5f64).ln_1p() + f / body;
            let noise = rng.random_range(-0.005..0.005);
            fitted = s.push(0.01, x, f + noise).or(fitted);
        }
        let k = fitted.unwrap();
        // The stiffness at 1 N within 10 %.
        let truth = 1.0 / (1.0 / skin.stiffness_at(1.0) + 1.0 / body);
        let got = s.effective(1.0, 1e6);
        assert!(
            (got / truth - 1.0).abs() < 0.1,
            "{body}: body {k}, {got} vs {truth}"
        );
    }
    // A slow press into a soft body: 2 mN more per reading, 24 readings
    // spread less than the fit needs, the readings kept span it.
    let mut s = ContactStiffness::new(skin, SAMPLE_SPAN_S);
    let mut fitted = None;
    for i in 0..425 {
        let f = 0.15 + 0.002 * i as f64;
        let x = 0.02 + 1.2e-3 * (f / 0.5f64).ln_1p() + f / 50.0;
        fitted = s
            .push(0.01, x, f + rng.random_range(-0.005..0.005))
            .or(fitted);
    }
    assert!(
        fitted.is_some_and(|k| (k / 50.0 - 1.0).abs() < 0.1),
        "{fitted:?}"
    );
    // Until fitted, the prior stands in.
    let s = ContactStiffness::new(skin, SAMPLE_SPAN_S);
    let prior = s.effective(1.0, 300.0);
    assert!((prior - 1.0 / (1.0 / 1250.0 + 1.0 / 300.0)).abs() < 1e-9);
}

/// Readings (every 10 ms, 5 mN of noise) of a 50 g plate on a 50 N/m
/// spring at half the critical damping, behind the skin, pressed at
/// 10 mm/s until 0.9 N and then held: (position of the BioTac, force).
fn plate_trace(rng: &mut ChaCha8Rng) -> Vec<(f64, f64)> {
    let skin = skin();
    let (m, k): (f64, f64) = (0.05, 50.0);
    let c = 0.5 * 2.0 * (k * m).sqrt();
    let (dt, mut arm, mut plate, mut v, mut f) = (1e-4, 0.0, 0.0, 0.0, 0.0);
    let mut speed = 0.01;
    let mut out = vec![];
    for i in 0..30_000 {
        f = skin.force(arm - plate);
        if f >= 0.9 {
            speed = 0.0;
        }
        // Semi-implicit Euler on the plate; the skin is the stiffest
        // spring (2 ms period at 1250 N/m on 50 g), 0.1 ms resolves it.
        v += (f - k * plate - c * v) / m * dt;
        plate += v * dt;
        arm += speed * dt;
        if i % 100 == 0 && f > 0.05 {
            out.push((arm, f + rng.random_range(-0.005..0.005)));
        }
    }
    assert!(
        speed == 0.0 && (f - 0.9).abs() < 0.2,
        "pressed and held: {f}"
    );
    out
}

#[test]
fn a_plate_with_mass_is_fitted_by_its_spring_through_its_ring() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let trace = plate_trace(&mut rng);
    // The stop rings the plate against the skin: the force swings while
    // the BioTac holds still.
    let held: Vec<f64> = trace.iter().rev().take(300).map(|(_, f)| *f).collect();
    let swing = held.iter().copied().fold(f64::NEG_INFINITY, f64::max)
        - held.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(swing > 0.1, "it rings: {swing}");
    let mut s = ContactStiffness::new(skin(), SAMPLE_SPAN_S);
    let mut fits = vec![];
    for (x, f) in trace {
        fits.extend(s.push(0.01, x, f));
    }
    // Every fit, through the approach and the ring after it, within 15 %
    // of the spring (the plate's damping adds 0.016 N at 10 mm/s).
    assert!(fits.len() > 10, "{fits:?}");
    for k in &fits {
        assert!((k / 50.0 - 1.0).abs() < 0.15, "{fits:?}");
    }
}

#[test]
fn forces_that_stray_from_a_line_are_no_fit() {
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    let mut s = ContactStiffness::new(skin(), SAMPLE_SPAN_S);
    // A 50 N/m press whose force swings +-0.25 N every 40 ms (slipping,
    // or a body ringing slower than the samples' span).
    for i in 0..200 {
        let x = 0.02 + 1e-4 * i as f64;
        let swing = if (i / 4) % 2 == 0 { 0.25 } else { -0.25 };
        let f = 0.3 + 50.0 * 1e-4 * i as f64 + swing + rng.random_range(-0.005..0.005);
        assert_eq!(s.push(0.01, x, f), None, "reading {i}");
    }
    assert_eq!(s.body(), None);
    // A fit that stood stays when the window strays.
    let mut s = ContactStiffness::new(skin(), SAMPLE_SPAN_S);
    for i in 0..40 {
        let f = 0.15 + 0.01 * i as f64;
        s.push(0.01, 0.02 + 1.2e-3 * (f / 0.5f64).ln_1p() + f / 300.0, f);
    }
    let k = s.body().unwrap();
    assert!((k / 300.0 - 1.0).abs() < 0.1, "{k}");
    // Then held where it reached 0.54 N, the force swinging +-0.3 N: one
    // sample up could be a stiffer body, once it swings back down no line
    // holds the window, and the fit that stood before stays (until the
    // swing alone fills the window: at a held position, that is a rigid
    // body's trace).
    let held = 0.02 + 1.2e-3 * (0.54 / 0.5f64).ln_1p() + 0.54 / 300.0;
    let mut stood = None;
    for i in 0..60 {
        let f = 0.54 + if (i / 4) % 2 == 0 { 0.3 } else { -0.3 };
        let fit = s.push(0.01, held, f);
        if i == 7 {
            stood = s.body();
        }
        if i >= 8 {
            assert_eq!(fit, None, "reading {i}");
        }
    }
    assert!(stood.is_some() && s.body() == stood);
}
