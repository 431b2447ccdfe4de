//! A candidate's cost predicted from its kind and size alone, before it
//! runs: what the budget, the estimate's time limit and the choice read.
//! A clock reading would make the same data choose differently on a loaded
//! machine (issue 70: two exact GPs within noise swapped places by their
//! measured estimate times from run to run); these predictions do not.
//!
//! Each family predicts its own ([`crate::learn::models::family::ModelFamily::cost`]):
//! its fit's per-unit times measured on 2 idle cores of the development
//! machine (docs/results.md, "`train --select` within its budget"), its
//! estimate's from [`crate::learn::models::estimate_cost`]. A faster
//! machine runs the same table in less time, and the same table.

use super::{Choice, Shape};
use crate::learn::models::estimate_cost::P99_OVER_P50;
use crate::learn::models::families;
use crate::learn::models::provenance::Cost;
use crate::learn::models::wrench_model::ModelError;

/// The longest an estimate (every axis with its standard deviation) may be
/// predicted to take at the 99th percentile, one core (µs): its predicted
/// median times [`P99_OVER_P50`].
pub(crate) const ESTIMATE_LIMIT_US: f64 = 1000.0;
/// Why [`ESTIMATE_LIMIT_US`], in words for the table.
pub(crate) const ESTIMATE_LIMIT_WHY: &str =
    "a tenth of the BioTac's 10 ms sample period: the estimator keeps up with \
     the sensor on a tenth of a core";

/// The 99th percentile of an estimate's time predicted from its median.
pub(crate) fn p99_us(cost: &Cost) -> f64 {
    P99_OVER_P50 * cost.estimate_us
}

/// `choice`'s cost on data of `shape`, as its family predicts it.
pub(super) fn predict(choice: &Choice, shape: &Shape) -> Result<Cost, ModelError> {
    Ok(families::of(choice)?.cost(choice, shape))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::choice::{Family, GpChoice, MeanKind};
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
        let exact = |n| predict(&gp(GpChoice::Exact(n), MeanKind::Zero), &s).unwrap();
        let sparse = |m| predict(&gp(GpChoice::Sparse(m), MeanKind::Zero), &s).unwrap();
        assert!(exact(1000).fit_s < exact(2000).fit_s && exact(2000).fit_s < exact(4000).fit_s);
        assert!(sparse(200).fit_s < sparse(500).fit_s);
        assert!(sparse(200).estimate_us < sparse(500).estimate_us);
        assert!(exact(2000).estimate_us < exact(4000).estimate_us);
        // benches/estimate.rs: sparse 500 133 µs, exact 1000 192.5 µs (p50).
        assert!(sparse(500).estimate_us < exact(1000).estimate_us);
        assert_eq!(exact(2000), exact(2000));
        // A network mean adds its network's training and pass.
        let network = predict(&gp(GpChoice::Exact(2000), MeanKind::Network), &s).unwrap();
        assert!(network.fit_s > exact(2000).fit_s && network.estimate_us > exact(2000).estimate_us);
        // More rows than the data hold cost what the data hold.
        let small = Shape {
            train_rows: 800,
            ..shape()
        };
        let g = gp(GpChoice::Exact(4000), MeanKind::Zero);
        assert_eq!(
            predict(&g, &small).unwrap(),
            predict(&gp(GpChoice::Exact(800), MeanKind::Zero), &small).unwrap()
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
                let c = predict(&gp(g, mean), &s).unwrap();
                assert!(p99_us(&c) < ESTIMATE_LIMIT_US, "{g} {mean:?}: {c:?}");
            }
        }
        let ensemble = Choice::of(Family::named("ensemble"), vec![Channel::Electrodes]);
        let ensemble = predict(&ensemble, &s).unwrap();
        assert!(p99_us(&ensemble) < ESTIMATE_LIMIT_US && ensemble.fit_s > 0.0);
        let huge = predict(&gp(GpChoice::Sparse(2000), MeanKind::Zero), &s).unwrap();
        let unknown = Choice::of(Family::named("none such"), vec![Channel::Electrodes]);
        let refused = predict(&unknown, &s).unwrap_err().to_string();
        assert!(
            refused.contains("\"none such\"") && refused.contains("gp or ensemble"),
            "{refused}"
        );
        assert!(p99_us(&huge) > ESTIMATE_LIMIT_US, "{huge:?}");
    }
}
