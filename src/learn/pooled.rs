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
use super::data::Dataset;
use super::evaluate::{check_fits, EvalError};
use super::models::families;
use super::models::family::{Fit, ModelFamily};
use super::models::gp::fit::FitProgress;
use super::models::gp::{GpParams, MeanKind};
use super::models::metrics::rmse_columns;
use super::models::wrench_gp::{
    std_scale, AdaptChoice, AdaptedFrom, DataFile, GpFamily, Making, ModelError, TareSpec,
    TrainedOn, Validation, WarmStart, WrenchGp,
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
    /// says), with `base`'s input scaling, for its sensor.
    pub fn pooled(
        &self,
        base: &WrenchGp,
        new: &Dataset,
        tare: TareSpec,
        params: &Checked<GpParams>,
        progress: &mut (dyn FnMut(Axis, FitProgress) + Send),
    ) -> Result<WrenchGp, ModelError> {
        let data =
            Dataset::concat(&[&self.data, new]).ok_or_else(|| ModelError::AdaptMismatch {
                base: format!("{:?}", self.data.features),
                data: format!("{:?}", new.features),
            })?;
        Ok(
            WrenchGp::train_scaled(&data, tare, base.scaling(), params, progress)?
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
/// row and on each trial of `test` (one trial: on
/// five contiguous blocks of it).
pub fn validate(
    name: &str,
    model: &dyn WrenchModel,
    test: &Dataset,
    sd: &[f64],
) -> Result<Validation, EvalError> {
    check_fits(model, test)?;
    let pred = model.predict_observed(test.x.view(), false)?.mean;
    let rmse = rmse_columns(test.y.view(), pred.view());
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
    Ok(Validation {
        model: name.into(),
        rmse: test.axes.axes().iter().copied().zip(rmse).collect(),
        score: chooser::score(test.y.view(), pred.view(), sd),
        trial_scores,
    })
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

/// The rows of new data held out to choose on: every fourth (set, trial)
/// group; with fewer than four, the last; with one, its last quarter.
/// Returns (training rows, held-out rows).
pub fn held_out(data: &Dataset) -> (Vec<usize>, Vec<usize>) {
    let groups = data.trials();
    let n = groups.len();
    let out = |k: usize| (k + 1).is_multiple_of(4) || (n < 4 && k + 1 == n);
    let (mut train, mut test) = (Vec::new(), Vec::new());
    if groups.len() == 1 {
        let rows = &groups[0].1;
        let cut = rows.len() - rows.len() / 4;
        return (rows[..cut].to_vec(), rows[cut..].to_vec());
    }
    for (k, (_, rows)) in groups.into_iter().enumerate() {
        match out(k) {
            true => test.extend(rows),
            false => train.extend(rows),
        }
    }
    (train, test)
}

/// `adapt`: the candidates for a new unit, each fitted on the new data less
/// its held-out part ([`held_out`]) and scored there: the base adapted
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
        let fit = |c: &Candidate,
                   d: &Dataset,
                   p: &mut (dyn FnMut(Axis, FitProgress) + Send)|
         -> Result<Box<dyn WrenchModel>, ModelError> {
            let (tare, scaling) = (self.tare.clone(), self.base.scaling());
            let alone = |family: &dyn ModelFamily, params, progress| {
                family.fit(Fit {
                    data: d,
                    tare: tare.clone(),
                    sensor: self.base.sensor().clone(),
                    input: scaling,
                    params,
                    warm: WarmStart::default(),
                    progress,
                })
            };
            match (c, &pool) {
                (Candidate::Other(family), _) => alone(*family, self.params, p),
                (Candidate::Gp(NEW_GP), _) => alone(&GpFamily, self.params, p),
                (Candidate::Gp(NEW_NETWORK), _) => alone(&GpFamily, &network, p),
                (Candidate::Gp(POOLED), Some((b, options))) => {
                    Ok(Box::new(b.pooled(self.base, d, tare, options, p)?))
                }
                _ => Ok(Box::new(self.base.adapt(
                    d,
                    tare,
                    self.from.clone(),
                    self.params,
                    p,
                )?)),
            }
        };
        let candidates = Candidate::all(pool.is_some());
        let (train, test) = held_out(self.data);
        let (train, test) = (self.data.select(&train), self.data.select(&test));
        let sd = spread(self.data);
        let mut validation = Vec::with_capacity(candidates.len());
        let mut fitted = Vec::with_capacity(candidates.len());
        let mut cost = Vec::with_capacity(candidates.len());
        for c in &candidates {
            let m = fit(c, &train, progress)?;
            validation.push(validate(&c.name(), m.as_ref(), &test, &sd)?);
            cost.push((m.predicted_estimate_us(), self.form(c, &pool)));
            fitted.push(m);
        }
        let (at, why) = choose(&validation, &cost);
        // The winner's standard deviation scale, from its held-out errors.
        let scales = std_scales(fitted[at].as_ref(), &test)?;
        drop(fitted);
        let chosen = &candidates[at];
        let choice = AdaptChoice {
            chosen: chosen.name(),
            held_out_rows: test.len(),
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
        let mut model = fit(chosen, self.data, progress)?;
        model.record(Making::StdScales(scales));
        model.record(Making::TrainedOn(trained_on));
        model.record(Making::AdaptChoice(Box::new(choice.clone())));
        Ok((model, choice))
    }

    /// The form of `candidate`, the pooled one's options `pool`.
    fn form(&self, candidate: &Candidate, pool: &Option<(&BaseData, Checked<GpParams>)>) -> Form {
        let gp = GpFamily::form_of;
        match (candidate, pool) {
            (Candidate::Other(f), _) => families::default_form(*f),
            (Candidate::Gp(NEW_NETWORK), _) => gp(MeanKind::Network),
            (Candidate::Gp(POOLED), Some((_, options))) => gp(options.mean),
            _ => gp(self.params.mean),
        }
    }
}

#[cfg(test)]
mod tests;
