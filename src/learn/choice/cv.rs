//! One candidate's cross-validation: its folds' fits (started warm from
//! the candidates before), held-out scores, standard deviation scale and
//! estimate latency.

use std::collections::BTreeMap;
use std::time::Instant;

use ndarray::Array2;
use rayon::prelude::*;

use super::cost;
use super::Shape;
use super::{AloneScore, Choice, Cost, CvRow};
use crate::learn::chooser::score;
use crate::learn::data::{layout_of, Dataset};
use crate::learn::models::families;
use crate::learn::models::family::Fit;
use crate::learn::models::gp::fit::FitProgress;
use crate::learn::models::gp::{GpParams, MeanKind, SeHyper};
use crate::learn::models::metrics::rmse_columns;
use crate::learn::models::nn::Mlp;
use crate::learn::models::wrench_gp::{std_scale_over_folds, Estimate};
use crate::learn::models::wrench_gp::{ModelError, TareSpec, WarmStart, WrenchGp};
use crate::learn::models::wrench_model::WrenchModel;
use crate::learn::tradeoff::{timed_rows, timed_us};
use crate::params::Checked;
use crate::sensor::SensorSpec;

/// Hyperparameters fitted so far, per axis, by the model's form (channels,
/// input scaling, prior mean: what the hyperparameters depend on) and fold;
/// and the networks of network means, by channels, input scaling and fold
/// (what a network depends on).
///
/// A candidate's fold starts its search warm from the same form's fit on
/// the same fold (another GP size) or on the fold before; only a form's
/// first fold runs the full multistart. A network mean's fold takes the
/// network fitted on the same rows, if any (another GP). Measured in
/// docs/results.md ("`train --select` within its budget").
#[derive(Default)]
pub(super) struct WarmStarts {
    hypers: BTreeMap<(String, usize), Vec<SeHyper>>,
    networks: BTreeMap<(String, usize), Mlp>,
}

impl WarmStarts {
    fn key(choice: &Choice) -> String {
        format!("{} {}", Self::rows_key(choice), choice.mean.name())
    }

    /// What a network depends on: the rows and their scaling.
    fn rows_key(choice: &Choice) -> String {
        format!("{:?} {}", choice.channels, choice.input.name())
    }

    /// The warm start of `choice`'s fold `fold`.
    fn get(&self, choice: &Choice, fold: usize) -> WarmStart<'_> {
        let key = Self::key(choice);
        let same = self.hypers.get(&(key.clone(), fold));
        let before = (0..fold)
            .rev()
            .find_map(|f| self.hypers.get(&(key.clone(), f)));
        WarmStart {
            hypers: same.or(before).map(Vec::as_slice),
            network: self.networks.get(&(Self::rows_key(choice), fold)),
        }
    }

    /// Fits the networks of `choice`'s folds not kept yet, all at once (a
    /// network trains on one thread); nothing for another mean.
    fn fit_networks(
        &mut self,
        choice: &Choice,
        sub: &Dataset,
        splits: &[(Vec<usize>, Vec<usize>)],
        params: &Checked<GpParams>,
    ) -> Result<(), String> {
        if choice.mean != MeanKind::Network {
            return Ok(());
        }
        let key = Self::rows_key(choice);
        let missing: Vec<usize> = (0..splits.len())
            .filter(|&f| !self.networks.contains_key(&(key.clone(), f)))
            .collect();
        let fitted: Vec<Option<Mlp>> = (missing.par_iter())
            .map(|&f| WrenchGp::fit_network(&sub.select(&splits[f].0), choice.input, params))
            .collect::<Result<_, _>>()
            .map_err(|e| e.to_string())?;
        for (f, net) in missing.into_iter().zip(fitted) {
            if let Some(net) = net {
                self.networks.insert((key.clone(), f), net);
            }
        }
        Ok(())
    }

    /// Keeps what `model` of `choice`'s fold `fold` can start others from.
    fn keep(&mut self, choice: &Choice, fold: usize, model: &WrenchGp) {
        self.hypers
            .insert((Self::key(choice), fold), model.hypers());
        if let Some(net) = model.network() {
            self.networks
                .insert((Self::rows_key(choice), fold), net.clone());
        }
    }
}

/// Rows a sparse candidate's inducing points are chosen from, and its VFE
/// bound optimised on, while it is scored.
pub(super) const SCORING_SPARSE_ROWS: usize = 2000;
/// L-BFGS iterations of a sparse candidate's VFE bound while it is scored
/// (10 before 2026-11-29: 5 keep the whole table of `scripts/select_bench.sh`
/// within 60 s, the scores within their noise, docs/results.md "`train
/// --select` across the families").
pub(super) const SCORING_SPARSE_ITERS: u64 = 5;

/// The options a candidate is scored with: `params` with the sparse GP's
/// inducing points and VFE search on at most [`SCORING_SPARSE_ROWS`] rows
/// (no fewer than its inducing points) for at most
/// [`SCORING_SPARSE_ITERS`] iterations (q(u) still conditioned
/// on every training row). The chosen options are then trained in full.
/// Why: on every row the two sparse candidates took 84 % of the whole
/// table's time on 20000 rows; the
/// scores' change is measured in docs/results.md ("`train --select` within
/// its budget").
pub(super) fn scoring(params: GpParams) -> GpParams {
    GpParams {
        sparse_candidates: (params.sparse_candidates.min(SCORING_SPARSE_ROWS))
            .max(params.inducing.unwrap_or(0)),
        sparse_fit_subset: params.sparse_fit_subset.min(SCORING_SPARSE_ROWS),
        sparse_iters: params.sparse_iters.min(SCORING_SPARSE_ITERS),
        ..params
    }
}

/// What every candidate's cross-validation shares.
pub(super) struct Cv<'a> {
    pub(super) data: &'a Dataset,
    pub(super) tare: &'a TareSpec,
    pub(super) splits: &'a [(Vec<usize>, Vec<usize>)],
    pub(super) base: &'a GpParams,
    /// The targets' standard deviations, per axis.
    pub(super) sd: &'a [f64],
}

impl Cv<'_> {
    /// `choice`'s cost on these folds, predicted from its kind and size;
    /// the reason when its family is not registered.
    pub(super) fn cost(&self, choice: &Choice) -> Result<Cost, String> {
        let train: usize = self.splits.iter().map(|(train, _)| train.len()).sum();
        let shape = Shape {
            train_rows: train / self.splits.len().max(1),
            folds: self.splits.len(),
            features: choice.features(layout_of(&self.data.features)).len(),
            axes: self.sd.len(),
        };
        cost::predict(choice, &shape).map_err(|e| e.to_string())
    }

    /// One candidate's folds; Err when the data cannot serve it (the reason).
    pub(super) fn run(
        &self,
        choice: &Choice,
        warm: &mut WarmStarts,
        progress: &mut (dyn FnMut(&Choice, FitProgress) + Send),
    ) -> Result<CvRow, String> {
        let (sub, sub_tare) = choice.cut(self.data, self.tare)?;
        let params = scoring(choice.gp_params(self.base))
            .validate()
            .map_err(|e| e.to_string())?;
        let (t0, cpu0) = (Instant::now(), cpu_seconds());
        warm.fit_networks(choice, &sub, self.splits, &params)?;
        let mut pooled = Pooled::new(self.data);
        let mut alone = (choice.mean == MeanKind::Network).then(|| Pooled::new(self.data));
        let mut latency = None;
        let mut z: Vec<Vec<Vec<f64>>> = vec![Vec::new(); self.sd.len()];
        for (fold, (train, test)) in self.splits.iter().enumerate() {
            let held_out = sub.select(test);
            let failed = |e: ModelError| e.to_string();
            let rows = Fold {
                index: fold,
                train: &sub.select(train),
                tare: &sub_tare,
                held_out: &held_out,
            };
            let (model, network_alone) = self.fit_fold(choice, &rows, &params, warm, progress)?;
            let p = model
                .predict_observed(held_out.x.view(), false)
                .map_err(failed)?;
            pooled.add(self, test, &held_out, p.mean);
            if let (Some(alone), Some(p)) = (&mut alone, network_alone) {
                alone.add(self, test, &held_out, p);
            }
            let errors =
                (model.standardised_errors(&held_out, CALIBRATION_ROWS)).map_err(failed)?;
            z.iter_mut().zip(errors).for_each(|(z, e)| z.push(e));
            if fold + 1 == self.splits.len() {
                latency = Some(latency_us(model.as_ref(), &held_out));
            }
        }
        let axes = self.data.axes.axes();
        let AloneScore {
            rmse,
            score,
            fold_scores,
        } = pooled.scores(self);
        Ok(CvRow {
            choice: choice.clone(),
            rmse,
            score,
            seconds: Some(t0.elapsed().as_secs_f64()),
            cpu_s: cpu_seconds().zip(cpu0).map(|(now, then)| now - then),
            predicted: self.cost(choice).ok(),
            fold_scores,
            latency_us: latency.map(|l| l.0),
            latency_p99_us: latency.map(|l| l.1),
            std_scale: (axes.iter().zip(&z))
                .filter_map(|(&a, z)| std_scale_over_folds(z).map(|s| (a, s)))
                .collect(),
            network_alone: alone.map(|a| a.scores(self)),
        })
    }

    /// `choice`'s model of one fold, and for a network mean its network's
    /// estimates alone of the held-out rows.
    fn fit_fold(
        &self,
        choice: &Choice,
        rows: &Fold,
        params: &Checked<GpParams>,
        warm: &mut WarmStarts,
        progress: &mut (dyn FnMut(&Choice, FitProgress) + Send),
    ) -> Result<FoldModel, String> {
        let failed = |e: ModelError| e.to_string();
        let model = families::of(choice).map_err(failed)?.fit(Fit {
            data: rows.train,
            tare: rows.tare.clone(),
            sensor: SensorSpec::default(),
            input: choice.input,
            params,
            warm: warm.get(choice, rows.index),
            progress: &mut |_, p| progress(choice, p),
        });
        let model = model.map_err(failed)?;
        let Some(gp) = model.as_any().downcast_ref::<WrenchGp>() else {
            return Ok((model, None));
        };
        warm.keep(choice, rows.index, gp);
        let alone = (gp.network_estimate(rows.held_out.x.view())).map_err(failed)?;
        Ok((model, alone))
    }
}

/// A fold's model, and a network mean's network's estimates alone.
type FoldModel = (Box<dyn WrenchModel>, Option<Array2<f64>>);

/// The rows of one fold, cut to a candidate's features.
struct Fold<'a> {
    index: usize,
    train: &'a Dataset,
    tare: &'a TareSpec,
    held_out: &'a Dataset,
}

/// One model's held-out estimates over the folds.
struct Pooled {
    pred: Array2<f64>,
    fold_scores: Vec<f64>,
}

impl Pooled {
    fn new(data: &Dataset) -> Self {
        Pooled {
            pred: Array2::zeros(data.y.raw_dim()),
            fold_scores: Vec::new(),
        }
    }

    /// Takes a fold's estimates `p` of its held-out rows `test`.
    fn add(&mut self, cv: &Cv, test: &[usize], held_out: &Dataset, p: Array2<f64>) {
        for (row, &i) in p.rows().into_iter().zip(test) {
            self.pred.row_mut(i).assign(&row);
        }
        self.fold_scores
            .push(score(held_out.y.view(), p.view(), cv.sd));
    }

    /// The RMSE per axis and the score over every fold, and each fold's.
    fn scores(self, cv: &Cv) -> AloneScore {
        let rmse = rmse_columns(cv.data.y.view(), self.pred.view());
        AloneScore {
            rmse: cv.data.axes.axes().iter().copied().zip(rmse).collect(),
            score: score(cv.data.y.view(), self.pred.view(), cv.sd),
            fold_scores: self.fold_scores,
        }
    }
}

/// Held-out rows of a fold whose errors are compared with the standard
/// deviation (evenly spread): an exact GP's variance costs O(m^2) a row, m
/// up to [`VARIANCE_ROWS`](crate::learn::models::gp::exact::VARIANCE_ROWS).
const CALIBRATION_ROWS: usize = 50;

/// Estimates timed per candidate (at most: as many as fit in
/// [`LATENCY_S`], at least 3), one at a time as the estimator makes them.
const LATENCY_ESTIMATES: usize = 300;
/// About the time spent timing a candidate's estimates (s).
const LATENCY_S: f64 = 0.05;

/// The median and the 99th percentile time (µs) of `model`'s estimate
/// with its standard deviation, as the estimator makes one, on rows of
/// `data`: one estimate first (it also warms the caches), then as many as
/// fit in [`LATENCY_S`]. Shown, never chosen by: a clock reading.
fn latency_us(model: &dyn WrenchModel, data: &Dataset) -> (f64, f64) {
    let mut ws = model.workspace();
    let mut out = vec![Estimate::default(); model.axes().len()];
    let mut estimate = |x: &[f64]| {
        // The rows have the model's features, so this cannot fail.
        let _ = model.estimate(x, &mut ws, true, &mut out);
    };
    let one = timed_us(&timed_rows(data, 1), &mut estimate)[0];
    let n = (LATENCY_S * 1e6 / one.max(1e-3)).clamp(3.0, LATENCY_ESTIMATES as f64) as usize;
    let rows = timed_rows(data, n.min(data.len()));
    let rows: Vec<Vec<f64>> = rows.iter().cycle().take(n).cloned().collect();
    let mut times = timed_us(&rows, estimate);
    times.sort_by(f64::total_cmp);
    let at = |q: f64| times[((times.len() - 1) as f64 * q).round() as usize];
    (at(0.5), at(0.99))
}

/// The process's CPU time so far (user + system, every thread, s), from
/// Linux's `/proc/self/stat`; None elsewhere. Load-independent, unlike the
/// wall time, on shared cores.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    parse_cpu_seconds(&stat, 100.0)
}

/// utime + stime (fields 14 and 15, in clock ticks of `hz`: USER_HZ, 100
/// on Linux) of a `/proc/<pid>/stat` line, in seconds.
pub(super) fn parse_cpu_seconds(stat: &str, hz: f64) -> Option<f64> {
    // The command name (field 2) may hold spaces: count after its ')'.
    let fields: Vec<&str> = stat.rsplit_once(')')?.1.split_whitespace().collect();
    let ticks = |i: usize| fields.get(i)?.parse::<f64>().ok();
    Some((ticks(11)? + ticks(12)?) / hz)
}
