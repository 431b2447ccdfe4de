//! Training data files as sessions, the one reader of every format: BioTac
//! CSV files, rosbag2 MCAP and ROS 1 bags (cut into trials), each a session
//! tared on its own, wrenches moved to the BioTac frame; or nail-camera
//! directories. It finds the files' electrode layout and checks their
//! sensor against a model's. The commands (`train`, `eval`, `adapt`,
//! `tradeoff`) and pooled retraining read through it.

use std::path::{Path, PathBuf};

use nalgebra::Vector3;

use super::bag::{read_bag, Bag, BagError, BagTopics};
use super::nail::read_nail_dirs;
use super::ros1::{is_ros1_bag, read_ros1_bag};
use super::trials::{split_trials, TrialSplit, TrialsArg};
use super::{channel_columns, Channel, Counts, Dataset, DatasetError, TareSpec};
use crate::biotac::hand::HandKind;
use crate::biotac::ElectrodeLayout;
use crate::exit::{Classify, ExitClass};
use crate::nail::collect::{is_nail_dir, NailDataError};
use crate::sensor::{biotac, nail, SensorSpec};
use crate::wrench::{AxisSet, FrameTransform, Wrench};

/// At rest, by default: the force within this of the first readings' mean (N).
pub const DEFAULT_REST_FORCE_N: f64 = 0.1;
/// The shortest rest between two presses, by default (s).
pub const DEFAULT_REST_MIN_S: f64 = 0.5;

/// Where the files' wrenches come from: the topics of a bag, how a bag is
/// cut into trials, and the F/T sensor's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Source {
    /// Topics read from bags and how their stamps pair.
    pub topics: BagTopics,
    /// How a bag is cut into trials.
    pub trials: TrialsArg,
    /// At rest: the force within this of the first 50 readings' mean (N).
    pub rest_force_n: f64,
    /// The shortest rest between two presses (s).
    pub rest_min_s: f64,
    /// Where the F/T sensor sits in the BioTac frame; None: the files are
    /// in the BioTac frame already.
    pub ft_to_biotac: Option<FrameTransform>,
}

impl Default for Source {
    /// The default topics, trials as the bag's message type says, no frame change.
    fn default() -> Self {
        Source {
            topics: BagTopics::default(),
            trials: TrialsArg::Auto,
            rest_force_n: DEFAULT_REST_FORCE_N,
            rest_min_s: DEFAULT_REST_MIN_S,
            ft_to_biotac: None,
        }
    }
}

impl Source {
    /// Cuts a bag's records into trials; the number of trials.
    fn split(&self, bag: &mut Bag) -> usize {
        let rests = TrialSplit::Rests {
            force_n: self.rest_force_n,
            min_rest_s: self.rest_min_s,
            rest_samples: biotac::DEFAULT_TARE_SAMPLES,
        };
        let how = match &self.trials {
            TrialsArg::Auto if HandKind::of(&bag.reading_type).is_some() => rests,
            TrialsArg::Auto | TrialsArg::Whole => TrialSplit::Whole,
            TrialsArg::Rests => rests,
            TrialsArg::Starts(times) => TrialSplit::Starts(times.clone()),
        };
        split_trials(&mut bag.records, &how)
    }

    /// `w` in the BioTac frame.
    fn to_biotac(&self, w: Wrench) -> Wrench {
        self.ft_to_biotac.map_or(w, |t| t.apply(&w))
    }
}

/// Errors reading sessions.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SessionError {
    /// A data file refused.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// A bag refused.
    #[error(transparent)]
    Bag(#[from] BagError),
    /// A nail-camera directory refused.
    #[error(transparent)]
    Nail(#[from] NailDataError),
    /// A trial could not be tared.
    #[error("taring {path}: {source}")]
    Tare {
        /// The file.
        path: String,
        /// Why.
        #[source]
        source: Box<DatasetError>,
    },
    /// The files' sensors differ from each other or from the model's.
    #[error("{0}")]
    Sensor(String),
    /// No data file given.
    #[error("no data file given")]
    NoFiles,
}

/// A file that cannot be written is a failure; anything else is input refused.
impl Classify for SessionError {
    fn class(&self) -> ExitClass {
        match self {
            SessionError::Dataset(e) => e.class(),
            SessionError::Bag(e) => e.class(),
            SessionError::Nail(e) => e.class(),
            _ => ExitClass::Refused,
        }
    }
}

/// Where what the reader has to say goes (a bag's pairing, a cut file).
pub type Say<'a> = &'a mut dyn FnMut(String);

/// Reads a CSV (its BioTac channels holding `counts`) or, by its `.mcap`
/// extension, a rosbag2 bag, or a ROS 1 bag (`.bag`, or a file that starts
/// as one) (raw readings, cut into trials); wrenches moved to the BioTac
/// frame when `source` says where the F/T sensor is.
pub fn read_file(
    path: &Path,
    features: &[String],
    axes: &AxisSet,
    counts: Counts,
    source: &Source,
    say: Say,
) -> Result<Dataset, SessionError> {
    let mcap = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"));
    let ros1 = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("bag"))
        || is_ros1_bag(path);
    if mcap || ros1 {
        let bag = match mcap {
            true => read_bag(path, &source.topics)?,
            false => read_ros1_bag(path, &source.topics)?,
        };
        return bag_rows(path, bag, features, axes, source, say);
    }
    if source.ft_to_biotac.is_none() {
        return Ok(Dataset::read_csv(path, features, axes, counts)?);
    }
    // Every BioTac-frame component needs the whole force (and torque).
    let torques = axes.axes().iter().any(|a| a.index() >= 3);
    let read = if torques {
        AxisSet::wrench()
    } else {
        AxisSet::forces()
    };
    let mut ds = Dataset::read_csv(path, features, &read, counts)?;
    ds.y = ndarray::Array2::from_shape_fn((ds.len(), axes.len()), |(i, j)| {
        let row = ds.y.row(i);
        let torque = match torques {
            true => Vector3::new(row[3], row[4], row[5]),
            false => Vector3::zeros(),
        };
        let w = Wrench::new(Vector3::new(row[0], row[1], row[2]), torque);
        source.to_biotac(w).get(axes.axes()[j])
    });
    ds.axes = axes.clone();
    Ok(ds)
}

/// A bag's records cut into trials, their wrenches in the BioTac frame.
fn bag_rows(
    path: &Path,
    mut bag: Bag,
    features: &[String],
    axes: &AxisSet,
    source: &Source,
    say: Say,
) -> Result<Dataset, SessionError> {
    if let Some(warning) = bag.cut_warning(path) {
        say(format!("warning: {warning}"));
    }
    let trials = source.split(&mut bag);
    let name = path.display().to_string();
    say(format!(
        "{name}: {} readings of {} paired with a wrench; unpaired: {} readings, {} wrenches; \
         trials: {trials}",
        bag.records.len(),
        bag.reading_type,
        bag.unpaired_readings,
        bag.unpaired_wrenches
    ));
    for r in &mut bag.records {
        r.wrench = source.to_biotac(r.wrench);
    }
    Ok(Dataset::from_records(&bag.records, features, axes, &name)?)
}

/// What training files hold: rows, the tare a model of them records, and
/// their sensor.
#[derive(Debug)]
pub struct Sessions {
    /// One data set per file.
    pub sets: Vec<Dataset>,
    /// The baselines averaged over sessions.
    pub tare: TareSpec,
    /// Their sensor (for the nail: the preprocessing they were projected with).
    pub sensor: SensorSpec,
}

impl Sessions {
    /// Every session's rows in one data set.
    pub fn pooled(&self) -> Result<Dataset, SessionError> {
        let refs: Vec<&Dataset> = self.sets.iter().collect();
        Dataset::concat(&refs).ok_or(SessionError::NoFiles)
    }
}

/// The BioTac features to read from data files.
#[derive(Debug, Clone, Copy)]
pub enum Features<'a> {
    /// These channels, of the electrodes the files hold (19, or 24 from a
    /// BioTac SP).
    Channels(&'a [Channel]),
    /// A model's features by name: the files must hold its sensor's layout.
    Model(&'a [String]),
}

/// The files to read as sessions and how.
#[derive(Debug, Clone, Copy)]
pub struct Request<'a> {
    /// Data files, or nail-camera directories.
    pub paths: &'a [PathBuf],
    /// The BioTac features (nail-camera directories give their own).
    pub features: Features<'a>,
    /// The targets.
    pub axes: &'a AxisSet,
    /// Each trial tared on its first rows (0: already tared; None: the
    /// sensor's default).
    pub tare_samples: Option<usize>,
    /// Where the wrenches come from.
    pub source: &'a Source,
    /// The sensor of the model the data are for, if any.
    pub sensor: Option<&'a SensorSpec>,
}

/// Reads sessions of either sensor as `r` says, each trial tared, refused
/// when they mix sensors or their sensor is not `r.sensor`. BioTac files
/// give the `features`. Nail-camera directories give the principal
/// components of their frames' nail pixels (`features` does not apply),
/// projected as `r.sensor` says or, without it, as fitted on these
/// directories' frames (no labels are used).
pub fn load_sessions(r: &Request, say: Say) -> Result<Sessions, SessionError> {
    let nail = r.paths.iter().filter(|p| is_nail_dir(p)).count();
    if nail > 0 && nail < r.paths.len() {
        let msg = "the data files mix nail-camera directories and BioTac files";
        return Err(SessionError::Sensor(msg.into()));
    }
    match r.sensor {
        Some(s @ SensorSpec::Nail(_)) if nail == 0 => Err(SessionError::Sensor(format!(
            "BioTac data given to a model of the {} sensor",
            s.name()
        ))),
        Some(s @ SensorSpec::Biotac { .. }) if nail > 0 => Err(SessionError::Sensor(format!(
            "nail-camera data given to a model of the {} sensor",
            s.name()
        ))),
        _ if nail > 0 => nail_sessions(r, say),
        _ => biotac_sessions(r, say),
    }
}

/// Nail-camera directories as sessions, projected as `r.sensor` (a nail
/// sensor's) says or as fitted on their frames.
fn nail_sessions(r: &Request, say: Say) -> Result<Sessions, SessionError> {
    let spec = match r.sensor {
        Some(SensorSpec::Nail(spec)) => Some(spec.as_ref()),
        _ => None,
    };
    let (mut sets, spec) = read_nail_dirs(r.paths, r.axes, spec)?;
    if r.sensor.is_none() {
        say(format!(
            "nail frames: {} nail pixels of {:?} px, {} principal components holding {:.1} % \
             of their variance",
            spec.preprocess.n_pixels(),
            spec.preprocess.out_size(),
            spec.projection.len(),
            spec.projection.explained * 100.0
        ));
    }
    let samples = r.tare_samples.unwrap_or(nail::TARE_FRAMES);
    let tare = tare_each(&mut sets, r.paths, samples)?;
    Ok(Sessions {
        sets,
        tare,
        sensor: SensorSpec::Nail(Box::new(spec)),
    })
}

/// BioTac files as sessions, their electrode layout `r.sensor`'s if given.
fn biotac_sessions(r: &Request, say: Say) -> Result<Sessions, SessionError> {
    let layout = layout_of_files(r.paths, r.axes, r.source)?;
    if let Some(&SensorSpec::Biotac { electrodes }) = r.sensor {
        if electrodes != layout {
            let msg = format!("model trained on {electrodes}, readings have {layout}");
            return Err(SessionError::Sensor(msg));
        }
    }
    let features = match r.features {
        Features::Channels(channels) => channel_columns(channels, layout),
        Features::Model(names) => names.to_vec(),
    };
    let samples = r.tare_samples.unwrap_or(biotac::DEFAULT_TARE_SAMPLES);
    // Untared files hold raw counts; tared ones may go below zero.
    let counts = match samples {
        0 => Counts::Tared,
        _ => Counts::Raw,
    };
    let mut sets = Vec::with_capacity(r.paths.len());
    for p in r.paths {
        sets.push(read_file(p, &features, r.axes, counts, r.source, say)?);
    }
    let tare = tare_each(&mut sets, r.paths, samples)?;
    Ok(Sessions {
        sets,
        tare,
        sensor: SensorSpec::biotac(layout),
    })
}

/// Tares each trial of each set (read from `paths`) on its first `samples`
/// rows (0: already tared); the baselines averaged over the sets.
fn tare_each(
    sets: &mut [Dataset],
    paths: &[PathBuf],
    samples: usize,
) -> Result<TareSpec, SessionError> {
    let width = sets.first().map_or(0, |s| s.features.len());
    let mut mean_baseline = vec![0.0; width];
    if samples > 0 {
        for (ds, path) in sets.iter_mut().zip(paths) {
            let base = ds.tare_per_trial(samples).map_err(|e| SessionError::Tare {
                path: path.display().to_string(),
                source: Box::new(e),
            })?;
            for (m, b) in mean_baseline.iter_mut().zip(base) {
                *m += b / paths.len() as f64;
            }
        }
    }
    Ok(TareSpec {
        samples,
        mean_baseline,
    })
}

/// The electrode layout of BioTac data files: a BioTac SP's when they hold
/// `e20`; refused when they mix layouts.
fn layout_of_files(
    paths: &[PathBuf],
    axes: &AxisSet,
    source: &Source,
) -> Result<ElectrodeLayout, SessionError> {
    let mut layouts = Vec::with_capacity(paths.len());
    for path in paths {
        let sp = ["e20".to_string()];
        let layout = match read_file(path, &sp, axes, Counts::Tared, source, &mut |_| {}) {
            Ok(_) => ElectrodeLayout::BiotacSp,
            Err(SessionError::Dataset(DatasetError::MissingColumn { column, .. }))
                if column == "e20" =>
            {
                ElectrodeLayout::Biotac
            }
            Err(e) => return Err(e),
        };
        layouts.push((path, layout));
    }
    let Some(&(first, layout)) = layouts.first() else {
        return Ok(ElectrodeLayout::default());
    };
    match layouts.iter().find(|(_, l)| *l != layout) {
        Some((other, l)) => Err(SessionError::Sensor(format!(
            "the data files mix sensors: {} holds {layout}, {} holds {l}",
            first.display(),
            other.display()
        ))),
        None => Ok(layout),
    }
}

#[cfg(test)]
mod tests;
