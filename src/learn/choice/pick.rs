//! Which scored candidate `--select` takes: among those within noise of the
//! best score, the simplest form (the GP's prior mean; the ensemble as
//! flexible as a network mean), then the cheapest estimate as predicted
//! from its kind and size (`cost.rs`, never a clock: a loaded machine
//! chooses as an idle one), then the first tried.
//!
//! A more flexible model can win the cross-validation by less than the
//! folds disagree, and then generalise worse to a new session (a cubic mean
//! over a linear one on a real unit, issue 45). The noise is measured on
//! the folds themselves: a candidate is within noise of the best when its
//! mean fold-wise score exceeds the best's by at most one standard error of
//! their fold-wise differences (the folds are shared, so the comparison is
//! paired), the "one standard error" rule of Hastie, Tibshirani and
//! Friedman (2009, Sec. 7.10).

use super::{Choice, CvRow, Family, MeanKind};
use crate::learn::models::metrics::mean_and_error;

/// How flexible a candidate's form is: what the data must pay for. A GP's
/// prior mean, from none to a network; an ensemble is networks.
pub(super) fn flexibility(choice: &Choice) -> u8 {
    match (choice.family, choice.mean) {
        (Family::Gp, MeanKind::Zero) => 0,
        (Family::Gp, MeanKind::Linear) => 1,
        (Family::Gp, MeanKind::Cubic) => 2,
        (Family::Gp, MeanKind::Network) | (Family::Ensemble, _) => 3,
    }
}

/// Its form in words: the GP's mean, or the ensemble.
fn form(choice: &Choice) -> String {
    match choice.family {
        Family::Gp => format!("{} mean", choice.mean.name()),
        Family::Ensemble => "the ensemble".into(),
    }
}

/// The mean of `row`'s fold scores less `best`'s, and the standard error of
/// that mean; None when the rows were not scored on the same folds.
fn paired_difference(row: &CvRow, best: &CvRow) -> Option<(f64, f64)> {
    if row.fold_scores.len() != best.fold_scores.len() {
        return None;
    }
    let d: Vec<f64> = (row.fold_scores.iter().zip(&best.fold_scores))
        .map(|(a, b)| a - b)
        .collect();
    mean_and_error(&d)
}

/// The index of the chosen row of `table` (not empty), and why.
pub(super) fn choose(table: &[CvRow]) -> (usize, String) {
    let Some((best_i, best)) =
        (table.iter().enumerate()).min_by(|a, b| a.1.score.total_cmp(&b.1.score))
    else {
        return (0, String::new());
    };
    let near: Vec<usize> = (0..table.len())
        .filter(|&i| {
            i == best_i || paired_difference(&table[i], best).is_some_and(|(mean, se)| mean <= se)
        })
        .collect();
    let cost = |i: &usize| {
        let r = &table[*i];
        let estimate_us = r.predicted.map_or(f64::INFINITY, |c| c.estimate_us);
        (flexibility(&r.choice), estimate_us)
    };
    // min_by keeps the first of equals: the one tried first.
    let chosen = near
        .iter()
        .copied()
        .min_by(|a, b| {
            let (ca, cb) = (cost(a), cost(b));
            ca.0.cmp(&cb.0).then(ca.1.total_cmp(&cb.1))
        })
        .unwrap_or(best_i);
    let why = if chosen == best_i {
        format!(
            "the best score ({:.4}); {} other candidate(s) within one standard error of it, none simpler or cheaper",
            best.score,
            near.len() - 1
        )
    } else {
        let c = &table[chosen];
        format!(
            "within one standard error of the best score ({:.4} vs {:.4}, {}), the simplest form \
             ({}) and then the cheapest estimate (predicted {:.0} µs) of the {} candidates there",
            c.score,
            best.score,
            best.choice,
            form(&c.choice),
            c.predicted.map_or(f64::NAN, |p| p.estimate_us),
            near.len()
        )
    };
    (chosen, why)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::choice::Choice;
    use crate::learn::models::provenance::Cost;

    fn row(mean: MeanKind, folds: &[f64], estimate_us: f64) -> CvRow {
        CvRow {
            choice: Choice {
                mean,
                ..Choice::default_options()
            },
            rmse: Default::default(),
            score: folds.iter().sum::<f64>() / folds.len() as f64,
            seconds: None,
            cpu_s: None,
            predicted: Some(Cost {
                fit_s: 1.0,
                estimate_us,
            }),
            fold_scores: folds.to_vec(),
            // A clock's reading, the other way round: never read.
            latency_us: Some(1e6 - estimate_us),
            latency_p99_us: None,
            std_scale: Default::default(),
            network_alone: None,
        }
    }

    #[test]
    fn a_flexible_mean_that_wins_by_less_than_the_folds_disagree_is_not_chosen() {
        // Cubic is better on average by 0.01, but linear's fold-wise
        // differences from it are -0.03, +0.05, -0.02, +0.04, +0.01: mean
        // 0.01, standard error 0.016. Zero is worse on every fold.
        let table = [
            row(MeanKind::Zero, &[0.50, 0.52, 0.49, 0.51, 0.50], 20.0),
            row(MeanKind::Linear, &[0.30, 0.35, 0.28, 0.33, 0.31], 25.0),
            row(MeanKind::Cubic, &[0.33, 0.30, 0.30, 0.29, 0.30], 26.0),
        ];
        let (i, why) = choose(&table);
        assert_eq!(i, 1, "{why}");
        assert!(why.contains("simplest form (linear mean)"), "{why}");
        let (mean, se) = paired_difference(&table[1], &table[2]).unwrap();
        assert!((mean - 0.01).abs() < 1e-12 && mean < se, "{mean} {se}");
    }

    #[test]
    fn a_flexible_mean_better_on_every_fold_is_chosen() {
        let table = [
            row(MeanKind::Linear, &[0.30, 0.35, 0.28, 0.33, 0.31], 25.0),
            row(MeanKind::Network, &[0.20, 0.26, 0.19, 0.22, 0.21], 60.0),
        ];
        let (i, why) = choose(&table);
        assert_eq!(i, 1, "{why}");
        assert!(why.starts_with("the best score (0.2160)"), "{why}");
    }

    #[test]
    fn the_ensemble_is_as_flexible_as_a_network_mean_and_chosen_when_it_wins() {
        let ensemble = |folds: &[f64], latency_us: f64| CvRow {
            choice: Choice::ensemble(Choice::default_options().channels),
            ..row(MeanKind::Zero, folds, latency_us)
        };
        // Within noise of a zero-mean GP: the GP, simpler.
        let table = [
            row(MeanKind::Zero, &[0.30, 0.35, 0.28], 300.0),
            ensemble(&[0.33, 0.30, 0.29], 10.0),
        ];
        let (i, why) = choose(&table);
        assert_eq!(i, 0, "{why}");
        assert!(why.contains("simplest form (zero mean)"), "{why}");
        // Within noise of a better network mean: the cheaper of the two.
        let table = [
            row(MeanKind::Network, &[0.30, 0.29, 0.28], 300.0),
            ensemble(&[0.27, 0.33, 0.30], 10.0),
        ];
        let (i, why) = choose(&table);
        assert_eq!(i, 1, "{why}");
        assert!(why.contains("simplest form (the ensemble)"), "{why}");
        // Better on every fold: the ensemble.
        let table = [
            row(MeanKind::Zero, &[0.30, 0.35, 0.28], 300.0),
            ensemble(&[0.20, 0.25, 0.19], 10.0),
        ];
        assert_eq!(choose(&table).0, 1);
    }

    #[test]
    fn among_equally_simple_candidates_the_cheaper_then_the_first_is_chosen() {
        let table = [
            row(MeanKind::Zero, &[0.300, 0.310, 0.290], 80.0),
            row(MeanKind::Zero, &[0.301, 0.308, 0.294], 30.0),
        ];
        assert_eq!(choose(&table).0, 1);
        // As cheap: the first tried, whatever the clock said.
        let mut same = table.clone();
        same[1].predicted = same[0].predicted;
        assert_eq!(choose(&same).0, 0);
        // Without fold scores (a file written before) only the best is known.
        let mut old = table.clone();
        old[1].fold_scores.clear();
        assert_eq!(choose(&old).0, 0);
    }
}
