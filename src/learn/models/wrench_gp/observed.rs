//! The standard deviation of a measured target (the GP's own with its
//! noise) and its scale per axis, fitted on held-out errors so that they
//! fall within two of it as often as they should: what `eval` judges a
//! model's doubt by (`coverage_1s`, `coverage_2s`).

use ndarray::ArrayView2;

use super::{ModelError, WrenchGp};
use crate::learn::models::Prediction;

impl WrenchGp {
    /// Means and, when `with_std`, the standard deviation of a measured
    /// target: the GP's latent one ([`WrenchGp::predict`], what the
    /// estimator publishes and the controller's doubt stop reads) with its
    /// noise added in quadrature, times the axis's scale. A GP's noise,
    /// fitted on its training rows, understates its errors on another
    /// stretch of data, so the scales come from errors on held-out rows
    /// ([`std_scale`], recorded as [`super::Making::StdScales`]); the estimator's
    /// own standard deviation stays the GP's: the controller's doubt stop
    /// compares it with a limit set for it. Held-out errors are judged
    /// against it ([`crate::learn::models::metrics::coverage`]).
    pub fn predict_observed(
        &self,
        x: ArrayView2<f64>,
        with_std: bool,
    ) -> Result<Prediction, ModelError> {
        let (mean, mut std) = self.predict(x, with_std)?;
        if !with_std {
            return Ok(Prediction { mean, std: None });
        }
        for (mut col, o) in std.columns_mut().into_iter().zip(&self.0.outputs) {
            let noise = o.gp.hyper().noise_var.sqrt() * o.target_scale;
            col.mapv_inplace(|s| s.hypot(noise) * o.std_scale);
        }
        Ok(Prediction {
            mean,
            std: Some(std),
        })
    }

    /// Each axis's scale of its standard deviation (1: as fitted).
    pub fn std_scales(&self) -> Vec<f64> {
        self.0.outputs.iter().map(|o| o.std_scale).collect()
    }
}

/// The scale that puts 95 % of held-out standardised errors `z` (error
/// over the model's observed standard deviation) within two standard
/// deviations: the 95th percentile of `|z|` over 1.96 (one scale of the
/// standard deviation per axis, fitted on held-out errors), at least 1: a
/// few held-out rows never make a model surer than its GPs are (on a
/// simulated unit, a scale of 0.74 from its recording's last trial left
/// another session's fz errors within two standard deviations 48 % of the
/// time). None without a finite one.
pub fn std_scale(z: &[f64]) -> Option<f64> {
    let mut a: Vec<f64> = z
        .iter()
        .map(|v| v.abs())
        .filter(|v| v.is_finite())
        .collect();
    if a.is_empty() {
        return None;
    }
    a.sort_by(f64::total_cmp);
    let q95 = a[((a.len() as f64 * 0.95).ceil() as usize).clamp(1, a.len()) - 1];
    Some((q95 / 1.96).max(1.0)).filter(|s| s.is_finite())
}

/// The scale from cross-validation's held-out errors, `folds` one list of
/// standardised errors per fold: each fold's [`std_scale`], then their mean,
/// the scale a held-out stretch needs on average. Pooled, the 95th
/// percentile is set by the recording's hardest stretches: on another lab's
/// robotic finger (docs/results.md) z's pooled scale left 99.35 % of the
/// next recording's errors within two standard deviations, the folds' mean
/// (2.14) 98.6 %, their median (1.28) 84.4 %. None without a fold that
/// gives one.
pub fn std_scale_over_folds(folds: &[Vec<f64>]) -> Option<f64> {
    let scales: Vec<f64> = folds.iter().filter_map(|z| std_scale(z)).collect();
    (!scales.is_empty()).then(|| scales.iter().sum::<f64>() / scales.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_std_scale_puts_95_percent_of_held_out_errors_within_two_and_never_narrows() {
        // |z| = 0.04, 0.08, .., 4.0: the 95th percentile is 3.8.
        let z: Vec<f64> = (1..=100)
            .map(|i| if i % 2 == 0 { 0.04 } else { -0.04 } * i as f64)
            .collect();
        assert!((std_scale(&z).unwrap() - 3.8 / 1.96).abs() < 1e-12);
        // Errors well within their standard deviation keep it as it is.
        assert_eq!(std_scale(&[0.1, -0.2, 0.3]), Some(1.0));
        assert_eq!(std_scale(&[f64::NAN]), None);
        assert_eq!(std_scale(&[]), None);
    }

    #[test]
    fn over_folds_the_scale_is_the_mean_of_the_folds_and_not_set_by_the_hardest() {
        // A fold whose 95th percentile of |z| is 1.96 s.
        let fold = |s: f64| -> Vec<f64> { (1..=100).map(|i| s * 1.96 * i as f64 / 95.0).collect() };
        let folds = [fold(2.0), fold(1.5), fold(6.0), fold(1.2), fold(2.5)];
        let mean = (2.0 + 1.5 + 6.0 + 1.2 + 2.5) / 5.0;
        assert!((std_scale_over_folds(&folds).unwrap() - mean).abs() < 1e-12);
        // Pooled, the hard fold sets the scale: above the mean.
        assert!(std_scale(&folds.concat()).unwrap() > mean + 1.0);
        // A fold without a finite error is left out; none at all gives none.
        let some = [fold(2.0), vec![f64::NAN], fold(3.0)];
        assert!((std_scale_over_folds(&some).unwrap() - 2.5).abs() < 1e-12);
        assert_eq!(std_scale_over_folds(&[vec![f64::NAN]]), None);
        assert_eq!(std_scale_over_folds(&[]), None);
    }
}
