//! Speed against accuracy: the exact GP on subsets of the training rows, the
//! sparse GP on all of them, and the baseline network, each trained on the
//! same rows and scored on the same held-out trials, with the fit time and the
//! single-sample prediction latency of each (`tactile_force tradeoff`).

use std::collections::BTreeMap;
use std::time::Instant;

use serde::Serialize;

use super::data::Dataset;
use super::evaluate::{scores, EvalError};
use super::models::family_learner::FamilyLearner;
use super::models::gp::{GpParams, Subset};
use super::models::nn::{NnLearner, NnParams};
use super::models::scale::InputScaling;
use super::models::wrench_gp::{GpFamily, ModelError, TareSpec};
use super::models::Learner;
use crate::params::Checked;
use crate::sensor::SensorSpec;
use crate::wrench::Axis;

/// The kind of model of a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ModelKind {
    /// Exact GP on a subset of the training rows.
    Exact,
    /// Sparse (variational) GP on all the training rows.
    Sparse,
    /// The baseline network on all the training rows.
    Nn,
}

/// One measured setting.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    /// Which model.
    pub model: ModelKind,
    /// Exact GP: how its training rows were chosen.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub subset: Option<Subset>,
    /// Training rows the model saw (exact GP: its subset).
    pub n_train: usize,
    /// Sparse GP: inducing points.
    pub m: Option<usize>,
    /// Training time (s), hyperparameters included.
    pub fit_s: f64,
    /// Single-sample latency of the mean of every axis (µs).
    pub latency_mean_us: f64,
    /// Single-sample latency of mean and standard deviation (µs); the
    /// network has no standard deviation.
    pub latency_mean_std_us: Option<f64>,
    /// Held-out RMSE per axis (N or Nm).
    pub rmse: BTreeMap<Axis, f64>,
    /// Held-out R² per axis.
    pub r2: BTreeMap<Axis, f64>,
}

impl Row {
    /// Mean of the per-axis RMSEs.
    pub fn mean_rmse(&self) -> f64 {
        self.rmse.values().sum::<f64>() / self.rmse.len().max(1) as f64
    }

    /// The latency that decides a control period: mean and std where the
    /// model has a std, the mean otherwise.
    pub fn latency_us(&self) -> f64 {
        self.latency_mean_std_us.unwrap_or(self.latency_mean_us)
    }

    /// A short name: `exact n=2000 (random)`, `sparse m=200`, `nn`.
    pub fn label(&self) -> String {
        match (self.model, self.subset) {
            (ModelKind::Exact, Some(s)) => format!("exact n={} ({})", self.n_train, s.name()),
            (ModelKind::Exact, None) => format!("exact n={}", self.n_train),
            (ModelKind::Sparse, _) => format!("sparse m={}", self.m.unwrap_or(0)),
            (ModelKind::Nn, _) => "nn".into(),
        }
    }
}

/// What to measure.
#[derive(Debug, Clone)]
pub struct TradeoffOptions {
    /// Training-set sizes of the exact GP (sizes above the training rows are skipped).
    pub exact_n: Vec<usize>,
    /// How the exact GP's rows are chosen; every size is run with each rule.
    pub subsets: Vec<Subset>,
    /// Inducing points of the sparse GP.
    pub sparse_m: Vec<usize>,
    /// GP options shared by every GP (kernel, starts, seed).
    pub gp: GpParams,
    /// The network's options; `None` skips it.
    pub nn: Option<Checked<NnParams>>,
    /// Held-out rows timed per latency pass (evenly spread).
    pub latency_rows: usize,
    /// Latency passes; the median pass is reported.
    pub latency_passes: usize,
}

impl Default for TradeoffOptions {
    fn default() -> Self {
        TradeoffOptions {
            exact_n: vec![250, 500, 1000, 2000, 4000],
            subsets: vec![Subset::Random, Subset::FarthestPoint],
            sparse_m: vec![25, 50, 100, 200, 400],
            gp: GpParams::default(),
            nn: None,
            latency_rows: 200,
            latency_passes: 5,
        }
    }
}

/// One setting to measure: its row's description and the model that fits.
struct Setting {
    label: String,
    model: ModelKind,
    subset: Option<Subset>,
    n_train: usize,
    m: Option<usize>,
    learner: Box<dyn Learner>,
}

/// The settings of `opts` for `rows` training rows: the exact GP on each
/// size not above them with each subset rule, the sparse GP on each size,
/// the network.
fn settings(
    rows: usize,
    tare: &TareSpec,
    opts: &TradeoffOptions,
) -> Result<Vec<Setting>, EvalError> {
    let gp = |params: GpParams| -> Result<Box<dyn Learner>, EvalError> {
        Ok(Box::new(FamilyLearner {
            family: &GpFamily,
            params: params.validate().map_err(ModelError::from)?,
            input: InputScaling::Standard,
            tare: tare.clone(),
            // Recorded in the model, which is not saved.
            sensor: SensorSpec::default(),
        }))
    };
    let mut settings = Vec::new();
    for &n in opts.exact_n.iter().filter(|&&n| n <= rows) {
        for &subset in &opts.subsets {
            let params = GpParams {
                max_train: n,
                subset,
                inducing: None,
                ..opts.gp.clone()
            };
            settings.push(Setting {
                label: format!("exact GP, n = {n}, {} rows", subset.name()),
                model: ModelKind::Exact,
                subset: Some(subset),
                n_train: n,
                m: None,
                learner: gp(params)?,
            });
        }
    }
    for &m in &opts.sparse_m {
        let params = GpParams {
            inducing: Some(m),
            ..opts.gp.clone()
        };
        settings.push(Setting {
            label: format!("sparse GP, m = {m}"),
            model: ModelKind::Sparse,
            subset: None,
            n_train: rows,
            m: Some(m),
            learner: gp(params)?,
        });
    }
    if let Some(nn) = &opts.nn {
        settings.push(Setting {
            label: "network".into(),
            model: ModelKind::Nn,
            subset: None,
            n_train: rows,
            m: None,
            learner: Box::new(NnLearner(nn.clone())),
        });
    }
    Ok(settings)
}

/// Trains every setting of `opts` on `train` and scores it on `test` (both
/// tared, same features and axes); `progress` is told each setting as it starts.
pub fn tradeoff(
    train: &Dataset,
    test: &Dataset,
    tare: &TareSpec,
    opts: &TradeoffOptions,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<Row>, EvalError> {
    if train.features != test.features || train.axes != test.axes {
        return Err(EvalError::Mismatch(format!(
            "features {:?} / axes {} vs features {:?} / axes {}",
            train.features, train.axes, test.features, test.axes
        )));
    }
    let timed = timed_rows(test, opts.latency_rows);
    let mut rows = Vec::new();
    for s in settings(train.len(), tare, opts)? {
        progress(&s.label);
        let t0 = Instant::now();
        let mut fitted = s.learner.fit(train, &mut |_, _| {})?;
        let fit_s = t0.elapsed().as_secs_f64();
        let pred = fitted.predict(test, false)?.mean;
        let scored = scores(
            &test.axes,
            test.y.view(),
            (pred.view(), None),
            fit_s,
            train.len(),
        );
        let has_std = fitted.has_std();
        let mut latency = |with_std| {
            median_latency_us(&timed, opts.latency_passes, |x| {
                // The rows have the model's features, so this cannot fail.
                let _ = fitted.predict_row(x, with_std);
            })
        };
        let latency_mean_us = latency(false);
        let latency_mean_std_us = has_std.then(|| latency(true));
        rows.push(Row {
            model: s.model,
            subset: s.subset,
            n_train: s.n_train,
            m: s.m,
            fit_s,
            latency_mean_us,
            latency_mean_std_us,
            rmse: scored.rmse,
            r2: scored.r2,
        });
    }
    Ok(rows)
}

/// At most `n` rows of `test`, evenly spread, as contiguous feature vectors.
pub(crate) fn timed_rows(test: &Dataset, n: usize) -> Vec<Vec<f64>> {
    let step = (test.len() / n.max(1)).max(1);
    test.x
        .rows()
        .into_iter()
        .step_by(step)
        .take(n)
        .map(|r| r.to_vec())
        .collect()
}

/// Median over `passes` of the mean time of `predict` per row (µs).
pub(crate) fn median_latency_us(
    rows: &[Vec<f64>],
    passes: usize,
    mut predict: impl FnMut(&[f64]),
) -> f64 {
    let mut per_row: Vec<f64> = (0..passes.max(1))
        .map(|_| {
            let t0 = Instant::now();
            for r in rows {
                predict(std::hint::black_box(r));
            }
            t0.elapsed().as_secs_f64() * 1e6 / rows.len().max(1) as f64
        })
        .collect();
    per_row.sort_by(f64::total_cmp);
    per_row[per_row.len() / 2]
}

/// The time of `predict` on each of `rows`, one call each (µs).
pub(crate) fn timed_us(rows: &[Vec<f64>], mut predict: impl FnMut(&[f64])) -> Vec<f64> {
    rows.iter()
        .map(|r| {
            let t0 = Instant::now();
            predict(std::hint::black_box(r));
            t0.elapsed().as_secs_f64() * 1e6
        })
        .collect()
}

/// For each row, true when no other row is at least as good on both `cost`
/// and the mean RMSE and strictly better on one (the Pareto front).
pub fn pareto_front(rows: &[Row], cost: impl Fn(&Row) -> f64) -> Vec<bool> {
    rows.iter()
        .map(|r| {
            let (c, e) = (cost(r), r.mean_rmse());
            !rows.iter().any(|o| {
                let (oc, oe) = (cost(o), o.mean_rmse());
                oc <= c && oe <= e && (oc < c || oe < e)
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(latency: f64, rmse: f64) -> Row {
        Row {
            model: ModelKind::Nn,
            subset: None,
            n_train: 1,
            m: None,
            fit_s: 0.0,
            latency_mean_us: latency,
            latency_mean_std_us: None,
            rmse: [(Axis::Fz, rmse)].into(),
            r2: [(Axis::Fz, 0.0)].into(),
        }
    }

    #[test]
    fn the_pareto_front_keeps_only_undominated_settings() {
        let rows = [row(1.0, 0.5), row(2.0, 0.3), row(3.0, 0.4), row(2.0, 0.3)];
        assert_eq!(
            pareto_front(&rows, Row::latency_us),
            [true, true, false, true]
        );
    }
}
