use super::*;

fn guided() -> GuidedMove {
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

fn input(force: Vector3<f64>) -> GuidedInput {
    GuidedInput {
        force,
        out_of_range: false,
        dt: 0.01,
        fresh: true,
        pressed_m: None,
        travelled_m: 0.0,
        normal_m: 0.0,
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
    let v = g.velocity(&input(Vector3::new(0.1, 0.0, 0.5)));
    assert!(v.x == 0.0 && v.z < 0.0, "deadband on x, press on z: {v}");
    assert_eq!(g.targets(), [Some(0.0), Some(0.0), Some(1.0)]);
}

#[test]
fn out_of_range_input_stops() {
    for force in [Vector3::new(0.5, 0.0, 1.0), Vector3::new(0.0, 0.0, 8.0)] {
        let mut g = guided();
        let i = GuidedInput {
            out_of_range: true,
            ..input(force)
        };
        assert_eq!(g.velocity(&i), Vector3::zeros());
        // Even over the limit: the estimate is not trusted.
        assert_eq!(g.reason(), Some(StopReason::OutOfRange), "{force}");
    }
}

#[test]
fn force_limit_stops_for_good() {
    let mut g = guided();
    assert_eq!(
        g.velocity(&input(Vector3::new(0.0, 0.0, 6.0))),
        Vector3::zeros()
    );
    assert_eq!(g.velocity(&input(Vector3::zeros())), Vector3::zeros());
    assert_eq!(
        (g.phase(), g.reason()),
        (Phase::Stopped, Some(StopReason::ForceLimit))
    );
}

#[test]
fn with_nothing_to_follow_it_stops_at_its_time_or_travel() {
    let mut g = guided();
    let steps = (0..1000)
        .position(|_| g.velocity(&input(Vector3::zeros())) == Vector3::zeros())
        .unwrap();
    assert_eq!((steps, g.reason()), (200, Some(StopReason::Timeout)));
    let mut g = guided();
    let far = GuidedInput {
        travelled_m: 0.1,
        ..input(Vector3::new(0.0, 0.0, 1.0))
    };
    assert_eq!(g.velocity(&far), Vector3::zeros());
    assert_eq!(g.reason(), Some(StopReason::TravelLimit));
}

#[test]
fn an_oscillating_axis_is_softened_then_the_pad_retracts() {
    let mut g = guided();
    g.velocity(&input(Vector3::new(0.0, 0.0, 1.0)));
    let (before, z) = (g.gains()[0].unwrap(), g.gains()[2]);
    let swing = |k: usize| Vector3::new(if k % 8 < 4 { 0.5 } else { -0.5 }, 0.0, 1.0);
    let mut k = 0;
    while g.figures().softened == 0 {
        g.velocity(&input(swing(k)));
        k += 1;
        assert!(k < 100, "never detected");
    }
    assert!((g.gains()[0].unwrap() / before - 0.5).abs() < 1e-9);
    assert_eq!(g.gains()[2], z, "z untouched");
    while g.phase() == Phase::Follow {
        g.velocity(&input(swing(k)));
        k += 1;
        assert!(k < 200, "never retracted");
    }
    assert_eq!(
        (g.phase(), g.reason()),
        (Phase::Retract, Some(StopReason::Oscillating))
    );
    let away = g.velocity(&input(Vector3::zeros()));
    assert!(away.z > 0.0, "{away}");
    let done = GuidedInput {
        normal_m: 0.006,
        ..input(Vector3::zeros())
    };
    assert_eq!(g.velocity(&done), Vector3::zeros());
    assert_eq!(g.phase(), Phase::Stopped);
}

#[test]
fn across_the_pad_the_arm_moves_with_the_finger_and_lags_it_less() {
    // A finger sliding at 30 mm/s along x over a contact of 250 N/m,
    // the arm tracking commands 40 ms late: the force it takes to move.
    let lag_behind = |feedforward: bool| {
        let mut g = guided();
        let (k, dt) = (250.0, 0.01);
        let (mut arm, mut finger, mut queue) = (0.0, 0.0, vec![0.0; 4]);
        let (mut v_arm, mut worst) = (0.0, 0.0f64);
        for step in 0..300 {
            finger += 0.03 * dt;
            let f = k * (finger - arm);
            let i = GuidedInput {
                arm_velocity: feedforward.then(|| Vector3::new(v_arm, 0.0, 0.0)),
                timing: LoopTiming {
                    latency_s: 0.04,
                    ..input(Vector3::zeros()).timing
                },
                ..input(Vector3::new(f, 0.0, 1.0))
            };
            queue.push(g.velocity(&i).x);
            v_arm = queue.remove(0);
            arm += v_arm * dt;
            if step > 200 {
                worst = worst.max(f.abs());
            }
        }
        worst
    };
    let (with, without) = (lag_behind(true), lag_behind(false));
    assert!(with < 0.7 * without, "{with} N with, {without} N without");
}

/// A finger of 20 g on its hand's spring (300 N/m, 3 N s/m, as
/// tests/ros/mujoco_ur5.py's) behind the skin's 1500 N/m across the pad,
/// its hand sliding at 40 mm/s along x; an arm without servo lag (8 ms of
/// latency, then a joint position servo); the arm's velocity measured over
/// 20 ms, as the controller does from joint_states. The x force's largest
/// change between two estimates once the slide is steady, and the times
/// the watchdog lowered a gain.
fn slide_with_a_massive_finger() -> (f64, u32) {
    let mut g = guided();
    let (h, period) = (0.0005, 0.01);
    let steps_per_period = (period / h) as usize;
    let (mut x_arm, mut v_arm, mut x_finger, mut v_finger) = (0.0, 0.0, 0.0, 0.0);
    let mut target = 0.0;
    let mut arm_at = vec![0.0; 41]; // the arm's positions of the last 20 ms
    let mut queue = vec![0.0; (0.008 / h) as usize];
    let (mut command, mut previous, mut worst) = (0.0, 0.0, 0.0f64);
    // 5 mN of uniform noise on the estimate (a fixed sequence).
    let mut seed = 1u64;
    let mut noise = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        0.01 * ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5)
    };
    for step in 0..(3.0 / h) as usize {
        let t = step as f64 * h;
        let hand = 0.04 * (t - 0.5).max(0.0);
        let skin = 1500.0 * (x_finger - x_arm) + 2.0 * (v_finger - v_arm);
        if step % steps_per_period == 0 {
            let i = GuidedInput {
                arm_velocity: Some(Vector3::new((x_arm - arm_at[0]) / 0.02, 0.0, 0.0)),
                timing: LoopTiming {
                    transport_s: 0.0005,
                    latency_s: 0.008,
                    lag_s: 0.01,
                    period_s: period,
                },
                ..input(Vector3::new(skin + noise(), 0.0, 1.0))
            };
            command = g.velocity(&i).x;
            if t > 1.5 {
                worst = worst.max((skin - previous).abs());
            }
            previous = skin;
        }
        // The joint servo integrates the command into a position it tracks,
        // critically damped at 200 rad/s.
        queue.push(command);
        let acting = queue.remove(0);
        target += acting * h;
        v_arm += h * (200.0f64.powi(2) * (target - x_arm) + 400.0 * (acting - v_arm));
        x_arm += v_arm * h;
        arm_at.push(x_arm);
        arm_at.remove(0);
        v_finger += h * (300.0 * (hand - x_finger) - 3.0 * v_finger - skin) / 0.02;
        x_finger += v_finger * h;
    }
    (worst, g.figures().softened)
}

#[test]
fn following_a_finger_with_mass_does_not_ring() {
    let (worst, softened) = slide_with_a_massive_finger();
    assert!(
        worst < 0.02 && softened == 0,
        "the force changed by up to {worst} N between estimates, {softened} gain(s) lowered"
    );
}
