//! What made a model, as its file records it: the model it was adapted
//! from (`adapt`), how its options were chosen (`train --select`), the
//! calibration on the robot that made it, the data it was trained on and
//! what `adapt` chose. The model file owns these types;
//! the workflows that make models fill them in.

use std::borrow::Cow;
use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::learn::data::Channel;
use crate::learn::models::gp::{GpParams, MeanKind, DEFAULT_MAX_TRAIN};
use crate::learn::models::scale::InputScaling;
use crate::wrench::Axis;

/// One thing a model records of what made it, in its model file
/// ([`super::wrench_model::WrenchModel::record`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Making {
    /// Per axis (output order), the scale of the standard deviation of a
    /// measured target that covers held-out errors; a scale not positive
    /// and finite leaves its axis as it is.
    StdScales(Vec<f64>),
    /// The data it was trained on (None: not known), which pooled
    /// retraining reads again; a family whose models pooling cannot
    /// retrain records none.
    TrainedOn(Option<TrainedOn>),
    /// How `train --select` chose its options.
    Selection(Box<Selection>),
    /// What `adapt` chose it over.
    AdaptChoice(Box<AdaptChoice>),
    /// The calibration on the robot that made it.
    Calibration(Box<CalibrationRecord>),
}

/// Sets each of `targets` to its scale in `scales` where that is positive
/// and finite ([`Making::StdScales`]).
pub(crate) fn set_scales<'a>(targets: impl Iterator<Item = &'a mut f64>, scales: &[f64]) {
    for (t, s) in targets.zip(scales) {
        if *s > 0.0 && s.is_finite() {
            *t = *s;
        }
    }
}

/// Where an adapted model came from (`adapt`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdaptedFrom {
    /// The base model file, as given.
    pub model: String,
    /// The recordings it was adapted with, as given.
    pub data: Vec<String>,
    /// Seconds of adaptation data (rows times the sensor's sample period).
    pub seconds: f64,
}

/// The GP a candidate trains.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GpChoice {
    /// The exact GP conditioned on at most this many rows.
    Exact(usize),
    /// The sparse GP with this many inducing points, on every row.
    Sparse(usize),
}

impl std::fmt::Display for GpChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            GpChoice::Exact(n) => write!(f, "exact {n}"),
            GpChoice::Sparse(m) => write!(f, "sparse {m}"),
        }
    }
}

/// A model family, by its name: what `train --family` makes and `select`
/// compares ([`super::families`] has them, [`super::family::ModelFamily`]
/// says what one is).
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Family(Cow<'static, str>);

impl Family {
    /// A GP per axis (its input scaling, size and prior mean chosen too).
    pub const GP: Family = Family(Cow::Borrowed("gp"));

    /// The family named `name`.
    pub fn named(name: &'static str) -> Family {
        Family(Cow::Borrowed(name))
    }

    /// Its name on the command line and in files.
    pub fn name(&self) -> &str {
        &self.0
    }

    /// True for the GP.
    pub fn is_gp(&self) -> bool {
        *self == Family::GP
    }
}

impl Default for Family {
    fn default() -> Self {
        Family::GP
    }
}

impl std::fmt::Display for Family {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

/// One set of the options `select` chooses: a family, the channels it
/// reads, and the GP's options (another family's models take none of
/// them, which stay at the GP's defaults).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Choice {
    /// The model family (absent in files before it: a GP).
    #[serde(default, skip_serializing_if = "Family::is_gp")]
    pub family: Family,
    /// The BioTac channels taken as features.
    pub channels: Vec<Channel>,
    /// How they reach the GP.
    pub input: InputScaling,
    /// Exact or sparse, and its size.
    pub gp: GpChoice,
    /// The GP's prior mean.
    pub mean: MeanKind,
}

impl Choice {
    /// The defaults of `train`: electrodes and PDC, standardised, the
    /// exact GP on 2000 rows, zero mean.
    pub fn default_options() -> Self {
        Choice {
            family: Family::GP,
            channels: vec![Channel::Electrodes, Channel::Pdc],
            input: InputScaling::Standard,
            gp: GpChoice::Exact(DEFAULT_MAX_TRAIN),
            mean: MeanKind::Zero,
        }
    }

    /// A model of `family` on `channels` (the GP's options left at their
    /// defaults: another family's two candidates differ only by channels).
    pub fn of(family: Family, channels: Vec<Channel>) -> Self {
        Choice {
            family,
            channels,
            ..Choice::default_options()
        }
    }
}

impl std::fmt::Display for Choice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let channels: Vec<&str> = self.channels.iter().map(|c| c.name()).collect();
        let channels = channels.join("+");
        match self.family.is_gp() {
            true => write!(
                f,
                "{channels}, {}, {}, {} mean",
                self.input.name(),
                self.gp,
                self.mean.name()
            ),
            false => write!(f, "{channels}, {}", self.family),
        }
    }
}

/// A candidate's cross-validation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CvRow {
    /// The options.
    pub choice: Choice,
    /// RMSE per axis on the held-out trials, pooled (N or Nm).
    pub rmse: BTreeMap<Axis, f64>,
    /// Mean over axes of the RMSE over the targets' standard deviation
    /// (lower is better).
    pub score: f64,
    /// Seconds its folds took, this run (a clock reading: shown, never
    /// chosen by, not written to the file, so that the same data and seed
    /// give the same file).
    #[serde(default, skip_serializing)]
    pub seconds: Option<f64>,
    /// CPU seconds the process spent in its folds, all threads, this run
    /// (None where the system does not say; not written, as `seconds`).
    #[serde(default, skip_serializing)]
    pub cpu_s: Option<f64>,
    /// Its cost predicted from its kind and size before it ran: what the
    /// budget, the estimate's time limit and the choice read (None in
    /// files written before).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub predicted: Option<Cost>,
    /// The score of each fold alone (empty in files written before).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub fold_scores: Vec<f64>,
    /// Median time of one estimate with its standard deviation (µs), as the
    /// estimator makes it, this run (not written, as `seconds`).
    #[serde(default, skip_serializing)]
    pub latency_us: Option<f64>,
    /// Its 99th percentile (µs), this run (not written, as `seconds`).
    #[serde(default, skip_serializing)]
    pub latency_p99_us: Option<f64>,
    /// Per axis, the scale of the standard deviation that puts 95 % of the
    /// held-out errors within two of it ([`super::wrench_gp::std_scale`]; empty in
    /// files written before).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub std_scale: BTreeMap<Axis, f64>,
    /// A network mean's network alone, on the same folds, without its GPs:
    /// it has no standard deviation, so the estimator does not run it and
    /// it is not a candidate; shown for comparison (None for other means).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub network_alone: Option<AloneScore>,
}

/// A candidate's cost predicted from its kind and size alone, never from a
/// clock (`learn::choice`): the same on any machine, under any load.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Cost {
    /// Seconds its cross-validation takes on 2 idle cores of the machine
    /// the prediction was measured on (docs/results.md).
    pub fit_s: f64,
    /// Microseconds of one estimate with its standard deviation, every
    /// axis, on one core of that machine.
    pub estimate_us: f64,
}

/// The cross-validation of a model that is shown, not chosen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AloneScore {
    /// RMSE per axis on the held-out trials, pooled.
    pub rmse: BTreeMap<Axis, f64>,
    /// As [`CvRow::score`].
    pub score: f64,
    /// The score of each fold alone.
    pub fold_scores: Vec<f64>,
}

/// What `select` did: every candidate's cross-validation, the one chosen,
/// and what the budget left untried.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Selection {
    /// Trial-wise folds per candidate.
    pub folds: usize,
    /// The time budget (s).
    pub budget_s: f64,
    /// The time the search took (s), this run (not written, as
    /// [`CvRow::seconds`]).
    #[serde(default, skip_serializing)]
    pub spent_s: Option<f64>,
    /// Every candidate scored, in the order tried.
    pub table: Vec<CvRow>,
    /// Index of the chosen candidate in `table`: among those within noise
    /// of the best score, the simplest, then the fastest.
    pub chosen: usize,
    /// Why it was chosen (empty in files written before).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub why: String,
    /// Sets of one trial, cross-validated on contiguous blocks of it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub blocks: Vec<u32>,
    /// Candidates the budget left untried, or the data could not serve (a
    /// channel missing), with the reason.
    pub untried: Vec<(Choice, String)>,
    /// The options the search could not vary, and why (the data hold one
    /// channel set; the user fixed it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_varied: Vec<String>,
}

impl Selection {
    /// The chosen options.
    pub fn choice(&self) -> &Choice {
        &self.table[self.chosen].choice
    }
}

/// One model scored on the held-out pushes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Validation {
    /// "current", "adapted", "from scratch" or "pooled".
    pub model: String,
    /// RMSE per axis on the held-out pushes (N or Nm).
    pub rmse: BTreeMap<Axis, f64>,
    /// Mean over axes of the RMSE over the targets' standard deviation.
    pub score: f64,
    /// The score on each held-out trial (push), in their order: what the
    /// chooser measures the noise on (absent in files before it).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub trial_scores: Vec<f64>,
}

/// What a calibration did (in the model file it made).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationRecord {
    /// "adapted", "from scratch" or "pooled".
    pub chosen: String,
    /// The current model and both candidates on the held-out pushes.
    pub validation: Vec<Validation>,
    /// The from-scratch candidate's options.
    pub scratch_options: Option<Choice>,
    /// Pushes recorded, and those held out (1-based).
    pub pushes: u32,
    /// The held-out pushes.
    pub held_out: Vec<u32>,
    /// Rows recorded.
    pub rows: usize,
    /// Seconds the arm moved.
    pub motion_s: f64,
    /// Seconds of compute (training and validation).
    pub compute_s: f64,
    /// The largest force the F/T sensor measured (N).
    pub peak_force_n: f64,
    /// The recording's file (MCAP), when written.
    pub session: Option<String>,
    /// Why the pooled candidate was not tried, or how many base rows it
    /// took (absent in files before it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pooling: Option<String>,
    /// Why the chooser took `chosen` (absent in files before it).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub why: String,
}

impl CalibrationRecord {
    /// The held-out RMSE per axis of the validation row of `model`
    /// ("current", or a candidate); empty when there is none.
    pub fn rmse_of(&self, model: &str) -> Vec<f64> {
        self.validation
            .iter()
            .find(|v| v.model == model)
            .map(|v| v.rmse.values().copied().collect())
            .unwrap_or_default()
    }

    /// "calibrated", and each axis the chosen model estimates worse than
    /// the current one on the held-out pushes (it won on the mean over
    /// axes): what replacing the current model gives up.
    pub fn outcome(&self) -> String {
        let of = |name: &str| self.validation.iter().find(|v| v.model == name);
        let (Some(current), Some(chosen)) = (of("current"), of(&self.chosen)) else {
            return "calibrated".into();
        };
        let worse: Vec<String> = (chosen.rmse.iter())
            .filter_map(|(axis, &new)| {
                let old = *current.rmse.get(axis)?;
                (new > old).then(|| format!("{axis} {old:.3} -> {new:.3}"))
            })
            .collect();
        match worse.is_empty() {
            true => "calibrated".into(),
            false => format!(
                "calibrated; worse than the current model on {} (RMSE on the held-out pushes, \
                 N or Nm), better over the axes (score {:.4} -> {:.4})",
                worse.join(", "),
                current.score,
                chosen.score
            ),
        }
    }
}

/// A training data file as a model records it: where it was, and enough of
/// its content to tell the same file from a changed one.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DataFile {
    /// The path, as given.
    pub path: String,
    /// FNV-1a (64 bits, hex) of its bytes.
    pub hash: String,
    /// Rows read from it.
    pub rows: usize,
}

/// The data behind a model (an adapted model's: its base's and its own) and
/// the options that retrain a model like its base from scratch on them: the
/// reference pooled retraining follows (`learn::pooled`). Not the data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainedOn {
    /// The files, each read as a session (CSV or rosbag2 MCAP).
    pub files: Vec<DataFile>,
    /// The GP options of the model trained on the first of them.
    pub params: GpParams,
}

/// What `adapt` chose between the adapted model and a model retrained on
/// the base's data pooled with the new (in the model file it wrote).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AdaptChoice {
    /// "adapted", "pooled", "new data: GP", "new data: GP, network mean" or
    /// "new data: ensemble".
    pub chosen: String,
    /// The candidates on the held-out rows of the new data.
    pub validation: Vec<Validation>,
    /// Rows of the new data held out: every row once, over the folds (in
    /// files before the folds: one held-out part).
    pub held_out_rows: usize,
    /// Folds of the new data's trials (or blocks) the candidates were
    /// scored on (0 in files before them: one held-out part).
    #[serde(default)]
    pub folds: usize,
    /// Why pooling was not a candidate, or how many base rows it took.
    pub pooling: String,
    /// Why the chooser took `chosen` (absent in files before it).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub why: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn validation(model: &str, fy: f64, score: f64) -> Validation {
        Validation {
            model: model.into(),
            rmse: [(Axis::Fx, 0.20), (Axis::Fy, fy), (Axis::Fz, 0.30)].into(),
            score,
            trial_scores: Vec::new(),
        }
    }

    #[test]
    fn a_calibration_says_each_axis_its_model_estimates_worse_than_the_current_one() {
        let mut record = CalibrationRecord {
            chosen: "adapted".into(),
            validation: vec![
                validation("current", 0.24, 0.50),
                validation("adapted", 0.28, 0.45),
            ],
            scratch_options: None,
            pushes: 24,
            held_out: vec![4, 8],
            rows: 100,
            motion_s: 1.0,
            compute_s: 1.0,
            peak_force_n: 1.0,
            session: None,
            pooling: None,
            why: String::new(),
        };
        // fx and fz equal: not worse.
        assert_eq!(
            record.outcome(),
            "calibrated; worse than the current model on fy 0.240 -> 0.280 (RMSE on the held-out \
             pushes, N or Nm), better over the axes (score 0.5000 -> 0.4500)"
        );
        record.validation[1] = validation("adapted", 0.20, 0.40);
        assert_eq!(record.outcome(), "calibrated");
    }
}
