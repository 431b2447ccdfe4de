use super::*;

fn mean_grey(f: &NailFrame, rows: std::ops::Range<usize>) -> f64 {
    let w = f.width();
    let px: Vec<f64> = rows
        .flat_map(|v| (w / 3..2 * w / 3).map(move |u| (u, v)))
        .map(|(u, v)| f64::from(f.at(u, v)))
        .collect();
    px.iter().sum::<f64>() / px.len() as f64
}

#[test]
fn the_shipped_config_parses_and_bad_values_are_named() {
    let c = NailSimConfig::default();
    assert_eq!((c.camera.width_px, c.camera.rate_hz), (96, 30.0));
    let bad = NAIL_SIM_YAML.replace("saturation_n: 6.0", "saturation_n: -1.0");
    let e = NailSimConfig::from_yaml_str(&bad).unwrap_err().to_string();
    assert!(e.contains("response.saturation_n"), "{e}");
    let bad = NAIL_SIM_YAML.replace("  rate_hz: 30.0\n  # Frames", "  rate_hz: 25.0\n  # Frames");
    let e = NailSimConfig::from_yaml_str(&bad).unwrap_err().to_string();
    assert!(e.contains("camera.rate_hz"), "{e}");
}

#[test]
fn pressing_whitens_the_distal_nail_and_saturates() {
    let c = NailSimConfig::default();
    let person = Person::new(&c, 1);
    let mut session = Session::new(&c, 1);
    let press = |fz: f64| Pressing {
        force: [0.0, 0.0, fz],
        ..Default::default()
    };
    let distal = |s: &mut Session, fz: f64| mean_grey(&s.render(&c, &person, &press(fz)), 30..45);
    let (g0, g3, g6, g9) = (
        distal(&mut session, 0.0),
        distal(&mut session, 3.0),
        distal(&mut session, 6.0),
        distal(&mut session, 9.0),
    );
    assert!(g3 > g0 + 15.0, "{g0} {g3}");
    assert!(
        g6 - g3 < g3 - g0 && g9 - g6 < g6 - g3,
        "saturates: {g0} {g3} {g6} {g9}"
    );
    // A sideways push shifts the pattern: the two halves differ.
    let side = Pressing {
        force: [0.0, 3.0, 6.0],
        ..Default::default()
    };
    let f = session.render(&c, &person, &side);
    let half = |us: std::ops::Range<usize>| {
        let n = us.len() as f64 * 20.0;
        us.flat_map(|u| (30..50).map(move |v| (u, v)))
            .map(|(u, v)| f64::from(f.at(u, v)))
            .sum::<f64>()
            / n
    };
    assert!(half(48..70) > half(26..48) + 5.0, "the +y side whitens");
}

#[test]
fn persons_and_sessions_differ_and_repeat() {
    let c = NailSimConfig::default();
    let frame = |person: u64, session: u64| {
        Session::new(&c, session).render(&c, &Person::new(&c, person), &Pressing::default())
    };
    assert_eq!(frame(1, 1), frame(1, 1));
    assert_ne!(frame(1, 1), frame(2, 1));
    assert_ne!(frame(1, 1), frame(1, 2));
}
