//! The closed loop at the edges: contact stiffness from 10 N/m to 1e6 N/m,
//! a jittery control period, a singular arm pose at the start, a BioTac that
//! stops sending or saturates, the force limit hit during the approach. Each
//! run must stay finite and bounded, and end holding or stopped safely.

use tactile_force::biotac::{BioTacReading, ADC_MAX};
use tactile_force::contact::BodyParams;
use tactile_force::control::{GuardedParams, GuidedParams, Phase, StopReason, TaskKind};
use tactile_force::report::summary::{summarize, RunInfo, Summary};
use tactile_force::report::TraceRow;
use tactile_force::runtime::demo::{run_scene, DemoRun};
use tactile_force::runtime::lockstep::ReadingTamper;
use tactile_force::runtime::{Pacing, Scene};
use tactile_force::sim::finger::Segment;

/// `pd.max_speed_mps` of config/world.yaml: no command is faster.
const MAX_SPEED: f64 = 0.08;

mod common;
use common::model;

fn run(scene: Scene) -> DemoRun {
    run_scene(&scene, Box::new(model()), 1, Pacing::Lockstep, &mut |_| {})
        .expect("the run completes")
}

/// Runs `scene` for its whole duration, each BioTac reading passing through
/// `fault` on its way to the estimator.
fn run_faulty(scene: &Scene, fault: ReadingTamper) -> DemoRun {
    let mut nodes = scene
        .build(Box::new(model()), &Default::default(), 1)
        .expect("the scene builds");
    let periods = (nodes.sim.duration_s() / nodes.sim.period_s()).round() as usize;
    let rows: Vec<TraceRow> = (0..=periods)
        .map(|_| {
            let period = nodes.step_period(fault, &mut |_, _| {});
            period.expect("the model takes 19 electrodes").row()
        })
        .collect();
    let info = RunInfo::new(
        &scene.controller,
        &scene.tasks,
        &nodes.controller.robot().name,
    )
    .unwrap();
    DemoRun {
        summary: summarize(&info, &rows),
        gains: nodes.controller.gains(),
        rows,
    }
}

/// Index of the first row at or after `t` (s).
fn at(rows: &[TraceRow], t: f64) -> usize {
    rows.iter()
        .position(|r| r.t >= t - 1e-9)
        .expect("the run reaches t")
}

/// Every number finite and every commanded speed within `max_mps`.
fn assert_sane(rows: &[TraceRow], max_mps: f64) {
    for r in rows {
        let est_ok = r
            .estimate
            .is_none_or(|(m, s)| m.iter().chain(s.iter()).all(|v| v.is_finite()));
        assert!(
            est_ok && r.measured.iter().all(|v| v.is_finite()),
            "t {}",
            r.t
        );
        assert!(r
            .offset
            .iter()
            .chain(r.velocity.iter())
            .all(|v| v.is_finite()));
        assert!(
            r.commanded.norm() <= max_mps + 1e-9,
            "t {}: {}",
            r.t,
            r.commanded
        );
    }
}

fn object(stiffness: f64) -> Scene {
    let body = BodyParams {
        stiffness_n_per_m: stiffness,
        damping_n_s_per_m: 1.0,
        friction: 0.5,
    };
    Scene::builtin(TaskKind::Guarded)
        .unwrap()
        .with_body("test", body)
        .with_only_object("test")
}

fn holds(s: &Summary) -> bool {
    s.overshoot_n <= 0.1 && s.steady_state_error_n.is_some_and(|e| e <= 0.05) && !s.aborted
}

#[test]
fn contact_stiffness_from_10_to_1e6_n_per_m() {
    for k in [1e2, 1e3, 1e4, 1e5, 1e6] {
        let r = run(object(k));
        assert_sane(&r.rows, MAX_SPEED);
        assert!(holds(&r.summary), "k {k}: {:?}", r.summary);
    }
    // 10 N/m: 1 N needs 100 mm of squeeze, more than the 50 mm approach
    // distance. The move presses gently, never past the force limit, and
    // stops at that distance (travel_limit).
    let r = run(object(10.0));
    assert_sane(&r.rows, MAX_SPEED);
    let s = &r.summary;
    assert!(s.contact_time_s.is_some() && s.peak_force_n < 1.0, "{s:?}");
    assert!(!s.aborted && s.final_phase == "stopped", "{s:?}");
    assert_eq!(s.reason, Some("travel_limit"), "{s:?}");
}

#[test]
fn a_control_period_jittering_by_30_percent() {
    let jitter = |task| {
        let mut scene = Scene::builtin(task).unwrap();
        scene.sim.period_jitter_fraction = 0.3;
        scene
    };
    let r = run(jitter(TaskKind::Guarded));
    assert_sane(&r.rows, MAX_SPEED);
    assert!(holds(&r.summary), "{:?}", r.summary);
    let gaps: Vec<f64> = r.rows.windows(2).map(|w| w[1].t - w[0].t).collect();
    let (lo, hi) = gaps
        .iter()
        .fold((1.0f64, 0.0f64), |(a, b), &g| (a.min(g), b.max(g)));
    assert!(
        lo < 0.008 && hi > 0.012,
        "the period really jitters: {lo} {hi}"
    );

    let r = run(jitter(TaskKind::Guided));
    assert_sane(&r.rows, MAX_SPEED);
    let s = &r.summary;
    assert!(
        s.rms_force_error_by_axis_n.values().all(|&e| e <= 0.3),
        "{s:?}"
    );
    assert!(s.max_off_axis_ratio.unwrap() <= 0.1 && !s.aborted, "{s:?}");
}

#[test]
fn a_singular_pose_at_the_start_gives_slow_bounded_motion() {
    // Arm stretched upright, wrist bent 90 deg: moving along the pad normal
    // is a singular direction; damping keeps joint speeds bounded.
    let start = |deg: [f64; 7]| {
        let mut scene = Scene::builtin(TaskKind::Guarded).unwrap();
        scene.sim.start_joints_deg = Some(deg.to_vec());
        scene
    };
    let r = run(start([0.0, 0.0, 0.0, 0.0, 0.0, 90.0, 0.0]));
    assert_sane(&r.rows, MAX_SPEED);
    let s = &r.summary;
    assert!(!s.aborted && s.peak_force_n < 0.1, "{s:?}");
    // It still creeps towards the object, slowly.
    let last = r.rows.last().unwrap();
    assert!(
        last.offset.z < -1e-4 && last.velocity.norm() < 1e-3,
        "{:?}",
        last.offset
    );
    // Straight up is singular too, but there the pad direction is free.
    let r = run(start([0.0; 7]));
    assert_sane(&r.rows, MAX_SPEED);
    assert!(holds(&r.summary), "{:?}", r.summary);
}

#[test]
fn pushing_harder_than_the_training_data_stops_on_the_estimators_doubt() {
    // The training data reach ~11 N. Asked for 25 N (limit 40 N), the move
    // must not trust an estimate that falls behind the true force: the GP's
    // standard deviation and PDC saturation stop it well before.
    let r = run(with_forces(
        Scene::builtin(TaskKind::Guarded).unwrap(),
        25.0,
        40.0,
    ));
    assert_sane(&r.rows, MAX_SPEED);
    let s = &r.summary;
    assert_eq!((s.reason, s.aborted), (Some("out_of_range"), true), "{s:?}");
    assert!(s.peak_force_n > 11.0 && s.peak_force_n < 16.0, "{s:?}");
    assert_eq!(s.final_phase, "stopped");
    assert!(
        r.rows.last().unwrap().measured.z < 0.1,
        "retracted off the object"
    );
}

/// `scene` with the guarded move's target force and force limit (N).
fn with_forces(mut scene: Scene, target_n: f64, limit_n: f64) -> Scene {
    scene
        .controller
        .edit_section(|g: &mut GuardedParams| {
            g.target_force_n = target_n;
            g.force_limit_n = limit_n;
        })
        .unwrap();
    scene
}

/// The guided move with a short finger path: it waits 2 s, then pushes
/// 30 mm along +x.
fn short_guided() -> Scene {
    let mut scene = Scene::builtin(TaskKind::Guided).unwrap();
    scene.sim.finger_path = Some(vec![
        Segment::Wait(2.0),
        Segment::Push {
            mm: [30.0, 0.0, 0.0],
            peak_speed_mps: 0.05,
        },
        Segment::Wait(1.0),
    ]);
    scene.sim.duration_s = 4.2;
    scene
}

/// Largest measured force magnitude (N).
fn peak_force(rows: &[TraceRow]) -> f64 {
    rows.iter().map(|r| r.measured.norm()).fold(0.0, f64::max)
}

/// Loses every BioTac reading of `scene` for 0.5 s from `from` (s); checks
/// that the last estimate drives the task only while it is at most
/// `stale_periods` old, that the arm is then halted with a zero command
/// until readings return, and that the task takes over again at once.
fn drop_readings_for_half_a_second(scene: &Scene, from: f64) -> DemoRun {
    let to = from + 0.5;
    let r = run_faulty(scene, &mut |t, reading| {
        if (from..to).contains(&t) {
            *reading = None;
        }
    });
    let rows = &r.rows;
    let p = scene.controller.clone();
    let (first, back) = (at(rows, from), at(rows, to));
    let last_reading = rows[first - 1].t;
    let halt = first + rows[first..].iter().position(|r| r.halted).unwrap();
    // Halted in the first period past the limit: 0.04 s after the last reading.
    let age = rows[halt].t - last_reading;
    assert!(
        (age - (p.stale_periods + 1.0) * p.control_period_s).abs() < 1e-9,
        "{age}"
    );
    assert!(rows[halt..back]
        .iter()
        .all(|r| r.halted && r.commanded.norm() == 0.0 && r.estimate.is_none()));
    assert!(!rows[back].halted && rows[back].estimate.is_some());
    r
}

#[test]
fn a_sensor_dropout_of_half_a_second_halts_the_arm_and_the_task_resumes() {
    // Guarded move, holding 1 N on the wooden box from ~1.8 s.
    let r = drop_readings_for_half_a_second(&Scene::builtin(TaskKind::Guarded).unwrap(), 3.0);
    assert_sane(&r.rows, MAX_SPEED);
    let s = &r.summary;
    // The halted arm keeps the force: 1.00..1.04 N measured while blind.
    let blind = &r.rows[at(&r.rows, 3.0)..at(&r.rows, 3.5)];
    assert!(blind.iter().all(|r| (r.measured.z - 1.0).abs() < 0.1));
    assert!(peak_force(&r.rows) < 1.1, "far below the 3 N limit: {s:?}");
    // Holds 1 N again (steady-state error 0.007 N).
    assert!(holds(s) && s.final_phase == "hold", "{s:?}");

    // Guided move, blind while the finger waits; its push comes after.
    let r = drop_readings_for_half_a_second(&short_guided(), 1.0);
    assert_sane(&r.rows, MAX_SPEED);
    let s = &r.summary;
    assert!(peak_force(&r.rows) < 2.0, "far below the 5 N limit: {s:?}");
    assert!(
        s.rms_force_error_by_axis_n.values().all(|&e| e <= 0.3),
        "{s:?}"
    );
    assert!(s.max_off_axis_ratio.unwrap() <= 0.1 && !s.aborted, "{s:?}");
    // It followed the push to where the finger went.
    let end = r.rows.last().unwrap();
    assert!(
        (end.offset.x - end.finger.unwrap().offset.x).abs() < 3e-3,
        "{end:?}"
    );
}

/// Pins the electrodes `which` (0-based) and, if `pdc`, PDC at the 12-bit
/// ADC's full scale (4095 counts, architecture page "BioTac") in the
/// readings from `from` to `until` (s).
fn saturate(
    which: std::ops::Range<usize>,
    pdc: bool,
    from: f64,
    until: f64,
) -> impl FnMut(f64, &mut Option<BioTacReading>) {
    move |t, reading| {
        if let (true, Some(r)) = ((from..until).contains(&t), reading) {
            r.electrodes[which.clone()].fill(ADC_MAX);
            if pdc {
                r.pdc = ADC_MAX;
            }
        }
    }
}

#[test]
fn saturated_electrodes_or_pdc_stop_the_move_as_out_of_range() {
    let scene = Scene::builtin(TaskKind::Guarded).unwrap();
    let limits = scene.controller.clone().out_of_range;
    // (what, electrodes, PDC, until): the fault starts at 3 s, mid-hold.
    let cases = [
        ("E17..E19 stuck", 16..19, false, f64::INFINITY),
        ("PDC stuck", 0..0, true, f64::INFINITY),
        ("all stuck", 0..19, true, f64::INFINITY),
        ("all for one frame", 0..19, true, 3.005),
    ];
    for (what, which, pdc, until) in cases {
        let electrodes = !which.is_empty();
        let r = run_faulty(&scene, &mut saturate(which, pdc, 3.0, until));
        assert_sane(&r.rows, MAX_SPEED);
        let i = at(&r.rows, 3.0);
        let (before, row) = (&r.rows[i - 1], &r.rows[i]);
        assert_eq!((before.phase, before.reason), (Phase::HOLD, None), "{what}");
        // Retract in the very cycle of the first saturated reading.
        assert_eq!(
            (row.phase, row.reason),
            (Phase::RETRACT, Some(StopReason::OUT_OF_RANGE)),
            "{what}"
        );
        assert!(
            (row.commanded.z - 0.01).abs() < 1e-9,
            "{what}: {}",
            row.commanded
        );
        // Which limit saw it: the GP's doubt, or PDC near saturation.
        let (std_z, pdc_rise) = (row.estimate.unwrap().1.z, row.pdc_rise.unwrap());
        assert_eq!(std_z > limits.max_std_n, electrodes, "{what}: {std_z}");
        assert_eq!(
            pdc_rise > limits.max_pdc_rise_counts,
            pdc,
            "{what}: {pdc_rise}"
        );
        let s = &r.summary;
        assert_eq!(
            (s.reason, s.aborted),
            (Some("out_of_range"), true),
            "{what}: {s:?}"
        );
        assert_eq!(s.final_phase, "stopped", "{what}");
        assert!(s.peak_force_n < 1.1, "{what}: {s:?}");
        assert!(
            r.rows.last().unwrap().measured.z < 0.1,
            "{what}: off the object"
        );
    }

    // The guided move stops where it is: the GP mean, over the 5 N limit,
    // is not read as a force.
    let r = run_faulty(
        &short_guided(),
        &mut saturate(0..19, true, 1.0, f64::INFINITY),
    );
    assert_sane(&r.rows, MAX_SPEED);
    let stop = at(&r.rows, 1.0);
    let limit: GuidedParams = short_guided().controller.section().unwrap();
    let mean = r.rows[stop].estimate.unwrap().0;
    assert!(mean.norm() > limit.force_limit_n, "{mean}");
    assert_eq!(r.rows[stop - 1].phase, Phase::FOLLOW);
    assert!(r.rows[stop..].iter().all(|r| r.phase == Phase::STOPPED
        && r.reason == Some(StopReason::OUT_OF_RANGE)
        && r.commanded.norm() == 0.0));
}

#[test]
fn a_single_saturated_reading_gives_a_finite_doubtful_estimate() {
    let scene = Scene::builtin(TaskKind::Guarded).unwrap();
    let limits = scene.controller.clone().out_of_range;
    let mut n = scene
        .build(Box::new(model()), &Default::default(), 1)
        .unwrap();
    // Out of contact: the estimator tares on its first readings.
    while !n.estimator.is_tared() {
        n.step_period(&mut |_, _| {}, &mut |_, _| {}).unwrap();
    }
    let normal = n.sim.sample().reading;
    let mut saturated = normal;
    saturated.electrodes.fill(ADC_MAX);
    saturated.pdc = ADC_MAX;
    let e = n.estimator.on_reading(&saturated).unwrap().unwrap();
    assert!(e.is_finite(), "{e:?}");
    // Far outside the data the mean means nothing (an exact GP falls back
    // towards the prior, a sparse one less so); the doubt is large on every axis.
    assert!(e.std.force.min() > 20.0 * limits.max_std_n, "{e:?}");
    assert!(e.pdc_rise > limits.max_pdc_rise_counts, "{e:?}");
    // The next good reading is estimated as if nothing happened.
    let e = n.estimator.on_reading(&normal).unwrap().unwrap();
    assert!(e.mean.force.norm() < 0.05 && e.std.force.z < 0.01, "{e:?}");
}

#[test]
fn the_force_limit_hit_during_the_approach_retracts_in_the_same_cycle() {
    // At 80 mm/s the pad moves 0.8 mm a period. With the object 0.7 mm short
    // of where the pad is at some tick, the previous tick sees no contact and
    // that tick 0.7 mm of skin squeeze, ~0.4 N: past a 0.3 N limit straight
    // from the approach. The approach does not depend on the object, so a
    // run without contact tells where the pad is at each tick. The
    // controller is told the body is a soft sponge, so that its safety
    // envelope accepts 80 mm/s against a 0.3 N limit: the wooden box's
    // would refuse it (the one way past the envelope is a wrong declaration).
    let fast = |gap_mm: f64| {
        let mut scene = Scene::builtin(TaskKind::Guarded)
            .unwrap()
            .with_approach_speed(0.08)
            .unwrap();
        let sponge = BodyParams {
            stiffness_n_per_m: 10.0,
            damping_n_s_per_m: 0.1,
            friction: 0.5,
        };
        let c = &mut scene.controller;
        c.objects.insert("sponge".into(), sponge);
        c.object = "sponge".into();
        c.safety.objects = vec!["sponge".into()];
        scene.sim.object_gap_mm = gap_mm;
        scene
    };
    let free = run(fast(80.0));
    let tick = free.rows.iter().find(|r| r.offset.z < -0.010).unwrap();
    let gap_mm = -tick.offset.z * 1e3 - 0.7;
    let r = run(with_forces(fast(gap_mm), 0.2, 0.3));
    assert_sane(&r.rows, MAX_SPEED);
    let over = r
        .rows
        .iter()
        .position(|r| r.phase != Phase::APPROACH)
        .unwrap();
    let (before, row) = (&r.rows[over - 1], &r.rows[over]);
    assert!((row.t - tick.t).abs() < 1e-9, "{} {}", row.t, tick.t);
    // No contact seen before: neither force nor PDC.
    let force = |r: &TraceRow| r.estimate.unwrap().0.z;
    assert!(force(before) < 0.15 && before.pdc_rise.unwrap() < 30.0);
    assert!(force(row) > 0.3);
    assert_eq!(
        (row.phase, row.reason),
        (Phase::RETRACT, Some(StopReason::FORCE_LIMIT))
    );
    assert!((row.commanded.z - 0.01).abs() < 1e-9, "{}", row.commanded);
    let s = &r.summary;
    assert_eq!((s.reason, s.aborted), (Some("force_limit"), true), "{s:?}");
    assert_eq!(s.final_phase, "stopped");
    assert!(r.rows.last().unwrap().measured.z < 0.1, "off the object");
}
#[test]
fn zz_debug() {
    let r = drop_readings_for_half_a_second(&short_guided(), 1.0);
    for row in r.rows.iter().step_by(5) {
        println!(
            "{:.2} m {:.3} {:.3} {:.3} cmd {:.4} {:.4} {:.4} h {}",
            row.t,
            row.measured.x,
            row.measured.y,
            row.measured.z,
            row.commanded.x,
            row.commanded.y,
            row.commanded.z,
            row.halted
        );
    }
}
