//! Training and scoring the GP and the baseline network on the same data:
//! trial-wise k-fold cross-validation (Huhnstock 2014, Tables 4.1-4.3) or one
//! train file against one test file.

use std::collections::BTreeMap;
use std::time::Instant;

use ndarray::{Array2, ArrayView2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::data::{trialwise_folds, Dataset};
use super::models::cnn::{CnnLearner, CnnParams};
use super::models::ensemble::EnsembleFamily;
use super::models::family::ModelFamily;
use super::models::family_learner::FamilyLearner;
use super::models::gp::{FitProgress, GpParams};
use super::models::metrics::{
    coverage, direction_error_at_peaks, r2_columns, rmse_columns, DirectionError,
};
use super::models::nn::{NnLearner, NnParams};
use super::models::scale::InputScaling;
use super::models::wrench_gp::{GpFamily, ModelError, TareSpec};
use super::models::wrench_model::WrenchModel;
use super::models::{Fitted, LearnError, Learner, Prediction};
use crate::exit::{Classify, ExitClass};
use crate::params::Checked;
use crate::sensor::SensorSpec;
use crate::wrench::{Axis, AxisSet};

mod estimates;
pub use estimates::estimates_csv;

/// Errors of an evaluation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// The model file's GP could not predict.
    #[error("GP: {0}")]
    Model(#[from] ModelError),
    /// A model could not be trained or predict.
    #[error(transparent)]
    Fit(#[from] LearnError),
    /// Train and test files have different features or axes.
    #[error("train and test data differ: {0}")]
    Mismatch(String),
    /// Fewer than two folds.
    #[error("cross-validation needs at least 2 folds, got {0}")]
    Folds(usize),
    /// A trained model that does not explain its own training data: a
    /// value in the data far from all others (a logging glitch) can do
    /// that.
    #[error(
        "the model explains {r2_pct:.0} % of {axis}'s variance on its own training data (at \
         least {min_pct:.0} % expected): look for a glitch in the data (a value far from the \
         others); nothing written"
    )]
    ExplainsNothing {
        /// The worst axis.
        axis: Axis,
        /// Its R2 as a percentage.
        r2_pct: f64,
        /// The smallest accepted, as a percentage.
        min_pct: f64,
    },
    /// Too few trials for the requested folds.
    #[error("{folds} folds need at least {folds} trials per set; set {set} has {trials}")]
    TooFewTrials {
        /// Folds requested.
        folds: usize,
        /// Set with too few trials.
        set: u32,
        /// Its number of trials.
        trials: usize,
    },
}

/// Data that cannot be split or compared are refused input; a model that
/// explains nothing of its data failed.
impl Classify for EvalError {
    fn class(&self) -> ExitClass {
        match self {
            EvalError::Model(e) => e.class(),
            EvalError::Fit(e) => e.class(),
            EvalError::ExplainsNothing { .. } => ExitClass::Failure,
            EvalError::Mismatch(_) | EvalError::Folds(_) | EvalError::TooFewTrials { .. } => {
                ExitClass::Refused
            }
        }
    }
}

/// Options shared by both evaluation modes.
#[derive(Debug, Clone)]
pub struct EvalOptions {
    /// Training rows used per fit (a seeded random subset when the training data is larger).
    pub max_train: usize,
    /// GP options (the GP is always evaluated).
    pub gp: Checked<GpParams>,
    /// How the GP's inputs are presented.
    pub scaling: InputScaling,
    /// Network options; `None` skips the network.
    pub nn: Option<Checked<NnParams>>,
    /// Also the ensemble of networks, fitted by its family (with the GP
    /// options' seed).
    pub ensemble: bool,
    /// The sensor the features come from.
    pub sensor: SensorSpec,
    /// CNN options, for data with images (the nail camera); `None` skips it.
    pub cnn: Option<Checked<CnnParams>>,
    /// Seed of the training subsets.
    pub seed: u64,
    /// Smallest tangential force of a peak whose direction is scored (N).
    pub min_peak_n: f64,
}

impl EvalOptions {
    /// The models to train: the GP, then the baselines asked for; the GP
    /// and the ensemble through their families.
    fn learners(&self, tare: &TareSpec) -> Vec<Box<dyn Learner>> {
        let family = |family: &'static dyn ModelFamily| -> Box<dyn Learner> {
            Box::new(FamilyLearner {
                family,
                params: self.gp.clone(),
                input: self.scaling,
                tare: tare.clone(),
                sensor: self.sensor.clone(),
            })
        };
        let mut learners = vec![family(&GpFamily)];
        if let Some(p) = &self.nn {
            learners.push(Box::new(NnLearner(p.clone())));
        }
        if self.ensemble {
            learners.push(family(&EnsembleFamily));
        }
        if let Some(p) = &self.cnn {
            learners.push(Box::new(CnnLearner(p.clone())));
        }
        learners
    }
}

/// Scores of one model on one test set.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scores {
    /// Root-mean-square error per axis (N or Nm).
    pub rmse: BTreeMap<Axis, f64>,
    /// Coefficient of determination per axis.
    pub r2: BTreeMap<Axis, f64>,
    /// Training time (s); for cross-validation, the mean over folds.
    pub fit_s: f64,
    /// Training rows; for cross-validation, per fold.
    pub n_train: usize,
    /// Direction error of the tangential force at the peaks, when fx and
    /// fy are estimated ([`direction_error_at_peaks`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub direction_deg: Option<DirectionError>,
    /// For a model with a standard deviation: per axis, the share of the
    /// errors within one of it ([`coverage`]; about 0.68 when calibrated).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coverage_1s: Option<BTreeMap<Axis, f64>>,
    /// The same within two (about 0.95 when calibrated).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub coverage_2s: Option<BTreeMap<Axis, f64>>,
}

/// Scores of one cross-validation fold.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct FoldScores {
    /// Fold number (1-based).
    pub fold: usize,
    /// Test rows.
    pub n_test: usize,
    /// GP scores.
    pub gp: Scores,
    /// The baselines' scores, by name (`nn`, `cnn`: those trained).
    #[serde(flatten)]
    pub baselines: BTreeMap<&'static str, Scores>,
}

/// Result of an evaluation: per fold, and overall on all test rows pooled.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evaluation {
    /// Per-fold scores (one entry for a train/test evaluation).
    pub folds: Vec<FoldScores>,
    /// GP scores over all test rows.
    pub gp: Scores,
    /// The baselines' scores over all test rows, by name.
    #[serde(flatten)]
    pub baselines: BTreeMap<&'static str, Scores>,
}

/// What an evaluation is doing, for progress displays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Progress {
    /// A fold starts (1-based).
    Fold(usize, usize),
    /// A model starts training (its name).
    Fit(&'static str),
    /// The fit of an axis progresses (the GP's hyperparameters).
    Axis(Axis, FitProgress),
}

/// The scores of the estimates `yhat` (with their standard deviations
/// `std`, when the model has them) of the targets `y`.
pub(crate) fn scores(
    axes: &AxisSet,
    y: ArrayView2<f64>,
    (yhat, std): (ArrayView2<f64>, Option<ArrayView2<f64>>),
    fit_s: f64,
    n_train: usize,
) -> Scores {
    let per_axis = |v: ndarray::Array1<f64>| -> BTreeMap<Axis, f64> {
        axes.axes().iter().copied().zip(v).collect()
    };
    let within = |k| std.map(|s| per_axis(coverage(y, yhat, s, k)));
    Scores {
        rmse: per_axis(rmse_columns(y, yhat)),
        r2: per_axis(r2_columns(y, yhat)),
        fit_s,
        n_train,
        direction_deg: None,
        coverage_1s: within(1.0),
        coverage_2s: within(2.0),
    }
}

/// `s` with the direction error of `pred` on `test` (None unless both fx
/// and fy are estimated).
fn with_direction(mut s: Scores, test: &Dataset, pred: ArrayView2<f64>, min_peak_n: f64) -> Scores {
    let axes = test.axes.axes();
    let col = |a: Axis| axes.iter().position(|&b| b == a);
    if let (Some(x), Some(y)) = (col(Axis::Fx), col(Axis::Fy)) {
        let pick = |m: ArrayView2<f64>| m.select(ndarray::Axis(1), &[x, y]);
        let trial: Vec<(u32, u32)> = test
            .set
            .iter()
            .copied()
            .zip(test.trial.iter().copied())
            .collect();
        s.direction_deg = direction_error_at_peaks(
            pick(test.y.view()).view(),
            pick(pred).view(),
            &trial,
            min_peak_n,
        );
    }
    s
}

/// One model's predictions on a test set, and its training time.
struct Predictions {
    name: &'static str,
    pred: Prediction,
    fit_s: f64,
}

/// Trains each learner that takes the data on `train` and predicts `test`,
/// with the rows trained on. The learners train on the same seeded subset
/// of `opts.max_train` rows, but for one that fits on every row (a GP's
/// prior mean, fitted as `train` fits it; the exact GP then takes its own
/// `max_train` of them).
fn fit_and_predict(
    train: &Dataset,
    test: &Dataset,
    learners: &[Box<dyn Learner>],
    opts: &EvalOptions,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<(Vec<Predictions>, usize), EvalError> {
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let subset = train.random_rows(opts.max_train, &mut rng);
    let mut out = Vec::with_capacity(learners.len());
    for l in learners
        .iter()
        .filter(|l| l.takes(&subset) && l.takes(test))
    {
        progress(Progress::Fit(l.name()));
        let rows = if l.every_row() { train } else { &subset };
        let t0 = Instant::now();
        let fitted = l.fit(rows, &mut |a, p| progress(Progress::Axis(a, p)))?;
        let fit_s = t0.elapsed().as_secs_f64();
        out.push(Predictions {
            name: l.name(),
            pred: with_sampled_std(fitted.as_ref(), test)?,
            fit_s,
        });
    }
    Ok((out, subset.len()))
}

/// Test rows a model's standard deviation is computed on at most, evenly
/// spread (an exact GP's costs O(m^2) a row, m up to
/// [`VARIANCE_ROWS`](crate::learn::models::gp::exact::VARIANCE_ROWS)).
const COVERAGE_ROWS: usize = 2000;

/// `fitted`'s means on every row of `test` and, for a model with a
/// standard deviation, that on at most [`COVERAGE_ROWS`] of them (NaN on
/// the others, which [`coverage`] leaves out).
fn with_sampled_std(fitted: &dyn Fitted, test: &Dataset) -> Result<Prediction, LearnError> {
    let mut pred = fitted.predict(test, false)?;
    if !fitted.has_std() {
        return Ok(pred);
    }
    let step = test.len().div_ceil(COVERAGE_ROWS).max(1);
    let rows: Vec<usize> = (0..test.len()).step_by(step).collect();
    if let Some(some) = fitted.predict(&test.select(&rows), true)?.std {
        let mut std = Array2::from_elem(pred.mean.raw_dim(), f64::NAN);
        for (r, &i) in some.rows().into_iter().zip(&rows) {
            std.row_mut(i).assign(&r);
        }
        pred.std = Some(std);
    }
    Ok(pred)
}

/// Trial-wise k-fold cross-validation of the GP and the network on the same
/// folds and the same training subsets. `data` must already be tared.
pub fn cross_validate(
    data: &Dataset,
    folds: usize,
    tare: &TareSpec,
    opts: &EvalOptions,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<Evaluation, EvalError> {
    if folds < 2 {
        return Err(EvalError::Folds(folds));
    }
    let mut per_set: BTreeMap<u32, usize> = BTreeMap::new();
    for ((set, _), _) in data.trials() {
        *per_set.entry(set).or_default() += 1;
    }
    if let Some((&set, &trials)) = per_set.iter().find(|(_, &t)| t < folds) {
        return Err(EvalError::TooFewTrials { folds, set, trials });
    }
    let splits = trialwise_folds(data, folds)
        .into_iter()
        .map(|(train, test)| (data.select(&train), vec![data.select(&test)]));
    evaluate_splits(splits, folds, tare, opts, progress)
}

/// Leave one session out: each session (a file, tared on its own) is
/// tested on a model trained on all the others; one fold per session.
pub fn leave_one_session_out(
    sessions: &[Dataset],
    tare: &TareSpec,
    opts: &EvalOptions,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<Evaluation, EvalError> {
    if sessions.len() < 2 {
        return Err(EvalError::Folds(sessions.len()));
    }
    let mut splits = Vec::with_capacity(sessions.len());
    for (i, test) in sessions.iter().enumerate() {
        let others: Vec<&Dataset> = (sessions.iter().enumerate())
            .filter_map(|(j, s)| (j != i).then_some(s))
            .collect();
        let train = Dataset::concat(&others)
            .ok_or_else(|| EvalError::Mismatch("the sessions differ in features or axes".into()))?;
        splits.push((train, vec![test.clone()]));
    }
    evaluate_splits(splits.into_iter(), sessions.len(), tare, opts, progress)
}

/// Trains once on `train` and scores on each test set (each a session,
/// already tared): one fold per test set.
pub fn train_test(
    train: &Dataset,
    tests: &[Dataset],
    tare: &TareSpec,
    opts: &EvalOptions,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<Evaluation, EvalError> {
    let split = std::iter::once((train.clone(), tests.to_vec()));
    evaluate_splits(split, 1, tare, opts, progress)
}

/// Fits on each split's training set and scores each of its test sets (one
/// fold per test set, numbered in order); pooled scores over every test row.
fn evaluate_splits(
    splits: impl Iterator<Item = (Dataset, Vec<Dataset>)>,
    n_splits: usize,
    tare: &TareSpec,
    opts: &EvalOptions,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<Evaluation, EvalError> {
    let learners = opts.learners(tare);
    let mut results = Vec::new();
    let mut pooled = Vec::new();
    // Per model, in the learners' order.
    let mut per_model: PerModel = Vec::new();
    let mut n_train = 0;
    for (s, (train, tests)) in splits.enumerate() {
        progress(Progress::Fold(s + 1, n_splits));
        let refs: Vec<&Dataset> = tests.iter().collect();
        let test = Dataset::concat(&refs)
            .filter(|t| t.features == train.features && t.axes == train.axes)
            .ok_or_else(|| {
                EvalError::Mismatch(format!(
                    "training features {:?} / axes {}; every test set must have them",
                    train.features, train.axes
                ))
            })?;
        let (preds, rows_trained) = fit_and_predict(&train, &test, &learners, opts, progress)?;
        n_train = rows_trained;
        score_test_sets(&tests, &preds, n_train, opts, &mut results)?;
        for p in preds {
            match per_model.iter_mut().find(|(name, _, _)| *name == p.name) {
                Some((_, preds, time)) => {
                    preds.push(p.pred);
                    *time += p.fit_s;
                }
                None => per_model.push((p.name, vec![p.pred], p.fit_s)),
            }
        }
        pooled.push(test);
    }
    let (gp, baselines) = pooled_scores(&per_model, &pooled, n_splits, n_train, opts)?;
    Ok(Evaluation {
        folds: results,
        gp,
        baselines,
    })
}

/// Each of `tests`' scores, a fold each, from the models' estimates
/// `preds` of them all (stacked in order), after `n_train` training rows.
fn score_test_sets(
    tests: &[Dataset],
    preds: &[Predictions],
    n_train: usize,
    opts: &EvalOptions,
    results: &mut Vec<FoldScores>,
) -> Result<(), EvalError> {
    let mut from = 0;
    for t in tests {
        let rows = from..from + t.len();
        from += t.len();
        let mut by_model = preds.iter().map(|p| {
            let pred = p.pred.mean.slice(ndarray::s![rows.clone(), ..]);
            let std = (p.pred.std.as_ref()).map(|m| m.slice(ndarray::s![rows.clone(), ..]));
            let s = scores(&t.axes, t.y.view(), (pred, std), p.fit_s, n_train);
            (p.name, with_direction(s, t, pred, opts.min_peak_n))
        });
        let (_, gp) = by_model.next().ok_or(EvalError::Folds(0))?;
        results.push(FoldScores {
            fold: results.len() + 1,
            n_test: t.len(),
            gp,
            baselines: by_model.collect(),
        });
    }
    Ok(())
}

/// Each model's predictions per split and its total training time.
type PerModel = Vec<(&'static str, Vec<Prediction>, f64)>;

/// The scores over the `pooled` test sets of every split of the models
/// that predicted each (the GP's, then the baselines').
fn pooled_scores(
    per_model: &PerModel,
    pooled: &[Dataset],
    n_splits: usize,
    n_train: usize,
    opts: &EvalOptions,
) -> Result<(Scores, BTreeMap<&'static str, Scores>), EvalError> {
    let refs: Vec<&Dataset> = pooled.iter().collect();
    let all = Dataset::concat(&refs).ok_or(EvalError::Folds(0))?;
    let nf = n_splits as f64;
    let mut overall = per_model
        .iter()
        .filter(|(_, preds, _)| preds.len() == pooled.len())
        .map(|(name, preds, time)| {
            let stack = |parts: Vec<_>| {
                ndarray::concatenate(ndarray::Axis(0), &parts)
                    .map_err(|e| EvalError::Mismatch(e.to_string()))
            };
            let pred = stack(preds.iter().map(|p| p.mean.view()).collect())?;
            let stds: Option<Vec<_>> = preds
                .iter()
                .map(|p| p.std.as_ref().map(|s| s.view()))
                .collect();
            let std = stds.map(stack).transpose()?;
            let both = (pred.view(), std.as_ref().map(|s| s.view()));
            let s = scores(&all.axes, all.y.view(), both, time / nf, n_train);
            Ok((*name, with_direction(s, &all, pred.view(), opts.min_peak_n)))
        })
        .collect::<Result<Vec<_>, EvalError>>()?
        .into_iter();
    let (_, gp) = overall.next().ok_or(EvalError::Folds(0))?;
    Ok((gp, overall.collect()))
}

/// The least share of its training targets' variance (R2) a model must
/// explain on every axis. Models of real and simulated BioTac data explain
/// 0.96-0.9999 of theirs (docs/training.md, "Training data that cannot be true"); one
/// force of 90000 N among 8000 rows left 0.14.
pub const MIN_TRAINING_R2: f64 = 0.5;

/// Rows the training fit is scored on at most (evenly spread).
const TRAINING_FIT_ROWS: usize = 5000;

/// The model's fit on its own training data `data` (at most 5000 rows,
/// evenly spread), refused ([`EvalError::ExplainsNothing`]) when an axis's
/// R2 is below [`MIN_TRAINING_R2`].
pub fn training_fit(model: &dyn WrenchModel, data: &Dataset) -> Result<Scores, EvalError> {
    let step = data.len().div_ceil(TRAINING_FIT_ROWS).max(1);
    let rows: Vec<usize> = (0..data.len()).step_by(step).collect();
    let s = score_model(model, &data.select(&rows), f64::INFINITY, false)?;
    let worst = s.r2.iter().min_by(|a, b| a.1.total_cmp(b.1));
    match worst {
        Some((&axis, &r2)) if r2 < MIN_TRAINING_R2 => Err(EvalError::ExplainsNothing {
            axis,
            r2_pct: r2.max(0.0) * 100.0,
            min_pct: MIN_TRAINING_R2 * 100.0,
        }),
        _ => Ok(s),
    }
}

/// Scores a trained model on `test` (tared, with the model's features and axes).
/// Directions are scored at peaks of at least `min_peak_n`; the coverage of
/// its standard deviation when `with_std`.
pub fn score_model(
    model: &dyn WrenchModel,
    test: &Dataset,
    min_peak_n: f64,
    with_std: bool,
) -> Result<Scores, EvalError> {
    check_fits(model, test)?;
    let pred = model.predict_observed(test.x.view(), with_std)?;
    let both = (pred.mean.view(), pred.std.as_ref().map(|s| s.view()));
    let s = scores(&test.axes, test.y.view(), both, 0.0, model.n_train());
    Ok(with_direction(s, test, pred.mean.view(), min_peak_n))
}

/// Refuses `test` when its features or axes are not `model`'s.
pub(crate) fn check_fits(model: &dyn WrenchModel, test: &Dataset) -> Result<(), EvalError> {
    if test.features != model.features() || &test.axes != model.axes() {
        return Err(EvalError::Mismatch(format!(
            "model has features {:?} / axes {}, test data {:?} / {}",
            model.features(),
            model.axes(),
            test.features,
            test.axes
        )));
    }
    Ok(())
}
