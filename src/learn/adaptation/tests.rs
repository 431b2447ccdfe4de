//! `adapt`: the choice, the folds, and the base's data it pools (the
//! reference, and why it may not be at hand).

use super::*;
use crate::learn::models::gp::MeanKind;
use crate::learn::models::wrench_gp::quick_params;
use crate::learn::models::wrench_gp::GpFamily;
use crate::learn::pooled::tests::{model_of, session};
use crate::learn::pooled::*;

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
