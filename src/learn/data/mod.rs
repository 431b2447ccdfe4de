//! Data sets (samples x features, with their targets and trials) and their
//! files: the training-data CSV format ([`csv`]), rosbag2 MCAP bags
//! ([`bag`]), ROS 1 bags ([`ros1`]) of hands' BioTac messages
//! ([`crate::biotac::hand`]), each a [`format::Format`] registered in
//! [`formats`]; bags cut into trials ([`trials`]) as their [`source`]
//! says; the nail camera's directories ([`nail`]); which columns hold what
//! ([`columns`]); any of them read as tared sessions of one sensor
//! ([`sessions`]).

pub mod bag;
pub mod columns;
pub mod csv;
pub mod format;
pub mod formats;
pub mod nail;
pub mod ros1;
pub mod sessions;
pub mod source;
pub mod trials;

use std::collections::BTreeMap;

use ndarray::{Array2, Array3, Axis as NdAxis};
use serde::{Deserialize, Serialize};

use crate::biotac::reading::Column;
use crate::biotac::ElectrodeLayout;
use crate::exit::{Classify, ExitClass};
use crate::record::Record;
use crate::wrench::AxisSet;
use columns::Plausible;

pub use columns::{
    channel_columns, electrode_columns, layout_of, Channel, Counts, MAX_FORCE_N, MAX_TORQUE_NM,
};
pub use csv::{csv_header, write_csv};

/// Errors reading or writing data sets.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DatasetError {
    /// The file could not be written.
    #[error("data file {path}: cannot write: {source}")]
    Write {
        /// File path.
        path: String,
        /// Underlying error.
        source: ::csv::Error,
    },
    /// The file could not be opened or read.
    #[error("data file {path}: {source}")]
    Io {
        /// File path.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The CSV structure is broken (e.g. a row with a different number of fields).
    #[error("data file {path}: malformed CSV: {source}")]
    Csv {
        /// File path.
        path: String,
        /// Underlying error.
        source: ::csv::Error,
    },
    /// A needed column is not in the header.
    #[error("{path}: missing column {column:?} (the header has: {header})")]
    MissingColumn {
        /// File path.
        path: String,
        /// Missing column name.
        column: String,
        /// The header found.
        header: String,
    },
    /// A field is not a finite number.
    #[error("{path}: line {line}, column {column:?}: {value:?} is not a finite number")]
    BadValue {
        /// File path.
        path: String,
        /// 1-based line number in the file.
        line: u64,
        /// Column name.
        column: String,
        /// Field text.
        value: String,
    },
    /// A value no BioTac or F/T sensor can give: a logging glitch.
    #[error("{path}: {at}, column {column:?}: {value:e} cannot be true: expected {expected}")]
    Implausible {
        /// File path.
        path: String,
        /// Where: "line N" (CSV) or "reading N" (bag).
        at: String,
        /// Column name.
        column: String,
        /// The value.
        value: f64,
        /// What such a column holds.
        expected: String,
    },
    /// Readings of a BioTac and of a BioTac SP in one session.
    #[error("{path}: readings of {first} and of {other} in one session")]
    MixedLayouts {
        /// File path.
        path: String,
        /// The first reading's layout.
        first: ElectrodeLayout,
        /// Another reading's.
        other: ElectrodeLayout,
    },
    /// The file has a header but no rows.
    #[error("{path}: no data rows")]
    Empty {
        /// File path.
        path: String,
    },
    /// A trial is too short to take its tare from its first rows.
    #[error(
        "set {set} trial {trial} has {rows} rows, fewer than the {needed} out-of-contact rows \
         needed for its tare"
    )]
    TareTooShort {
        /// Set number.
        set: u32,
        /// Trial number.
        trial: u32,
        /// Rows in the trial.
        rows: usize,
        /// Rows needed.
        needed: usize,
    },
}

/// How the training features were tared.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TareSpec {
    /// Out-of-contact samples at the start of each trial that gave its baseline.
    pub samples: usize,
    /// Baseline of each feature, averaged over the training trials (counts).
    pub mean_baseline: Vec<f64>,
}

/// A file not written is a failure; anything else is a data file refused.
impl Classify for DatasetError {
    fn class(&self) -> ExitClass {
        match self {
            DatasetError::Write { .. } => ExitClass::Failure,
            _ => ExitClass::Refused,
        }
    }
}

/// The electrode layout of every record (a BioTac's when there are none),
/// refused when they mix layouts.
pub fn records_layout(records: &[Record], source: &str) -> Result<ElectrodeLayout, DatasetError> {
    let Some(first) = records.first().map(|r| r.reading.electrodes.layout()) else {
        return Ok(ElectrodeLayout::default());
    };
    match records
        .iter()
        .map(|r| r.reading.electrodes.layout())
        .find(|l| *l != first)
    {
        Some(other) => Err(DatasetError::MixedLayouts {
            path: source.to_string(),
            first,
            other,
        }),
        None => Ok(first),
    }
}

/// Samples as rows: features, targets and the trial each row belongs to.
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// Feature column names, in the column order of `x`.
    pub features: Vec<String>,
    /// Features, samples x features.
    pub x: Array2<f64>,
    /// Target axes, in the column order of `y`.
    pub axes: AxisSet,
    /// Targets, samples x axes (N or Nm).
    pub y: Array2<f64>,
    /// Set of each row (0 when the file has no `set` column).
    pub set: Vec<u32>,
    /// Trial of each row (0 when the file has no `trial` column).
    pub trial: Vec<u32>,
    /// An image per row (rows x height x width), for a sensor that has
    /// them: the nail camera's registered nail, for the CNN. None for the
    /// BioTac.
    pub images: Option<Array3<f32>>,
}

impl Dataset {
    /// The `features` (columns of [`csv_header`]: e1..e19 or e1..e24, pdc,
    /// pac_mean, tdc, tac) and `axes` targets of records, as
    /// [`Dataset::read_csv`] reads them back from [`write_csv`]'s file;
    /// `source` names the records in an error.
    pub fn from_records(
        records: &[Record],
        features: &[String],
        axes: &AxisSet,
        source: &str,
    ) -> Result<Self, DatasetError> {
        let layout = records_layout(records, source)?;
        let columns = features
            .iter()
            .map(|f| {
                Column::from_name(f)
                    .filter(|c| !matches!(c, Column::Electrode(i) if *i >= layout.count()))
                    .ok_or_else(|| DatasetError::MissingColumn {
                        path: source.to_string(),
                        column: f.clone(),
                        header: csv_header(layout).join(","),
                    })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let n = records.len();
        if n == 0 {
            return Err(DatasetError::Empty {
                path: source.to_string(),
            });
        }
        let x = Array2::from_shape_fn((n, columns.len()), |(i, j)| {
            columns[j].value(&records[i].reading)
        });
        let y = Array2::from_shape_fn((n, axes.len()), |(i, j)| {
            records[i].wrench.get(axes.axes()[j])
        });
        // Readings are raw counts; a reading or wrench that cannot be true
        // is refused with its place.
        let names = features
            .iter()
            .map(String::as_str)
            .zip(x.columns())
            .chain(axes.axes().iter().map(|a| a.name()).zip(y.columns()));
        for (name, column) in names {
            let plausible = Plausible::of(name, Counts::Raw);
            for (i, &value) in column.iter().enumerate() {
                let bad = (!value.is_finite())
                    .then_some("a finite number")
                    .or_else(|| plausible.as_ref().and_then(|c| c.check(value)))
                    .map(String::from);
                if let Some(expected) = bad {
                    return Err(DatasetError::Implausible {
                        path: source.to_string(),
                        at: format!("reading {}", i + 1),
                        column: name.to_string(),
                        value,
                        expected,
                    });
                }
            }
        }
        Ok(Dataset {
            features: features.to_vec(),
            x,
            axes: axes.clone(),
            y,
            set: records.iter().map(|r| r.set).collect(),
            trial: records.iter().map(|r| r.trial).collect(),
            images: None,
        })
    }

    /// At most `n` rows, drawn at random without replacement and kept in
    /// their original order; all rows when there are not more than `n`.
    pub fn random_rows(&self, n: usize, rng: &mut impl rand::Rng) -> Dataset {
        if self.len() <= n {
            return self.clone();
        }
        let mut idx = rand::seq::index::sample(rng, self.len(), n).into_vec();
        idx.sort_unstable();
        self.select(&idx)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.x.nrows()
    }

    /// True when there is no sample.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The (set, trial) groups in order of first appearance, with their rows.
    pub fn trials(&self) -> Vec<((u32, u32), Vec<usize>)> {
        let mut order: Vec<(u32, u32)> = Vec::new();
        let mut rows: BTreeMap<(u32, u32), Vec<usize>> = BTreeMap::new();
        for (i, key) in self
            .set
            .iter()
            .copied()
            .zip(self.trial.iter().copied())
            .enumerate()
        {
            rows.entry(key)
                .or_insert_with(|| {
                    order.push(key);
                    Vec::new()
                })
                .push(i);
        }
        order
            .into_iter()
            .map(|k| (k, rows.remove(&k).unwrap_or_default()))
            .collect()
    }

    /// The data with the one trial of each set that has only one cut into
    /// `k` contiguous blocks of rows, each a trial (trial-wise folds then
    /// never hold rows of one stretch on both sides), and the sets so cut.
    pub fn single_trials_in_blocks(&self, k: usize) -> (Dataset, Vec<u32>) {
        let trials = self.trials();
        let mut per_set: BTreeMap<u32, Vec<&[usize]>> = BTreeMap::new();
        for ((set, _), rows) in &trials {
            per_set.entry(*set).or_default().push(rows);
        }
        let mut out = self.clone();
        let mut cut = Vec::new();
        for (set, rows) in per_set {
            if let [rows] = rows[..] {
                let n = rows.len().max(1);
                for (j, &i) in rows.iter().enumerate() {
                    out.trial[i] = (j * k / n) as u32 + 1;
                }
                cut.push(set);
            }
        }
        (out, cut)
    }

    /// Subtracts from every feature and target its mean over the first
    /// `samples` rows of the same trial (taken out of contact), as the
    /// BioTac and the F/T sensor are tared before each trial. A file without
    /// set/trial columns is one trial. Returns the feature baselines
    /// averaged over the trials.
    pub fn tare_per_trial(&mut self, samples: usize) -> Result<Vec<f64>, DatasetError> {
        let trials = self.trials();
        let mut mean_base = vec![0.0; self.x.ncols()];
        for ((set, trial), rows) in &trials {
            let (set, trial) = (*set, *trial);
            if rows.len() < samples || samples == 0 {
                return Err(DatasetError::TareTooShort {
                    set,
                    trial,
                    rows: rows.len(),
                    needed: samples.max(1),
                });
            }
            let base = self
                .x
                .select(NdAxis(0), &rows[..samples])
                .mean_axis(NdAxis(0))
                .expect("at least one row");
            let offset = self
                .y
                .select(NdAxis(0), &rows[..samples])
                .mean_axis(NdAxis(0))
                .expect("at least one row");
            for &r in rows {
                let mut row = self.x.row_mut(r);
                row -= &base;
                let mut target = self.y.row_mut(r);
                target -= &offset;
            }
            for (m, b) in mean_base.iter_mut().zip(&base) {
                *m += b / trials.len() as f64;
            }
        }
        Ok(mean_base)
    }

    /// The rows of `parts` one after the other; None when they differ in
    /// features or axes, or there are none.
    pub fn concat(parts: &[&Dataset]) -> Option<Dataset> {
        let first = parts.first()?;
        if parts
            .iter()
            .any(|p| p.features != first.features || p.axes != first.axes)
        {
            return None;
        }
        let stack = |m: Vec<ndarray::ArrayView2<f64>>| ndarray::concatenate(NdAxis(0), &m).ok();
        Some(Dataset {
            features: first.features.clone(),
            x: stack(parts.iter().map(|p| p.x.view()).collect())?,
            axes: first.axes.clone(),
            y: stack(parts.iter().map(|p| p.y.view()).collect())?,
            set: parts.iter().flat_map(|p| p.set.iter().copied()).collect(),
            trial: parts.iter().flat_map(|p| p.trial.iter().copied()).collect(),
            images: parts
                .iter()
                .map(|p| p.images.as_ref().map(|m| m.view()))
                .collect::<Option<Vec<_>>>()
                .and_then(|v| ndarray::concatenate(NdAxis(0), &v).ok()),
        })
    }

    /// The rows `idx`, in that order.
    pub fn select(&self, idx: &[usize]) -> Dataset {
        Dataset {
            features: self.features.clone(),
            x: self.x.select(NdAxis(0), idx),
            axes: self.axes.clone(),
            y: self.y.select(NdAxis(0), idx),
            set: idx.iter().map(|&i| self.set[i]).collect(),
            trial: idx.iter().map(|&i| self.trial[i]).collect(),
            images: self.images.as_ref().map(|m| m.select(NdAxis(0), idx)),
        }
    }

    /// Only its feature columns `names` (those it has), in that order.
    pub fn with_features(&self, names: &[String]) -> Dataset {
        let idx: Vec<usize> = (names.iter())
            .filter_map(|n| self.features.iter().position(|f| f == n))
            .collect();
        Dataset {
            features: idx.iter().map(|&i| self.features[i].clone()).collect(),
            x: self.x.select(NdAxis(1), &idx),
            axes: self.axes.clone(),
            y: self.y.clone(),
            set: self.set.clone(),
            trial: self.trial.clone(),
            images: self.images.clone(),
        }
    }
}

/// Trial-wise k-fold split as in Huhnstock (2014): within each set, the
/// trials are cut into `k` consecutive blocks; fold `f` tests on block `f` of
/// every set and trains on the rest (10 trials, k = 5: 8 train, 2 test).
/// Returns (train rows, test rows) per fold; a trial is never on both sides.
pub fn trialwise_folds(ds: &Dataset, k: usize) -> Vec<(Vec<usize>, Vec<usize>)> {
    let trials = ds.trials();
    let mut by_set: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (t, ((set, _), _)) in trials.iter().enumerate() {
        by_set.entry(*set).or_default().push(t);
    }
    (0..k)
        .map(|f| {
            let (mut train, mut test) = (Vec::new(), Vec::new());
            for set_trials in by_set.values() {
                let m = set_trials.len();
                for (j, &t) in set_trials.iter().enumerate() {
                    let side = if j * k / m.max(1) == f {
                        &mut test
                    } else {
                        &mut train
                    };
                    side.extend_from_slice(&trials[t].1);
                }
            }
            (train, test)
        })
        .collect()
}

#[cfg(test)]
mod tests;
