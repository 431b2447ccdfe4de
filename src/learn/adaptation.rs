//! `adapt`: the candidates for a new unit ([`crate::learn::candidates`])
//! cross-validated on folds of the new data ([`adapt_folds`]) and chosen
//! by the chooser's rule ([`choose`]), as the calibration chooses; and the
//! scores both read ([`validate`]).

use super::candidates::{Candidate, Fitter, NEW_DATA};
use super::chooser::{self, spread, Form, Scored};
use super::data::{trialwise_folds, Dataset};
use super::evaluate::{check_fits, EvalError};
use super::models::gp::fit::FitProgress;
use super::models::gp::{GpParams, SeHyper};
use super::models::metrics::rmse_columns;
use super::models::wrench_gp::{
    std_scale, std_scale_over_folds, AdaptChoice, AdaptedFrom, Making, ModelError, TareSpec,
    TrainedOn, Validation, WarmStart, WrenchGp,
};
use super::models::wrench_model::WrenchModel;
use super::pooled::{pooling_note, BaseData, Unavailable};
use crate::params::Checked;
use crate::wrench::Axis;

/// Contiguous blocks a held-out part of one trial is scored on, as parts.
const BLOCKS_OF_ONE_TRIAL: usize = 5;

/// `model` scored on `test` as `name`: RMSE per axis, and their mean over
/// axes in units of `sd` ([`chooser::score`], lower is better), over every
/// row and on each trial of `test` (one trial: on five contiguous blocks of
/// it), the chooser's parts.
pub fn validate(
    name: &str,
    model: &dyn WrenchModel,
    test: &Dataset,
    sd: &[f64],
) -> Result<Validation, EvalError> {
    check_fits(model, test)?;
    let pred = model.predict_observed(test.x.view(), false)?.mean;
    Ok(scored(name, test, pred.view(), sd))
}

/// Estimates `pred` of `test`'s rows scored as `name`, as [`validate`]
/// scores a model's.
fn scored(name: &str, test: &Dataset, pred: ndarray::ArrayView2<f64>, sd: &[f64]) -> Validation {
    let on = |rows: &[usize]| {
        let y = test.y.select(ndarray::Axis(0), rows);
        chooser::score(y.view(), pred.select(ndarray::Axis(0), rows).view(), sd)
    };
    let trials = test.trials();
    let trial_scores = match trials.as_slice() {
        [(_, rows)] => {
            let block = rows.len().div_ceil(BLOCKS_OF_ONE_TRIAL);
            rows.chunks(block).map(on).collect()
        }
        _ => trials.iter().map(|(_, rows)| on(rows)).collect(),
    };
    Validation {
        model: name.into(),
        rmse: (test.axes.axes().iter().copied())
            .zip(rmse_columns(test.y.view(), pred))
            .collect(),
        score: chooser::score(test.y.view(), pred, sd),
        trial_scores,
    }
}

/// The candidate of `validation` (each with its fitted model's predicted
/// estimate time and form) the chooser takes, and why; the first when no
/// score is a number.
pub fn choose(validation: &[Validation], cost: &[(f64, Form)]) -> (usize, String) {
    let scored: Vec<Scored> = (validation.iter().zip(cost))
        .map(|(v, &(estimate_us, form))| Scored {
            name: v.model.clone(),
            score: v.score,
            parts: &v.trial_scores,
            form,
            estimate_us,
        })
        .collect();
    chooser::choose(&scored).unwrap_or((0, "no score is a number: the first candidate".into()))
}

/// Held-out rows whose errors set a chosen model's standard deviation
/// scale (evenly spread).
const CALIBRATION_ROWS: usize = 500;

/// Per axis, the scale of `model`'s standard deviation that covers its
/// errors on `test` ([`std_scale`]; 1 without one).
pub fn std_scales(model: &dyn WrenchModel, test: &Dataset) -> Result<Vec<f64>, ModelError> {
    let z = model.standardised_errors(test, CALIBRATION_ROWS)?;
    Ok(z.iter().map(|z| std_scale(z).unwrap_or(1.0)).collect())
}

/// Folds `adapt` scores its candidates on.
pub const ADAPT_FOLDS: usize = 2;

/// The folds of new data `adapt` scores on, (training rows, held-out rows)
/// each, every row held out once: its trials in [`ADAPT_FOLDS`] trial-wise
/// folds (a set of fewer trials in fewer), a set of one trial cut into
/// that many contiguous blocks first ([`Dataset::single_trials_in_blocks`]).
pub fn adapt_folds(data: &Dataset) -> Vec<(Vec<usize>, Vec<usize>)> {
    let (blocked, _) = data.single_trials_in_blocks(ADAPT_FOLDS);
    let mut folds = trialwise_folds(&blocked, ADAPT_FOLDS);
    folds.retain(|(train, test)| !train.is_empty() && !test.is_empty());
    folds
}

/// `adapt`: the candidates for a new unit ([`Candidate::list`]: the base
/// adapted, retrained on the base's data pooled with the new when
/// `base_data` is at hand, and each family on the new data alone), each
/// fitted on the folds of the new data ([`adapt_folds`]) and scored on
/// their held-out rows. The one the chooser takes ([`choose`]) is fitted
/// again on all of `data`, its standard deviations scaled to cover its
/// held-out errors ([`std_scale`]), and returned with what was chosen. The
/// GPs record `trained_on` (the new data's own, `new_only`, for those
/// trained on it alone).
pub struct Adaptation<'a> {
    /// The base model.
    pub base: &'a WrenchGp,
    /// The new data (tared as `tare` says).
    pub data: &'a Dataset,
    /// Its tare.
    pub tare: TareSpec,
    /// What the adapted model records it came from.
    pub from: AdaptedFrom,
    /// The adaptation GPs' options (and the new-data candidates').
    pub params: &'a Checked<GpParams>,
    /// The reference the adapted and pooled models record.
    pub trained_on: Option<TrainedOn>,
    /// The reference the models of the new data alone record.
    pub new_only: Option<TrainedOn>,
}

/// A candidate of [`Adaptation`] cross-validated on the new data.
struct CrossValidated {
    /// Its scores.
    validation: Validation,
    /// Per axis, per fold, its held-out standardised errors.
    errors: Vec<Vec<Vec<f64>>>,
    /// Its estimate's predicted time (µs).
    estimate_us: f64,
    /// A GP's hyperparameters of its first fold, per axis.
    hypers: Option<Vec<SeHyper>>,
}

impl Adaptation<'_> {
    /// Runs it (see [`Adaptation`]); `progress` is told every fit's progress.
    pub fn run(
        self,
        base_data: Result<BaseData, Unavailable>,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<(Box<dyn WrenchModel>, AdaptChoice), EvalError> {
        let pooling = pooling_note(&base_data);
        let pool = match base_data {
            Ok(b) => {
                let options = b.params.clone().validate().map_err(ModelError::from)?;
                Some((Box::new(b), options))
            }
            Err(_) => None,
        };
        let candidates = Candidate::list(Some(self.base), pool, self.params, &NEW_DATA)?;
        let fitter = Fitter {
            from: self.from.clone(),
            params: self.params.clone(),
            input: self.base.scaling(),
            sensor: self.base.sensor().clone(),
        };
        let folds = adapt_folds(self.data);
        let sd = spread(self.data);
        let mut validation = Vec::with_capacity(candidates.len());
        let mut errors = Vec::with_capacity(candidates.len());
        let mut hypers = Vec::with_capacity(candidates.len());
        let mut cost = Vec::with_capacity(candidates.len());
        for c in &candidates {
            let scored = self.cross_validate(c, &fitter, &folds, &sd, progress)?;
            validation.push(scored.validation);
            errors.push(scored.errors);
            hypers.push(scored.hypers);
            cost.push((scored.estimate_us, fitter.form(c)));
        }
        let (at, why) = choose(&validation, &cost);
        // The winner's standard deviation scale, from its held-out errors.
        let scales: Vec<f64> = (errors.swap_remove(at).iter())
            .map(|z| std_scale_over_folds(z).unwrap_or(1.0))
            .collect();
        let chosen = &candidates[at];
        let choice = AdaptChoice {
            chosen: chosen.name(),
            held_out_rows: self.data.len(),
            folds: folds.len(),
            pooling,
            validation,
            why,
        };
        let trained_on = match chosen {
            Candidate::Alone(..) => self.new_only.clone(),
            _ => self.trained_on.clone(),
        };
        // Fitted again on every row, started from its first fold's search.
        let warm = WarmStart {
            hypers: hypers[at].as_deref(),
            network: None,
        };
        let mut model = fitter.fit(chosen, self.data, self.tare.clone(), warm, progress)?;
        model.record(Making::StdScales(scales));
        model.record(Making::TrainedOn(trained_on));
        model.record(Making::AdaptChoice(Box::new(choice.clone())));
        Ok((model, choice))
    }

    /// `candidate` fitted by `fitter` on each fold's training rows of the
    /// new data and scored on its held-out rows ([`validate`]'s scores, in
    /// units of `sd`: every row is held out once). A GP's folds after the
    /// first start their search from the first's hyperparameters.
    fn cross_validate(
        &self,
        candidate: &Candidate,
        fitter: &Fitter,
        folds: &[(Vec<usize>, Vec<usize>)],
        sd: &[f64],
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<CrossValidated, EvalError> {
        let y = &self.data.y;
        let mut pred = ndarray::Array2::zeros(y.raw_dim());
        let mut errors = vec![Vec::new(); y.ncols()];
        let (mut first, mut estimate_us) = (None, 0.0);
        for (train, test) in folds {
            let held = self.data.select(test);
            let warm = WarmStart {
                hypers: first.as_deref(),
                network: None,
            };
            let train = self.data.select(train);
            let m = fitter.fit(candidate, &train, self.tare.clone(), warm, progress)?;
            check_fits(m.as_ref(), &held)?;
            let p = m.predict_observed(held.x.view(), false)?.mean;
            for (row, &i) in p.rows().into_iter().zip(test) {
                pred.row_mut(i).assign(&row);
            }
            let z = m.standardised_errors(&held, CALIBRATION_ROWS)?;
            errors.iter_mut().zip(z).for_each(|(e, z)| e.push(z));
            estimate_us = m.predicted_estimate_us();
            let gp = m.as_any().downcast_ref::<WrenchGp>();
            first = first.or_else(|| gp.map(WrenchGp::hypers));
        }
        let validation = scored(&candidate.name(), self.data, pred.view(), sd);
        Ok(CrossValidated {
            validation,
            errors,
            estimate_us,
            hypers: first,
        })
    }
}

#[cfg(test)]
mod tests;
