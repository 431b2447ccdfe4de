//! The time of one estimate (every axis with its standard deviation, one
//! core) predicted from a model's kind and size, never from a clock: what
//! `train --select` reads before it fits a candidate and the chooser reads
//! of a fitted one (`learn::chooser`).
//!
//! Per-unit times are the medians of six runs of `cargo bench --bench
//! estimate` on 2 cores of the development machine (docs/results.md,
//! "Estimate time per candidate"): a faster machine estimates sooner, in
//! the same order.

use super::gp::exact::VARIANCE_ROWS;

/// Microseconds per point and feature of a GP's kernel vector.
const KERNEL_TERM_US: f64 = 0.0003;
/// Microseconds per element of the exact GP's packed triangular factor (in
/// single precision, of at most [`VARIANCE_ROWS`] rows) that its standard
/// deviation runs through.
const VARIANCE_SINGLE_US: f64 = 0.000117;
/// Microseconds per element of the sparse GP's two packed triangular
/// factors (in double precision, of its points).
const VARIANCE_PAIR_US: f64 = 0.00018;
/// Microseconds of a network mean's pass, every axis (the exact GP on 2000
/// rows took 198.5 µs, with a network mean 201).
pub const NETWORK_US: f64 = 3.0;
/// Microseconds of an ensemble of networks' estimate, every axis.
pub const ENSEMBLE_US: f64 = 12.0;
/// An estimate's time at the 99th percentile over its median: the largest
/// ratio of the six bench runs was 2.85 (the exact GP on 4000 rows, whose
/// factors may have left the cache).
pub const P99_OVER_P50: f64 = 3.0;

/// Elements of a packed triangular factor of `n` rows.
fn packed(n: f64) -> f64 {
    n * (n + 1.0) / 2.0
}

/// One axis of an exact GP on `rows` rows of `features`.
pub fn exact_us(rows: usize, features: usize) -> f64 {
    let var = rows.min(VARIANCE_ROWS) as f64;
    KERNEL_TERM_US * (rows * features) as f64 + VARIANCE_SINGLE_US * packed(var)
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
        // benches/estimate.rs, 2026-12-04, 19 features, 3 axes: the median
        // p50 of six runs, µs.
        for (us, measured) in [
            (3.0 * exact_us(1000, 19), 192.5),
            (3.0 * exact_us(2000, 19), 198.5),
            (3.0 * exact_us(4000, 19), 244.0),
            (3.0 * sparse_us(200, 19), 27.0),
            (3.0 * sparse_us(500, 19), 133.0),
            (3.0 * exact_us(2000, 19) + NETWORK_US, 201.0),
        ] {
            assert!((us / measured - 1.0).abs() < 0.1, "{us} vs {measured}");
        }
        // The variance of an exact GP is bounded by its clusters' rows.
        let var = |n| exact_us(n, 0);
        assert_eq!(var(4000), var(VARIANCE_ROWS));
        assert!(var(500) < var(VARIANCE_ROWS));
    }
}
