//! The training-data CSV format.
//!
//! Header of a collected file (one row per BioTac frame, 100 Hz):
//!
//! `t,set,trial,e1..e19,pdc,pac_mean,tdc,tac,fx,fy,fz,tx,ty,tz`
//! (`e1..e24` from a BioTac SP)
//!
//! | column | meaning | unit |
//! |---|---|---|
//! | t | time since the start of the trial | s |
//! | set | data set: 1 mainly x, 2 mainly y, 3 mainly z, 4 combined | - |
//! | trial | trial number within the set | - |
//! | e1..e19 (e1..e24) | raw electrode values (not tared) | ADC counts |
//! | pdc, pac_mean, tdc, tac | static pressure, mean of the 22 PAC samples, temperature, heat flow | ADC counts |
//! | fx, fy, fz | reference force on the finger, BioTac frame | N |
//! | tx, ty, tz | reference torque about the BioTac origin, BioTac frame | Nm |
//!
//! Readers need only the columns they use: the feature columns, the target
//! columns of the requested axes and, optionally, `set` and `trial`. Other
//! columns are ignored.

use std::path::Path;

use ndarray::Array2;

use super::columns::{electrode_columns, layout_of, Counts, Plausible};
use super::{records_layout, Dataset, DatasetError};
use crate::biotac::ElectrodeLayout;
use crate::record::Record;
use crate::wrench::{Axis, AxisSet};

/// The full header of a collected file from a sensor of `layout`.
pub fn csv_header(layout: ElectrodeLayout) -> Vec<String> {
    let mut h: Vec<String> = ["t", "set", "trial"].map(String::from).to_vec();
    h.extend(electrode_columns(layout));
    h.extend(["pdc", "pac_mean", "tdc", "tac"].map(String::from));
    h.extend(Axis::ALL.iter().map(|a| a.name().to_string()));
    h
}

/// Writes records as CSV with the header [`csv_header`] of their layout;
/// refuses records that mix layouts.
pub fn write_csv(path: &Path, records: &[Record]) -> Result<(), DatasetError> {
    let p = path.display().to_string();
    let header = csv_header(records_layout(records, &p)?);
    let csv_err = |source| DatasetError::Write {
        path: p.clone(),
        source,
    };
    let mut w = csv::Writer::from_path(path).map_err(csv_err)?;
    w.write_record(&header).map_err(csv_err)?;
    let mut row: Vec<String> = Vec::with_capacity(header.len());
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
        CsvFile::open(path)?.rows(features, axes, counts)
    }
}

/// A CSV data file in memory, its header read.
pub struct CsvFile {
    path: String,
    bytes: Vec<u8>,
    header: Vec<String>,
}

impl CsvFile {
    /// Reads the file at `path` and its header.
    pub fn open(path: &Path) -> Result<Self, DatasetError> {
        let p = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|source| DatasetError::Io {
            path: p.clone(),
            source,
        })?;
        let header = reader(&bytes)
            .headers()
            .map_err(|source| DatasetError::Csv {
                path: p.clone(),
                source,
            })?
            .iter()
            .map(String::from)
            .collect();
        Ok(CsvFile {
            path: p,
            bytes,
            header,
        })
    }

    /// The electrode layout its columns hold.
    pub fn layout(&self) -> ElectrodeLayout {
        layout_of(&self.header)
    }

    /// True when it has the column `name`.
    pub fn holds(&self, name: &str) -> bool {
        self.header.iter().any(|h| h == name)
    }

    /// The named feature columns and the target columns of `axes`, as
    /// [`Dataset::read_csv`] reads them.
    pub fn rows(
        &self,
        features: &[String],
        axes: &AxisSet,
        counts: Counts,
    ) -> Result<Dataset, DatasetError> {
        let (p, header) = (&self.path, &self.header);
        let csv_err = |source| DatasetError::Csv {
            path: p.clone(),
            source,
        };
        let find = |name: &str| header.iter().position(|h| h == name);
        let need = |name: &str| {
            find(name).ok_or_else(|| DatasetError::MissingColumn {
                path: p.clone(),
                column: name.to_string(),
                header: header.join(","),
            })
        };
        let feature_idx: Vec<usize> = features.iter().map(|f| need(f)).collect::<Result<_, _>>()?;
        let axis_idx: Vec<usize> = (axes.axes().iter())
            .map(|a| need(a.name()))
            .collect::<Result<_, _>>()?;
        let (set_idx, trial_idx) = (find("set"), find("trial"));
        let fields = Fields {
            path: p,
            bytes: &self.bytes,
            header,
            plausible: header.iter().map(|h| Plausible::of(h, counts)).collect(),
        };

        let mut xs = Vec::new();
        let mut ys = Vec::new();
        let (mut set, mut trial) = (Vec::new(), Vec::new());
        let mut reader = reader(&self.bytes);
        let mut rec = csv::ByteRecord::new();
        while reader.read_byte_record(&mut rec).map_err(csv_err)? {
            let num = |i: usize| fields.value(&rec, i);
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
            return Err(DatasetError::Empty { path: p.clone() });
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
}

/// A reader of CSV `bytes` whose fields are trimmed as they are parsed:
/// one record is reused and only the columns taken are looked at.
fn reader(bytes: &[u8]) -> csv::Reader<&[u8]> {
    csv::ReaderBuilder::new()
        .trim(csv::Trim::Headers)
        .from_reader(bytes)
}

/// A CSV file's header and each column's plausible values: a field's value,
/// checked, or the error naming its line and column.
struct Fields<'a> {
    path: &'a str,
    bytes: &'a [u8],
    header: &'a [String],
    plausible: Vec<Option<Plausible>>,
}

impl Fields<'_> {
    /// The finite, plausible number in column `i` of `rec`.
    fn value(&self, rec: &csv::ByteRecord, i: usize) -> Result<f64, DatasetError> {
        let line = || rec.position().map_or(0, |pos| self.line_at(pos.byte()));
        let field = rec.get(i).unwrap_or(b"");
        let value = std::str::from_utf8(field)
            .ok()
            .and_then(|text| text.trim().parse::<f64>().ok())
            .filter(|v| v.is_finite())
            .ok_or_else(|| DatasetError::BadValue {
                path: self.path.into(),
                line: line(),
                column: self.header[i].clone(),
                value: String::from_utf8_lossy(field).trim().to_string(),
            })?;
        match self.plausible[i].as_ref().and_then(|c| c.check(value)) {
            None => Ok(value),
            Some(expected) => Err(DatasetError::Implausible {
                path: self.path.into(),
                at: format!("line {}", line()),
                column: self.header[i].clone(),
                value,
                expected: expected.to_string(),
            }),
        }
    }

    /// The line a record starting at `byte` is on, counted here: in files
    /// with CRLF line ends the csv crate's count, and its record offset,
    /// fall one line end short (the offset is at the '\n' of the previous one).
    fn line_at(&self, byte: u64) -> u64 {
        let bytes = self.bytes;
        let mut end = usize::try_from(byte).unwrap_or(usize::MAX).min(bytes.len());
        while bytes.get(end).is_some_and(|b| matches!(b, b'\r' | b'\n')) {
            end += 1;
        }
        1 + bytes[..end].iter().filter(|&&b| b == b'\n').count() as u64
    }
}
