//! Tests of choice.rs.

use super::cv::{parse_cpu_seconds, scoring, SCORING_SPARSE_ITERS, SCORING_SPARSE_ROWS};
use super::*;
use crate::biotac::sim::BioTacSimConfig;
use crate::sim::collect::{collect, CollectConfig};
use crate::wrench::Axis;

/// A short simulated session with every channel, tared per trial.
fn session() -> (Dataset, TareSpec) {
    let cfg = CollectConfig::default().with_trials(3).unwrap();
    let records = collect(&cfg, &BioTacSimConfig::default(), 1, 1);
    let all = channel_columns(
        &[
            Channel::Electrodes,
            Channel::Pdc,
            Channel::Tdc,
            Channel::Tac,
        ],
        ElectrodeLayout::Biotac,
    );
    let mut ds = Dataset::from_records(&records, &all, &"fz".parse().unwrap(), "session").unwrap();
    // Every 4th row keeps it quick.
    let rows: Vec<usize> = (0..ds.len()).step_by(4).collect();
    ds = ds.select(&rows);
    let baseline = ds.tare_per_trial(10).unwrap();
    let tare = TareSpec {
        samples: 10,
        mean_baseline: baseline,
    };
    (ds, tare)
}

/// Every channel held.
fn every() -> Space {
    use Channel::{Electrodes, Pdc, Tac, Tdc};
    Space::free(vec![Electrodes, Pdc, Tdc, Tac])
}

/// The first `cols` feature columns of `ds` and `tare`.
fn first_columns(ds: &Dataset, tare: &TareSpec, cols: usize) -> (Dataset, TareSpec) {
    let sub = Dataset {
        features: ds.features[..cols].to_vec(),
        x: ds.x.slice(ndarray::s![.., ..cols]).to_owned(),
        ..ds.clone()
    };
    let tare = TareSpec {
        samples: tare.samples,
        mean_baseline: tare.mean_baseline[..cols].to_vec(),
    };
    (sub, tare)
}

fn quick() -> GpParams {
    GpParams {
        restarts: 1,
        restart_subset: 200,
        ..GpParams::default()
    }
}

/// The chosen row has the table's lowest score.
/// The best score was chosen, or one within noise of it with a simpler
/// mean, or as simple and faster; and the reason is given.
fn assert_chose_the_best_or_simpler(s: &Selection) {
    let best = (s.table.iter())
        .min_by(|a, b| a.score.total_cmp(&b.score))
        .unwrap();
    let chosen = &s.table[s.chosen];
    let flexibility = |r: &CvRow| families::form(&r.choice).flexibility;
    let cost = |r: &CvRow| r.predicted.unwrap().estimate_us;
    let simpler = flexibility(chosen) < flexibility(best)
        || (flexibility(chosen) == flexibility(best) && cost(chosen) <= cost(best));
    assert!(chosen.score == best.score || simpler, "{s:?}");
    assert!(!s.why.is_empty());
}

#[test]
fn the_search_keeps_the_best_score_and_records_every_candidate() {
    let (ds, tare) = session();
    let s = select(&ds, &tare, &every(), 5, 600.0, &quick(), &mut |_, _| {}).unwrap();
    assert_eq!(s.folds, 3, "3 trials per set: 3 folds");
    assert_eq!(s.table[0].choice, Choice::default_options());
    assert_chose_the_best_or_simpler(&s);
    // Every stage ran: channels, input, mean, GP (rows permit sparse 200).
    let tried = |f: &dyn Fn(&Choice) -> bool| s.table.iter().any(|r| f(&r.choice));
    assert!(tried(&|c| c.channels == [Channel::Pdc]));
    assert!(tried(&|c| c.input == InputScaling::Raw));
    assert!(tried(&|c| c.mean == MeanKind::Cubic));
    assert!(tried(&|c| c.gp == GpChoice::Sparse(200)));
    assert!(tried(&|c| c.family == Family::named("ensemble")));
    assert!(s.untried.is_empty(), "{:?}", s.untried);
    for r in &s.table {
        assert!(
            r.score.is_finite() && r.score > 0.0 && r.rmse[&Axis::Fz] > 0.0,
            "{r:?}"
        );
        // The network of a network mean is scored alone too, on the same
        // folds; no other mean has one.
        let alone = r.network_alone.as_ref();
        assert_eq!(alone.is_some(), r.choice.mean == MeanKind::Network, "{r:?}");
        if let Some(a) = alone {
            assert!(
                a.score.is_finite() && a.score > 0.0 && a.score != r.score,
                "{a:?}"
            );
            assert_eq!(a.fold_scores.len(), s.folds);
        }
        // Every candidate, the ensemble too, has its folds' scores, its
        // estimate's latency and the scale of its standard deviation.
        assert_eq!(r.fold_scores.len(), s.folds, "{r:?}");
        assert!(r.latency_us.is_some_and(|l| l > 0.0), "{r:?}");
        assert!(r.latency_p99_us >= r.latency_us, "{r:?}");
        assert!(
            r.predicted
                .is_some_and(|c| c.fit_s > 0.0 && c.estimate_us > 0.0),
            "{r:?}"
        );
        assert!(r.std_scale[&Axis::Fz] >= 1.0, "{r:?}");
    }
    assert!(tried(&|c| c.mean == MeanKind::Network));
    // The record survives JSON, less what this run measured by the clock.
    let back: Selection = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
    let unclocked = Selection {
        spent_s: None,
        table: (s.table.iter())
            .map(|r| CvRow {
                seconds: None,
                cpu_s: None,
                latency_us: None,
                latency_p99_us: None,
                ..r.clone()
            })
            .collect(),
        ..s.clone()
    };
    assert_eq!(back, unclocked);
}

#[test]
fn a_candidate_is_not_tried_when_its_estimate_or_its_time_is_predicted_over_the_limits() {
    let cost = |fit_s, estimate_us| Cost { fit_s, estimate_us };
    // The limit is on the 99th percentile, three times the median.
    assert_eq!(not_tried(&cost(2.0, 330.0), 2.0), None);
    let why = not_tried(&cost(2.0, 340.0), 100.0).unwrap();
    assert!(
        why.starts_with(
            "its estimate is predicted at 1020 µs at the 99th percentile, over the 1000 µs"
        ),
        "{why}"
    );
    assert!(why.contains("BioTac's 10 ms sample period"), "{why}");
    let why = not_tried(&cost(2.5, 10.0), 2.0).unwrap();
    assert_eq!(
        why,
        "predicted 2.5 s, over the 2.0 s the time budget leaves"
    );
    let why = not_tried(&cost(2.5, 10.0), -1.0).unwrap();
    assert!(
        why.ends_with("over the 0.0 s the time budget leaves"),
        "{why}"
    );
}

#[test]
fn the_budget_stops_the_search_and_says_what_it_left() {
    let (ds, tare) = session();
    let s = select(&ds, &tare, &every(), 5, 0.0, &quick(), &mut |_, _| {});
    // Nothing fits in no time but the defaults, which are always scored.
    let s = s.unwrap();
    assert_eq!(s.table.len(), 1);
    assert_eq!(s.choice(), &Choice::default_options());
    assert!(!s.untried.is_empty());
    assert!(
        (s.untried.iter()).all(|(_, why)| why.ends_with("over the 0.0 s the time budget leaves")),
        "{s:?}"
    );
    // One trial is cut into contiguous blocks; one row cannot be.
    let one_trial = ds.select(&(0..50).collect::<Vec<_>>());
    let s = select(
        &one_trial,
        &tare,
        &every(),
        5,
        0.0,
        &quick(),
        &mut |_, _| {},
    )
    .unwrap();
    assert_eq!((s.blocks.as_slice(), s.folds), (&[1][..], 5));
    let one_row = ds.select(&[0]);
    let e = select(&one_row, &tare, &every(), 5, 0.0, &quick(), &mut |_, _| {});
    let e = e.unwrap_err();
    assert!(e.to_string().contains("at least 2"), "{e}");
}

#[test]
fn the_candidates_are_the_channels_held_and_the_options_left_free() {
    use Channel::{Electrodes, Pdc, Tac, Tdc};
    let best = Choice::default_options();
    let channel_stage = |space: &Space| -> Vec<Vec<Channel>> {
        let stages = space.stages(&best, 10_000);
        stages
            .last()
            .unwrap()
            .iter()
            .map(|c| c.channels.clone())
            .collect()
    };
    // Electrodes and PDC held: no candidate takes TDC or TAC.
    let ep = Space::free(vec![Electrodes, Pdc]);
    assert_eq!(
        channel_stage(&ep),
        [vec![Electrodes, Pdc], vec![Electrodes], vec![Pdc]]
    );
    assert!(ep.not_varied().is_empty());
    assert_eq!(channel_stage(&every()).len(), 4);
    // Electrodes only: one set, said so; the first candidate takes it.
    let e = Space::free(vec![Electrodes]);
    assert_eq!(channel_stage(&e), [vec![Electrodes]]);
    assert_eq!(e.start().channels, [Electrodes]);
    assert_eq!(e.not_varied(), ["channels: the data hold electrodes only"]);
    // The form first, the channels last: input, mean, GP, family, channels.
    let stages = every().stages(&best, 10_000);
    assert_eq!(stages.len(), 5);
    assert!(stages[0].iter().any(|c| c.input == InputScaling::Raw));
    assert!(stages[1].iter().any(|c| c.mean == MeanKind::Cubic));
    assert!(stages[2].iter().any(|c| c.gp == GpChoice::Sparse(500)));
    assert_eq!(
        stages[3],
        [Choice::of(Family::named("ensemble"), best.channels.clone())]
    );
    assert!(stages[4]
        .iter()
        .any(|c| c.channels == [Electrodes, Pdc, Tdc, Tac]));
    // The ensemble fixed: it is the first candidate, only its channels vary.
    let ensemble = Space {
        family: Some(Family::named("ensemble")),
        ..every()
    };
    assert_eq!(
        ensemble.start(),
        Choice::of(Family::named("ensemble"), vec![Electrodes, Pdc])
    );
    let stages = ensemble.stages(&ensemble.start(), 10_000);
    assert_eq!(stages.len(), 1, "{stages:?}");
    assert!(stages[0]
        .iter()
        .all(|c| c.family == Family::named("ensemble")));
    assert_eq!(stages[0].len(), 4);
    assert_eq!(ensemble.not_varied(), ["family: fixed by --family"]);
    // Fixed options have no stage, and every candidate keeps them.
    let fixed = Space {
        channels: Some(vec![Electrodes, Tdc]),
        gp: Some(GpChoice::Sparse(300)),
        ..every()
    };
    assert_eq!(fixed.start().channels, [Electrodes, Tdc]);
    assert_eq!(fixed.start().gp, GpChoice::Sparse(300));
    let stages = fixed.stages(&fixed.start(), 10_000);
    assert_eq!(
        stages.len(),
        3,
        "input, mean, the one channel set: a GP fixed"
    );
    assert!(stages
        .iter()
        .flatten()
        .all(|c| c.gp == GpChoice::Sparse(300)));
    assert_eq!(
        fixed.not_varied(),
        [
            "channels: fixed by --channels",
            "family: a GP option was fixed",
            "GP: fixed by --inducing or --max-train"
        ]
    );
}

#[test]
fn electrode_only_data_vary_the_rest() {
    use Channel::Electrodes;
    let (ds, tare) = session();
    let (e, e_tare) = first_columns(&ds, &tare, 19);
    let space = Space {
        input: Some(InputScaling::Pattern),
        ..Space::free(vec![Electrodes])
    };
    let s = select(&e, &e_tare, &space, 5, 600.0, &quick(), &mut |_, _| {}).unwrap();
    assert!(s.untried.is_empty(), "{:?}", s.untried);
    assert!(s
        .table
        .iter()
        .all(|r| { r.choice.channels == [Electrodes] && r.choice.input == InputScaling::Pattern }));
    // The first candidate, 3 means, 4 more GPs below the 6000 rows.
    assert_eq!(s.table.len(), 8, "{s:?}");
    assert_eq!(
        s.not_varied,
        [
            "channels: the data hold electrodes only",
            "family: a GP option was fixed",
            "input: fixed by --input"
        ]
    );
    assert_chose_the_best_or_simpler(&s);
}

#[test]
fn sparse_candidates_are_scored_on_fewer_rows_and_iterations_exact_ones_as_trained() {
    let sparse = GpParams {
        inducing: Some(200),
        ..GpParams::default()
    };
    let s = scoring(sparse.clone());
    assert_eq!(
        (s.sparse_candidates, s.sparse_fit_subset, s.sparse_iters),
        (
            SCORING_SPARSE_ROWS,
            SCORING_SPARSE_ROWS,
            SCORING_SPARSE_ITERS
        )
    );
    assert_eq!((s.inducing, s.restarts, s.max_train), (Some(200), 3, 2000));
    // Never fewer candidate rows than inducing points.
    let big = scoring(GpParams {
        inducing: Some(3000),
        ..sparse
    });
    assert_eq!(big.sparse_candidates, 3000);
    assert!(big.validate().is_ok());
    // Smaller settings are kept, and the other options.
    let small = GpParams {
        sparse_candidates: 1000,
        sparse_fit_subset: 500,
        sparse_iters: SCORING_SPARSE_ITERS - 1,
        ..GpParams::default()
    };
    assert_eq!(scoring(small.clone()), small);
}

#[test]
fn cpu_seconds_are_user_plus_system_ticks_after_the_command_name() {
    // Fields 14 and 15 (utime, stime) of a stat line whose name holds ") ".
    let stat = "42 (a) b) S 1 42 42 0 -1 4194560 100 0 0 0 250 130 0 0 20 0 3";
    assert_eq!(parse_cpu_seconds(stat, 100.0), Some(3.8));
    assert_eq!(parse_cpu_seconds("42 (a) S 1 2", 100.0), None);
    assert_eq!(parse_cpu_seconds("no name", 100.0), None);
    // Each candidate's CPU time is measured (Linux) and positive.
    if cfg!(target_os = "linux") {
        let (ds, tare) = session();
        let s = select(&ds, &tare, &every(), 3, 0.0, &quick(), &mut |_, _| {}).unwrap();
        assert!(s.table[0].cpu_s.is_some_and(|c| c > 0.0), "{s:?}");
    }
}
