//! Training data files as sessions: each file read in its format
//! ([`super::formats`]), each trial tared on its own, wrenches moved to the
//! BioTac frame; or nail-camera directories. It finds the files' electrode
//! layout and checks their sensor against a model's. The commands
//! (`train`, `eval`, `adapt`, `tradeoff`) and pooled retraining read
//! through it.

use std::cell::Cell;
use std::path::PathBuf;

use super::format::{FileError, Say};
use super::formats;
use super::nail::read_nail_dirs;
use super::source::Source;
use super::{channel_columns, Channel, Counts, Dataset, DatasetError, TareSpec};
use crate::exit::{Classify, ExitClass};
use crate::nail::collect::{is_nail_dir, NailDataError};
use crate::sensor::{biotac, nail, SensorSpec};
use crate::wrench::AxisSet;

/// Errors reading sessions.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SessionError {
    /// A data file refused.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
    /// A bag refused.
    #[error(transparent)]
    Bag(#[from] super::bag::BagError),
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

impl From<FileError> for SessionError {
    fn from(e: FileError) -> Self {
        match e {
            FileError::Dataset(e) => SessionError::Dataset(e),
            FileError::Bag(e) => SessionError::Bag(e),
            FileError::Sensor(why) => SessionError::Sensor(why),
        }
    }
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
    /// The `channels` whose columns its rows hold.
    pub fn channels_of(&self, channels: &[Channel]) -> Vec<Channel> {
        let (Some(first), SensorSpec::Biotac { electrodes: layout }) =
            (self.sets.first(), &self.sensor)
        else {
            return Vec::new();
        };
        let holds = |c: &Channel| {
            channel_columns(&[*c], *layout)
                .iter()
                .all(|n| first.features.contains(n))
        };
        channels.iter().copied().filter(holds).collect()
    }

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
    /// These channels where every file holds them (the electrodes always):
    /// one a file lacks is left out of all.
    Held(&'a [Channel]),
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

/// BioTac files as sessions, each read once, their electrode layout
/// `r.sensor`'s if given; refused when they mix layouts.
fn biotac_sessions(r: &Request, say: Say) -> Result<Sessions, SessionError> {
    let samples = r.tare_samples.unwrap_or(biotac::DEFAULT_TARE_SAMPLES);
    // Untared files hold raw counts; tared ones may go below zero.
    let counts = match samples {
        0 => Counts::Tared,
        _ => Counts::Raw,
    };
    let first = Cell::new(None);
    let mut sets = Vec::with_capacity(r.paths.len());
    for path in r.paths {
        let features = |layout, holds: &dyn Fn(&str) -> bool| {
            let held = |p: &PathBuf, l| format!("{} holds {l}", p.display());
            match (first.get(), r.sensor) {
                (Some(l), _) if l != layout => Err(FileError::Sensor(format!(
                    "the data files mix sensors: {}, {}",
                    held(&r.paths[0], l),
                    held(path, layout)
                ))),
                (_, Some(&SensorSpec::Biotac { electrodes })) if electrodes != layout => {
                    Err(FileError::Sensor(format!(
                        "model trained on {electrodes}, readings have {layout}"
                    )))
                }
                _ => {
                    first.set(Some(layout));
                    Ok(match r.features {
                        Features::Channels(channels) => channel_columns(channels, layout),
                        Features::Model(names) => names.to_vec(),
                        Features::Held(channels) => {
                            let held = channels.iter().copied().filter(|&c| {
                                c == Channel::Electrodes
                                    || channel_columns(&[c], layout).iter().all(|n| holds(n))
                            });
                            channel_columns(&held.collect::<Vec<_>>(), layout)
                        }
                    })
                }
            }
        };
        sets.push(formats::read(path, &features, r.axes, counts, r.source, say)?.rows);
    }
    if let Features::Held(_) = r.features {
        let names = sets.first().map_or(Vec::new(), |s| s.features.clone());
        let common: Vec<String> = (names.into_iter())
            .filter(|n| sets.iter().all(|s| s.features.contains(n)))
            .collect();
        for set in &mut sets {
            *set = set.with_features(&common);
        }
    }
    let tare = tare_each(&mut sets, r.paths, samples)?;
    Ok(Sessions {
        sets,
        tare,
        sensor: SensorSpec::biotac(first.get().unwrap_or_default()),
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

#[cfg(test)]
mod tests;
