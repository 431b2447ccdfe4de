//! The training options chosen on the user's data (`train --select`): the
//! channels, how they reach the GP, exact or sparse and its size, and the
//! prior mean, by trial-wise cross-validation within a time budget.
//!
//! The search starts from the defaults and changes one option at a time,
//! keeping what scores better: the channels, then the input scaling, the
//! prior mean, and last the GP's kind and size (the costliest fits). Each
//! candidate is trained as `train` trains it (every training row of a fold;
//! the exact GP on its own subset) and scored on the held-out trials. The
//! score is the mean over axes of the RMSE over the standard deviation of
//! the axis's targets, so that forces and torques weigh alike. When the
//! budget runs out the search stops, at the latest after the fold that
//! passed it, and says what it did not try. The defaults are scored
//! whatever the budget: they are what every other candidate must beat.

use std::collections::BTreeMap;
use std::time::Instant;

use ndarray::{Array2, Axis as NdAxis};

use super::data::{channel_columns, layout_of, trialwise_folds, Channel, Dataset};
use super::models::gp::fit::FitProgress;
use super::models::gp::{GpParams, MeanKind};
use super::models::metrics::rmse_columns;
use super::models::scale::InputScaling;
use super::models::wrench_gp::{ModelError, TareSpec, WrenchGp};
use crate::biotac::ElectrodeLayout;

use crate::exit::{Classify, ExitClass};

pub use super::models::wrench_gp::{Choice, CvRow, GpChoice, Selection};

impl Choice {
    /// The defaults of `train`: electrodes and PDC, standardised, the
    /// exact GP on 2000 rows, zero mean.
    pub fn default_options() -> Self {
        Choice {
            channels: vec![Channel::Electrodes, Channel::Pdc],
            input: InputScaling::Standard,
            gp: GpChoice::Exact(2000),
            mean: MeanKind::Zero,
        }
    }

    /// The feature columns it takes from a sensor of `layout`.
    pub fn features(&self, layout: ElectrodeLayout) -> Vec<String> {
        channel_columns(&self.channels, layout)
    }

    /// `data` and `tare` cut to its features; the reason when the data lack one.
    pub fn cut(&self, data: &Dataset, tare: &TareSpec) -> Result<(Dataset, TareSpec), String> {
        columns(data, tare, &self.features(layout_of(&data.features)))
            .map_err(|column| format!("the data have no column {column:?}"))
    }

    /// `base` with this choice's GP and mean.
    pub fn gp_params(&self, base: &GpParams) -> GpParams {
        let (max_train, inducing) = match self.gp {
            GpChoice::Exact(n) => (n, None),
            GpChoice::Sparse(m) => (base.max_train, Some(m)),
        };
        GpParams {
            mean: self.mean,
            max_train,
            inducing,
            ..base.clone()
        }
    }
}

/// Errors of a selection.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SelectError {
    /// Fewer than two trials in a set: no trial-wise cross-validation.
    #[error(
        "--select cross-validates by trials: set {set} has {trials} trial(s), at least 2 needed"
    )]
    TooFewTrials {
        /// The set.
        set: u32,
        /// Its trials.
        trials: usize,
    },
    /// Even the defaults could not be scored (a channel missing, or a fit failed).
    #[error("--select: the defaults ({0}) cannot be scored on this data")]
    NoBaseline(String),
    /// Training failed.
    #[error(transparent)]
    Model(#[from] ModelError),
}

/// Too few trials are refused input; a search that scored nothing failed.
impl Classify for SelectError {
    fn class(&self) -> ExitClass {
        match self {
            SelectError::TooFewTrials { .. } => ExitClass::Refused,
            SelectError::NoBaseline(_) => ExitClass::Failure,
            SelectError::Model(e) => e.class(),
        }
    }
}

/// Why a candidate was not tried when the budget stopped the search.
const BUDGET_RAN_OUT: &str = "the time budget ran out";

/// The options tried after the defaults, one stage at a time (each from the
/// best so far): channels, input scaling, prior mean, GP.
fn stages(best: &Choice, rows: usize) -> Vec<Vec<Choice>> {
    use Channel::{Electrodes, Pdc, Tac, Tdc};
    let with = |f: &dyn Fn(&mut Choice)| {
        let mut c = best.clone();
        f(&mut c);
        c
    };
    let channels = [vec![Electrodes], vec![Electrodes, Pdc, Tdc, Tac], vec![Pdc]];
    let inputs = [InputScaling::Pattern, InputScaling::Raw];
    let means = [MeanKind::Linear, MeanKind::Cubic];
    // Smaller exact subsets and sparse sizes, then more rows when there are.
    let gps = [
        GpChoice::Sparse(200),
        GpChoice::Sparse(500),
        GpChoice::Exact(1000),
        GpChoice::Exact(4000),
    ];
    vec![
        channels
            .iter()
            .map(|ch| with(&|c| c.channels = ch.clone()))
            .collect(),
        inputs.iter().map(|&i| with(&|c| c.input = i)).collect(),
        means.iter().map(|&m| with(&|c| c.mean = m)).collect(),
        gps.iter()
            .filter(|g| match g {
                GpChoice::Exact(n) | GpChoice::Sparse(n) => *n < rows,
            })
            .map(|&g| with(&|c| c.gp = g))
            .collect(),
    ]
}

/// Chooses the training options on `data` (tared; its features the union
/// of every channel it has, tared as `tare` says) by trial-wise
/// cross-validation with `folds` folds (fewer when a set has fewer trials),
/// within `budget_s` seconds. `base` holds the other GP options (restarts,
/// seed). `progress` hears of each candidate as it starts.
pub fn select(
    data: &Dataset,
    tare: &TareSpec,
    folds: usize,
    budget_s: f64,
    base: &GpParams,
    progress: &mut (dyn FnMut(&Choice, FitProgress) + Send),
) -> Result<Selection, SelectError> {
    let mut per_set: BTreeMap<u32, usize> = BTreeMap::new();
    for ((set, _), _) in data.trials() {
        *per_set.entry(set).or_default() += 1;
    }
    if let Some((&set, &trials)) = per_set.iter().min_by_key(|(_, t)| **t) {
        if trials < 2 {
            return Err(SelectError::TooFewTrials { set, trials });
        }
    }
    let k = folds.min(per_set.values().copied().min().unwrap_or(folds));
    let splits = trialwise_folds(data, k);
    let sd: Vec<f64> = data
        .y
        .columns()
        .into_iter()
        .map(|c| c.std(0.0).max(f64::MIN_POSITIVE))
        .collect();
    let start = Instant::now();
    let over = || start.elapsed().as_secs_f64() > budget_s;
    let mut table: Vec<CvRow> = Vec::new();
    let mut untried = Vec::new();
    // A candidate's cross-validation; `budgeted`: stopped by the budget.
    let mut run = |choice: &Choice,
                   budgeted: bool,
                   table: &mut Vec<CvRow>,
                   untried: &mut Vec<(Choice, String)>| {
        if table.iter().any(|r| &r.choice == choice) || untried.iter().any(|(c, _)| c == choice) {
            return;
        }
        let stop = || budgeted && over();
        if stop() {
            untried.push((choice.clone(), BUDGET_RAN_OUT.into()));
            return;
        }
        match cross_validate(data, tare, choice, &splits, base, &sd, &stop, progress) {
            Ok(Some(row)) => table.push(row),
            Ok(None) => untried.push((choice.clone(), BUDGET_RAN_OUT.into())),
            Err(why) => untried.push((choice.clone(), why)),
        }
    };
    let defaults = Choice::default_options();
    run(&defaults, false, &mut table, &mut untried);
    if let (true, Some((_, why))) = (table.is_empty(), untried.first()) {
        return Err(SelectError::NoBaseline(format!("{defaults}: {why}")));
    }
    for stage in 0..4 {
        let best = best_of(&table).choice.clone();
        let candidates = stages(&best, data.len()).swap_remove(stage);
        for c in &candidates {
            run(c, true, &mut table, &mut untried);
        }
    }
    let chosen = table
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.score.total_cmp(&b.1.score))
        .map_or(0, |(i, _)| i);
    Ok(Selection {
        folds: k,
        budget_s,
        spent_s: start.elapsed().as_secs_f64(),
        table,
        chosen,
        untried,
    })
}

fn best_of(table: &[CvRow]) -> &CvRow {
    table
        .iter()
        .min_by(|a, b| a.score.total_cmp(&b.score))
        .expect("the defaults were scored")
}

/// One candidate's folds; None when the budget ran out in them; Err when
/// the data cannot serve it (the reason).
#[allow(clippy::too_many_arguments)]
fn cross_validate(
    data: &Dataset,
    tare: &TareSpec,
    choice: &Choice,
    splits: &[(Vec<usize>, Vec<usize>)],
    base: &GpParams,
    sd: &[f64],
    over: &dyn Fn() -> bool,
    progress: &mut (dyn FnMut(&Choice, FitProgress) + Send),
) -> Result<Option<CvRow>, String> {
    let (sub, sub_tare) = choice.cut(data, tare)?;
    let params = choice
        .gp_params(base)
        .validate()
        .map_err(|e| e.to_string())?;
    let t0 = Instant::now();
    let mut pred = Array2::zeros(data.y.raw_dim());
    for (train, test) in splits {
        let model = WrenchGp::train_scaled(
            &sub.select(train),
            sub_tare.clone(),
            choice.input,
            &params,
            &mut |_, p| progress(choice, p),
        )
        .map_err(|e| e.to_string())?;
        let (p, _) = model
            .predict(sub.select(test).x.view(), false)
            .map_err(|e| e.to_string())?;
        for (row, &i) in p.rows().into_iter().zip(test) {
            pred.row_mut(i).assign(&row);
        }
        if over() {
            return Ok(None);
        }
    }
    let rmse = rmse_columns(data.y.view(), pred.view());
    let axes = data.axes.axes();
    let score = rmse.iter().zip(sd).map(|(e, s)| e / s).sum::<f64>() / axes.len() as f64;
    Ok(Some(CvRow {
        choice: choice.clone(),
        rmse: axes.iter().copied().zip(rmse.iter().copied()).collect(),
        score,
        seconds: t0.elapsed().as_secs_f64(),
    }))
}

/// `data` and `tare` cut to the columns `features`; the name of one that is
/// missing.
pub(crate) fn columns(
    data: &Dataset,
    tare: &TareSpec,
    features: &[String],
) -> Result<(Dataset, TareSpec), String> {
    let idx = features
        .iter()
        .map(|f| {
            data.features
                .iter()
                .position(|g| g == f)
                .ok_or_else(|| f.clone())
        })
        .collect::<Result<Vec<_>, _>>()?;
    let sub = Dataset {
        features: features.to_vec(),
        x: data.x.select(NdAxis(1), &idx),
        ..data.clone()
    };
    let tare = TareSpec {
        samples: tare.samples,
        mean_baseline: idx.iter().map(|&i| tare.mean_baseline[i]).collect(),
    };
    Ok((sub, tare))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::biotac::sim::BioTacSimConfig;
    use crate::sim::collect::{collect, CollectConfig};
    use crate::wrench::Axis;

    /// A short simulated session with every channel, tared per trial.
    fn session() -> (Dataset, TareSpec) {
        let cfg = CollectConfig::default().with_trials(3).unwrap();
        let records = collect(&cfg, &BioTacSimConfig::default(), 1, 1);
        let all = channel_columns(
            &[
                Channel::Electrodes,
                Channel::Pdc,
                Channel::Tdc,
                Channel::Tac,
            ],
            ElectrodeLayout::Biotac,
        );
        let mut ds =
            Dataset::from_records(&records, &all, &"fz".parse().unwrap(), "session").unwrap();
        // Every 4th row keeps it quick.
        let rows: Vec<usize> = (0..ds.len()).step_by(4).collect();
        ds = ds.select(&rows);
        let baseline = ds.tare_per_trial(10).unwrap();
        let tare = TareSpec {
            samples: 10,
            mean_baseline: baseline,
        };
        (ds, tare)
    }

    fn quick() -> GpParams {
        GpParams {
            restarts: 1,
            restart_subset: 200,
            ..GpParams::default()
        }
    }

    #[test]
    fn the_search_keeps_the_best_score_and_records_every_candidate() {
        let (ds, tare) = session();
        let s = select(&ds, &tare, 5, 600.0, &quick(), &mut |_, _| {}).unwrap();
        assert_eq!(s.folds, 3, "3 trials per set: 3 folds");
        assert_eq!(s.table[0].choice, Choice::default_options());
        let best = s
            .table
            .iter()
            .map(|r| r.score)
            .fold(f64::INFINITY, f64::min);
        assert_eq!(s.table[s.chosen].score, best);
        // Every stage ran: channels, input, mean, GP (rows permit sparse 200).
        let tried = |f: &dyn Fn(&Choice) -> bool| s.table.iter().any(|r| f(&r.choice));
        assert!(tried(&|c| c.channels == [Channel::Pdc]));
        assert!(tried(&|c| c.input == InputScaling::Raw));
        assert!(tried(&|c| c.mean == MeanKind::Cubic));
        assert!(tried(&|c| c.gp == GpChoice::Sparse(200)));
        assert!(s.untried.is_empty(), "{:?}", s.untried);
        for r in &s.table {
            assert!(
                r.score.is_finite() && r.score > 0.0 && r.rmse[&Axis::Fz] > 0.0,
                "{r:?}"
            );
        }
        // The record survives JSON.
        let back: Selection = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(back, s);
    }

    #[test]
    fn the_budget_stops_the_search_and_says_what_it_left() {
        let (ds, tare) = session();
        let s = select(&ds, &tare, 5, 0.0, &quick(), &mut |_, _| {});
        // Nothing fits in no time but the defaults, which are always scored.
        let s = s.unwrap();
        assert_eq!(s.table.len(), 1);
        assert_eq!(s.choice(), &Choice::default_options());
        assert!(!s.untried.is_empty());
        assert!(
            s.untried.iter().all(|(_, why)| why == BUDGET_RAN_OUT),
            "{s:?}"
        );
        let without_tdc = Dataset {
            features: ds.features[..20].to_vec(),
            x: ds.x.slice(ndarray::s![.., ..20]).to_owned(),
            ..ds.clone()
        };
        let tare20 = TareSpec {
            samples: 10,
            mean_baseline: tare.mean_baseline[..20].to_vec(),
        };
        let s = select(&without_tdc, &tare20, 5, 600.0, &quick(), &mut |_, _| {}).unwrap();
        let missing = s
            .untried
            .iter()
            .find(|(c, _)| c.channels.contains(&Channel::Tdc))
            .expect("a candidate with tdc");
        assert!(missing.1.contains("no column \"tdc\""), "{missing:?}");
        let one_trial = ds.select(&(0..50).collect::<Vec<_>>());
        let e = select(&one_trial, &tare, 5, 60.0, &quick(), &mut |_, _| {}).unwrap_err();
        assert!(e.to_string().contains("at least 2"), "{e}");
    }
}
