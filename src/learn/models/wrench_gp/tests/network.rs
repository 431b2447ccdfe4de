//! The network as the GPs' prior mean.

use super::*;

#[test]
fn a_network_mean_carries_the_estimate_the_gps_its_doubt_and_the_file_both() {
    // y0 = 2 sin(x0) + x1, y1 = x0 x1 / 5 on 300 rows in -5..5.
    let n = 300;
    let x = Array2::from_shape_fn((n, 3), |(i, j)| {
        ((i * (7 + 2 * j) + 3 * j) % 101) as f64 / 10.0 - 5.0
    });
    let y = Array2::from_shape_fn((n, 2), |(i, j)| match j {
        0 => 2.0 * x[[i, 0]].sin() + x[[i, 1]],
        _ => x[[i, 0]] * x[[i, 1]] / 5.0,
    });
    let data = Dataset {
        x,
        y,
        set: vec![1; n],
        trial: vec![1; n],
        ..small_model_data()
    };
    let model = train_with_mean(&data, MeanKind::Network);
    assert_eq!(model.prior_mean(), "network");
    let (mean, std) = model.predict(data.x.view(), true).unwrap();
    let worst = (&mean - &data.y).iter().fold(0.0f64, |m, e| m.max(e.abs()));
    assert!(worst < 0.3, "{worst}");
    let f = tempfile::NamedTempFile::new().unwrap();
    model.save(f.path()).unwrap();
    estimates_one_row_at_a_time_as_the_batch(
        &WrenchGp::load(f.path()).unwrap(),
        &data,
        &mean,
        &std,
    );
    a_given_network_is_taken_as_it_is(&model, &data, &mean);
    // The observed std adds each GP's noise to its doubt.
    let observed = model.predict_observed(data.x.view(), true).unwrap();
    let s = observed.std.unwrap();
    assert!(s.iter().zip(&std).all(|(o, l)| o > l));
    a_network_of_other_inputs_is_refused_by_name(
        &data,
        &std::fs::read_to_string(f.path()).unwrap(),
    );
}

/// One row at a time, as the estimator runs it, `back` (a model after a
/// round trip) estimates as the batch did (`mean`, `std`), and far from
/// every training row its GPs doubt, whatever the network says.
fn estimates_one_row_at_a_time_as_the_batch(
    back: &WrenchGp,
    data: &Dataset,
    mean: &Array2<f64>,
    std: &Array2<f64>,
) {
    let mut ws = back.workspace();
    let mut one = [Estimate::default(); 2];
    for (i, row) in data.x.rows().into_iter().enumerate().step_by(37) {
        back.predict_one(&row.to_vec(), &mut ws, true, &mut one)
            .unwrap();
        for (j, e) in one.iter().enumerate() {
            assert!(
                (e.mean - mean[[i, j]]).abs() < 1e-9,
                "{e:?} vs {}",
                mean[[i, j]]
            );
            assert!(
                (e.std - std[[i, j]]).abs() < 1e-6,
                "{e:?} vs {}",
                std[[i, j]]
            );
        }
    }
    back.predict_one(&[40.0, -40.0, 40.0], &mut ws, true, &mut one)
        .unwrap();
    let inside = std.iter().fold(0.0f64, |m, s| m.max(*s));
    assert!(
        one.iter().all(|e| e.std > 3.0 * inside),
        "{one:?} vs {inside}"
    );
}

/// Given `model`'s network (another GP on the same rows, as `--select`
/// does), a fit takes it as it is, and estimates as `model` did (`mean`).
fn a_given_network_is_taken_as_it_is(model: &WrenchGp, data: &Dataset, mean: &Array2<f64>) {
    let params = crate::learn::models::gp::GpParams {
        restarts: 1,
        mean: MeanKind::Network,
        ..Default::default()
    };
    let warm = WarmStart {
        hypers: None,
        network: model.network(),
    };
    let again = WrenchGp::train_from(
        data,
        model.tare().clone(),
        model.scaling(),
        &params.validate().unwrap(),
        warm,
        &mut |_, _| {},
    )
    .unwrap();
    assert_eq!(again.network(), model.network());
    let (again_mean, _) = again.predict(data.x.view(), false).unwrap();
    let apart = (&again_mean - mean)
        .iter()
        .fold(0.0f64, |m, e| m.max(e.abs()));
    assert!(apart < 1e-3, "{apart}");
}

/// A saved model (`saved`) given a network of other inputs is refused by
/// name.
fn a_network_of_other_inputs_is_refused_by_name(data: &Dataset, saved: &str) {
    let two = Dataset {
        features: vec!["e1".into(), "e2".into()],
        x: data.x.slice(ndarray::s![.., ..2]).to_owned(),
        ..data.clone()
    };
    let other = serde_json::to_value(train_with_mean(&two, MeanKind::Network)).unwrap();
    let mut value: serde_json::Value = serde_json::from_str(saved).unwrap();
    value["network"] = other["network"].clone();
    let err = load_text(&value.to_string()).unwrap_err().to_string();
    assert!(
        err.contains("a network mean of 2 inputs and 2 outputs, but 3 inputs"),
        "{err}"
    );
}
