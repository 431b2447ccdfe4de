//! The one rule by which a model is chosen among scored candidates:
//! `train --select` among its options (scored on folds), `adapt` and the
//! calibration among their candidates (scored on the new data). Among the
//! candidates within noise of the best score, the simplest form (the least
//! flexible, then on the fewest points), then the cheapest estimate as
//! predicted from the model's kind and size ([`crate::learn::models::estimate_cost`], never a clock: a
//! loaded machine chooses as an idle one), then the first.
//!
//! A more flexible model can win by less than the parts it is scored on
//! disagree, and then generalise worse to a new session (a cubic mean over
//! a linear one on a real unit, issue 45). The noise is measured on those
//! parts: a candidate is within noise of the best when its mean score over
//! them exceeds the best's by at most one standard error of their
//! part-wise differences (the parts are shared, so the comparison is
//! paired), the "one standard error" rule of Hastie, Tibshirani and
//! Friedman (2009, Sec. 7.10).

use ndarray::ArrayView2;

use super::data::Dataset;
pub use super::models::family::Form;
use super::models::metrics::{mean_and_error, rmse_columns};

/// A candidate as the rule sees it.
#[derive(Debug, Clone)]
pub struct Scored<'a> {
    /// Its name in the reason.
    pub name: String,
    /// Its score (lower is better; see [`score`]).
    pub score: f64,
    /// Its scores on the parts every candidate was scored on (folds, or
    /// held-out trials), in the same order: what the noise is measured on.
    pub parts: &'a [f64],
    /// Its form.
    pub form: Form,
    /// Its estimate's predicted time (µs).
    pub estimate_us: f64,
}

/// The mean over axes of the RMSE of `pred` for `y` (rows x axes) over each
/// axis's spread `sd`: every candidate's score.
pub fn score(y: ArrayView2<f64>, pred: ArrayView2<f64>, sd: &[f64]) -> f64 {
    let rmse = rmse_columns(y, pred);
    rmse.iter().zip(sd).map(|(e, s)| e / s).sum::<f64>() / sd.len() as f64
}

/// The mean of `a`'s part scores less `best`'s and its standard error; None
/// when they were not scored on the same parts.
fn paired_difference(a: &Scored, best: &Scored) -> Option<(f64, f64)> {
    if a.parts.len() != best.parts.len() {
        return None;
    }
    let d: Vec<f64> = (a.parts.iter().zip(best.parts))
        .map(|(a, b)| a - b)
        .collect();
    mean_and_error(&d)
}

/// The index of the chosen candidate and why; None when no score is a
/// number.
pub fn choose(candidates: &[Scored]) -> Option<(usize, String)> {
    let (best_i, best) = (candidates.iter().enumerate())
        .filter(|(_, c)| c.score.is_finite())
        .min_by(|a, b| a.1.score.total_cmp(&b.1.score))?;
    let near: Vec<usize> = (0..candidates.len())
        .filter(|&i| {
            i == best_i
                || (candidates[i].score.is_finite()
                    && paired_difference(&candidates[i], best).is_some_and(|(m, se)| m <= se))
        })
        .collect();
    // min_by keeps the first of equals.
    let chosen = (near.iter().copied())
        .min_by(|&a, &b| {
            let (a, b) = (&candidates[a], &candidates[b]);
            (a.form.flexibility.cmp(&b.form.flexibility))
                .then(a.form.points.cmp(&b.form.points))
                .then(a.estimate_us.total_cmp(&b.estimate_us))
        })
        .unwrap_or(best_i);
    let why = if chosen == best_i {
        format!(
            "the best score ({:.4}); {} other candidate(s) within one standard error of it, none simpler or cheaper",
            best.score,
            near.len() - 1
        )
    } else {
        let c = &candidates[chosen];
        format!(
            "within one standard error of the best score ({:.4} vs {:.4}, {}), the simplest form \
             ({}) and then the cheapest estimate (predicted {:.0} µs) of the {} candidates there",
            c.score,
            best.score,
            best.name,
            c.form,
            c.estimate_us,
            near.len()
        )
    };
    Some((chosen, why))
}

/// Per axis, the targets' standard deviation: the scores' units.
pub fn spread(data: &Dataset) -> Vec<f64> {
    let sd = |c: ndarray::ArrayView1<f64>| c.std(0.0).max(1e-9);
    data.y.columns().into_iter().map(sd).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const ZERO: Form = Form {
        name: "zero mean",
        flexibility: 0,
        points: 0,
    };
    const NETWORK: Form = Form {
        name: "network mean",
        flexibility: 3,
        points: 0,
    };
    const ENSEMBLE: Form = Form {
        name: "the ensemble",
        flexibility: 3,
        points: 0,
    };

    fn scored<'a>(name: &str, form: Form, parts: &'a [f64], estimate_us: f64) -> Scored<'a> {
        Scored {
            name: name.into(),
            score: parts.iter().sum::<f64>() / parts.len() as f64,
            parts,
            form,
            estimate_us,
        }
    }

    #[test]
    fn within_noise_the_simplest_form_then_the_cheapest_then_the_first() {
        // The network mean is best by 0.004 on average, but its held-out
        // trials disagree by more; the ensemble is as flexible.
        let best = [0.30, 0.26, 0.33, 0.28];
        let near = [0.29, 0.31, 0.30, 0.29];
        let worse = [0.50, 0.52, 0.49, 0.51];
        let c = [
            scored("network", NETWORK, &best, 300.0),
            scored("ensemble", ENSEMBLE, &near, 12.0),
            scored("adapted", ZERO, &near, 400.0),
            scored("zero", ZERO, &worse, 10.0),
        ];
        let (i, why) = choose(&c).unwrap();
        assert_eq!(i, 2, "{why}");
        assert!(
            why.contains("simplest form (zero mean)") && why.contains("0.2925, network"),
            "{why}"
        );
        // Equally simple: the cheaper; as cheap: the first.
        let mut two = c.clone();
        two[1].form = ZERO;
        assert_eq!(choose(&two).unwrap().0, 1);
        two[2].estimate_us = two[1].estimate_us;
        assert_eq!(choose(&two).unwrap().0, 1);
        // Equally flexible: on fewer points, however costly its estimate.
        two[1].form.points = 1000;
        two[2].form.points = 500;
        two[2].estimate_us = 900.0;
        let (i, why) = choose(&two).unwrap();
        assert_eq!(i, 2, "{why}");
        assert!(
            why.contains("simplest form (zero mean, 500 points)"),
            "{why}"
        );
    }

    #[test]
    fn better_on_every_part_wins_and_a_score_that_is_not_a_number_never_does() {
        let (best, worse) = ([0.20, 0.21, 0.19], [0.30, 0.31, 0.29]);
        let nan = [f64::NAN, 0.1, 0.1];
        let c = [
            scored("zero", ZERO, &worse, 10.0),
            scored("network", NETWORK, &best, 300.0),
            scored("broken", ZERO, &nan, 1.0),
        ];
        let (i, why) = choose(&c).unwrap();
        assert_eq!(i, 1, "{why}");
        assert!(why.starts_with("the best score (0.2000)"), "{why}");
        // Scored on other parts: only the best is known.
        let c = [
            scored("zero", ZERO, &worse[..2], 10.0),
            scored("network", NETWORK, &worse, 300.0),
        ];
        assert_eq!(choose(&c).unwrap().0, 1);
        assert!(choose(&[scored("broken", ENSEMBLE, &nan, 1.0)]).is_none());
    }
}
