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
use super::models::cnn::{Cnn, CnnError, CnnParams};
use super::models::gp::fit::FitProgress;
use super::models::gp::{GpParams, MeanKind};
use super::models::metrics::{direction_error_at_peaks, r2_columns, rmse_columns, DirectionError};
use super::models::nn::{Mlp, NnError, NnParams};
use super::models::scale::InputScaling;
use super::models::wrench_gp::{ModelError, TareSpec, WrenchGp};
use crate::exit::{Classify, ExitClass};
use crate::params::Checked;
use crate::wrench::{Axis, AxisSet};

/// Errors of an evaluation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum EvalError {
    /// GP training or prediction failed.
    #[error("GP: {0}")]
    Gp(#[from] ModelError),
    /// Network training failed.
    #[error("neural network: {0}")]
    Nn(#[from] NnError),
    /// CNN training failed.
    #[error("CNN: {0}")]
    Cnn(#[from] CnnError),
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
            EvalError::Gp(e) => e.class(),
            EvalError::Nn(e) => e.class(),
            EvalError::Cnn(e) => e.class(),
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
    /// GP options.
    pub gp: Checked<GpParams>,
    /// How the GP's inputs are presented.
    pub scaling: InputScaling,
    /// Network options; `None` skips the network.
    pub nn: Option<Checked<NnParams>>,
    /// CNN options, for data with images (the nail camera); `None` skips it.
    pub cnn: Option<Checked<CnnParams>>,
    /// Seed of the training subsets.
    pub seed: u64,
    /// Smallest tangential force of a peak whose direction is scored (N).
    pub min_peak_n: f64,
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
    /// Network scores, when it was trained.
    pub nn: Option<Scores>,
    /// CNN scores, when it was trained.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cnn: Option<Scores>,
}

/// Result of an evaluation: per fold, and overall on all test rows pooled.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Evaluation {
    /// Per-fold scores (one entry for a train/test evaluation).
    pub folds: Vec<FoldScores>,
    /// GP scores over all test rows.
    pub gp: Scores,
    /// Network scores over all test rows.
    pub nn: Option<Scores>,
    /// CNN scores over all test rows (data with images).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cnn: Option<Scores>,
}

/// What an evaluation is doing, for progress displays.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Progress {
    /// A fold starts (1-based).
    Fold(usize, usize),
    /// The GP fit of an axis progresses.
    Gp(Axis, FitProgress),
    /// The network is training.
    Nn,
    /// The CNN is training.
    Cnn,
}

pub(crate) fn scores(
    axes: &AxisSet,
    y: ArrayView2<f64>,
    yhat: ArrayView2<f64>,
    fit_s: f64,
    n_train: usize,
) -> Scores {
    let rmse = rmse_columns(y, yhat);
    let r2 = r2_columns(y, yhat);
    Scores {
        rmse: axes
            .axes()
            .iter()
            .copied()
            .zip(rmse.iter().copied())
            .collect(),
        r2: axes
            .axes()
            .iter()
            .copied()
            .zip(r2.iter().copied())
            .collect(),
        fit_s,
        n_train,
        direction_deg: None,
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

/// Predictions of both models on one test set, and their training times.
struct FoldPredictions {
    gp: Array2<f64>,
    gp_fit_s: f64,
    nn: Option<(Array2<f64>, f64)>,
    cnn: Option<(Array2<f64>, f64)>,
    n_train: usize,
}

fn fit_and_predict(
    train: &Dataset,
    test: &Dataset,
    tare: &TareSpec,
    opts: &EvalOptions,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<FoldPredictions, EvalError> {
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let subset = train.random_rows(opts.max_train, &mut rng);
    // A zero-mean GP is fitted on the networks' subset. A prior mean is
    // fitted on every training row, as `train` fits it; the exact GP then
    // takes its own `max_train` of them.
    let gp_rows = match opts.gp.mean {
        MeanKind::Zero => &subset,
        MeanKind::Linear | MeanKind::Cubic => train,
    };
    let t0 = Instant::now();
    let gp = WrenchGp::train_scaled(
        gp_rows,
        tare.clone(),
        opts.scaling,
        &opts.gp,
        &mut |a, p| progress(Progress::Gp(a, p)),
    )?;
    let gp_fit_s = t0.elapsed().as_secs_f64();
    let (gp_pred, _) = gp.predict(test.x.view(), false)?;
    let nn = match &opts.nn {
        Some(params) => {
            progress(Progress::Nn);
            let t0 = Instant::now();
            let net = Mlp::fit(params, subset.x.view(), subset.y.view())?;
            let fit_s = t0.elapsed().as_secs_f64();
            Some((net.predict(test.x.view()), fit_s))
        }
        None => None,
    };
    let cnn = match (&opts.cnn, &subset.images, &test.images) {
        (Some(params), Some(images), Some(test_images)) => {
            progress(Progress::Cnn);
            let t0 = Instant::now();
            let (net, _) = Cnn::fit(images.view(), subset.y.view(), params)?;
            let fit_s = t0.elapsed().as_secs_f64();
            Some((net.predict(test_images.view())?, fit_s))
        }
        _ => None,
    };
    Ok(FoldPredictions {
        gp: gp_pred,
        gp_fit_s,
        nn,
        cnn,
        n_train: subset.len(),
    })
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
    let mut results = Vec::new();
    let (mut pooled, mut gps, mut nns, mut cnns) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut gp_time, mut nn_time, mut cnn_time, mut n_train) = (0.0, 0.0, 0.0, 0);
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
        let pred = fit_and_predict(&train, &test, tare, opts, progress)?;
        gp_time += pred.gp_fit_s;
        n_train = pred.n_train;
        let mut from = 0;
        for t in &tests {
            let rows = from..from + t.len();
            from += t.len();
            let score = |p: &Array2<f64>, fit_s| {
                let p = p.slice(ndarray::s![rows.clone(), ..]);
                let s = scores(&t.axes, t.y.view(), p, fit_s, pred.n_train);
                with_direction(s, t, p, opts.min_peak_n)
            };
            results.push(FoldScores {
                fold: results.len() + 1,
                n_test: t.len(),
                gp: score(&pred.gp, pred.gp_fit_s),
                nn: pred.nn.as_ref().map(|(p, fit_s)| score(p, *fit_s)),
                cnn: pred.cnn.as_ref().map(|(p, fit_s)| score(p, *fit_s)),
            });
        }
        if let Some((p, t)) = &pred.nn {
            nn_time += t;
            nns.push(p.clone());
        }
        if let Some((p, t)) = &pred.cnn {
            cnn_time += t;
            cnns.push(p.clone());
        }
        pooled.push(test);
        gps.push(pred.gp);
    }
    let refs: Vec<&Dataset> = pooled.iter().collect();
    let all = Dataset::concat(&refs).ok_or(EvalError::Folds(0))?;
    let stack = |m: &[Array2<f64>]| {
        let views: Vec<_> = m.iter().map(|a| a.view()).collect();
        ndarray::concatenate(ndarray::Axis(0), &views)
            .map_err(|e| EvalError::Mismatch(e.to_string()))
    };
    let nf = n_splits as f64;
    let score = |pred: &Array2<f64>, fit_s| {
        let s = scores(&all.axes, all.y.view(), pred.view(), fit_s, n_train);
        with_direction(s, &all, pred.view(), opts.min_peak_n)
    };
    Ok(Evaluation {
        folds: results,
        gp: score(&stack(&gps)?, gp_time / nf),
        nn: match opts.nn {
            Some(_) => Some(score(&stack(&nns)?, nn_time / nf)),
            None => None,
        },
        cnn: match cnns.len() {
            0 => None,
            _ => Some(score(&stack(&cnns)?, cnn_time / nf)),
        },
    })
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
pub fn training_fit(model: &WrenchGp, data: &Dataset) -> Result<Scores, EvalError> {
    let step = data.len().div_ceil(TRAINING_FIT_ROWS).max(1);
    let rows: Vec<usize> = (0..data.len()).step_by(step).collect();
    let s = score_model(model, &data.select(&rows), f64::INFINITY)?;
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
/// Directions are scored at peaks of at least `min_peak_n`.
pub fn score_model(model: &WrenchGp, test: &Dataset, min_peak_n: f64) -> Result<Scores, EvalError> {
    if test.features != model.features() || &test.axes != model.axes() {
        return Err(EvalError::Mismatch(format!(
            "model has features {:?} / axes {}, test data {:?} / {}",
            model.features(),
            model.axes(),
            test.features,
            test.axes
        )));
    }
    let (pred, _) = model.predict(test.x.view(), false)?;
    let s = scores(&test.axes, test.y.view(), pred.view(), 0.0, model.n_train());
    Ok(with_direction(s, test, pred.view(), min_peak_n))
}
