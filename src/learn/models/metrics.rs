//! Regression metrics: root-mean-squared error and coefficient of
//! determination, for one output or per column.
//!
//! NaN in either argument propagates to the result.

use ndarray::{Array1, ArrayView1, ArrayView2, Axis};

/// Root-mean-squared error `√(1/N Σ (y_i − ŷ_i)²)`; NaN when empty.
///
/// # Panics
/// If `y` and `yhat` differ in length.
pub fn rmse(y: ArrayView1<f64>, yhat: ArrayView1<f64>) -> f64 {
    assert_eq!(y.len(), yhat.len(), "rmse: lengths differ");
    (ss_res(y, yhat) / y.len() as f64).sqrt()
}

/// Coefficient of determination `R² = 1 − SS_res / SS_tot` with
/// `SS_res = Σ (y_i − ŷ_i)²` and `SS_tot = Σ (y_i − ȳ)²`.
///
/// 1 is a perfect fit, 0 is no better than predicting the mean, and it is
/// negative for worse predictions. When `y` is constant (all values equal, so
/// `SS_tot = 0`) R² is undefined; we return 1 if the prediction is exact
/// (`SS_res = 0`) and 0 otherwise, the convention of scikit-learn's
/// `r2_score`, so that averages over outputs stay finite. NaN when empty.
///
/// # Panics
/// If `y` and `yhat` differ in length.
pub fn r2(y: ArrayView1<f64>, yhat: ArrayView1<f64>) -> f64 {
    assert_eq!(y.len(), yhat.len(), "r2: lengths differ");
    let Some(&first) = y.first() else {
        return f64::NAN;
    };
    let res = ss_res(y, yhat);
    if y.iter().all(|&v| v == first) {
        return if res == 0.0 { 1.0 } else { 0.0 };
    }
    let mean = y.sum() / y.len() as f64;
    let tot: f64 = y.iter().map(|v| (v - mean).powi(2)).sum();
    1.0 - res / tot
}

/// [`rmse`] of every column of `y` against the same column of `yhat`.
///
/// # Panics
/// If the shapes differ.
pub fn rmse_columns(y: ArrayView2<f64>, yhat: ArrayView2<f64>) -> Array1<f64> {
    per_column(y, yhat, rmse)
}

/// [`r2`] of every column of `y` against the same column of `yhat`.
///
/// # Panics
/// If the shapes differ.
pub fn r2_columns(y: ArrayView2<f64>, yhat: ArrayView2<f64>) -> Array1<f64> {
    per_column(y, yhat, r2)
}

/// Per column, the share of the errors `y - yhat` within `k` standard
/// deviations `std` (the same shape; rows whose `std` is NaN are left out):
/// about 0.68 for `k = 1` and 0.95 for `k = 2` when the errors are Gaussian
/// with that standard deviation; NaN for a column with no such row.
///
/// # Panics
/// If the shapes differ.
pub fn coverage(
    y: ArrayView2<f64>,
    yhat: ArrayView2<f64>,
    std: ArrayView2<f64>,
    k: f64,
) -> Array1<f64> {
    assert!(
        y.dim() == yhat.dim() && y.dim() == std.dim(),
        "coverage: shapes differ"
    );
    let within = |y: ArrayView1<f64>, yhat: ArrayView1<f64>, std: ArrayView1<f64>| {
        let rows = (y.iter().zip(yhat).zip(std)).filter(|(_, s)| !s.is_nan());
        let (n, inside) = rows.fold((0usize, 0usize), |(n, i), ((y, m), s)| {
            (n + 1, i + usize::from((y - m).abs() <= k * s))
        });
        inside as f64 / n as f64
    };
    let cols = y
        .columns()
        .into_iter()
        .zip(yhat.columns())
        .zip(std.columns());
    cols.map(|((y, m), s)| within(y, m, s)).collect()
}

/// The mean of `x` and its standard error (the sample standard deviation
/// over the square root of the count); None for fewer than two values.
pub fn mean_and_error(x: &[f64]) -> Option<(f64, f64)> {
    let n = x.len();
    (n >= 2).then(|| {
        let mean = x.iter().sum::<f64>() / n as f64;
        let var = x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        (mean, (var / n as f64).sqrt())
    })
}

/// Applies a metric column by column.
fn per_column(
    y: ArrayView2<f64>,
    yhat: ArrayView2<f64>,
    metric: fn(ArrayView1<f64>, ArrayView1<f64>) -> f64,
) -> Array1<f64> {
    assert_eq!(y.dim(), yhat.dim(), "metric: shapes differ");
    y.axis_iter(Axis(1))
        .zip(yhat.axis_iter(Axis(1)))
        .map(|(a, b)| metric(a, b))
        .collect()
}

/// Residual sum of squares `Σ (y_i − ŷ_i)²`.
fn ss_res(y: ArrayView1<f64>, yhat: ArrayView1<f64>) -> f64 {
    y.iter().zip(yhat).map(|(a, b)| (a - b).powi(2)).sum()
}

/// How far the estimated tangential force points from the true one at the
/// peaks of the pushes: Watanabe et al. 2023 report the "tangential
/// direction error at the peak points of the applied force" (within about
/// ±2.5° for their individual models).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct DirectionError {
    /// Smallest true tangential force of a scored peak (N).
    pub min_peak_n: f64,
    /// Peaks scored.
    pub peaks: usize,
    /// Median of the absolute angle (deg).
    pub median_deg: f64,
    /// 95th percentile (deg).
    pub p95_deg: f64,
    /// Largest (deg).
    pub max_deg: f64,
}

/// Default smallest true tangential force of a scored peak (N).
pub const DEFAULT_PEAK_MIN_N: f64 = 1.0;

/// The direction error of `(fx, fy)` estimates `ft_hat` against the truth
/// `ft` (both n x 2) at the peak of every push: a push is a run of rows of
/// one `trial` whose true tangential force is at least half `min_peak_n`
/// (with 1 N, well above the reference's noise at rest); its peak is the
/// row of the largest, scored when at least `min_peak_n`. None without a
/// peak.
pub fn direction_error_at_peaks(
    ft: ArrayView2<f64>,
    ft_hat: ArrayView2<f64>,
    trial: &[(u32, u32)],
    min_peak_n: f64,
) -> Option<DirectionError> {
    let push_min_n = min_peak_n / 2.0;
    let size = |i: usize| ft[[i, 0]].hypot(ft[[i, 1]]);
    let mut peaks = Vec::new();
    let mut push: Option<usize> = None;
    for i in 0..ft.nrows() {
        let same_push = i > 0 && trial[i] == trial[i - 1] && size(i) >= push_min_n;
        if !same_push {
            peaks.extend(push.take());
        }
        if size(i) >= push_min_n && push.is_none_or(|p| size(i) > size(p)) {
            push = Some(i);
        }
    }
    peaks.extend(push);
    let mut errors: Vec<f64> = peaks
        .into_iter()
        .filter(|&i| size(i) >= min_peak_n)
        .map(|i| {
            let truth = ft[[i, 1]].atan2(ft[[i, 0]]);
            let estimate = ft_hat[[i, 1]].atan2(ft_hat[[i, 0]]);
            let d = (estimate - truth).to_degrees().rem_euclid(360.0);
            d.min(360.0 - d)
        })
        .collect();
    if errors.is_empty() {
        return None;
    }
    errors.sort_by(f64::total_cmp);
    let at = |q: f64| errors[((errors.len() - 1) as f64 * q).round() as usize];
    Some(DirectionError {
        min_peak_n,
        peaks: errors.len(),
        median_deg: at(0.5),
        p95_deg: at(0.95),
        max_deg: at(1.0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coverage_counts_errors_within_k_standard_deviations_where_there_is_one() {
        let y = ndarray::array![[0.0], [0.0], [0.0], [0.0]];
        let yhat = ndarray::array![[0.5], [-1.5], [2.5], [9.0]];
        let std = ndarray::array![[1.0], [1.0], [1.0], [f64::NAN]];
        let c1 = coverage(y.view(), yhat.view(), std.view(), 1.0);
        let c2 = coverage(y.view(), yhat.view(), std.view(), 2.0);
        assert!((c1[0] - 1.0 / 3.0).abs() < 1e-15 && (c2[0] - 2.0 / 3.0).abs() < 1e-15);
        let (mean, se) = mean_and_error(&[1.0, 2.0, 3.0, 4.0]).unwrap();
        assert!(
            (mean - 2.5).abs() < 1e-15 && (se - (5.0f64 / 12.0).sqrt()).abs() < 1e-12,
            "{se}"
        );
        assert_eq!(mean_and_error(&[1.0]), None);
    }
    use ndarray::{array, Array1};

    #[test]
    fn rmse_by_hand() {
        // Residuals 1, −2, 2: SS_res = 9, N = 3, RMSE = √3.
        let y = array![1.0, 2.0, 3.0];
        let yhat = array![0.0, 4.0, 1.0];
        assert!((rmse(y.view(), yhat.view()) - 3f64.sqrt()).abs() < 1e-15);
        assert_eq!(rmse(y.view(), y.view()), 0.0);
        assert!(rmse(Array1::zeros(0).view(), Array1::zeros(0).view()).is_nan());
    }

    #[test]
    fn r2_by_hand() {
        // ȳ = 2.5, SS_tot = 2.25 + 0.25 + 0.25 + 2.25 = 5; residuals 0.5, −0.5, 0, 0.5:
        // SS_res = 0.75, R² = 1 − 0.75 / 5 = 0.85.
        let y = array![1.0, 2.0, 3.0, 4.0];
        let yhat = array![0.5, 2.5, 3.0, 3.5];
        assert!((r2(y.view(), yhat.view()) - 0.85).abs() < 1e-15);
        assert_eq!(r2(y.view(), y.view()), 1.0);
        // Predicting the mean gives 0; predicting the reversed series, SS_res = 20: R² = −3.
        assert_eq!(r2(y.view(), Array1::from_elem(4, 2.5).view()), 0.0);
        assert!((r2(y.view(), array![4.0, 3.0, 2.0, 1.0].view()) + 3.0).abs() < 1e-15);
    }

    #[test]
    fn r2_of_a_constant_target_is_one_if_exact_else_zero() {
        let y = array![0.1, 0.1, 0.1];
        assert_eq!(r2(y.view(), y.view()), 1.0);
        assert_eq!(r2(y.view(), array![0.1, 0.2, 0.1].view()), 0.0);
        assert!(r2(Array1::zeros(0).view(), Array1::zeros(0).view()).is_nan());
    }

    #[test]
    fn column_helpers_apply_the_metric_per_column() {
        let y = array![[1.0, 1.0], [2.0, 2.0], [3.0, 3.0], [4.0, 4.0]];
        let yhat = array![[0.5, 1.0], [2.5, 2.0], [3.0, 3.0], [3.5, 4.0]];
        // Column 0: SS_res = 0.75, RMSE = √(0.75 / 4); column 1 is exact.
        let e = rmse_columns(y.view(), yhat.view());
        assert!((e[0] - (0.75f64 / 4.0).sqrt()).abs() < 1e-15);
        assert_eq!(e[1], 0.0);
        let r = r2_columns(y.view(), yhat.view());
        assert!((r[0] - 0.85).abs() < 1e-15);
        assert_eq!(r[1], 1.0);
    }

    #[test]
    #[should_panic(expected = "lengths differ")]
    fn mismatched_lengths_panic() {
        rmse(array![1.0, 2.0].view(), array![1.0].view());
    }

    #[test]
    fn direction_errors_are_taken_at_the_peak_of_each_push() {
        // Two trials back to back, each with two pushes along +x (peaks 3 N
        // and 1.5 N) apart by a rest; the estimate turns by 10 deg in the
        // first push of a trial, 20 deg in the second. A ripple of 0.05 N
        // puts many local maxima on each push: one peak each all the same.
        let n = 100;
        let mut ft = ndarray::Array2::zeros((2 * n, 2));
        let mut hat = ndarray::Array2::zeros((2 * n, 2));
        for k in 0..2 * n {
            let (i, second) = ((k % n) as f64, k % n >= 50);
            let (top, centre, turn) = match second {
                false => (3.0, 20.0, 10f64),
                true => (1.5, 75.0, 20f64),
            };
            let f =
                (top * (1.0 - (i - centre).abs() / 20.0)).max(0.0) + 0.05 * (i * 2.0).sin().abs();
            let (s, c) = turn.to_radians().sin_cos();
            ft[[k, 0]] = f;
            hat[[k, 0]] = f * c;
            hat[[k, 1]] = f * s;
        }
        let trial: Vec<(u32, u32)> = (0..2 * n).map(|k| (1, 1 + (k / n) as u32)).collect();
        let e = direction_error_at_peaks(ft.view(), hat.view(), &trial, 1.0).unwrap();
        assert_eq!(e.peaks, 4);
        assert!((e.median_deg - 10.0).abs() < 1e-9 || (e.median_deg - 20.0).abs() < 1e-9);
        assert!((e.max_deg - 20.0).abs() < 1e-9, "{e:?}");
        // A push that peaks under 1 N is not scored.
        let small = ft.mapv(|v| v * 0.4);
        let e = direction_error_at_peaks(small.view(), hat.view(), &trial, 1.0).unwrap();
        assert_eq!(e.peaks, 2);
        assert!((e.max_deg - 10.0).abs() < 1e-9, "{e:?}");
        let tiny = ft.mapv(|v| v * 0.1);
        assert!(direction_error_at_peaks(tiny.view(), hat.view(), &trial, 1.0).is_none());
    }
}
