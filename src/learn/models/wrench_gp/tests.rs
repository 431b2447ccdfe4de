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
            WarmStart::default(),
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
        .adapt(
            &other,
            tare,
            from,
            &quick_params(),
            WarmStart::default(),
            &mut |_, _| {},
        )
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
    assert_eq!(model.prior_mean(), "linear");
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
    assert_eq!(model.prior_mean(), "cubic");
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
        matches!(
            err,
            ModelError::Stored {
                source: GpError::InvalidHyper { .. },
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("signal variance -"), "{err}");
}

/// Found by the property tests below: a stored GP that cannot be rebuilt
/// was said without the file, its hyperparameters in Rust's debug form,
/// and a row count not a whole number of rows as "40 input rows but 40
/// targets".
#[test]
fn a_stored_gp_that_cannot_be_rebuilt_names_the_file_the_axis_and_the_numbers() {
    let json: serde_json::Value = serde_json::to_value(small_model()).unwrap();
    fn gp(v: &mut serde_json::Value) -> &mut serde_json::Value {
        &mut v["outputs"][0]["gp"]["exact"]
    }
    let f = tempfile::NamedTempFile::new().unwrap();
    let path = f.path().display().to_string();
    let load = |v: &serde_json::Value| {
        std::fs::write(f.path(), serde_json::to_vec(v).unwrap()).unwrap();
        WrenchGp::load(f.path()).unwrap_err().to_string()
    };

    let mut short = json.clone();
    gp(&mut short)["x"].as_array_mut().unwrap().pop();
    assert_eq!(
        load(&short),
        format!(
            "model file {path}: axis fx: 119 input values for 40 targets of 3 inputs each \
             (expected 120)"
        )
    );

    let mut noiseless = json.clone();
    gp(&mut noiseless)["hyper"]["noise_var"] = serde_json::json!(0.0);
    let e = load(&noiseless);
    assert!(
        e.starts_with(&format!(
            "model file {path}: axis fx: invalid hyperparameters for 3 inputs: signal variance "
        )),
        "{e}"
    );
    assert!(
        e.contains("noise variance 0, lengthscales [") && !e.contains("SeHyper"),
        "{e}"
    );
}

/// Every leaf and branch of a JSON tree, by its path of keys and indices.
fn paths(v: &serde_json::Value, at: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    out.push(at.clone());
    let children: Vec<(String, &serde_json::Value)> = match v {
        serde_json::Value::Object(m) => m.iter().map(|(k, c)| (k.clone(), c)).collect(),
        serde_json::Value::Array(a) => a
            .iter()
            .enumerate()
            .map(|(i, c)| (i.to_string(), c))
            .collect(),
        _ => Vec::new(),
    };
    for (k, c) in children {
        at.push(k);
        paths(c, at, out);
        at.pop();
    }
}

fn slot<'a>(v: &'a mut serde_json::Value, path: &[String]) -> &'a mut serde_json::Value {
    path.iter().fold(v, |v, k| match v {
        serde_json::Value::Object(m) => m.get_mut(k).unwrap(),
        serde_json::Value::Array(a) => &mut a[k.parse::<usize>().unwrap()],
        _ => unreachable!("paths() only descends into objects and arrays"),
    })
}

/// A model that loads predicts without a panic, or says why it cannot.
fn usable(m: &WrenchGp) {
    let x = vec![0.5; m.features().len()];
    let mut out = vec![Estimate::default(); m.axes().len()];
    let _ = m.predict_one(&x, &mut m.workspace(), true, &mut out);
}

/// A refused file's error names the model file once, and its cause.
fn clear(err: &ModelError, path: &str) -> Result<(), proptest::test_runner::TestCaseError> {
    let msg = err.to_string();
    proptest::prop_assert!(msg.starts_with(&format!("model file {path}: ")), "{msg}");
    proptest::prop_assert_eq!(msg.matches(path).count(), 1, "{}", msg);
    proptest::prop_assert!(msg.len() > path.len() + 14, "{}", msg);
    Ok(())
}

mod props {
    use proptest::prelude::*;

    use super::*;

    fn valid() -> &'static (String, serde_json::Value, Vec<Vec<String>>) {
        static VALID: std::sync::OnceLock<(String, serde_json::Value, Vec<Vec<String>>)> =
            std::sync::OnceLock::new();
        VALID.get_or_init(|| {
            let text = serde_json::to_string(&small_model()).unwrap();
            let value: serde_json::Value = serde_json::from_str(&text).unwrap();
            let mut all = Vec::new();
            paths(&value, &mut Vec::new(), &mut all);
            (text, value, all)
        })
    }

    fn load_bytes(bytes: &[u8]) -> (Result<WrenchGp, ModelError>, String) {
        let f = tempfile::NamedTempFile::new().unwrap();
        std::fs::write(f.path(), bytes).unwrap();
        (WrenchGp::load(f.path()), f.path().display().to_string())
    }

    /// What replaces a part of a valid file.
    fn replacement() -> impl Strategy<Value = serde_json::Value> {
        prop_oneof![
            Just(serde_json::Value::Null),
            any::<bool>().prop_map(serde_json::Value::from),
            any::<i64>().prop_map(serde_json::Value::from),
            prop_oneof![
                Just(0.0),
                Just(-1.0),
                Just(1e308),
                Just(-1e-308),
                any::<f64>()
            ]
            .prop_map(|x| serde_json::json!(x)),
            "[a-z0-9]{0,6}".prop_map(serde_json::Value::from),
            Just(serde_json::json!([])),
            Just(serde_json::json!({})),
            proptest::collection::vec(-3.0..3.0f64, 0..5).prop_map(|v| serde_json::json!(v)),
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]

        #[test]
        fn arbitrary_bytes_are_refused_naming_the_file(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
            let (got, path) = load_bytes(&bytes);
            let err = got.expect_err("arbitrary bytes are not a model");
            clear(&err, &path)?;
        }

        #[test]
        fn a_cut_file_is_refused_as_truncated(cut in 0.0..1.0f64) {
            let text = &valid().0;
            let at = (cut * text.len() as f64) as usize;
            let (got, path) = load_bytes(&text.as_bytes()[..at]);
            let err = got.expect_err("a cut file is not a model");
            clear(&err, &path)?;
            prop_assert!(matches!(err, ModelError::Corrupt { .. }), "{}", err);
        }

        #[test]
        fn a_flipped_byte_loads_a_usable_model_or_is_refused(at in 0.0..1.0f64, bit in 0u8..8) {
            let mut bytes = valid().0.clone().into_bytes();
            let i = (at * bytes.len() as f64) as usize;
            bytes[i] ^= 1 << bit;
            match load_bytes(&bytes) {
                (Ok(m), _) => usable(&m),
                (Err(e), path) => clear(&e, &path)?,
            }
        }

        #[test]
        fn a_part_replaced_loads_a_usable_model_or_is_refused(which in 0.0..1.0f64, by in replacement()) {
            let (_, value, all) = valid();
            let path = &all[(which * all.len() as f64) as usize];
            let mut v = value.clone();
            *slot(&mut v, path) = by;
            match load_bytes(&serde_json::to_vec(&v).unwrap()) {
                (Ok(m), _) => usable(&m),
                (Err(e), file) => clear(&e, &file)?,
            }
        }
    }
}

#[test]
fn the_training_data_reference_round_trips_and_files_without_it_load() {
    let on = TrainedOn {
        files: vec![DataFile {
            path: "a.csv".into(),
            hash: "00ff".into(),
            rows: 40,
        }],
        params: GpParams {
            max_train: 33,
            ..GpParams::default()
        },
    };
    let model = small_model().with_trained_on(Some(on.clone()));
    let json = serde_json::to_string(&model).unwrap();
    assert_eq!(load_text(&json).unwrap().trained_on(), Some(&on));
    // A version 6 file, from before the reference.
    let old = serde_json::to_string(&small_model())
        .unwrap()
        .replace(&format!("\"version\":{MODEL_VERSION}"), "\"version\":6");
    assert!(!old.contains("trained_on") && old.contains("\"version\":6"));
    let back = load_text(&old).unwrap();
    assert_eq!((back.trained_on(), back.adapt_choice()), (None, None));
}

#[test]
fn shared_hyperparameters_serve_every_axis_and_batch_matches_single_rows() {
    let data = small_model_data();
    let params = super::super::gp::GpParams {
        restarts: 1,
        shared: true,
        ..Default::default()
    };
    let tare = TareSpec {
        samples: 5,
        mean_baseline: vec![0.0; 3],
    };
    let mut heard = Vec::new();
    let model = WrenchGp::train(&data, tare, &params.validate().unwrap(), &mut |a, _| {
        heard.push(a)
    })
    .unwrap();
    let hypers = model.hypers();
    assert_eq!(hypers.len(), 2);
    assert_eq!(hypers[0], hypers[1]);
    assert!(heard.contains(&Axis::Fx) && heard.contains(&Axis::Fz));
    let (mean, std) = model.predict(data.x.view(), true).unwrap();
    let mut ws = model.workspace();
    let mut one = [Estimate::default(); 2];
    for (i, row) in data.x.rows().into_iter().enumerate().step_by(7) {
        let row = row.to_vec();
        model.predict_one(&row, &mut ws, true, &mut one).unwrap();
        for (j, e) in one.iter().enumerate() {
            let (m, s) = (mean[[i, j]], std[[i, j]]);
            // Variances (not std: near 0 they differ by the round-off of s2 - |v|^2).
            let var_diff = (e.std * e.std - s * s).abs();
            assert!(
                (e.mean - m).abs() < 1e-9 && var_diff < 1e-9,
                "{e:?} vs {m} {s}"
            );
        }
    }
    // Each axis keeps its own target scale: the two axes differ.
    assert!((0..data.len()).any(|i| (mean[[i, 0]] - mean[[i, 1]]).abs() > 0.1));
}

mod network;
