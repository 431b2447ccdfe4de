//! Which scored row of its table `--select` takes: the chooser's one rule
//! ([`crate::learn::chooser`]) over the rows' fold scores, forms and
//! predicted estimate times.

use super::CvRow;
use crate::learn::chooser::{self, Scored};
use crate::learn::models::families;

/// The index of the chosen row of `table` (not empty), and why.
pub(super) fn choose(table: &[CvRow]) -> (usize, String) {
    let scored: Vec<Scored> = (table.iter())
        .map(|r| Scored {
            name: r.choice.to_string(),
            score: r.score,
            parts: &r.fold_scores,
            form: families::form(&r.choice),
            estimate_us: r.predicted.map_or(f64::INFINITY, |c| c.estimate_us),
        })
        .collect();
    chooser::choose(&scored).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::choice::{Choice, Family, MeanKind};
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
        assert!(
            why.contains("simplest form (linear mean, 2000 points)"),
            "{why}"
        );
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
            choice: Choice::of(
                Family::named("ensemble"),
                Choice::default_options().channels,
            ),
            ..row(MeanKind::Zero, folds, latency_us)
        };
        // Within noise of a zero-mean GP: the GP, simpler.
        let table = [
            row(MeanKind::Zero, &[0.30, 0.35, 0.28], 300.0),
            ensemble(&[0.33, 0.30, 0.29], 10.0),
        ];
        let (i, why) = choose(&table);
        assert_eq!(i, 0, "{why}");
        assert!(
            why.contains("simplest form (zero mean, 2000 points)"),
            "{why}"
        );
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
