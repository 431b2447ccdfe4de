//! The training-data CSV format and data sets (samples x features).
//!
//! Header of a collected file (one row per BioTac frame, 100 Hz):
//!
//! `t,set,trial,e1..e19,pdc,pac_mean,tdc,tac,fx,fy,fz,tx,ty,tz`
//!
//! | column | meaning | unit |
//! |---|---|---|
//! | t | time since the start of the trial | s |
//! | set | data set: 1 mainly x, 2 mainly y, 3 mainly z, 4 combined | - |
//! | trial | trial number within the set | - |
//! | e1..e19 | raw electrode values (not tared) | ADC counts |
//! | pdc, pac_mean, tdc, tac | static pressure, mean of the 22 PAC samples, temperature, heat flow | ADC counts |
//! | fx, fy, fz | reference force on the finger, BioTac frame | N |
//! | tx, ty, tz | reference torque about the BioTac origin, BioTac frame | Nm |
//!
//! Readers need only the columns they use: the feature columns, the target
//! columns of the requested axes and, optionally, `set` and `trial`. Other
//! columns are ignored.

use std::collections::BTreeMap;
use std::path::Path;

use ndarray::{Array2, Array3, Axis as NdAxis};

use crate::biotac::reading::Column;
use crate::biotac::{ADC_MAX, N_ELECTRODES};
use crate::record::Record;
use crate::wrench::{Axis, AxisSet};

/// Errors reading or writing data sets.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DatasetError {
    /// The file could not be written.
    #[error("{path}: cannot write: {source}")]
    Write {
        /// File path.
        path: String,
        /// Underlying error.
        source: csv::Error,
    },
    /// The file could not be opened or read.
    #[error("{path}: {source}")]
    Io {
        /// File path.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The CSV structure is broken (e.g. a row with a different number of fields).
    #[error("{path}: malformed CSV: {source}")]
    Csv {
        /// File path.
        path: String,
        /// Underlying error.
        source: csv::Error,
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

/// What the BioTac channel columns of a file hold.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Counts {
    /// Raw 12-bit ADC counts, 0 to 4095 (docs/ARCHITECTURE.md, "BioTac").
    Raw,
    /// Counts already tared: -4095 to 4095.
    Tared,
}

/// The largest force (N) in a data file that can be true: a million
/// newtons, beyond what any six-axis F/T sensor measures and anything a
/// fingertip survives. A modelling bound that catches logging glitches.
pub const MAX_FORCE_N: f64 = 1e6;
/// The same for torques (Nm).
pub const MAX_TORQUE_NM: f64 = 1e5;

/// What column `name` must hold when `value` cannot be true there: a
/// BioTac channel beyond the 12-bit range, a force or torque beyond any
/// sensor's. None when the value can be true (or the column is no
/// BioTac channel or wrench axis).
fn implausible(name: &str, value: f64, counts: Counts) -> Option<String> {
    let adc = f64::from(ADC_MAX);
    if Column::from_name(name).is_some() {
        let low = match counts {
            Counts::Raw => 0.0,
            Counts::Tared => -adc,
        };
        let what = match counts {
            Counts::Raw => "a raw",
            Counts::Tared => "a tared",
        };
        return (!(low..=adc).contains(&value))
            .then(|| format!("{what} 12-bit BioTac count, {low} to {adc}"));
    }
    let axis: Axis = name.parse().ok()?;
    let (max, unit) = if axis.index() < 3 {
        (MAX_FORCE_N, "N")
    } else {
        (MAX_TORQUE_NM, "Nm")
    };
    (value.abs() > max)
        .then(|| format!("a wrench within +-{max:e} {unit}, what an F/T sensor can measure"))
}

/// Names of the 19 electrode columns, `e1..e19`: the GP's features.
pub fn electrode_columns() -> Vec<String> {
    (1..=N_ELECTRODES).map(|i| format!("e{i}")).collect()
}

/// A group of BioTac channels a model may take as features.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Channel {
    /// The 19 impedance electrodes, `e1..e19`.
    Electrodes,
    /// Static pressure, `pdc`.
    Pdc,
    /// Temperature, `tdc`.
    Tdc,
    /// Heat flow, `tac`.
    Tac,
}

impl std::str::FromStr for Channel {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim() {
            "electrodes" => Ok(Channel::Electrodes),
            "pdc" => Ok(Channel::Pdc),
            "tdc" => Ok(Channel::Tdc),
            "tac" => Ok(Channel::Tac),
            other => Err(format!(
                "unknown channel {other:?}: expected electrodes, pdc, tdc or tac"
            )),
        }
    }
}

impl Channel {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Channel::Electrodes => "electrodes",
            Channel::Pdc => "pdc",
            Channel::Tdc => "tdc",
            Channel::Tac => "tac",
        }
    }
}

/// The feature columns of `channels`, in the order given.
pub fn channel_columns(channels: &[Channel]) -> Vec<String> {
    channels
        .iter()
        .flat_map(|c| match c {
            Channel::Electrodes => electrode_columns(),
            Channel::Pdc => vec!["pdc".into()],
            Channel::Tdc => vec!["tdc".into()],
            Channel::Tac => vec!["tac".into()],
        })
        .collect()
}

/// The full header of a collected file.
pub fn csv_header() -> Vec<String> {
    let mut h: Vec<String> = ["t", "set", "trial"].map(String::from).to_vec();
    h.extend(electrode_columns());
    h.extend(["pdc", "pac_mean", "tdc", "tac"].map(String::from));
    h.extend(Axis::ALL.iter().map(|a| a.name().to_string()));
    h
}

/// Writes records as CSV with the header [`csv_header`].
pub fn write_csv(path: &Path, records: &[Record]) -> Result<(), DatasetError> {
    let p = path.display().to_string();
    let csv_err = |source| DatasetError::Write {
        path: p.clone(),
        source,
    };
    let mut w = csv::Writer::from_path(path).map_err(csv_err)?;
    w.write_record(csv_header()).map_err(csv_err)?;
    let mut row: Vec<String> = Vec::with_capacity(csv_header().len());
    for r in records {
        row.clear();
        row.push(format!("{:.2}", r.t));
        row.push(r.set.to_string());
        row.push(r.trial.to_string());
        row.extend(r.reading.electrodes.iter().map(|e| e.to_string()));
        row.push(r.reading.pdc.to_string());
        row.push(format!("{:.2}", r.reading.pac_mean()));
        row.push(r.reading.tdc.to_string());
        row.push(r.reading.tac.to_string());
        row.extend(Axis::ALL.iter().map(|&a| format!("{:.6}", r.wrench.get(a))));
        w.write_record(&row).map_err(csv_err)?;
    }
    w.flush().map_err(|e| csv_err(e.into()))
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
    /// Reads the named feature columns and the target columns of `axes`;
    /// BioTac channel columns hold `counts`. A value that cannot be true
    /// (a count beyond 12 bits, a force beyond any F/T sensor's) is refused
    /// with its line and column.
    pub fn read_csv(
        path: &Path,
        features: &[String],
        axes: &AxisSet,
        counts: Counts,
    ) -> Result<Self, DatasetError> {
        let p = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| DatasetError::Io {
            path: p.clone(),
            source,
        })?;
        let csv_err = |source| DatasetError::Csv {
            path: p.clone(),
            source,
        };
        // The line a record starts on, counted here: in files with CRLF
        // line ends the csv crate's count, and its record offset, fall one
        // line end short (the offset is at the '\n' of the previous one).
        let line_at = |byte: u64| {
            let mut end = usize::try_from(byte).unwrap_or(usize::MAX).min(bytes.len());
            while bytes.get(end).is_some_and(|b| matches!(b, b'\r' | b'\n')) {
                end += 1;
            }
            1 + bytes[..end].iter().filter(|&&b| b == b'\n').count() as u64
        };
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(bytes.as_slice());
        let header: Vec<String> = reader
            .headers()
            .map_err(csv_err)?
            .iter()
            .map(String::from)
            .collect();
        let find = |name: &str| header.iter().position(|h| h == name);
        let need = |name: &str| {
            find(name).ok_or_else(|| DatasetError::MissingColumn {
                path: p.clone(),
                column: name.to_string(),
                header: header.join(","),
            })
        };
        let feature_idx = features
            .iter()
            .map(|f| need(f))
            .collect::<Result<Vec<_>, _>>()?;
        let axis_idx = axes
            .axes()
            .iter()
            .map(|a| need(a.name()))
            .collect::<Result<Vec<_>, _>>()?;
        let (set_idx, trial_idx) = (find("set"), find("trial"));

        let mut xs = Vec::new();
        let mut ys = Vec::new();
        let (mut set, mut trial) = (Vec::new(), Vec::new());
        for rec in reader.records() {
            let rec = rec.map_err(csv_err)?;
            let line = || rec.position().map_or(0, |pos| line_at(pos.byte()));
            let num = |i: usize| -> Result<f64, DatasetError> {
                let text = rec.get(i).unwrap_or("");
                let value = text
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| DatasetError::BadValue {
                        path: p.clone(),
                        line: line(),
                        column: header[i].clone(),
                        value: text.to_string(),
                    })?;
                match implausible(&header[i], value, counts) {
                    None => Ok(value),
                    Some(expected) => Err(DatasetError::Implausible {
                        path: p.clone(),
                        at: format!("line {}", line()),
                        column: header[i].clone(),
                        value,
                        expected,
                    }),
                }
            };
            for &i in &feature_idx {
                xs.push(num(i)?);
            }
            for &i in &axis_idx {
                ys.push(num(i)?);
            }
            set.push(set_idx.map(num).transpose()?.unwrap_or(0.0) as u32);
            trial.push(trial_idx.map(num).transpose()?.unwrap_or(0.0) as u32);
        }
        let n = set.len();
        if n == 0 {
            return Err(DatasetError::Empty { path: p });
        }
        let shape_ok = "row-major buffers sized rows x columns";
        Ok(Dataset {
            features: features.to_vec(),
            x: Array2::from_shape_vec((n, features.len()), xs).expect(shape_ok),
            axes: axes.clone(),
            y: Array2::from_shape_vec((n, axes.len()), ys).expect(shape_ok),
            set,
            trial,
            images: None,
        })
    }

    /// The `features` (columns of [`csv_header`]: e1..e19, pdc, pac_mean,
    /// tdc, tac) and `axes` targets of records, as [`Dataset::read_csv`]
    /// reads them back from [`write_csv`]'s file; `source` names the
    /// records in an error.
    pub fn from_records(
        records: &[Record],
        features: &[String],
        axes: &AxisSet,
        source: &str,
    ) -> Result<Self, DatasetError> {
        let columns = features
            .iter()
            .map(|f| {
                Column::from_name(f).ok_or_else(|| DatasetError::MissingColumn {
                    path: source.to_string(),
                    column: f.clone(),
                    header: csv_header().join(","),
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
            for (i, &value) in column.iter().enumerate() {
                let bad = (!value.is_finite())
                    .then(|| "a finite number".to_string())
                    .or_else(|| implausible(name, value, Counts::Raw));
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
mod tests {
    use super::*;
    use std::io::Write;

    fn write(text: &str) -> tempfile::NamedTempFile {
        let mut f = tempfile::NamedTempFile::new().unwrap();
        f.write_all(text.as_bytes()).unwrap();
        f
    }

    #[test]
    fn reads_only_the_needed_columns_and_names_a_missing_one() {
        let f = write("t,set,trial,e1,junk,fz,fx\n0,1,1,10,x,0.5,0.1\n0.01,1,2,12,y,0.7,0.2\n");
        let axes: AxisSet = "fx,fz".parse().unwrap();
        let ds = Dataset::read_csv(f.path(), &["e1".into()], &axes, Counts::Raw).unwrap();
        assert_eq!(ds.x.column(0).to_vec(), vec![10.0, 12.0]);
        assert_eq!(ds.y.row(1).to_vec(), vec![0.2, 0.7]);
        assert_eq!(ds.trial, vec![1, 2]);
        let err = Dataset::read_csv(f.path(), &["e2".into()], &axes, Counts::Raw).unwrap_err();
        assert!(err.to_string().contains("missing column \"e2\""), "{err}");
        let err = Dataset::read_csv(f.path(), &["junk".into()], &axes, Counts::Raw).unwrap_err();
        assert!(err.to_string().contains("line 2, column \"junk\""), "{err}");
    }

    #[test]
    fn values_that_cannot_be_true_are_refused_with_their_line_even_in_crlf_files() {
        let axes: AxisSet = "fz,tx".parse().unwrap();
        let e1 = ["e1".to_string()];
        for (row, says, counts) in [
            ("1,1,1e300,0.5,0", "1e300 cannot be true", Counts::Raw),
            ("1,1,4096,0.5,0", "0 to 4095", Counts::Raw),
            ("1,1,-1,0.5,0", "a raw 12-bit", Counts::Raw),
            ("1,1,-4096,0.5,0", "a tared 12-bit", Counts::Tared),
            ("1,1,10,2e6,0", "column \"fz\"", Counts::Raw),
            ("1,1,10,0.5,-2e5", "column \"tx\"", Counts::Raw),
        ] {
            for end in ["\n", "\r\n"] {
                let text = format!("set,trial,e1,fz,tx{end}1,1,10,0.5,0{end}{row}{end}");
                let f = write(&text);
                let err = Dataset::read_csv(f.path(), &e1, &axes, counts).unwrap_err();
                let msg = err.to_string();
                assert!(
                    msg.contains("line 3,") && msg.contains(says),
                    "{end:?}: {msg}"
                );
            }
        }
        // Tared counts may go below zero; raw ones up to 4095.
        let f = write("set,trial,e1,fz,tx\n1,1,-40,0.5,0\n1,1,4095,-0.5,1\n");
        Dataset::read_csv(f.path(), &e1, &axes, Counts::Tared).unwrap();
        let f = write("set,trial,e1,fz,tx\n1,1,40,0.5,0\n1,1,4095,-0.5,1\n");
        Dataset::read_csv(f.path(), &e1, &axes, Counts::Raw).unwrap();
    }

    #[test]
    fn a_bag_reading_or_wrench_that_cannot_be_true_is_refused_with_its_place() {
        use crate::biotac::{BioTacReading, N_PAC};
        use crate::wrench::Wrench;
        let record = |e1: u16, fz: f64| {
            let mut electrodes = [2000; N_ELECTRODES];
            electrodes[0] = e1;
            Record {
                t: 0.0,
                set: 1,
                trial: 1,
                reading: BioTacReading {
                    seq: 0,
                    stamp_s: 0.0,
                    electrodes,
                    pdc: 2000,
                    pac: [2000; N_PAC],
                    tdc: 2000,
                    tac: 2000,
                },
                wrench: Wrench::new(nalgebra::Vector3::new(0.0, 0.0, fz), Default::default()),
            }
        };
        let (e1, fz): (Vec<String>, AxisSet) = (vec!["e1".into()], "fz".parse().unwrap());
        let from = |records: &[Record]| Dataset::from_records(records, &e1, &fz, "bag.mcap");
        from(&[record(2000, 1.0), record(4095, -2.0)]).unwrap();
        let e = from(&[record(2000, 1.0), record(4096, 1.0)])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("bag.mcap: reading 2, column \"e1\"") && e.contains("4095"),
            "{e}"
        );
        let e = from(&[record(2000, f64::NAN)]).unwrap_err().to_string();
        assert!(
            e.contains("reading 1, column \"fz\"") && e.contains("finite"),
            "{e}"
        );
        let e = from(&[record(2000, 3e6)]).unwrap_err().to_string();
        assert!(
            e.contains("reading 1, column \"fz\"") && e.contains("1e6 N"),
            "{e}"
        );
    }

    #[test]
    fn records_in_memory_equal_records_read_back_from_csv() {
        use crate::biotac::sim::BioTacSimConfig;
        use crate::sim::collect::{collect, CollectConfig};
        let records = &collect(&CollectConfig::default(), &BioTacSimConfig::default(), 3, 3)[..300];
        let f = tempfile::NamedTempFile::new().unwrap();
        write_csv(f.path(), records).unwrap();
        let axes = AxisSet::forces();
        let all = [
            Channel::Electrodes,
            Channel::Pdc,
            Channel::Tdc,
            Channel::Tac,
        ];
        let features = channel_columns(&all);
        assert_eq!(features.len(), 22);
        let read = Dataset::read_csv(f.path(), &features, &axes, Counts::Raw).unwrap();
        let mem = Dataset::from_records(records, &features, &axes, "memory").unwrap();
        assert_eq!((mem.x, mem.set, mem.trial), (read.x, read.set, read.trial));
        let err = Dataset::from_records(records, &["pressure".into()], &axes, "memory");
        assert!(err
            .unwrap_err()
            .to_string()
            .contains("missing column \"pressure\""));
        // The file keeps targets to the precision it writes them with.
        let worst = (&mem.y - &read.y)
            .mapv(f64::abs)
            .fold(0.0f64, |a, &b| a.max(b));
        assert!(worst < 1e-6, "{worst}");
    }

    #[test]
    fn folds_never_mix_a_trial_and_cover_every_row_once() {
        let mut text = String::from("set,trial,e1,fz\n");
        for set in 1..=4 {
            for trial in 1..=10 {
                for s in 0..3 {
                    text += &format!("{set},{trial},{s},0\n");
                }
            }
        }
        let f = write(&text);
        let ds = Dataset::read_csv(
            f.path(),
            &["e1".into()],
            &"fz".parse().unwrap(),
            Counts::Raw,
        )
        .unwrap();
        let folds = trialwise_folds(&ds, 5);
        let mut tested = vec![0; ds.len()];
        for (train, test) in &folds {
            let key = |i: &usize| (ds.set[*i], ds.trial[*i]);
            let train_trials: std::collections::BTreeSet<_> = train.iter().map(key).collect();
            let test_trials: std::collections::BTreeSet<_> = test.iter().map(key).collect();
            assert!(train_trials.is_disjoint(&test_trials));
            assert_eq!((train_trials.len(), test_trials.len()), (32, 8));
            test.iter().for_each(|&i| tested[i] += 1);
        }
        assert!(tested.iter().all(|&c| c == 1));
    }

    #[test]
    fn tare_subtracts_each_trials_own_baseline() {
        let f = write(
            "set,trial,e1,fz\n1,1,100,0\n1,1,102,0\n1,1,90,1\n1,2,50,0\n1,2,50,0\n1,2,40,1\n",
        );
        let mut ds = Dataset::read_csv(
            f.path(),
            &["e1".into()],
            &"fz".parse().unwrap(),
            Counts::Raw,
        )
        .unwrap();
        ds.tare_per_trial(2).unwrap();
        assert_eq!(
            ds.x.column(0).to_vec(),
            vec![-1.0, 1.0, -11.0, 0.0, 0.0, -10.0]
        );
        assert!(matches!(
            ds.tare_per_trial(4),
            Err(DatasetError::TareTooShort { needed: 4, .. })
        ));
    }
}
