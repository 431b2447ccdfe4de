//! The model file: round trips, adaptation, prior means, broken files.

use super::*;
use crate::learn::models::gp::MeanKind;
use ndarray::Array2;

fn small_model_data() -> Dataset {
    let n = 40;
    let x = Array2::from_shape_fn((n, 3), |(i, j)| ((i * 7 + j * 3) % 11) as f64 - 5.0);
    let y = Array2::from_shape_fn((n, 2), |(i, j)| x[[i, 0]] * (j as f64 + 1.0) + x[[i, 1]]);
    Dataset {
        features: vec!["e1".into(), "e2".into(), "e3".into()],
        x,
        axes: "fx,fz".parse().unwrap(),
        y,
        set: vec![1; n],
        trial: vec![1; n],
        images: None,
    }
}

fn small_model() -> WrenchGp {
    let tare = TareSpec {
        samples: 5,
        mean_baseline: vec![1.0, 2.0, 3.0],
    };
    quick_fit(&small_model_data(), tare)
}

fn load_text(text: &str) -> Result<WrenchGp, ModelError> {
    let f = tempfile::NamedTempFile::new().unwrap();
    std::fs::write(f.path(), text).unwrap();
    WrenchGp::load(f.path())
}

#[test]
fn saved_model_loads_and_predicts_the_same() {
    let model = small_model();
    let f = tempfile::NamedTempFile::new().unwrap();
    model.save(f.path()).unwrap();
    let back = WrenchGp::load(f.path()).unwrap();
    let (mut a, mut b) = ([Estimate::default(); 2], [Estimate::default(); 2]);
    let x = [0.5, -1.0, 2.0];
    model
        .predict_one(&x, &mut model.workspace(), true, &mut a)
        .unwrap();
    back.predict_one(&x, &mut back.workspace(), true, &mut b)
        .unwrap();
    assert_eq!(a, b);
    assert!(a.iter().all(|e| e.mean.is_finite() && e.std > 0.0));
    assert_eq!(back.tare().mean_baseline, vec![1.0, 2.0, 3.0]);
    let err = model.predict_one(&x[..2], &mut model.workspace(), true, &mut a);
    assert!(matches!(
        err,
        Err(ModelError::FeatureCount {
            expected: 3,
            found: 2
        })
    ));
}

#[test]
fn an_adapted_model_adds_a_correction_to_its_base_and_loads_back() {
    let base = small_model();
    let mut data = Dataset {
        // Another unit: the base's targets plus an offset growing with e1.
        y: base.predict(small_model_data().x.view(), false).unwrap().0,
        ..small_model_data()
    };
    for (i, mut row) in data.y.rows_mut().into_iter().enumerate() {
        row += 0.5 * data.x[[i, 0]];
    }
    let from = AdaptedFrom {
        model: "base.json".into(),
        data: vec!["new.csv".into()],
        seconds: 0.4,
    };
    let tare = base.tare().clone();
    let adapted = base
        .adapt(
            &data,
            tare.clone(),
            from.clone(),
            &quick_params(),
            &mut |_, _| {},
        )
        .unwrap();
    assert_eq!(adapted.adapted_from(), Some(&from));
    let x = [2.0, -1.0, 1.0];
    let (mut b, mut a) = ([Estimate::default(); 2], [Estimate::default(); 2]);
    base.predict_one(&x, &mut base.workspace(), true, &mut b)
        .unwrap();
    adapted
        .predict_one(&x, &mut adapted.workspace(), true, &mut a)
        .unwrap();
    for (a, b) in a.iter().zip(&b) {
        assert!((a.mean - b.mean - 0.5 * x[0]).abs() < 0.1, "{a:?} {b:?}");
    }
    // The batch prediction agrees with the single one.
    let (batch, _) = adapted.predict(ndarray::aview2(&[x]), false).unwrap();
    assert!((batch[[0, 1]] - a[1].mean).abs() < 1e-9);
    let f = tempfile::NamedTempFile::new().unwrap();
    adapted.save(f.path()).unwrap();
    let back = WrenchGp::load(f.path()).unwrap();
    let mut c = [Estimate::default(); 2];
    back.predict_one(&x, &mut back.workspace(), true, &mut c)
        .unwrap();
    assert_eq!(a, c);
    assert_eq!(back.adapted_from(), Some(&from));

    let other = Dataset {
        features: vec!["e1".into(), "e2".into(), "pdc".into()],
        ..data
    };
    let err = base
        .adapt(&other, tare, from, &quick_params(), &mut |_, _| {})
        .unwrap_err();
    assert!(matches!(err, ModelError::AdaptMismatch { .. }), "{err}");
}

#[test]
fn a_pattern_model_predicts_the_same_after_loading_and_checks_its_inputs() {
    let data = small_model_data();
    let tare = TareSpec {
        samples: 5,
        mean_baseline: vec![0.0; 3],
    };
    let model = WrenchGp::train_scaled(
        &data,
        tare,
        InputScaling::Pattern,
        &quick_params(),
        &mut |_, _| {},
    )
    .unwrap();
    // Three electrodes: the pattern and its magnitude, four inputs.
    assert!(model.fits().all(|(_, gp, _)| gp.dim() == 4));
    let f = tempfile::NamedTempFile::new().unwrap();
    model.save(f.path()).unwrap();
    let back = WrenchGp::load(f.path()).unwrap();
    let x = [3.0, -2.0, 1.0];
    let (mut a, mut b) = ([Estimate::default(); 2], [Estimate::default(); 2]);
    model
        .predict_one(&x, &mut model.workspace(), true, &mut a)
        .unwrap();
    back.predict_one(&x, &mut back.workspace(), true, &mut b)
        .unwrap();
    assert_eq!(a, b);
    let (batch, _) = back.predict(ndarray::aview2(&[x]), false).unwrap();
    assert!((batch[[0, 0]] - a[0].mean).abs() < 1e-9);
    // The same file said to be standardised: three features, four inputs.
    let json = std::fs::read_to_string(f.path()).unwrap();
    let err = load_text(&json.replace("\"scaling\":\"pattern\"", "\"scaling\":\"standard\""));
    let err = err.unwrap_err().to_string();
    assert!(
        err.contains("3 features (3 inputs, Standard), but 4 input means"),
        "{err}"
    );
}

/// A one-start model of `data` with the prior mean `mean`.
fn train_with_mean(data: &Dataset, mean: MeanKind) -> WrenchGp {
    let params = super::super::gp::GpParams {
        restarts: 1,
        mean,
        ..Default::default()
    };
    let tare = TareSpec {
        samples: 5,
        mean_baseline: vec![0.0; 3],
    };
    WrenchGp::train(data, tare, &params.validate().unwrap(), &mut |_, _| {}).unwrap()
}

#[test]
fn a_linear_mean_extrapolates_loads_back_and_is_checked() {
    // y = 2 x0 - x1 + 0.5 on inputs in [-5, 5], asked at x0 = 1000: the
    // line goes on (2010.5); without it the GP of what the line left (0)
    // says 0.
    let mut data = small_model_data();
    data.y = Array2::from_shape_fn((data.len(), 2), |(i, _)| {
        2.0 * data.x[[i, 0]] - data.x[[i, 1]] + 0.5
    });
    let model = train_with_mean(&data, MeanKind::Linear);
    let far = ndarray::aview2(&[[1000.0, -10.0, 0.0]]);
    let at = |m: &WrenchGp| m.predict(far, false).unwrap().0[[0, 0]];
    assert!((at(&model) - 2010.5).abs() < 1e-3, "{}", at(&model));
    let f = tempfile::NamedTempFile::new().unwrap();
    model.save(f.path()).unwrap();
    assert_eq!(at(&WrenchGp::load(f.path()).unwrap()), at(&model));
    let mut value: serde_json::Value =
        serde_json::from_slice(&std::fs::read(f.path()).unwrap()).unwrap();
    for o in value["outputs"].as_array_mut().unwrap() {
        o.as_object_mut().unwrap().remove("linear");
    }
    let without = load_text(&value.to_string()).unwrap();
    assert!(at(&without).abs() < 1.0, "{}", at(&without));
    let json = std::fs::read_to_string(f.path()).unwrap();
    let err = load_text(&json.replacen("\"weights\":[", "\"weights\":[1.0,", 1));
    let err = err.unwrap_err().to_string();
    assert!(
        err.contains("linear mean of 4 weights (expected 3"),
        "{err}"
    );
}

#[test]
fn a_cubic_mean_round_trips_and_a_bad_bend_is_refused() {
    // y = x0 + 0.3 x0^3 - x1: the bent mean carries it, the file keeps it.
    let mut data = small_model_data();
    data.y = Array2::from_shape_fn((data.len(), 2), |(i, _)| {
        let (a, b) = (data.x[[i, 0]], data.x[[i, 1]]);
        a + 0.3 * a.powi(3) - b
    });
    let model = train_with_mean(&data, MeanKind::Cubic);
    let fitted = model.predict(data.x.view(), false).unwrap().0;
    let worst = (&fitted - &data.y)
        .iter()
        .fold(0.0f64, |m, e| m.max(e.abs()));
    assert!(worst < 0.05, "{worst}");
    let row = data.x.slice(ndarray::s![3..4, ..]);
    let at = |m: &WrenchGp| m.predict(row, false).unwrap().0[[0, 0]];
    let f = tempfile::NamedTempFile::new().unwrap();
    model.save(f.path()).unwrap();
    assert_eq!(at(&WrenchGp::load(f.path()).unwrap()), at(&model));
    let json = std::fs::read_to_string(f.path()).unwrap();
    assert!(json.contains("\"bend\":{\"along\":["), "{json}");
    let bend = json.find("\"bend\"").unwrap();
    let broken = format!(
        "{}{}",
        &json[..bend],
        json[bend..].replacen("\"scale\":[", "\"scale\":[-", 1)
    );
    let err = load_text(&broken);
    let err = err.unwrap_err().to_string();
    assert!(
        err.contains("bend of 2 lines") && err.contains("scales [-"),
        "{err}"
    );
}

#[test]
fn broken_model_files_give_clear_errors() {
    let json = serde_json::to_string(&small_model()).unwrap();
    let err = load_text(&json[..json.len() / 2]).unwrap_err();
    assert!(matches!(err, ModelError::Corrupt { .. }), "{err}");
    assert!(err.to_string().contains("truncated or corrupt"));

    let err = load_text("{\"format\": \"something else\"}").unwrap_err();
    assert!(matches!(err, ModelError::WrongFormat { .. }), "{err}");

    let v1 = json.replace(&format!("\"version\":{MODEL_VERSION}"), "\"version\":1");
    let err = load_text(&v1).unwrap_err();
    assert!(
        matches!(err, ModelError::UnsupportedVersion { found: 1, .. }),
        "{err}"
    );

    let four = json.replace("[\"e1\",\"e2\",\"e3\"]", "[\"e1\",\"e2\",\"e3\",\"e4\"]");
    let err = load_text(&four).unwrap_err();
    assert!(matches!(err, ModelError::Inconsistent { .. }), "{err}");
    assert!(err.to_string().contains("4 features"), "{err}");

    let missing = json.replace("\"n_train\":40,", "");
    let err = load_text(&missing).unwrap_err();
    assert!(err.to_string().contains("n_train"), "{err}");

    let nan_hyper = json.replacen("\"signal_var\":", "\"signal_var\":-", 1);
    let err = load_text(&nan_hyper).unwrap_err();
    assert!(
        matches!(err, ModelError::Gp(GpError::InvalidHyper { .. })),
        "{err}"
    );
}
