//! Pooled retraining, a candidate beside an adapted model: a model
//! trained from scratch, with the base model's options, on the base's own
//! training data (found through the reference its file keeps, [`TrainedOn`])
//! pooled with the new data. `adapt` scores it with the adapted model and
//! the models of the new data alone on the same held-out part of the new
//! data and chooses by the chooser's rule ([`Adaptation`], [`choose`]), as
//! the calibration does; when
//! the base's data is not at hand they say why ([`Unavailable`]).

use std::io::Read;
use std::path::{Path, PathBuf};

use super::chooser::{self, Form, Scored};
use super::data::sessions::{load_sessions, Features, Request};
use super::data::source::Source;
use super::data::{trialwise_folds, Dataset};
use super::evaluate::{check_fits, EvalError};
use super::models::families;
use super::models::family::{Fit, ModelFamily};
use super::models::gp::fit::FitProgress;
use super::models::gp::{GpParams, MeanKind, SeHyper};
use super::models::metrics::rmse_columns;
use super::models::wrench_gp::{
    std_scale, std_scale_over_folds, AdaptChoice, AdaptedFrom, DataFile, GpFamily, Making,
    ModelError, TareSpec, TrainedOn, Validation, WarmStart, WrenchGp,
};
use super::models::wrench_model::WrenchModel;
use crate::params::Checked;
use crate::wrench::Axis;

/// Why the base model's training data cannot be pooled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Unavailable {
    /// The model file holds no reference (older, trained in memory, or from
    /// files read with options pooling does not repeat).
    #[error("the base model file records no training data")]
    NoReference,
    /// A recorded file is not where it was.
    #[error("its training data file {path} is missing ({reason})")]
    Missing {
        /// The file.
        path: String,
        /// The reading error.
        reason: String,
    },
    /// A file is not the one the model was trained on.
    #[error("training data file {path} changed since the model was trained (FNV-1a {found}, recorded {recorded})")]
    Changed {
        /// The file.
        path: String,
        /// Its hash now.
        found: String,
        /// The recorded hash(es).
        recorded: String,
    },
    /// A file could not be read as training data.
    #[error("training data file {path}: {reason}")]
    Unreadable {
        /// The file.
        path: String,
        /// Why.
        reason: String,
    },
    /// Pooling was switched off.
    #[error("pooling switched off")]
    Off,
}

/// FNV-1a (64 bits) of a file's bytes, as hex.
pub fn file_hash(path: &Path) -> std::io::Result<String> {
    let mut file = std::fs::File::open(path)?;
    let mut buf = vec![0u8; 1 << 16];
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    loop {
        let n = file.read(&mut buf)?;
        if n == 0 {
            return Ok(format!("{h:016x}"));
        }
        for &b in &buf[..n] {
            h = (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

/// `path`'s reference: as given, its hash and the `rows` read from it.
pub fn data_file(path: &Path, rows: usize) -> std::io::Result<DataFile> {
    Ok(DataFile {
        path: path.display().to_string(),
        hash: file_hash(path)?,
        rows,
    })
}

/// The reference an adapted or pooled model records: its base's files
/// (when recorded) and the new ones, with the base's options.
pub fn lineage(base: Option<&TrainedOn>, new: Vec<DataFile>) -> Option<TrainedOn> {
    base.map(|b| TrainedOn {
        files: b.files.iter().cloned().chain(new).collect(),
        params: b.params.clone(),
    })
}

/// The base model's training data, tared as it was, with the options to
/// retrain on it.
#[derive(Debug, Clone)]
pub struct BaseData {
    /// Its rows (every file's, pooled; maybe thinned: [`BaseData::thin`]).
    pub data: Dataset,
    /// Rows before thinning.
    pub rows: usize,
    /// The files read.
    pub files: Vec<DataFile>,
    /// The base model's GP options.
    pub params: GpParams,
}

/// The training data `model` records, read again as it was (`given`: the
/// same files elsewhere, matched by content).
pub fn base_data(model: &WrenchGp, given: Option<&[PathBuf]>) -> Result<BaseData, Unavailable> {
    let reference = model.trained_on().ok_or(Unavailable::NoReference)?;
    let recorded = |hash: &str| reference.files.iter().find(|f| f.hash == hash);
    let paths: Vec<PathBuf> = match given {
        Some(g) => g.to_vec(),
        None => reference
            .files
            .iter()
            .map(|f| PathBuf::from(&f.path))
            .collect(),
    };
    let mut sets = Vec::with_capacity(paths.len());
    let mut files = Vec::with_capacity(paths.len());
    for path in &paths {
        let p = path.display().to_string();
        let hash = file_hash(path).map_err(|e| Unavailable::Missing {
            path: p.clone(),
            reason: e.to_string(),
        })?;
        let Some(file) = recorded(&hash) else {
            let expected: Vec<&str> = match given {
                Some(_) => reference.files.iter().map(|f| f.hash.as_str()).collect(),
                None => reference
                    .files
                    .iter()
                    .filter(|f| f.path == p)
                    .map(|f| f.hash.as_str())
                    .collect(),
            };
            return Err(Unavailable::Changed {
                path: p,
                found: hash,
                recorded: expected.join(", "),
            });
        };
        let unreadable = |reason: String| Unavailable::Unreadable {
            path: p.clone(),
            reason,
        };
        let ds = read_session(path, model).map_err(unreadable)?;
        if ds.len() != file.rows {
            let why = format!("{} rows read, {} recorded", ds.len(), file.rows);
            return Err(unreadable(why));
        }
        files.push(DataFile {
            path: p.clone(),
            ..file.clone()
        });
        sets.push(ds);
    }
    let refs: Vec<&Dataset> = sets.iter().collect();
    let data = Dataset::concat(&refs).ok_or(Unavailable::NoReference)?;
    Ok(BaseData {
        rows: data.len(),
        data,
        files,
        params: reference.params.clone(),
    })
}

/// One training file read with `model`'s features and axes as the
/// defaults read it ([`load_sessions`]), each trial tared on its first rows
/// as the model's were.
fn read_session(path: &Path, model: &WrenchGp) -> Result<Dataset, String> {
    let request = Request {
        paths: &[path.to_path_buf()],
        features: Features::Model(model.features()),
        axes: model.axes(),
        tare_samples: Some(model.tare().samples),
        source: &Source::default(),
        sensor: Some(model.sensor()),
    };
    let sessions = load_sessions(&request, &mut |_| {}).map_err(|e| e.to_string())?;
    let no_rows = || format!("{}: nothing read", path.display());
    sessions.sets.into_iter().next().ok_or_else(no_rows)
}

impl BaseData {
    /// At most `max_rows` of its rows, evenly spaced (all when fewer).
    pub fn thin(mut self, max_rows: usize) -> Self {
        let n = self.data.len();
        if n > max_rows && max_rows > 0 {
            let idx: Vec<usize> = (0..max_rows).map(|i| i * n / max_rows).collect();
            self.data = self.data.select(&idx);
        }
        self
    }

    /// What the pooled candidate took, for the output.
    pub fn describe(&self) -> String {
        let used = self.data.len();
        match used < self.rows {
            true => format!(
                "base rows subsampled {} -> {used} of {} file(s)",
                self.rows,
                self.files.len()
            ),
            false => format!("{used} base rows of {} file(s)", self.files.len()),
        }
    }

    /// A model trained from scratch with `params` (the base's:
    /// [`BaseData::params`]) on these rows and `new` (tared as `tare`
    /// says), with `base`'s input scaling, for its sensor, its search
    /// started from `warm`.
    pub fn pooled(
        &self,
        base: &WrenchGp,
        new: &Dataset,
        tare: TareSpec,
        params: &Checked<GpParams>,
        warm: WarmStart,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<WrenchGp, ModelError> {
        let data =
            Dataset::concat(&[&self.data, new]).ok_or_else(|| ModelError::AdaptMismatch {
                base: format!("{:?}", self.data.features),
                data: format!("{:?}", new.features),
            })?;
        Ok(
            WrenchGp::train_from(&data, tare, base.scaling(), params, warm, progress)?
                .with_sensor(base.sensor().clone()),
        )
    }
}

/// Per axis, the targets' standard deviation: the scores' units.
pub fn spread(data: &Dataset) -> Vec<f64> {
    let sd = |c: ndarray::ArrayView1<f64>| c.std(0.0).max(1e-9);
    data.y.columns().into_iter().map(sd).collect()
}

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

/// `params` with the network as the GPs' prior mean: the candidate of the
/// new data alone beside the GP (`adapt`, the calibration).
pub fn with_network_mean(params: &GpParams) -> Result<Checked<GpParams>, ModelError> {
    let p = GpParams {
        mean: MeanKind::Network,
        ..params.clone()
    };
    Ok(p.validate()?)
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

/// `adapt`: the candidates for a new unit, each fitted on the folds of the
/// new data ([`adapt_folds`]) and scored on their held-out rows: the base adapted
/// ([`WrenchGp::adapt`]); retrained on the base's data pooled with the new,
/// when `base_data` is at hand; and each family on the new data alone (the
/// GP, the GP with the network as its mean, each other family
/// ([`families::besides_gp`]): the ensemble of networks). The
/// one the chooser takes ([`choose`]) is fitted again on all of `data`, its standard deviations scaled to
/// cover its held-out errors ([`std_scale`]), and returned with what was
/// chosen. The GPs record `trained_on` (the new data's own, `new_only`, for
/// those trained on it alone).
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

/// The candidates of [`Adaptation`], by the names they are scored under
/// (each other family's: "new data: " and its name).
const ADAPTED: &str = "adapted";
const POOLED: &str = "pooled";
const NEW_GP: &str = "new data: GP";
const NEW_NETWORK: &str = "new data: GP, network mean";

/// The pooled candidate's base data and options, when it is one.
type Pool<'a> = Option<(&'a BaseData, Checked<GpParams>)>;

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

/// A candidate of [`Adaptation`].
enum Candidate {
    /// The base adapted, retrained pooled, or the GP of the new data alone
    /// (its mean the options' or a network): by name.
    Gp(&'static str),
    /// Another family on the new data alone.
    Other(&'static dyn ModelFamily),
}

impl Candidate {
    /// Every candidate, the pooled one when `pooled`.
    fn all(pooled: bool) -> Vec<Candidate> {
        let gps = [ADAPTED, POOLED, NEW_GP, NEW_NETWORK].into_iter();
        let gps = gps.filter(|n| *n != POOLED || pooled).map(Candidate::Gp);
        let others = families::besides_gp().into_iter().map(Candidate::Other);
        gps.chain(others).collect()
    }

    fn name(&self) -> String {
        match self {
            Candidate::Gp(name) => (*name).into(),
            Candidate::Other(family) => format!("new data: {}", family.name()),
        }
    }
}

impl Adaptation<'_> {
    /// Runs it (see [`Adaptation`]); `progress` is told every fit's progress.
    pub fn run(
        self,
        base_data: Result<BaseData, Unavailable>,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<(Box<dyn WrenchModel>, AdaptChoice), EvalError> {
        let pool = match &base_data {
            Ok(b) => Some((b, b.params.clone().validate().map_err(ModelError::from)?)),
            Err(_) => None,
        };
        let network = with_network_mean(self.params)?;
        let candidates = Candidate::all(pool.is_some());
        let folds = adapt_folds(self.data);
        let sd = spread(self.data);
        let mut validation = Vec::with_capacity(candidates.len());
        let mut errors = Vec::with_capacity(candidates.len());
        let mut hypers = Vec::with_capacity(candidates.len());
        let mut cost = Vec::with_capacity(candidates.len());
        for c in &candidates {
            let scored = self.cross_validate(c, (&pool, &network), &folds, &sd, progress)?;
            validation.push(scored.validation);
            errors.push(scored.errors);
            hypers.push(scored.hypers);
            cost.push((scored.estimate_us, self.form(c, &pool)));
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
            pooling: match &base_data {
                Ok(b) => b.describe(),
                Err(why) => format!("not considered: {why}"),
            },
            validation,
            why,
        };
        let trained_on = match chosen {
            Candidate::Gp(NEW_GP | NEW_NETWORK) => self.new_only.clone(),
            _ => self.trained_on.clone(),
        };
        // Fitted again on every row, started from its first fold's search.
        let warm = WarmStart {
            hypers: hypers[at].as_deref(),
            network: None,
        };
        let mut model = self.fit(chosen, (&pool, &network), self.data, warm, progress)?;
        model.record(Making::StdScales(scales));
        model.record(Making::TrainedOn(trained_on));
        model.record(Making::AdaptChoice(Box::new(choice.clone())));
        Ok((model, choice))
    }

    /// `candidate` fitted on `d` (tared as the new data), its search
    /// started from `warm`; `pool` and `network` are the pooled candidate's
    /// base data and options, and the network-mean GP's options.
    fn fit(
        &self,
        candidate: &Candidate,
        (pool, network): (&Pool, &Checked<GpParams>),
        d: &Dataset,
        warm: WarmStart,
        p: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<Box<dyn WrenchModel>, ModelError> {
        let tare = self.tare.clone();
        let alone = |family: &dyn ModelFamily, params, progress| {
            family.fit(Fit {
                data: d,
                tare: tare.clone(),
                sensor: self.base.sensor().clone(),
                input: self.base.scaling(),
                params,
                warm,
                progress,
            })
        };
        match (candidate, pool) {
            (Candidate::Other(family), _) => alone(*family, self.params, p),
            (Candidate::Gp(NEW_GP), _) => alone(&GpFamily, self.params, p),
            (Candidate::Gp(NEW_NETWORK), _) => alone(&GpFamily, network, p),
            (Candidate::Gp(POOLED), Some((b, options))) => {
                Ok(Box::new(b.pooled(self.base, d, tare, options, warm, p)?))
            }
            _ => Ok(Box::new(self.base.adapt(
                d,
                tare,
                self.from.clone(),
                self.params,
                warm,
                p,
            )?)),
        }
    }

    /// `candidate` fitted ([`Adaptation::fit`]) on each fold's training rows of the new
    /// data and scored on its held-out rows ([`scored`], in units of `sd`:
    /// every row is held out once). A GP's folds after the first start their
    /// search from the first's hyperparameters.
    fn cross_validate(
        &self,
        candidate: &Candidate,
        fitting: (&Pool, &Checked<GpParams>),
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
            let m = self.fit(candidate, fitting, &self.data.select(train), warm, progress)?;
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

    /// The form of `candidate`, the pooled one's options `pool`.
    fn form(&self, candidate: &Candidate, pool: &Pool) -> Form {
        let gp = GpFamily::form_of_params;
        match (candidate, pool) {
            (Candidate::Other(f), _) => families::default_form(*f),
            (Candidate::Gp(NEW_NETWORK), _) => {
                GpFamily::form_of(MeanKind::Network, gp(self.params).points)
            }
            (Candidate::Gp(POOLED), Some((_, options))) => gp(options),
            _ => gp(self.params),
        }
    }
}

#[cfg(test)]
mod tests;
