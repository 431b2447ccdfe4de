//! Pooled retraining, a candidate beside an adapted model
//! ([`crate::learn::candidates`]): a model trained from scratch, with the
//! base model's options, on the base's own training data (found through
//! the reference its file keeps, [`TrainedOn`]) pooled with the new data;
//! when the base's data is not at hand, why ([`Unavailable`]).

use std::io::Read;
use std::path::{Path, PathBuf};

use super::data::sessions::{load_sessions, Features, Request};
use super::data::source::Source;
use super::data::Dataset;
use super::models::gp::fit::FitProgress;
use super::models::gp::GpParams;
use super::models::wrench_gp::{DataFile, ModelError, TareSpec, TrainedOn, WarmStart, WrenchGp};
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

/// What pooling took of the base's data, or why it is not a candidate:
/// what `adapt` and the calibration record.
pub fn pooling_note(base: &Result<BaseData, Unavailable>) -> String {
    match base {
        Ok(b) => b.describe(),
        Err(why) => format!("not considered: {why}"),
    }
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

#[cfg(test)]
pub(in crate::learn) mod tests;
