//! Training and scoring the GP and the baseline network on the same data:
//! trial-wise k-fold cross-validation (Huhnstock 2014, Tables 4.1-4.3) or one
//! train file against one test file.

use std::collections::BTreeMap;
use std::time::Instant;

use ndarray::{Array2, ArrayView2};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::Serialize;

use super::dataset::{trialwise_folds, Dataset};
use super::gp::fit::FitProgress;
use super::gp::ValidGpParams;
use super::metrics::{r2_columns, rmse_columns};
use super::model::{ModelError, TareSpec, WrenchGp};
use super::nn::{Mlp, NnError, ValidNnParams};
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
    /// Train and test files have different features or axes.
    #[error("train and test data differ: {0}")]
    Mismatch(String),
    /// Fewer than two folds.
    #[error("cross-validation needs at least 2 folds, got {0}")]
    Folds(usize),
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

/// Options shared by both evaluation modes.
#[derive(Debug, Clone)]
pub struct EvalOptions {
    /// Training rows used per fit (a seeded random subset when the training data is larger).
    pub max_train: usize,
    /// GP options.
    pub gp: ValidGpParams,
    /// Network options; `None` skips the network.
    pub nn: Option<ValidNnParams>,
    /// Seed of the training subsets.
    pub seed: u64,
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
    }
}

/// Predictions of both models on one test set, and their training times.
struct FoldPredictions {
    gp: Array2<f64>,
    gp_fit_s: f64,
    nn: Option<(Array2<f64>, f64)>,
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
    let train = train.random_rows(opts.max_train, &mut rng);
    let t0 = Instant::now();
    let gp = WrenchGp::train(&train, tare.clone(), &opts.gp, &mut |a, p| {
        progress(Progress::Gp(a, p))
    })?;
    let gp_fit_s = t0.elapsed().as_secs_f64();
    let (gp_pred, _) = gp.predict(test.x.view(), false)?;
    let nn = match &opts.nn {
        Some(params) => {
            progress(Progress::Nn);
            let t0 = Instant::now();
            let net = Mlp::fit(params, train.x.view(), train.y.view())?;
            let fit_s = t0.elapsed().as_secs_f64();
            Some((net.predict(test.x.view()), fit_s))
        }
        None => None,
    };
    Ok(FoldPredictions {
        gp: gp_pred,
        gp_fit_s,
        nn,
        n_train: train.len(),
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
    let k = data.axes.len();
    let n = data.len();
    let mut pooled_gp = Array2::zeros((n, k));
    let mut pooled_nn = Array2::zeros((n, k));
    let mut results = Vec::with_capacity(folds);
    let (mut gp_time, mut nn_time, mut n_train) = (0.0, 0.0, 0);
    for (f, (train_rows, test_rows)) in trialwise_folds(data, folds).into_iter().enumerate() {
        progress(Progress::Fold(f + 1, folds));
        let (train, test) = (data.select(&train_rows), data.select(&test_rows));
        let pred = fit_and_predict(&train, &test, tare, opts, progress)?;
        for (r, &row) in test_rows.iter().enumerate() {
            pooled_gp.row_mut(row).assign(&pred.gp.row(r));
            if let Some((nn, _)) = &pred.nn {
                pooled_nn.row_mut(row).assign(&nn.row(r));
            }
        }
        gp_time += pred.gp_fit_s;
        n_train = pred.n_train;
        let nn = pred.nn.as_ref().map(|(p, t)| {
            nn_time += t;
            scores(&data.axes, test.y.view(), p.view(), *t, pred.n_train)
        });
        results.push(FoldScores {
            fold: f + 1,
            n_test: test.len(),
            gp: scores(
                &data.axes,
                test.y.view(),
                pred.gp.view(),
                pred.gp_fit_s,
                pred.n_train,
            ),
            nn,
        });
    }
    let nf = folds as f64;
    let y = data.y.view();
    Ok(Evaluation {
        folds: results,
        gp: scores(&data.axes, y, pooled_gp.view(), gp_time / nf, n_train),
        nn: opts
            .nn
            .as_ref()
            .map(|_| scores(&data.axes, y, pooled_nn.view(), nn_time / nf, n_train)),
    })
}

/// Scores a trained model on `test` (tared, with the model's features and axes).
pub fn score_model(model: &WrenchGp, test: &Dataset) -> Result<Scores, EvalError> {
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
    Ok(scores(
        &test.axes,
        test.y.view(),
        pred.view(),
        0.0,
        model.n_train(),
    ))
}

/// Trains on `train` and scores on `test` (both already tared).
pub fn train_test(
    train: &Dataset,
    test: &Dataset,
    tare: &TareSpec,
    opts: &EvalOptions,
    progress: &mut (dyn FnMut(Progress) + Send),
) -> Result<Evaluation, EvalError> {
    if train.features != test.features || train.axes != test.axes {
        return Err(EvalError::Mismatch(format!(
            "features {:?} / axes {} vs features {:?} / axes {}",
            train.features, train.axes, test.features, test.axes
        )));
    }
    let pred = fit_and_predict(train, test, tare, opts, progress)?;
    let gp = scores(
        &test.axes,
        test.y.view(),
        pred.gp.view(),
        pred.gp_fit_s,
        pred.n_train,
    );
    let nn = pred
        .nn
        .as_ref()
        .map(|(p, t)| scores(&test.axes, test.y.view(), p.view(), *t, pred.n_train));
    Ok(Evaluation {
        folds: vec![FoldScores {
            fold: 1,
            n_test: test.len(),
            gp: gp.clone(),
            nn: nn.clone(),
        }],
        gp,
        nn,
    })
}
