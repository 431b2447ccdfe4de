use ndarray::Array2;

use super::*;
use crate::learn::models::model_file;
use crate::learn::models::wrench_model::WrenchModel;
use crate::params::Check;
use crate::wrench::AxisSet;

/// `n` rows of two features spread over [-1, 1] (trial 1 then 2), targets
/// fx = sin(2 x0) + x1 / 2 and fz = x0 x1, with noise of 0.02.
fn data(n: usize, seed: u64) -> Dataset {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let x = Array2::from_shape_fn((n, 2), |_| rng.random_range(-1.0f64..1.0));
    let y = Array2::from_shape_fn((n, 2), |(i, j)| {
        let (a, b) = (x[[i, 0]], x[[i, 1]]);
        let clean = if j == 0 {
            (2.0 * a).sin() + b / 2.0
        } else {
            a * b
        };
        clean + 0.02 * rng.random_range(-1.7..1.7)
    });
    Dataset {
        features: vec!["e1".into(), "e2".into()],
        x,
        axes: "fx,fz".parse::<AxisSet>().unwrap(),
        y,
        set: vec![1; n],
        trial: (0..n).map(|i| 1 + (2 * i / n) as u32).collect(),
        images: None,
    }
}

fn tare() -> TareSpec {
    TareSpec {
        samples: 0,
        mean_baseline: vec![0.0; 2],
    }
}

fn trained(members: usize) -> WrenchEnsemble {
    let params = NnParams {
        hidden: 16,
        learning_rate: 1e-2,
        ..NnParams::default()
    }
    .checked("nn")
    .unwrap();
    WrenchEnsemble::train(&data(600, 1), tare(), &params, members).unwrap()
}

fn one_row(m: &WrenchEnsemble, row: [f64; 2]) -> Vec<Estimate> {
    let mut ws = m.workspace();
    let mut out = vec![Estimate::default(); 2];
    m.estimate(&row, &mut ws, true, &mut out).unwrap();
    out
}

#[test]
fn the_estimate_is_the_networks_mean_and_their_spread_grows_away_from_the_data() {
    let m = trained(DEFAULT_MEMBERS);
    let inside = one_row(&m, [0.3, -0.4]);
    assert!(
        (inside[0].mean - ((0.6f64).sin() - 0.2)).abs() < 0.1,
        "{inside:?}"
    );
    assert!((inside[1].mean + 0.12).abs() < 0.1, "{inside:?}");
    // Ten times the training range: the networks disagree.
    let outside = one_row(&m, [10.0, -10.0]);
    for j in 0..2 {
        assert!(
            outside[j].std > 5.0 * inside[j].std && outside[j].std > 0.1,
            "axis {j}: inside {:?}, outside {:?}",
            inside[j],
            outside[j]
        );
    }
    // One row at a time and rows together agree.
    let x = Array2::from_shape_vec((1, 2), vec![0.3, -0.4]).unwrap();
    let batch = m.spread(x.view());
    assert!((batch.0[[0, 0]] - inside[0].mean).abs() < 1e-12);
    assert!((batch.1[[0, 1]] - inside[1].std).abs() < 1e-12);
}

#[test]
fn held_out_errors_fall_within_two_standard_deviations_about_as_often_as_they_should() {
    let m = trained(DEFAULT_MEMBERS);
    let test = data(2000, 7);
    let p = m.predict_observed(test.x.view(), true).unwrap();
    let std = p.std.unwrap();
    for j in 0..2 {
        let within = (0..test.len())
            .filter(|&i| (p.mean[[i, j]] - test.y[[i, j]]).abs() <= 2.0 * std[[i, j]])
            .count() as f64
            / test.len() as f64;
        assert!((0.85..=0.999).contains(&within), "axis {j}: {within}");
    }
    assert!(
        m.noise_std().iter().all(|s| *s > 0.01 && *s < 0.2),
        "{:?}",
        m.noise_std()
    );
}

#[test]
fn a_saved_ensemble_loads_as_a_model_of_its_family_and_estimates_the_same() {
    let m = trained(3);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ensemble.json");
    m.save(&path).unwrap();
    let loaded = model_file::load(&path).unwrap();
    assert_eq!(loaded.family(), "ensemble");
    assert_eq!(loaded.features(), ["e1", "e2"]);
    let mut ws = loaded.workspace();
    let mut out = vec![Estimate::default(); 2];
    loaded
        .estimate(&[0.1, 0.2], &mut ws, true, &mut out)
        .unwrap();
    assert_eq!(out, one_row(&m, [0.1, 0.2]));
    // Another model's scratch and a wrong feature count are refused.
    let mut foreign = trained(2).workspace();
    let err = loaded.estimate(&[0.1, 0.2], &mut foreign, true, &mut out);
    assert!(matches!(err, Err(ModelError::ForeignWorkspace)), "{err:?}");
    let err = loaded
        .estimate(&[0.1], &mut ws, true, &mut out)
        .unwrap_err();
    assert!(
        matches!(
            err,
            ModelError::FeatureCount {
                expected: 2,
                found: 1
            }
        ),
        "{err}"
    );
}

#[test]
fn a_file_that_disagrees_with_itself_is_refused_with_the_reason() {
    let m = trained(2);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ensemble.json");
    m.save(&path).unwrap();
    let good: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let cases: [(&str, serde_json::Value, &str); 4] = [
        (
            "members",
            serde_json::json!([good["members"][0]]),
            "1 networks, at least 2",
        ),
        ("noise_std", serde_json::json!([0.1]), "noise_std [0.1]"),
        (
            "std_scale",
            serde_json::json!([1.0, -1.0]),
            "std_scale [1.0, -1.0]",
        ),
        (
            "version",
            serde_json::json!(9),
            "version 9, this build reads versions 1 to 4",
        ),
    ];
    for (key, value, said) in cases {
        let mut bad = good.clone();
        bad[key] = value;
        std::fs::write(&path, serde_json::to_vec(&bad).unwrap()).unwrap();
        let err = model_file::load(&path).unwrap_err().to_string();
        assert!(err.contains(said), "{key}: {err}");
    }
    // A file of version 1, before `selection`, is read.
    let mut v1 = good.clone();
    v1["version"] = 1.into();
    std::fs::write(&path, serde_json::to_vec(&v1).unwrap()).unwrap();
    assert_eq!(model_file::load(&path).unwrap().family(), "ensemble");
    let mut other = good.clone();
    other["format"] = "tactile_force/other".into();
    std::fs::write(&path, serde_json::to_vec(&other).unwrap()).unwrap();
    let err = model_file::load(&path).unwrap_err().to_string();
    assert!(
        err.contains("expected tactile_force/wrench_gp or tactile_force/wrench_ensemble"),
        "{err}"
    );
    // The GP's own reader names only its format.
    std::fs::write(&path, serde_json::to_vec(&good).unwrap()).unwrap();
    let err = crate::learn::models::wrench_gp::WrenchGp::load(&path)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("\"tactile_force/wrench_ensemble\", expected tactile_force/wrench_gp"),
        "{err}"
    );
}

#[test]
fn one_network_is_no_ensemble() {
    let params = NnParams::default().checked("nn").unwrap();
    let err = WrenchEnsemble::train(&data(50, 1), tare(), &params, 1).unwrap_err();
    assert!(
        err.to_string().contains("at least 2 networks, got 1"),
        "{err}"
    );
}
