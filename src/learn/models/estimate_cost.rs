//! The time of one estimate (every axis with its standard deviation, one
//! core) predicted from a model's kind and size, never from a clock: what
//! `train --select` reads before it fits a candidate and the chooser reads
//! of a fitted one (`learn::chooser`).
//!
//! Per-unit times are the medians of `cargo bench --bench estimate` on 2
//! cores of the development machine (docs/results.md, "Estimate time per
//! candidate"): a faster machine estimates sooner, in the same order.

use super::gp::exact::VARIANCE_ROWS;

/// Microseconds per point and feature of a GP's kernel vector.
const KERNEL_TERM_US: f64 = 0.0006;
/// Microseconds per element of a packed triangular factor that a standard
/// deviation runs through: the exact GP's one, of at most
/// [`VARIANCE_ROWS`] rows; the sparse GP's two, of its points.
const VARIANCE_PAIR_US: f64 = 0.00018;
/// Microseconds of a network mean's pass, every axis.
pub const NETWORK_US: f64 = 120.0;
/// Microseconds of an ensemble of networks' estimate, every axis.
pub const ENSEMBLE_US: f64 = 12.0;

/// Elements of a packed triangular factor of `n` rows.
fn packed(n: f64) -> f64 {
    n * (n + 1.0) / 2.0
}

/// One axis of an exact GP on `rows` rows of `features`.
pub fn exact_us(rows: usize, features: usize) -> f64 {
    let var = rows.min(VARIANCE_ROWS) as f64;
    KERNEL_TERM_US * (rows * features) as f64 + VARIANCE_PAIR_US * packed(var)
}

/// One axis of a sparse GP of `points` inducing points on `features`.
pub fn sparse_us(points: usize, features: usize) -> f64 {
    let m = points as f64;
    KERNEL_TERM_US * m * features as f64 + 2.0 * VARIANCE_PAIR_US * packed(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_predictions_follow_the_bench_medians_within_a_tenth() {
        // benches/estimate.rs, 2026-12-04, 19 features, 3 axes: p50 µs.
        for (us, measured) in [
            (3.0 * exact_us(1000, 19), 301.0),
            (3.0 * exact_us(2000, 19), 321.0),
            (3.0 * exact_us(4000, 19), 402.0),
            (3.0 * sparse_us(200, 19), 26.0),
            (3.0 * exact_us(2000, 19) + NETWORK_US, 440.0),
        ] {
            assert!((us / measured - 1.0).abs() < 0.1, "{us} vs {measured}");
        }
        // The sparse GP of 500 points: 152 predicted, 137 measured.
        assert!((3.0 * sparse_us(500, 19) / 137.0 - 1.0).abs() < 0.12);
        // The variance of an exact GP is bounded by its clusters' rows.
        let var = |n| exact_us(n, 0);
        assert_eq!(var(4000), var(VARIANCE_ROWS));
        assert!(var(500) < var(VARIANCE_ROWS));
    }
}
