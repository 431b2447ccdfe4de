//! The data file formats, registered in one place: CSV, rosbag2 MCAP and
//! ROS 1 bags. Every data file is read through [`read`]: the sessions
//! reader ([`super::sessions`]) and so `train`, `eval`, `adapt`,
//! `tradeoff`, pooled retraining and the calibration's pooled candidate.
//! A new format is one module implementing [`Format`] and its line in
//! `SHIPPED` below; one defined outside the crate is added with [`register`].

use std::path::Path;
use std::sync::{PoisonError, RwLock};

use nalgebra::Vector3;

use super::bag::{read_bag, Bag};
use super::columns::Counts;
use super::csv::CsvFile;
use super::format::{has_extension, FeaturesFor, FileError, FileRows, Format, Say, Want};
use super::ros1::{is_ros1_bag, read_ros1_bag};
use super::source::Source;
use crate::wrench::{AxisSet, Wrench};

/// The shipped formats, tried in this order after those registered; a
/// file none reads is read as CSV.
const SHIPPED: [&dyn Format; 3] = [&Csv, &Mcap, &Ros1];

/// Formats registered at run time, tried first.
static REGISTERED: RwLock<Vec<&'static dyn Format>> = RwLock::new(Vec::new());

/// Adds `format` to those every data file is tried with, before the
/// shipped ones; a format of the same name is added once.
pub fn register(format: &'static dyn Format) {
    let mut formats = REGISTERED.write().unwrap_or_else(PoisonError::into_inner);
    if formats.iter().all(|f| f.name() != format.name()) {
        formats.push(format);
    }
}

/// The format of the file at `path`: the first registered, then shipped,
/// that reads it; CSV when none does.
pub fn format_of(path: &Path) -> &'static dyn Format {
    let registered = REGISTERED.read().unwrap_or_else(PoisonError::into_inner);
    let found = registered.iter().chain(&SHIPPED).find(|f| f.reads(path));
    found.copied().unwrap_or(&Csv)
}

/// The file at `path` in its format: the `features` for its layout and the
/// targets `axes`, its BioTac channels holding `counts`; wrenches moved to
/// the BioTac frame when `source` says where the F/T sensor is.
pub fn read(
    path: &Path,
    features: FeaturesFor,
    axes: &AxisSet,
    counts: Counts,
    source: &Source,
    say: Say,
) -> Result<FileRows, FileError> {
    // Every BioTac-frame component needs the whole force (and torque).
    let torques = axes.axes().iter().any(|a| a.index() >= 3);
    let read = match (source.ft_to_biotac, torques) {
        (None, _) => axes.clone(),
        (Some(_), true) => AxisSet::wrench(),
        (Some(_), false) => AxisSet::forces(),
    };
    let want = Want {
        features,
        axes: &read,
        counts,
        source,
    };
    let mut file = format_of(path).read(path, &want, say)?;
    if let Some(transform) = source.ft_to_biotac {
        let ds = &mut file.rows;
        ds.y = ndarray::Array2::from_shape_fn((ds.len(), axes.len()), |(i, j)| {
            let row = ds.y.row(i);
            let torque = match torques {
                true => Vector3::new(row[3], row[4], row[5]),
                false => Vector3::zeros(),
            };
            let w = Wrench::new(Vector3::new(row[0], row[1], row[2]), torque);
            transform.apply(&w).get(axes.axes()[j])
        });
        ds.axes = axes.clone();
    }
    Ok(file)
}

/// CSV files ([`super::csv`]), by their `.csv` extension.
struct Csv;

impl Format for Csv {
    fn name(&self) -> &'static str {
        "CSV"
    }

    fn reads(&self, path: &Path) -> bool {
        has_extension(path, "csv")
    }

    fn read(&self, path: &Path, want: &Want, _: Say) -> Result<FileRows, FileError> {
        let file = CsvFile::open(path)?;
        let layout = file.layout();
        let features = (want.features)(layout, &|c| file.holds(c))?;
        let rows = file.rows(&features, want.axes, want.counts)?;
        Ok(FileRows { layout, rows })
    }
}

/// rosbag2 MCAP files ([`super::bag`]), by their `.mcap` extension.
struct Mcap;

impl Format for Mcap {
    fn name(&self) -> &'static str {
        "rosbag2 MCAP"
    }

    fn reads(&self, path: &Path) -> bool {
        has_extension(path, "mcap")
    }

    fn read(&self, path: &Path, want: &Want, say: Say) -> Result<FileRows, FileError> {
        let bag = read_bag(path, &want.source.topics)?;
        bag_rows(path, bag, want, say)
    }
}

/// ROS 1 bags ([`super::ros1`]): `.bag` files, or files that start as one.
struct Ros1;

impl Format for Ros1 {
    fn name(&self) -> &'static str {
        "ROS 1 bag"
    }

    fn reads(&self, path: &Path) -> bool {
        has_extension(path, "bag") || is_ros1_bag(path)
    }

    fn read(&self, path: &Path, want: &Want, say: Say) -> Result<FileRows, FileError> {
        let bag = read_ros1_bag(path, &want.source.topics)?;
        bag_rows(path, bag, want, say)
    }
}

/// A bag's records cut into trials as `want.source` says, what was paired said.
fn bag_rows(path: &Path, mut bag: Bag, want: &Want, say: Say) -> Result<FileRows, FileError> {
    if let Some(warning) = bag.cut_warning(path) {
        say(format!("warning: {warning}"));
    }
    let trials = want.source.split(&mut bag);
    let name = path.display().to_string();
    say(format!(
        "{name}: {} readings of {} paired with a wrench; unpaired: {} readings, {} wrenches; \
         trials: {trials}",
        bag.records.len(),
        bag.reading_type,
        bag.unpaired_readings,
        bag.unpaired_wrenches
    ));
    want.records(&bag.records, &name)
}
