use super::*;
use crate::biotac::Tare;
use crate::wrench::Axis;

fn noise_free_reference() -> CollectConfig {
    let mut p = CollectConfig::default().params;
    p.ft_noise_std = FtNoiseStd {
        force_n: [0.0; 3],
        torque_nm: [0.0; 3],
    };
    p.validate().expect("valid")
}

fn trial(records: &[Record], set: u32, trial: u32) -> Vec<&Record> {
    records
        .iter()
        .filter(|r| r.set == set && r.trial == trial)
        .collect()
}

#[test]
fn shipped_protocol_is_the_thesis_protocol() {
    let c = CollectConfig::default();
    let p = c.params();
    assert_eq!(p.trials_per_set, 10);
    assert_eq!(c.samples_per_trial(), 2000);
    assert_eq!(p.tare_samples, 50);
    assert_eq!(c.ft_noise_std().get(Axis::Fz), 0.02);
    assert_eq!(
        c,
        CollectConfig::from_yaml_str(DEFAULT_CONFIG_YAML).expect("valid")
    );
}

/// Mean electrode values and TDC over the tare window of the first trial.
fn first_baselines(records: &[Record], n: usize) -> ([f64; 19], f64) {
    let mean = |f: &dyn Fn(&Record) -> f64| records[..n].iter().map(f).sum::<f64>() / n as f64;
    let e = std::array::from_fn(|i| mean(&|r| f64::from(r.reading.electrodes[i])));
    (e, mean(&|r| f64::from(r.reading.tdc)))
}

#[test]
fn the_unit_fixes_the_sensor_and_the_session_the_day() {
    let c = CollectConfig::default().with_trials(1).expect("valid");
    let s = BioTacSimConfig::default();
    let n = c.params().tare_samples as usize;
    let largest_gap = |unit: u64, records: &[Record]| {
        let (measured, tdc) = first_baselines(records, n);
        let mut sim = BioTacSim::new(&s, unit_seed(unit));
        sim.set_temperature(tdc);
        let expected = sim.electrode_baselines();
        (0..19)
            .map(|i| (measured[i] - expected[i]).abs())
            .fold(0.0, f64::max)
    };
    let (day1, day2) = (collect(&c, &s, 5, 1), collect(&c, &s, 5, 2));
    // Unit 5's baselines, within the noise of a 50-sample mean, on any day.
    assert!(largest_gap(5, &day1) < 3.0, "{}", largest_gap(5, &day1));
    assert!(largest_gap(5, &day2) < 3.0, "{}", largest_gap(5, &day2));
    assert!(largest_gap(6, &day1) > 20.0, "unit 6 is another sensor");
    // Another day: another temperature, other pushes.
    assert!((first_baselines(&day1, n).1 - first_baselines(&day2, n).1).abs() > 1.0);
    assert!(day1[500].wrench != day2[500].wrench);
    assert!(
        collect(&c, &s, 5, 1) == day1,
        "same unit and session, same records"
    );
}

#[test]
fn trials_shortens_the_protocol_and_refuses_zero() {
    let c = CollectConfig::default();
    let one = c.with_trials(1).expect("valid");
    assert_eq!(one.params().trials_per_set, 1);
    // Four sets of one 20 s trial: 80 s.
    let records = collect(&one, &BioTacSimConfig::default(), 1, 1);
    assert_eq!(records.len(), 4 * 2000);
    let e = c.with_trials(0).expect_err("no trial").to_string();
    assert!(e.contains("protocol.trials_per_set = 0"), "{e}");
}

#[test]
fn collect_is_4_sets_of_10_trials_of_2000_rows_and_deterministic() {
    let (c, s) = (CollectConfig::default(), BioTacSimConfig::default());
    let a = collect(&c, &s, 1, 42);
    assert_eq!(a.len(), 4 * 10 * 2000);
    for set in 1..=4 {
        for t in 1..=10 {
            let rows = trial(&a, set, t);
            assert_eq!(rows.len(), 2000, "set {set} trial {t}");
            assert_eq!(rows[0].t, 0.0);
            assert!((rows[1999].t - 19.99).abs() < 1e-9);
        }
    }
    assert!(a == collect(&c, &s, 1, 42), "same seed, same records");
    let b = collect(&c, &s, 1, 43);
    assert!(a[0].reading != b[0].reading && a[500].wrench != b[500].wrench);
}

#[test]
fn each_set_pushes_mainly_along_its_axis_within_the_configured_bounds() {
    let c = CollectConfig::default();
    let p = c.params();
    let records = collect(&c, &BioTacSimConfig::default(), 1, 7);
    let slack = 5.0 * 0.02;
    // The contact angle and the mount tilt the normal by at most 7 deg into y.
    let tilt = (p.contact_angle_deg[1] + p.session.mount_offset_angle_deg[1])
        .to_radians()
        .sin();
    for (set, name, spec) in p.sets.numbered() {
        let max = |axis: Axis| {
            records
                .iter()
                .filter(|r| r.set == set)
                .map(|r| r.wrench.get(axis).abs())
                .fold(0.0, f64::max)
        };
        let (fx, fy, fz) = (max(Axis::Fx), max(Axis::Fy), max(Axis::Fz));
        let normal = spec.max_normal_n(p.max_traction_ratio);
        let tangential = spec.tangential_peak_n[1];
        assert!(fz <= normal + slack, "{name}: fz {fz} > {normal}");
        assert!(fx <= tangential + slack, "{name}: fx {fx}");
        assert!(fy <= tangential + tilt * normal + slack, "{name}: fy {fy}");
        match name {
            "x" => assert!(fx > 0.8 * tangential && fx > 2.0 * fy, "x: {fx} {fy}"),
            "y" => assert!(fy > 0.8 * tangential && fy > 2.0 * fx, "y: {fx} {fy}"),
            "z" => assert!(fz > 0.85 * normal && fz > 4.0 * fx.max(fy), "z: {fz}"),
            _ => assert!(fx > 0.8 * tangential && fy > 0.8 * tangential && fz > 0.85 * normal),
        }
    }
    // Thesis table 3.1: up to ~11 N in z, ~6-7 N in x/y.
    let fz = records.iter().map(|r| r.wrench.force.z).fold(0.0, f64::max);
    assert!(fz > 10.0 && fz < 11.2, "max fz {fz}");
}

#[test]
fn trials_start_with_tare_samples_and_end_out_of_contact() {
    let c = noise_free_reference();
    let config = BioTacSimConfig::default();
    let records = collect(&c, &config, 1, 3);
    let tare_n = c.params().tare_samples as usize;
    let noise = config.params().electrodes.noise_counts;
    for set in 1..=4 {
        for t in 1..=10 {
            let rows = trial(&records, set, t);
            let idle = |r: &&Record| r.wrench == Wrench::default();
            assert!(
                rows[..tare_n].iter().all(idle),
                "set {set} trial {t} starts in contact"
            );
            assert!(
                idle(&rows[rows.len() - 1]),
                "set {set} trial {t} ends in contact"
            );
            assert!(rows.iter().any(|r| r.wrench.force.z > 2.0));
            // The tare from the idle start removes the baseline of the idle end.
            let start: Vec<_> = rows[..tare_n].iter().map(|r| r.reading).collect();
            let tare = Tare::from_readings(&start).expect("non-empty");
            let end = tare.tared(&rows[rows.len() - 1].reading);
            assert!(end.iter().all(|v| v.abs() < 5.0 * noise + 3.0), "{end:?}");
        }
    }
}

/// Where the plate touched the pad in every row pressed with more than
/// 0.5 N, from the reference wrench: (x in mm, angle about +x in deg).
fn touched(records: &[Record]) -> Vec<(f64, f64)> {
    let mut points = Vec::new();
    for r in records.iter().filter(|r| r.wrench.force.norm() > 0.5) {
        let (f, tau) = (r.wrench.force, r.wrench.torque * 1e3); // torque in N mm
        assert!(
            tau.dot(&f).abs() < 1e-9 * f.norm_squared(),
            "torque not normal to force"
        );
        // The line of action r0 + l F must cross the pad where the plate touched it.
        let r0 = f.cross(&tau) / f.norm_squared();
        let a = f.y * f.y + f.z * f.z;
        let b = 2.0 * (r0.y * f.y + r0.z * f.z);
        let cc = r0.y * r0.y + r0.z * r0.z - SKIN_RADIUS_MM * SKIN_RADIUS_MM;
        let disc = (b * b - 4.0 * a * cc).max(0.0).sqrt();
        let hit = [(-b - disc) / (2.0 * a), (-b + disc) / (2.0 * a)]
            .map(|l| r0 + f * l)
            .into_iter()
            .fold(Vector3::new(0.0, 0.0, f64::INFINITY), |m, q| {
                if q.z < m.z {
                    q
                } else {
                    m
                }
            });
        points.push((hit.x, hit.y.atan2(-hit.z).to_degrees()));
    }
    points
}

#[test]
fn reference_torque_is_r_cross_f_for_a_point_on_the_pad() {
    let c = noise_free_reference();
    let p = c.params();
    let records = collect(&c, &BioTacSimConfig::default(), 1, 5);
    let m = &p.session;
    let (x0, x1) = (
        p.contact_x_mm[0] + m.mount_offset_x_mm[0],
        p.contact_x_mm[1] + m.mount_offset_x_mm[1],
    );
    let angle_max = p.contact_angle_deg[1] + m.mount_offset_angle_deg[1];
    let points = touched(&records);
    for &(x, angle) in &points {
        assert!(x > x0 - 1e-6 && x < x1 + 1e-6, "{x}");
        assert!(angle.abs() <= angle_max + 1e-6, "{angle}");
    }
    assert!(points.len() > 40_000, "{} rows in contact", points.len());
}

#[test]
fn on_the_arm_every_session_touches_where_the_protocol_says() {
    let c = noise_free_reference().with_trials(1).unwrap();
    let p = c.params();
    let sim = BioTacSimConfig::default();
    // Mounted by hand, sessions shift the contact (mount_offset_x_mm).
    let off: Vec<_> = (1..=4)
        .map(|s| touched(&collect(&c, &sim, 1, s)))
        .filter(|t| t.iter().any(|&(x, _)| x < p.contact_x_mm[0] - 0.01))
        .collect();
    assert!(
        !off.is_empty(),
        "no session mounted off the protocol's range"
    );
    // On the arm, none does.
    let arm = c.on_the_arm();
    for s in 1..=4 {
        for (x, angle) in touched(&collect(&arm, &sim, 1, s)) {
            assert!(
                x >= p.contact_x_mm[0] - 1e-6 && x <= p.contact_x_mm[1] + 1e-6,
                "{x}"
            );
            assert!(angle.abs() <= p.contact_angle_deg[1] + 1e-6, "{angle}");
        }
    }
}

#[test]
fn pushes_respect_the_friction_cone_and_fit_the_trial() {
    let c = CollectConfig::default();
    let p = c.params();
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mount = Mount {
        x_mm: 1.0,
        angle_deg: -3.0,
    };
    for (_, _, spec) in p.sets.numbered() {
        for _ in 0..50 {
            let plan = TrialPlan::sample(p, spec, &mount, &mut rng);
            let last = plan.pushes.last().expect("pushes >= 1");
            assert!(last.start_s + last.duration_s <= p.trial_duration_s - p.min_rest_s + 1e-9);
            assert!(plan.pushes[0].start_s >= 0.5 + p.min_rest_s - 1e-9);
            for k in 0..2000 {
                let Some(contact) = plan.contact_at(k as f64 * 0.01) else {
                    continue;
                };
                let n = contact.surface().normal;
                let normal = contact.normal_force();
                let tangential = (contact.force + n * normal).norm();
                assert!(tangential <= p.max_traction_ratio * normal + 1e-9);
            }
        }
    }
}

fn error_of(yaml: &str) -> String {
    CollectConfig::from_yaml_str(yaml)
        .expect_err("must be rejected")
        .to_string()
}

#[test]
fn config_errors_name_the_key() {
    let missing = DEFAULT_CONFIG_YAML.replace("  tare_samples: 50\n", "");
    let e = error_of(&missing);
    assert!(e.contains("protocol: missing field `tare_samples`"), "{e}");
    let unknown =
        DEFAULT_CONFIG_YAML.replace("      pushes: 2\n", "      pushes: 2\n      pulls: 1\n");
    let e = error_of(&unknown);
    assert!(e.contains("protocol.sets.x: unknown field `pulls`"), "{e}");
    let negative = DEFAULT_CONFIG_YAML.replace("[0.02, 0.02, 0.02]", "[0.02, -0.02, 0.02]");
    let e = error_of(&negative);
    assert!(
        e.contains("protocol.ft_noise_std.force_n[1] = -0.02"),
        "{e}"
    );
    let nan = DEFAULT_CONFIG_YAML.replace("trial_duration_s: 20.0", "trial_duration_s: .nan");
    assert!(
        error_of(&nan).contains("protocol.trial_duration_s = NaN"),
        "{}",
        error_of(&nan)
    );
    let long = DEFAULT_CONFIG_YAML.replace("[6.0, 8.0]", "[6.0, 9.5]");
    let e = error_of(&long);
    assert!(
        e.contains("protocol.sets.combined.push_duration_s[1] = 9.5: expected at most 9.000 s"),
        "{e}"
    );
    let none = DEFAULT_CONFIG_YAML.replace("[90.0, 270.0]", "[]");
    assert!(error_of(&none).contains("protocol.sets.y.directions_deg is empty"));
    // The sensor section is not the protocol's business, but it must be well-formed YAML.
    let only_protocol =
        &DEFAULT_CONFIG_YAML[DEFAULT_CONFIG_YAML.find("protocol:").expect("section")..];
    assert_eq!(
        CollectConfig::from_yaml_str(only_protocol).expect("valid"),
        CollectConfig::default()
    );
}
