//! The training options chosen on the user's data (`train --select`): the
//! channels, how they reach the GP, exact or sparse and its size, and the
//! prior mean, by trial-wise cross-validation within a time budget.
//!
//! The search starts from the defaults within what the data hold
//! ([`Space`]: the channels the data have, the options the user fixed) and
//! changes one option at a time, going on from the candidate that would be
//! chosen so far: the options that change the model's form first (input
//! scaling, prior mean, the GP's kind and size), the channels last. Each candidate is trained as `train`
//! trains it (every training row of a fold; the exact GP on its own
//! subset; a sparse GP's search on fewer rows, `scoring`), its search
//! started warm where the same form was fitted before
//! (`WarmStarts`), and scored on the held-out trials (each candidate's
//! wall and CPU seconds and its estimate's time shown, not recorded). The
//! score is the mean over axes of the RMSE over the standard deviation of
//! the axis's targets, so that forces and torques weigh alike. A set
//! recorded as one trial is cut into contiguous blocks, each a trial.
//!
//! No clock decides anything: each candidate's cost is predicted from its
//! kind and size before it runs (`cost.rs`). A candidate whose estimate is
//! predicted slower than `cost::ESTIMATE_LIMIT_US` at the 99th percentile
//! is not a candidate; one
//! predicted beyond what the budget leaves is not tried; both are listed
//! with the reason. The defaults are scored whatever the budget: they are
//! what every other candidate must beat. Among the candidates within noise
//! of the best score, the simplest, then the cheapest estimate, then the
//! first tried is chosen (`pick.rs`). So the same data, options and seed
//! give the same table, choice and model file on a loaded machine as on an
//! idle one.

use std::collections::BTreeMap;
use std::time::Instant;

use ndarray::Axis as NdAxis;

use super::chooser::spread;
use super::data::{channel_columns, layout_of, trialwise_folds, Channel, Dataset};
use super::models::families;
use super::models::gp::fit::FitProgress;
use super::models::gp::{GpParams, MeanKind, DEFAULT_MAX_TRAIN};
use super::models::scale::InputScaling;
use super::models::wrench_gp::{ModelError, TareSpec};
use crate::biotac::ElectrodeLayout;

use crate::exit::{Classify, ExitClass};

pub use super::models::family::Shape;
pub use super::models::provenance::{Cost, Family};
pub use super::models::wrench_gp::{AloneScore, Choice, CvRow, GpChoice, Selection};

impl Choice {
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

/// Why a candidate of `cost` is not tried with `left_s` predicted seconds
/// of the budget left: its estimate is predicted slower than
/// `cost::ESTIMATE_LIMIT_US` at the 99th percentile (not a candidate), or
/// its cross-validation longer than what is left; None when it is tried.
fn not_tried(cost: &Cost, left_s: f64) -> Option<String> {
    let p99 = cost::p99_us(cost);
    if p99 > cost::ESTIMATE_LIMIT_US {
        return Some(format!(
            "its estimate is predicted at {p99:.0} µs at the 99th percentile, over the {:.0} µs \
             an estimate may take ({})",
            cost::ESTIMATE_LIMIT_US,
            cost::ESTIMATE_LIMIT_WHY
        ));
    }
    (cost.fit_s > left_s).then(|| {
        format!(
            "predicted {:.1} s, over the {:.1} s the time budget leaves",
            cost.fit_s,
            left_s.max(0.0)
        )
    })
}

/// What the search may vary: the channels the data hold, and the options
/// the user fixed (`train --select --channels ...`).
#[derive(Debug, Clone, PartialEq)]
pub struct Space {
    /// The BioTac channels the data hold.
    pub held: Vec<Channel>,
    /// Channels fixed by the user.
    pub channels: Option<Vec<Channel>>,
    /// Model family fixed by the user (fixing a GP option fixes the GP).
    pub family: Option<Family>,
    /// Input scaling fixed by the user.
    pub input: Option<InputScaling>,
    /// GP kind and size fixed by the user.
    pub gp: Option<GpChoice>,
    /// Prior mean fixed by the user.
    pub mean: Option<MeanKind>,
}

/// The channel sets the search tries, each where the data hold it.
const CHANNEL_SETS: [&[Channel]; 4] = {
    use Channel::{Electrodes, Pdc, Tac, Tdc};
    [
        &[Electrodes, Pdc],
        &[Electrodes],
        &[Electrodes, Pdc, Tdc, Tac],
        &[Pdc],
    ]
};

impl Space {
    /// Everything free on data holding `held`.
    pub fn free(held: Vec<Channel>) -> Self {
        Space {
            held,
            channels: None,
            family: None,
            input: None,
            gp: None,
            mean: None,
        }
    }

    /// The channel sets of [`CHANNEL_SETS`] the data hold, or the fixed one.
    fn channel_sets(&self) -> Vec<Vec<Channel>> {
        match &self.channels {
            Some(c) => vec![c.clone()],
            None => CHANNEL_SETS
                .iter()
                .filter(|set| set.iter().all(|c| self.held.contains(c)))
                .map(|set| set.to_vec())
                .collect(),
        }
    }

    /// The first candidate: the defaults of `train` within what the data
    /// hold, with the fixed options.
    pub fn start(&self) -> Choice {
        let d = Choice::default_options();
        let channels = self.channel_sets().into_iter().next().unwrap_or(d.channels);
        match self.family() {
            Some(family) if !family.is_gp() => return Choice::of(family, channels),
            _ => {}
        }
        Choice {
            family: Family::GP,
            channels,
            input: self.input.unwrap_or(d.input),
            gp: self.gp.unwrap_or(d.gp),
            mean: self.mean.unwrap_or(d.mean),
        }
    }

    /// The family fixed: by the user, or by a GP option they fixed.
    fn family(&self) -> Option<Family> {
        let gp_fixed = self.input.is_some() || self.mean.is_some() || self.gp.is_some();
        (self.family.clone()).or(gp_fixed.then_some(Family::GP))
    }

    /// What the search cannot vary, and why, for the record.
    pub fn not_varied(&self) -> Vec<String> {
        let mut out = Vec::new();
        let sets = self.channel_sets();
        if self.channels.is_some() {
            out.push("channels: fixed by --channels".to_string());
        } else if sets.len() < 2 {
            let held: Vec<&str> = self.held.iter().map(|c| c.name()).collect();
            out.push(format!("channels: the data hold {} only", held.join(", ")));
        }
        match (&self.family, self.family()) {
            (Some(_), _) => out.push("family: fixed by --family".to_string()),
            (None, Some(_)) => out.push("family: a GP option was fixed".to_string()),
            (None, None) => {}
        }
        let fixed = [
            (self.input.is_some(), "input: fixed by --input"),
            (self.mean.is_some(), "mean: fixed by --mean"),
            (self.gp.is_some(), "GP: fixed by --inducing or --max-train"),
        ];
        out.extend(fixed.iter().filter(|f| f.0).map(|f| f.1.to_string()));
        out
    }

    /// The options tried after the first, one stage at a time (each from
    /// the best so far). The options that change the model's form come
    /// first, the channels last: input scaling, prior mean, the GP (its
    /// kind and size), the family (the best GP against each other family
    /// on its channels, [`families::besides_gp`]), channels. Fixed options, the GP's options of a fixed
    /// ensemble and channel sets the data do not hold have no stage.
    fn stages(&self, best: &Choice, rows: usize) -> Vec<Vec<Choice>> {
        let with = |f: &dyn Fn(&mut Choice)| {
            let mut c = best.clone();
            f(&mut c);
            c
        };
        let inputs = [
            InputScaling::Standard,
            InputScaling::Pattern,
            InputScaling::Raw,
        ];
        let means = [
            MeanKind::Zero,
            MeanKind::Linear,
            MeanKind::Cubic,
            MeanKind::Network,
        ];
        // Smaller exact subsets and sparse sizes, then more rows when there are.
        let gps = [
            GpChoice::Exact(DEFAULT_MAX_TRAIN),
            GpChoice::Sparse(200),
            GpChoice::Exact(1000),
            GpChoice::Sparse(500),
            GpChoice::Exact(4000),
        ];
        let mut out = Vec::new();
        let gp = self.family().is_none_or(|f| f.is_gp());
        if gp && self.input.is_none() {
            out.push(inputs.iter().map(|&i| with(&|c| c.input = i)).collect());
        }
        if gp && self.mean.is_none() {
            out.push(means.iter().map(|&m| with(&|c| c.mean = m)).collect());
        }
        if gp && self.gp.is_none() {
            out.push(
                gps.iter()
                    .filter(|g| match g {
                        GpChoice::Exact(n) | GpChoice::Sparse(n) => *n < rows,
                    })
                    .map(|&g| with(&|c| c.gp = g))
                    .collect(),
            );
        }
        if self.family().is_none() {
            let others = families::besides_gp().into_iter();
            out.push(
                others
                    .map(|f| Choice::of(Family::named(f.name()), best.channels.clone()))
                    .collect(),
            );
        }
        out.push(
            self.channel_sets()
                .into_iter()
                .map(|ch| with(&|c| c.channels = ch.clone()))
                .collect(),
        );
        out
    }
}

/// Chooses the training options on `data` (tared; its features the union
/// of the channels `space` says it holds, tared as `tare` says) by
/// trial-wise cross-validation with `folds` folds (fewer when a set has
/// fewer trials; a set of one trial cut into `folds` contiguous blocks),
/// within `budget_s` seconds, among what `space` leaves free.
/// `base` holds the other GP options (restarts, seed). `progress` hears of
/// each candidate as it starts.
#[allow(clippy::too_many_arguments)]
pub fn select(
    data: &Dataset,
    tare: &TareSpec,
    space: &Space,
    folds: usize,
    budget_s: f64,
    base: &GpParams,
    progress: &mut (dyn FnMut(&Choice, FitProgress) + Send),
) -> Result<Selection, SelectError> {
    let (data, blocks) = data.single_trials_in_blocks(folds);
    let data = &data;
    let k = fold_count(data, folds)?;
    let splits = trialwise_folds(data, k);
    let sd = spread(data);
    let start = Instant::now();
    let mut table: Vec<CvRow> = Vec::new();
    let mut untried = Vec::new();
    let mut warm = WarmStarts::default();
    let cv = Cv {
        data,
        tare,
        splits: &splits,
        base,
        sd: &sd,
    };
    // Seconds the candidates run so far are predicted to take.
    let mut predicted_s = 0.0;
    // A candidate's cross-validation; `budgeted`: within the budget's
    // prediction, else it runs whatever its cost (the defaults).
    let mut run = |choice: &Choice,
                   budgeted: bool,
                   table: &mut Vec<CvRow>,
                   untried: &mut Vec<(Choice, String)>| {
        if table.iter().any(|r| &r.choice == choice) || untried.iter().any(|(c, _)| c == choice) {
            return;
        }
        let cost = match cv.cost(choice) {
            Ok(cost) => cost,
            Err(why) => return untried.push((choice.clone(), why)),
        };
        if let Some(why) = budgeted
            .then(|| not_tried(&cost, budget_s - predicted_s))
            .flatten()
        {
            return untried.push((choice.clone(), why));
        }
        predicted_s += cost.fit_s;
        match cv.run(choice, &mut warm, progress) {
            Ok(row) => table.push(row),
            Err(why) => untried.push((choice.clone(), why)),
        }
    };
    let defaults = space.start();
    run(&defaults, false, &mut table, &mut untried);
    if let (true, Some((_, why))) = (table.is_empty(), untried.first()) {
        return Err(SelectError::NoBaseline(format!("{defaults}: {why}")));
    }
    let n_stages = space.stages(&defaults, data.len()).len();
    for stage in 0..n_stages {
        // Each stage goes on from what would be chosen so far.
        let best = table[pick::choose(&table).0].choice.clone();
        let candidates = space.stages(&best, data.len()).swap_remove(stage);
        for c in &candidates {
            run(c, true, &mut table, &mut untried);
        }
    }
    let (chosen, why) = pick::choose(&table);
    Ok(Selection {
        folds: k,
        budget_s,
        spent_s: Some(start.elapsed().as_secs_f64()),
        table,
        chosen,
        why,
        blocks,
        untried,
        not_varied: space.not_varied(),
    })
}

/// The folds `data` (its sets of one trial cut into blocks) gives: `folds`,
/// fewer when a set has fewer trials; refused when a set has one.
fn fold_count(data: &Dataset, folds: usize) -> Result<usize, SelectError> {
    let mut per_set: BTreeMap<u32, usize> = BTreeMap::new();
    for ((set, _), _) in data.trials() {
        *per_set.entry(set).or_default() += 1;
    }
    match per_set.iter().min_by_key(|(_, t)| **t) {
        Some((&set, &trials)) if trials < 2 => Err(SelectError::TooFewTrials { set, trials }),
        Some((_, &trials)) => Ok(folds.min(trials)),
        None => Ok(folds),
    }
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

mod cost;
mod cv;
mod pick;

use cv::{Cv, WarmStarts};
#[cfg(test)]
mod tests;
