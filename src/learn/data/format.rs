//! What a data file format is to the readers: which files it reads, and
//! their rows for the columns asked. The shipped formats and the registry
//! are in [`super::formats`]; a format of one's own implements [`Format`]
//! in a file of its own (tests/format_seam.rs).

use std::path::Path;

use super::bag::BagError;
use super::columns::Counts;
use super::source::Source;
use super::{records_layout, Dataset, DatasetError};
use crate::biotac::ElectrodeLayout;
use crate::exit::{Classify, ExitClass};
use crate::record::Record;
use crate::wrench::AxisSet;

/// Where what a reader has to say goes (a bag's pairing, a cut file).
pub type Say<'a> = &'a mut dyn FnMut(String);

/// A data file format.
pub trait Format: Sync {
    /// Its name, in messages.
    fn name(&self) -> &'static str;
    /// True when it reads the file at `path` (by its extension or its
    /// first bytes).
    fn reads(&self, path: &Path) -> bool;
    /// The rows of the file at `path` that `want` asks for, and the
    /// electrode layout of its readings.
    fn read(&self, path: &Path, want: &Want, say: Say) -> Result<FileRows, FileError>;
}

/// A file's rows and the electrode layout of its readings.
#[derive(Debug)]
pub struct FileRows {
    /// The electrode layout of its readings.
    pub layout: ElectrodeLayout,
    /// Its rows: the features asked for that layout, the axes asked.
    pub rows: Dataset,
}

/// Errors reading a data file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FileError {
    /// A file of rows refused.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// A bag refused.
    #[error(transparent)]
    Bag(#[from] BagError),
    /// Its sensor is not the one the rows are for.
    #[error("{0}")]
    Sensor(String),
}

/// A file that cannot be written is a failure; anything else is input refused.
impl Classify for FileError {
    fn class(&self) -> ExitClass {
        match self {
            FileError::Dataset(e) => e.class(),
            FileError::Bag(e) => e.class(),
            FileError::Sensor(_) => ExitClass::Refused,
        }
    }
}

/// The feature columns for a file of an electrode layout holding the
/// columns a test says it holds, or why that layout is refused.
pub type FeaturesFor<'a> =
    &'a dyn Fn(ElectrodeLayout, &dyn Fn(&str) -> bool) -> Result<Vec<String>, FileError>;

/// What is asked of a file.
pub struct Want<'a> {
    /// The feature columns for the file's electrode layout.
    pub features: FeaturesFor<'a>,
    /// The targets, in the file's own frame.
    pub axes: &'a AxisSet,
    /// What its BioTac channel columns hold.
    pub counts: Counts,
    /// Where its wrenches come from (a bag's topics and trials).
    pub source: &'a Source,
}

impl Want<'_> {
    /// The rows of `records` (a recording's, their trials numbered; every
    /// channel held), named `name` in errors.
    pub fn records(&self, records: &[Record], name: &str) -> Result<FileRows, FileError> {
        let layout = records_layout(records, name)?;
        let features = (self.features)(layout, &|_| true)?;
        let rows = Dataset::from_records(records, &features, self.axes, name)?;
        Ok(FileRows { layout, rows })
    }
}

/// True when the file at `path` has the extension `ext` (any case).
pub fn has_extension(path: &Path, ext: &str) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case(ext))
}
