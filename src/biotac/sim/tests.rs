use super::*;
use crate::biotac::geometry::ELECTRODES;
use crate::biotac::ADC_MAX;
use crate::biotac::{FRAME_PERIOD_S, N_ELECTRODES};
use std::path::Path;

fn pad_contact(force: Vector3<f64>) -> Contact {
    Contact {
        x_mm: -4.0,
        angle_rad: 0.0,
        force,
    }
}

fn noise_free() -> BioTacSimConfig {
    let mut p = BioTacSimConfig::default().params;
    p.electrodes.noise_counts = 0.0;
    p.pdc.noise_counts = 0.0;
    p.pac.noise_counts = 0.0;
    p.tac.noise_counts = 0.0;
    p.tdc.noise_counts = 0.0;
    p.validate().expect("valid")
}

/// Index of the electrode at the y-mirrored position (E1 <-> E11, E8 <-> E9, ...).
fn mirror(i: usize) -> usize {
    let [x, y, z] = ELECTRODES[i].position_mm;
    ELECTRODES
        .iter()
        .position(|e| e.position_mm == [x, -y, z])
        .expect("every electrode has a mirror image")
}

#[test]
fn shipped_config_is_valid_and_default_loads_it() {
    let c = BioTacSimConfig::from_yaml_str(DEFAULT_CONFIG_YAML).expect("valid");
    assert_eq!(c, BioTacSimConfig::default());
    assert_eq!(c.params().electrodes.noise_counts, 2.0);
}

#[test]
fn contact_wrench_is_r_cross_f_in_metres() {
    let c = pad_contact(Vector3::new(1.0, 2.0, 10.0));
    let w = c.wrench();
    assert_eq!(w.force, c.force);
    // r = (-4, 0, -7) mm.
    let expected = Vector3::new(
        0.0 * 10.0 - (-0.007) * 2.0,
        -0.007 - (-0.004) * 10.0,
        -0.004 * 2.0,
    );
    assert!((w.torque - expected).norm() < 1e-15, "{:?}", w.torque);
    assert!((c.normal_force() - 10.0).abs() < 1e-12);
    // A force pulling the skin away is not compressive.
    assert_eq!(
        pad_contact(Vector3::new(0.0, 0.0, -3.0)).normal_force(),
        0.0
    );
}

#[test]
fn electrodes_drop_monotonically_under_normal_force_and_stay_in_range() {
    let sim = BioTacSim::new(&noise_free(), 7);
    let base = sim.electrode_baselines();
    let mut last = base.clone();
    let e17 = 16;
    for k in 1..=60 {
        let f = 0.5 * k as f64;
        let v = sim.electrode_values(Some(&pad_contact(Vector3::new(0.0, 0.0, f))));
        for i in 0..N_ELECTRODES {
            assert!(v[i] < last[i], "E{} did not drop at {f} N", i + 1);
            assert!(v[i] > 0.0 && v[i] < ADC);
        }
        last = v;
    }
    // Under the contact (E17 at x = -2.8 mm): a large drop, not saturated at 11 N.
    let at = |f: f64| sim.electrode_values(Some(&pad_contact(Vector3::new(0.0, 0.0, f))))[e17];
    let per_n_low = at(0.0) - at(1.0);
    let per_n_11 = at(10.5) - at(11.5);
    let per_n_30 = at(29.5) - at(30.5);
    assert!(per_n_low > 150.0, "{per_n_low} counts/N at 0.5 N");
    assert!(per_n_11 > 20.0, "{per_n_11} counts/N at 11 N: saturated");
    assert!(
        per_n_30 < per_n_11 / 2.0,
        "no saturation: {per_n_30} counts/N at 30 N"
    );
    // Far electrode (E6 at x = -13.4 mm on the flank) changes little.
    let drop6 = base[5] - last[5];
    let drop17 = base[e17] - last[e17];
    assert!(drop6 < 0.2 * drop17, "E6 {drop6} vs E17 {drop17}");
}

#[test]
fn readings_are_rounded_counts_within_the_adc_range_even_at_huge_forces() {
    let mut sim = BioTacSim::new(&BioTacSimConfig::default(), 3);
    for f in [0.0, 5.0, 50.0, 1e4] {
        let c = pad_contact(Vector3::new(f, -f, f));
        let r = sim.step(Some(&c), FRAME_PERIOD_S);
        assert!(r
            .electrodes
            .iter()
            .chain(r.pac.iter())
            .all(|&v| v <= ADC_MAX));
        assert!(r.pdc <= ADC_MAX && r.tdc <= ADC_MAX && r.tac <= ADC_MAX);
    }
}

#[test]
fn x_and_y_tangential_forces_give_distinct_patterns() {
    let sim = BioTacSim::new(&noise_free(), 11);
    let base = sim.electrode_baselines();
    let delta = |f: Vector3<f64>| {
        let v = sim.electrode_values(Some(&pad_contact(f)));
        std::array::from_fn::<f64, N_ELECTRODES, _>(|i| v[i] - base[i])
    };
    let z = Vector3::new(0.0, 0.0, 5.0);
    let px = delta(z + Vector3::new(3.0, 0.0, 0.0));
    let nx = delta(z - Vector3::new(3.0, 0.0, 0.0));
    let py = delta(z + Vector3::new(0.0, 3.0, 0.0));
    let ny = delta(z - Vector3::new(0.0, 3.0, 0.0));
    let dist = |a: &[f64; N_ELECTRODES], b: &[f64; N_ELECTRODES]| {
        a.iter()
            .zip(b)
            .map(|(p, q)| (p - q).powi(2))
            .sum::<f64>()
            .sqrt()
    };
    for (name, a, b) in [
        ("+x/-x", &px, &nx),
        ("+y/-y", &py, &ny),
        ("+x/+y", &px, &py),
    ] {
        assert!(
            dist(a, b) > 300.0,
            "{name}: patterns differ by only {}",
            dist(a, b)
        );
    }
    // +x pushes the skin towards the tip: E17 (ahead of x = -4) compresses
    // more than under -x, E18 (behind) less.
    assert!(px[16] < nx[16] && px[17] > nx[17]);
    // +y compresses the +y flank (E12, index 11) and releases the -y flank (E2).
    assert!(py[11] < py[1] - 100.0);
}

#[test]
fn y_mirror_symmetry_is_exact_for_a_symmetric_unit() {
    let mut p = noise_free().params;
    let t = &mut p.electrodes.thermal;
    t.a_counts = [500.0; 2];
    t.b_counts = [-900.0; 2];
    t.c_per_count = [-0.002; 2];
    t.d_counts = [2800.0; 2];
    p.electrodes.gain_spread = 0.0;
    let sim = BioTacSim::new(&p.validate().expect("valid"), 1);
    let f = Vector3::new(1.0, 2.5, 6.0);
    let a = sim.electrode_values(Some(&pad_contact(f)));
    let b = sim.electrode_values(Some(&pad_contact(Vector3::new(f.x, -f.y, f.z))));
    for i in 0..N_ELECTRODES {
        assert!((a[i] - b[mirror(i)]).abs() < 1e-9, "E{}", i + 1);
    }
    assert!((a[1] - a[11]).abs() > 100.0, "Fy must break the y symmetry");
}

#[test]
fn pdc_rises_with_normal_force_and_saturates() {
    let mut sim = BioTacSim::new(&noise_free(), 5);
    let mut pdc = |f: f64| {
        let r = sim.step(
            Some(&pad_contact(Vector3::new(0.0, 0.0, f))),
            FRAME_PERIOD_S,
        );
        f64::from(r.pdc)
    };
    let levels: Vec<f64> = [0.0, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0].map(&mut pdc).to_vec();
    assert!(levels.windows(2).all(|w| w[1] > w[0]), "{levels:?}");
    let first = levels[1] - levels[0];
    let late = levels[6] - levels[5];
    assert!(first > 200.0 && late < 0.1 * first, "{levels:?}");
    let rise_max = BioTacSimConfig::default().params.pdc.rise_max_counts;
    assert!(levels[6] - levels[0] <= rise_max + 1.0);
}

#[test]
fn pac_responds_to_the_rate_of_change_of_force() {
    let mut sim = BioTacSim::new(&noise_free(), 5);
    let rest = sim.step(None, FRAME_PERIOD_S).pac_mean();
    let _ = sim.step(
        Some(&pad_contact(Vector3::new(0.0, 0.0, 0.05))),
        FRAME_PERIOD_S,
    );
    let rising = sim.step(
        Some(&pad_contact(Vector3::new(0.0, 0.0, 0.10))),
        FRAME_PERIOD_S,
    );
    // 5 N/s at 15 counts per N/s.
    assert!(
        (rising.pac_mean() - rest - 75.0).abs() < 1.0,
        "{}",
        rising.pac_mean() - rest
    );
    for _ in 0..2 {
        let _ = sim.step(
            Some(&pad_contact(Vector3::new(0.0, 0.0, 0.10))),
            FRAME_PERIOD_S,
        );
    }
    let held = sim.step(
        Some(&pad_contact(Vector3::new(0.0, 0.0, 0.10))),
        FRAME_PERIOD_S,
    );
    assert!((held.pac_mean() - rest).abs() < 1.0);
}

#[test]
fn thermal_drift_moves_baselines_by_the_formula() {
    let mut sim = BioTacSim::new(&noise_free(), 9);
    let coeffs = sim.thermal();
    for tdc in [1500.0, 1800.0, 2300.0] {
        sim.set_temperature(tdc);
        let r = sim.step(None, FRAME_PERIOD_S);
        for (i, k) in coeffs.iter().enumerate() {
            let e0 = k.a * (1.0 - (k.c * (tdc + k.b)).exp()) + k.d;
            assert!(
                (f64::from(r.electrodes[i]) - e0).abs() <= 0.5,
                "E{} at {tdc}",
                i + 1
            );
        }
        assert_eq!(r.tdc, tdc as u16);
    }
    // Coefficients come from the configured ranges.
    let t = &BioTacSimConfig::default().params.electrodes.thermal;
    let inside = |v: f64, r: [f64; 2]| v >= r[0] && v <= r[1];
    assert!(coeffs.iter().all(|k| inside(k.a, t.a_counts)
        && inside(k.b, t.b_counts)
        && inside(k.c, t.c_per_count)
        && inside(k.d, t.d_counts)));
}

#[test]
fn same_unit_seed_same_readings_other_seed_other_unit() {
    let c = BioTacSimConfig::default();
    let contact = pad_contact(Vector3::new(1.0, 0.0, 3.0));
    let run = |seed| {
        let mut sim = BioTacSim::new(&c, seed);
        (0..20)
            .map(|_| sim.step(Some(&contact), FRAME_PERIOD_S))
            .collect::<Vec<_>>()
    };
    assert_eq!(run(1), run(1));
    assert_ne!(run(1)[0].electrodes, run(2)[0].electrodes);
    let r = run(1);
    assert_eq!(r[19].seq, 19);
    assert!((r[19].stamp_s - 0.19).abs() < 1e-12);
}

fn error_of(yaml: &str) -> String {
    BioTacSimConfig::from_yaml_str(yaml)
        .expect_err("must be rejected")
        .to_string()
}

#[test]
fn config_errors_name_the_key() {
    let missing = DEFAULT_CONFIG_YAML.replace("    shear_gain: 1.0\n", "");
    let e = error_of(&missing);
    assert!(
        e.contains("sensor.electrodes: missing field `shear_gain`"),
        "{e}"
    );
    let unknown = DEFAULT_CONFIG_YAML.replace(
        "    shear_gain: 1.0\n",
        "    shear_gain: 1.0\n    shear_gian: 1.0\n",
    );
    let e = error_of(&unknown);
    assert!(
        e.contains("sensor.electrodes: unknown field `shear_gian`"),
        "{e}"
    );
    let negative = DEFAULT_CONFIG_YAML.replace(
        "    noise_counts: 3.0\n  pac:",
        "    noise_counts: -3.0\n  pac:",
    );
    let e = error_of(&negative);
    assert!(e.contains("sensor.pdc.noise_counts = -3"), "{e}");
    let nan = DEFAULT_CONFIG_YAML.replace("pressure_width_mm: 4.0", "pressure_width_mm: .nan");
    let e = error_of(&nan);
    assert!(
        e.contains("sensor.electrodes.pressure_width_mm = NaN"),
        "{e}"
    );
    let reversed = DEFAULT_CONFIG_YAML.replace("[-1232.0, -680.0]", "[-680.0, -1232.0]");
    let e = error_of(&reversed);
    assert!(
        e.contains("sensor.electrodes.thermal.b_counts = [-680, -1232]"),
        "{e}"
    );
    let e = BioTacSimConfig::from_file(Path::new("/nonexistent/biotac_sim.yaml"))
        .expect_err("missing file");
    assert!(e.to_string().contains("/nonexistent/biotac_sim.yaml"));
}
