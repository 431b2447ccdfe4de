//! `adapt`: the choice, the folds, and the base's data it pools (the
//! reference, and why it may not be at hand).

use super::*;
use crate::biotac::sim::BioTacSimConfig;
use crate::biotac::ElectrodeLayout;
use crate::learn::data::{electrode_columns, write_csv, Counts};
use crate::learn::models::gp::MeanKind;
use crate::learn::models::wrench_gp::quick_params;
use crate::learn::models::wrench_gp::{DataFile, GpFamily};
use crate::learn::pooled::*;
use crate::sim::collect::{collect, CollectConfig};
use std::path::{Path, PathBuf};

fn scored(model: &str, trials: &[f64]) -> Validation {
    Validation {
        model: model.into(),
        rmse: Default::default(),
        score: trials.iter().sum::<f64>() / trials.len() as f64,
        trial_scores: trials.to_vec(),
    }
}

#[test]
fn adapt_and_the_calibration_choose_by_the_rule_of_select() {
    let name = |v: &[Validation], cost: &[(f64, Form)]| v[choose(v, cost).0].model.clone();
    let form = GpFamily::form_of;
    let gp = |us| (us, form(MeanKind::Zero, 2000));
    let network = |us| (us, form(MeanKind::Network, 2000));
    let (better, worse) = ([0.20, 0.22, 0.21], [0.30, 0.31, 0.29]);
    // Better on every held-out trial: the better, however flexible.
    let two = [
        scored("adapted", &worse),
        scored("new data: GP, network mean", &better),
    ];
    assert_eq!(name(&two, &[gp(400.0), network(300.0)]), two[1].model);
    // Better on average by less than the trials disagree: the simpler.
    let near = [0.23, 0.19, 0.24];
    let two = [
        scored("adapted", &near),
        scored("new data: GP, network mean", &better),
    ];
    assert_eq!(name(&two, &[gp(400.0), network(300.0)]), "adapted");
    // As simple: the cheaper estimate; as cheap: the first.
    let two = [scored("adapted", &near), scored("new data: GP", &better)];
    assert_eq!(name(&two, &[gp(400.0), gp(300.0)]), "new data: GP");
    assert_eq!(name(&two, &[gp(300.0), gp(300.0)]), "adapted");
    // A score that is not a number never wins.
    let nan = [f64::NAN, 0.1, 0.1];
    let two = [scored("adapted", &nan), scored("pooled", &worse)];
    assert_eq!(name(&two, &[gp(1.0), gp(1.0)]), "pooled");
}

/// `rows` rows in `groups` (set, trial) groups of equal size.
fn grouped(groups: u32, rows: usize) -> Dataset {
    let per = rows / groups as usize;
    Dataset {
        features: vec!["e1".into()],
        x: ndarray::Array2::zeros((rows, 1)),
        axes: "fz".parse().unwrap(),
        y: ndarray::Array2::zeros((rows, 1)),
        set: (0..rows).map(|i| 1 + (i / per) as u32 / 2).collect(),
        trial: (0..rows).map(|i| 1 + (i / per) as u32 % 2).collect(),
        images: None,
    }
}

#[test]
fn adapt_holds_every_row_out_once_over_folds_of_trials_or_blocks() {
    let rows = |r: std::ops::Range<usize>| r.collect::<Vec<_>>();
    // Four sets of two trials: each set's first trial in one fold, its
    // second in another (the two folds that would hold none are dropped).
    let folds = adapt_folds(&grouped(8, 80));
    let first: Vec<usize> = [0..10, 20..30, 40..50, 60..70]
        .into_iter()
        .flatten()
        .collect();
    let second: Vec<usize> = [10..20, 30..40, 50..60, 70..80]
        .into_iter()
        .flatten()
        .collect();
    assert_eq!(folds, [(second.clone(), first.clone()), (first, second)]);
    // One trial: ADAPT_FOLDS contiguous blocks, each held out once.
    let folds = adapt_folds(&grouped(1, 40));
    assert_eq!(folds.len(), ADAPT_FOLDS);
    let block = 40 / ADAPT_FOLDS;
    for (f, (train, test)) in folds.iter().enumerate() {
        assert_eq!(test, &rows(f * block..(f + 1) * block));
        let rest: Vec<usize> = (0..40).filter(|i| !test.contains(i)).collect();
        assert_eq!(train, &rest);
    }
}

#[test]
fn the_hash_is_fnv_1a_of_the_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("f");
    for (bytes, hash) in [(&b""[..], "cbf29ce484222325"), (b"a", "af63dc4c8601ec8c")] {
        std::fs::write(&f, bytes).unwrap();
        assert_eq!(file_hash(&f).unwrap(), hash);
    }
    let r = data_file(&f, 7).unwrap();
    assert_eq!((r.path.as_str(), r.rows), (f.to_str().unwrap(), 7));
}

#[test]
fn an_adapted_model_records_its_base_s_files_and_its_own() {
    let file = |p: &str| DataFile {
        path: p.into(),
        hash: "0".into(),
        rows: 1,
    };
    let base = TrainedOn {
        files: vec![file("a.csv")],
        params: GpParams {
            max_train: 77,
            ..GpParams::default()
        },
    };
    let on = lineage(Some(&base), vec![file("b.csv")]).unwrap();
    assert_eq!(on.files, vec![file("a.csv"), file("b.csv")]);
    assert_eq!(on.params.max_train, 77);
    assert_eq!(lineage(None, vec![file("b.csv")]), None);
}

/// Unit `unit`'s set 1 (two trials), every 4th row, written to `dir`.
fn session(dir: &Path, unit: u64) -> (PathBuf, Dataset) {
    let cfg = CollectConfig::default().with_trials(2).unwrap();
    let records: Vec<_> = collect(&cfg, &BioTacSimConfig::default(), unit, 1)
        .into_iter()
        .filter(|r| r.set == 1)
        .step_by(4)
        .collect();
    let path = dir.join(format!("u{unit}.csv"));
    write_csv(&path, &records).unwrap();
    let features = electrode_columns(ElectrodeLayout::Biotac);
    let axes = "fx,fz".parse().unwrap();
    let data = Dataset::read_csv(&path, &features, &axes, Counts::Raw).unwrap();
    (path, data)
}

/// A model of `data` (tared on 10 rows) that records `path` as its data.
fn model_of(path: &Path, data: &Dataset) -> (WrenchGp, Dataset, TareSpec) {
    let mut tared = data.clone();
    let tare = TareSpec {
        samples: 10,
        mean_baseline: tared.tare_per_trial(10).unwrap(),
    };
    let params = quick_params();
    let on = TrainedOn {
        files: vec![data_file(path, data.len()).unwrap()],
        params: GpParams::clone(&params),
    };
    let model = WrenchGp::train(&tared, tare.clone(), &params, &mut |_, _| {})
        .unwrap()
        .with_trained_on(Some(on));
    (model, tared, tare)
}

#[test]
fn the_base_s_data_is_read_again_or_said_why_not() {
    let dir = tempfile::tempdir().unwrap();
    let (path, data) = session(dir.path(), 1);
    let (model, tared, _) = model_of(&path, &data);
    let base = base_data(&model, None).unwrap();
    assert_eq!(base.data.x, tared.x);
    assert_eq!((base.rows, base.files.len()), (data.len(), 1));
    let thin = base.clone().thin(100);
    assert_eq!(thin.data.len(), 100);
    assert_eq!(
        thin.describe(),
        format!("base rows subsampled {} -> 100 of 1 file(s)", data.len())
    );

    // Moved: missing where recorded, found by content where given.
    let moved = dir.path().join("moved.csv");
    std::fs::rename(&path, &moved).unwrap();
    let p = path.display().to_string();
    assert!(matches!(base_data(&model, None), Err(Unavailable::Missing { path, .. }) if path == p));
    let given = base_data(&model, Some(std::slice::from_ref(&moved))).unwrap();
    assert_eq!(given.data.x, tared.x);

    // Changed: named, with both hashes.
    let text = std::fs::read_to_string(&moved).unwrap();
    std::fs::write(&path, text.replacen(",1,", ",2,", 1)).unwrap();
    let err = base_data(&model, None).unwrap_err();
    assert!(
        matches!(&err, Unavailable::Changed { path, .. } if *path == p),
        "{err}"
    );
    let said = err.to_string();
    assert!(
        said.contains(&model.trained_on().unwrap().files[0].hash),
        "{said}"
    );

    let bare = model.with_trained_on(None);
    assert_eq!(
        base_data(&bare, None).unwrap_err(),
        Unavailable::NoReference
    );
}

#[test]
fn adaptation_scores_every_candidate_over_folds_of_the_new_data_and_chooses_by_the_rule() {
    let dir = tempfile::tempdir().unwrap();
    let (path, data) = session(dir.path(), 1);
    let (base, _, _) = model_of(&path, &data);
    let (_, new) = session(dir.path(), 2);
    let mut new_tared = new.clone();
    let tare = TareSpec {
        samples: 10,
        mean_baseline: new_tared.tare_per_trial(10).unwrap(),
    };
    let run = |pool| {
        let adaptation = Adaptation {
            base: &base,
            data: &new_tared,
            tare: tare.clone(),
            from: AdaptedFrom {
                model: "base".into(),
                data: vec![],
                seconds: 1.0,
            },
            params: &quick_params(),
            trained_on: None,
            new_only: None,
        };
        adaptation.run(pool, &mut |_, _| {}).unwrap()
    };
    let (model, choice) = run(base_data(&base, None));
    let folds = adapt_folds(&new_tared).len();
    assert!(folds >= 2, "{folds}");
    let names: Vec<&str> = choice.validation.iter().map(|v| v.model.as_str()).collect();
    assert_eq!(
        names,
        [
            "adapted",
            "pooled",
            "new data: GP",
            "new data: GP, network mean",
            "new data: ensemble"
        ]
    );
    // The chooser's rule: the best score, or one within noise of it over
    // the held-out trials, and why.
    let best = (choice.validation.iter())
        .min_by(|a, b| a.score.total_cmp(&b.score))
        .unwrap();
    assert!(
        choice.why.contains(&format!("{:.4}", best.score)),
        "{choice:?}"
    );
    // The chooser's parts: the held-out estimates scored trial by trial
    // (one trial: on five contiguous blocks).
    let parts = match new_tared.trials().len() {
        1 => 5,
        trials => trials,
    };
    assert!((choice.validation.iter()).all(|v| v.trial_scores.len() == parts));
    assert_eq!(
        (choice.held_out_rows, choice.folds),
        (new_tared.len(), folds)
    );
    let ensemble = choice.chosen == "new data: ensemble";
    assert_eq!(model.family(), if ensemble { "ensemble" } else { "gp" });
    if !ensemble {
        let file = dir.path().join("adapted.json");
        model.save(&file).unwrap();
        let gp = WrenchGp::load(&file).unwrap();
        assert_eq!(gp.adapted_from().is_some(), choice.chosen == "adapted");
    }
    assert_eq!(model.adapt_choice(), Some(&choice));
    // Its standard deviations were scaled on the held-out rows, never down
    // (std_scale's own test checks the scale).
    assert!(
        (model.std_scales().iter()).all(|s| *s >= 1.0 && s.is_finite()),
        "{:?}",
        model.std_scales()
    );

    let (_, choice) = run(Err(Unavailable::NoReference));
    let names: Vec<&str> = choice.validation.iter().map(|v| v.model.as_str()).collect();
    assert_eq!(
        names,
        [
            "adapted",
            "new data: GP",
            "new data: GP, network mean",
            "new data: ensemble"
        ]
    );
    assert_eq!(
        choice.pooling,
        "not considered: the base model file records no training data"
    );
}
