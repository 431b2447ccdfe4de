//! A candidate's cost predicted from its kind and size alone, before it
//! runs: what the budget, the estimate's time limit and the choice read.
//! A clock reading would make the same data choose differently on a loaded
//! machine (issue 70: two exact GPs within noise swapped places by their
//! measured estimate times from run to run); these predictions do not.
//!
//! The fit's constants are per-unit times measured on 2 idle cores of the
//! development machine (docs/results.md, "`train --select` within its
//! budget"), the estimate's are the models' own
//! ([`crate::learn::models::estimate_cost`]): a faster machine runs the
//! same table in less time, and the same table.

use super::{Choice, Family, GpChoice, MeanKind};
use crate::learn::models::estimate_cost::{exact_us, sparse_us, ENSEMBLE_US, NETWORK_US};
use crate::learn::models::provenance::Cost;

/// The longest an estimate (every axis with its standard deviation) may be
/// predicted to take, one core (µs).
pub(crate) const ESTIMATE_LIMIT_US: f64 = 1000.0;
/// Why [`ESTIMATE_LIMIT_US`], in words for the table.
pub(crate) const ESTIMATE_LIMIT_WHY: &str =
    "a tenth of the BioTac's 10 ms sample period: the estimator keeps up with \
     the sensor on a tenth of a core";

/// What a candidate's cost depends on besides its options.
pub(super) struct Shape {
    /// Training rows of a fold.
    pub train_rows: usize,
    /// Folds.
    pub folds: usize,
    /// The candidate's features.
    pub features: usize,
    /// Axes estimated.
    pub axes: usize,
}

/// Seconds of one axis's exact GP on one fold: fixed (the hyperparameter
/// search on its subsets), and per (n / 1000)^2 of its rows.
const EXACT_FOLD_S: f64 = 0.032;
const EXACT_PER_MILLION_PAIRS_S: f64 = 0.033;
/// Seconds of one axis's sparse GP on one fold: fixed, and per 1000
/// training rows times (m / 100)^2 inducing points (q(u) on every row).
const SPARSE_FOLD_S: f64 = 0.056;
const SPARSE_PER_UNIT_S: f64 = 0.0013;
/// Seconds of one fold's network (a network mean's), per 1000 rows.
const NETWORK_PER_1000_ROWS_S: f64 = 0.053;
/// Seconds of one fold's ensemble of networks, per 1000 rows.
const ENSEMBLE_PER_1000_ROWS_S: f64 = 0.068;

/// `choice`'s cost on data of `shape`.
pub(super) fn predict(choice: &Choice, shape: &Shape) -> Cost {
    let k1 = |rows: usize| rows as f64 / 1000.0;
    let (folds, axes) = (shape.folds as f64, shape.axes as f64);
    let network = choice.mean == MeanKind::Network;
    let (fit_axis_s, estimate_axis_us) = match (choice.family, choice.gp) {
        (Family::Ensemble, _) => (0.0, 0.0),
        (Family::Gp, GpChoice::Exact(n)) => {
            let n = n.min(shape.train_rows);
            let fit = EXACT_FOLD_S + EXACT_PER_MILLION_PAIRS_S * k1(n).powi(2);
            (fit, exact_us(n, shape.features))
        }
        (Family::Gp, GpChoice::Sparse(m)) => {
            let m = m.min(shape.train_rows);
            let fit = SPARSE_FOLD_S
                + SPARSE_PER_UNIT_S * k1(shape.train_rows) * (m as f64 / 100.0).powi(2);
            (fit, sparse_us(m, shape.features))
        }
    };
    let per_fold_s = match (choice.family, network) {
        (Family::Ensemble, _) => ENSEMBLE_PER_1000_ROWS_S * k1(shape.train_rows),
        (Family::Gp, true) => NETWORK_PER_1000_ROWS_S * k1(shape.train_rows),
        (Family::Gp, false) => 0.0,
    };
    let extra_us = match (choice.family, network) {
        (Family::Ensemble, _) => ENSEMBLE_US,
        (Family::Gp, true) => NETWORK_US,
        (Family::Gp, false) => 0.0,
    };
    Cost {
        fit_s: folds * (axes * fit_axis_s + per_fold_s),
        estimate_us: axes * estimate_axis_us + extra_us,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::data::Channel;

    fn shape() -> Shape {
        Shape {
            train_rows: 16_000,
            folds: 5,
            features: 19,
            axes: 3,
        }
    }

    fn gp(gp: GpChoice, mean: MeanKind) -> Choice {
        Choice {
            gp,
            mean,
            channels: vec![Channel::Electrodes],
            ..Choice::default_options()
        }
    }

    #[test]
    fn the_cost_grows_with_the_size_and_is_the_same_every_time() {
        let s = shape();
        let exact = |n| predict(&gp(GpChoice::Exact(n), MeanKind::Zero), &s);
        let sparse = |m| predict(&gp(GpChoice::Sparse(m), MeanKind::Zero), &s);
        assert!(exact(1000).fit_s < exact(2000).fit_s && exact(2000).fit_s < exact(4000).fit_s);
        assert!(sparse(200).fit_s < sparse(500).fit_s);
        assert!(sparse(200).estimate_us < sparse(500).estimate_us);
        assert!(exact(2000).estimate_us < exact(4000).estimate_us);
        // benches/estimate.rs: sparse 500 137 µs, exact 1000 301 µs (p50).
        assert!(sparse(500).estimate_us < exact(1000).estimate_us);
        assert_eq!(exact(2000), exact(2000));
        // A network mean adds its network's training and pass.
        let network = predict(&gp(GpChoice::Exact(2000), MeanKind::Network), &s);
        assert!(network.fit_s > exact(2000).fit_s && network.estimate_us > exact(2000).estimate_us);
        // More rows than the data hold cost what the data hold.
        let small = Shape {
            train_rows: 800,
            ..shape()
        };
        let g = gp(GpChoice::Exact(4000), MeanKind::Zero);
        assert_eq!(
            predict(&g, &small),
            predict(&gp(GpChoice::Exact(800), MeanKind::Zero), &small)
        );
    }

    #[test]
    fn the_shipped_candidates_estimate_within_the_limit_and_a_huge_one_does_not() {
        let s = shape();
        for g in [
            GpChoice::Exact(1000),
            GpChoice::Exact(2000),
            GpChoice::Exact(4000),
            GpChoice::Sparse(200),
            GpChoice::Sparse(500),
        ] {
            for mean in [MeanKind::Zero, MeanKind::Network] {
                let c = predict(&gp(g, mean), &s);
                assert!(c.estimate_us < ESTIMATE_LIMIT_US, "{g} {mean:?}: {c:?}");
            }
        }
        let ensemble = predict(&Choice::ensemble(vec![Channel::Electrodes]), &s);
        assert!(ensemble.estimate_us < ESTIMATE_LIMIT_US && ensemble.fit_s > 0.0);
        let huge = predict(&gp(GpChoice::Sparse(2000), MeanKind::Zero), &s);
        assert!(huge.estimate_us > ESTIMATE_LIMIT_US, "{huge:?}");
    }
}
