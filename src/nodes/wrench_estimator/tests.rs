use super::*;
use crate::biotac::BioTacReading;
use crate::learn::data::{electrode_columns, Dataset};
use crate::learn::models::wrench_gp::TareSpec;
use ndarray::Array2;

/// One trial of features `features`, rows `x`, targets fz `y`.
fn fz_data(features: Vec<String>, x: Array2<f64>, y: Array2<f64>) -> Dataset {
    let n = x.nrows();
    Dataset {
        features,
        x,
        axes: "fz".parse().unwrap(),
        y,
        set: vec![1; n],
        trial: vec![1; n],
        images: None,
    }
}

/// A model on the 19 electrodes, fz = minus the mean tared electrode.
pub(super) fn electrode_model() -> Box<dyn WrenchModel> {
    let n = 30;
    let x = Array2::from_shape_fn((n, 19), |(i, j)| -(((i * 7 + j * 3) % 11) as f64));
    let y = Array2::from_shape_fn((n, 1), |(i, _)| -x.row(i).sum() / 19.0);
    let data = fz_data(
        electrode_columns(crate::biotac::ElectrodeLayout::Biotac),
        x,
        y,
    );
    let tare = TareSpec {
        samples: 3,
        mean_baseline: vec![2000.0; 19],
    };
    Box::new(crate::learn::models::wrench_gp::quick_fit(&data, tare))
}

pub(super) fn reading(stamp_s: f64, pressed: u16) -> BioTacReading {
    BioTacReading {
        seq: 0,
        stamp_s,
        electrodes: [2000 - pressed; 19].into(),
        pdc: 2000 + pressed,
        pac: [0; 22].into(),
        tdc: 0,
        tac: 0,
    }
}

#[test]
fn late_readings_and_an_unknown_clock_are_dropped_and_counted() {
    let node = EstimatorNode::<BioTacInput>::new(electrode_model(), true).unwrap();
    assert!(matches!(
        node.clone().with_stale_timeout(0.0),
        Err(EstimatorError::StaleTimeout(_))
    ));
    let mut node = node.with_stale_timeout(0.03).unwrap();
    for i in 0..3 {
        assert_eq!(node.on_received(&reading(i as f64 * 0.01, 0), 0.03), None);
    }
    assert!(node.is_tared());
    assert!(node.on_received(&reading(1.0, 5), 1.02).is_some());
    assert_eq!(node.on_received(&reading(1.0, 5), 1.04), None);
    assert_eq!(node.on_received(&reading(1.0, 5), f64::NAN), None);
    node.count_unusable(true);
    node.count_unusable(false);
    let d = node.dropped();
    assert_eq!((d.stale, d.invalid, d.refused, d.non_finite), (2, 1, 1, 0));
    assert_eq!((d.total(), node.estimates()), (4, 1));
}

#[test]
fn a_stale_reading_of_another_clock_says_how_to_replay_a_recording() {
    let mut node = EstimatorNode::<BioTacInput>::new(electrode_model(), true)
        .unwrap()
        .with_stale_timeout(0.03)
        .unwrap();
    assert_eq!(node.stale_hint(), None, "nothing stale yet");
    // Late, but of this clock: no hint.
    assert_eq!(node.on_received(&reading(1.0, 0), 1.5), None);
    assert_eq!(node.stale_hint(), None);
    // A recording's readings, an hour old on arrival.
    assert_eq!(node.on_received(&reading(1.0, 0), 3601.0), None);
    let hint = node.stale_hint().unwrap();
    assert!(
        hint.starts_with("the last stale reading was 3600.0 s old"),
        "{hint}"
    );
    assert!(
        hint.contains("use_sim_time:=true") && hint.contains("--clock"),
        "{hint}"
    );
    // A fresh reading after it (the clock set right): the hint goes.
    node.on_received(&reading(3601.0, 0), 3601.01);
    assert_eq!(node.stale_hint(), None);
}

#[test]
fn readings_of_another_layout_are_refused_by_name_and_counted() {
    let mut node = EstimatorNode::<BioTacInput>::new(electrode_model(), true).unwrap();
    assert_eq!(node.refusal(), None);
    let mut sp = reading(0.0, 0);
    sp.electrodes =
        crate::biotac::Electrodes::filled(crate::biotac::ElectrodeLayout::BiotacSp, 2000);
    for _ in 0..4 {
        assert_eq!(node.on_received(&sp, 0.0), None);
    }
    // Refused before the tare: none of them was taken into it.
    assert!(!node.is_tared());
    let d = node.dropped();
    assert_eq!((d.layout, d.non_finite, d.total()), (4, 0, 4));
    assert_eq!(
        node.refusal(),
        Some("model trained on 19 electrodes, readings have 24 electrodes")
    );
    let status = node.status();
    assert_eq!(status.level, Level::Error);
    assert_eq!(
        status.message,
        "taring; refusing readings: model trained on 19 electrodes, readings have 24 electrodes"
    );
    assert!(status
        .values
        .contains(&("dropped_layout".into(), "4".into())));
    let said = d.since(&Dropped::default()).unwrap();
    assert!(
        said.starts_with("dropped 4 readings: 0 undecodable"),
        "{said}"
    );
    assert!(said.contains("4 of another electrode layout"), "{said}");
    assert_eq!(d.since(&d), None);
}

#[test]
fn the_status_says_loading_then_taring_then_estimating_then_what_was_dropped() {
    let has = |s: &Status, key: &str, value: &str| s.values.contains(&(key.into(), value.into()));
    let status = loading_status(12.4);
    assert_eq!(status.level, Level::Warn);
    assert!(status.message.contains("no estimate yet"), "{status:?}");
    assert!(has(&status, "model_ready", "false") && has(&status, "model_loading_s", "12"));
    let mut node = EstimatorNode::<BioTacInput>::new(electrode_model(), true)
        .unwrap()
        .with_ready_after(27.04);
    let status = node.status();
    assert_eq!(
        (status.level, status.message.as_str()),
        (Level::Warn, "taring")
    );
    assert!(has(&status, "model_ready", "true") && has(&status, "model_ready_after_s", "27.0"));
    for i in 0..4 {
        node.on_received(&reading(i as f64, 0), i as f64);
    }
    let status = node.status();
    assert_eq!(
        (status.level, status.message.as_str()),
        (Level::Ok, "estimating")
    );
    assert!(status.values.contains(&("estimates".into(), "1".into())));
    node.count_unusable(false);
    let status = node.status();
    assert_eq!(
        (status.level, status.message.as_str()),
        (Level::Warn, "estimating; 1 readings dropped so far")
    );
}

#[test]
fn a_saved_tare_is_used_at_once_and_gives_the_same_estimate() {
    let mut first = EstimatorNode::<BioTacInput>::new(electrode_model(), false).unwrap();
    for i in 0..3 {
        first.on_received(&reading(i as f64, 0), i as f64);
    }
    let pressed = reading(5.0, 6);
    let before = first.on_received(&pressed, 5.0).unwrap();
    // A restart while pressed: taring on the press would read ~0 N.
    let mut restarted = EstimatorNode::<BioTacInput>::new(electrode_model(), false).unwrap();
    restarted.set_tare(first.tare().unwrap().clone());
    let after = restarted.on_received(&pressed, 5.0).unwrap();
    assert_eq!(after.mean, before.mean);
    assert!(before.mean.force.z > 3.0, "{:?}", before.mean);
}

/// A model on `features`, fz = the first feature / 100.
fn model_on(features: &[&str]) -> Box<dyn WrenchModel> {
    let n = 30;
    let d = features.len();
    let x = Array2::from_shape_fn((n, d), |(i, j)| ((i * 7 + j * 3) % 11) as f64 * 10.0);
    let y = Array2::from_shape_fn((n, 1), |(i, _)| x[[i, 0]] / 100.0);
    let data = fz_data(features.iter().map(|f| f.to_string()).collect(), x, y);
    let tare = TareSpec {
        samples: 3,
        mean_baseline: vec![0.0; d],
    };
    Box::new(crate::learn::models::wrench_gp::quick_fit(&data, tare))
}

/// An ensemble of networks on the 19 electrodes: fz = the mean press
/// (counts) / 50, trained on presses of 0 to 100 counts.
fn electrode_ensemble() -> Box<dyn WrenchModel> {
    use crate::learn::models::ensemble::{WrenchEnsemble, DEFAULT_MEMBERS};
    use crate::learn::models::nn::NnParams;
    use crate::params::Check;
    let n = 500;
    let x = Array2::from_shape_fn((n, 19), |(i, j)| {
        -((i * 37 % 101) as f64) * (1.0 + 0.02 * ((i + j) % 5) as f64)
    });
    let y = Array2::from_shape_fn((n, 1), |(i, _)| -x.row(i).sum() / 19.0 / 50.0);
    let data = fz_data(
        electrode_columns(crate::biotac::ElectrodeLayout::Biotac),
        x,
        y,
    );
    let tare = TareSpec {
        samples: 3,
        mean_baseline: vec![2000.0; 19],
    };
    let params = NnParams::default().checked("nn").unwrap();
    Box::new(WrenchEnsemble::train(&data, tare, &params, DEFAULT_MEMBERS).unwrap())
}

#[test]
fn an_ensemble_estimates_and_doubts_a_press_far_beyond_its_training() {
    let mut node = EstimatorNode::<BioTacInput>::new(electrode_ensemble(), true).unwrap();
    for i in 0..3 {
        node.on_received(&reading(i as f64, 0), i as f64);
    }
    let known = node.on_received(&reading(3.0, 50), 3.0).unwrap();
    assert!((known.mean.force.z - 1.0).abs() < 0.1, "{:?}", known.mean);
    // Ten times the deepest press it learnt: its networks disagree,
    // beyond the controller's out-of-range limit (config/world.yaml,
    // max_std_n 0.05 N), which they are well within on a known press.
    let beyond = node.on_received(&reading(4.0, 1000), 4.0).unwrap();
    let (inside, outside) = (known.std.force.z, beyond.std.force.z);
    assert!(
        inside < 0.02 && outside > 0.05,
        "std {inside} N, then {outside} N"
    );
}

#[test]
fn models_on_other_channels_are_fed_those_channels_tared() {
    let mut node = EstimatorNode::<BioTacInput>::new(model_on(&["pdc", "e1"]), false).unwrap();
    for i in 0..3 {
        node.on_received(&reading(i as f64, 0), i as f64);
    }
    // PDC 50 counts above its tare: about 0.5 N.
    let e = node.on_received(&reading(5.0, 50), 5.0).unwrap();
    assert!((e.mean.force.z - 0.5).abs() < 0.1, "{:?}", e.mean);
    let err = EstimatorNode::<BioTacInput>::new(model_on(&["pdc", "pressure"]), false).unwrap_err();
    assert!(
        err.to_string().contains("\"pressure\"]; this node feeds"),
        "{err}"
    );
}

#[test]
fn a_new_model_keeps_the_tare_and_is_refused_while_pressed() {
    let mut node = EstimatorNode::<BioTacInput>::new(model_on(&["pdc"]), false).unwrap();
    for i in 0..3 {
        node.on_received(&reading(i as f64, 0), i as f64);
    }
    // Pressed (PDC 60 counts up: about 0.6 N): refused, the model kept.
    let pressed = node.on_received(&reading(3.0, 60), 3.0).unwrap();
    let e = node.take_model(model_on(&["pdc", "e1"])).unwrap_err();
    let said = e.to_string();
    assert!(
        matches!(e, EstimatorError::Pressed { .. }) && said.contains("0.3 N"),
        "{said}"
    );
    assert_eq!(
        node.on_received(&reading(3.0, 60), 3.0).unwrap().mean,
        pressed.mean
    );
    assert_eq!(node.model().features(), ["pdc"]);
    // Out of contact: taken, on the same tare (no readings spent on a
    // new one), the counts kept.
    node.on_received(&reading(4.0, 0), 4.0).unwrap();
    node.take_model(model_on(&["pdc", "e1"])).unwrap();
    assert_eq!(node.model().features(), ["pdc", "e1"]);
    let e = node.on_received(&reading(5.0, 50), 5.0).unwrap();
    assert!((e.mean.force.z - 0.5).abs() < 0.1, "{:?}", e.mean);
    assert_eq!(node.estimates(), 4);
}
