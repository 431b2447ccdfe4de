//! Training data files for `train`, `eval`, `adapt` and `tradeoff`: BioTac
//! CSV or rosbag2 MCAP files, each a session tared on its own, wrenches
//! moved to the BioTac frame; or nail-camera directories.

use std::path::{Path, PathBuf};

use clap::Args;
use nalgebra::Vector3;

use tactile_force::learn::data::bag::{read_bag, BagTopics};
use tactile_force::learn::data::nail::read_nail_dirs;
use tactile_force::learn::data::{Counts, Dataset};
use tactile_force::learn::models::wrench_gp::TareSpec;
use tactile_force::nail::collect::is_nail_dir;
use tactile_force::sensor::nail;
use tactile_force::sensor::{biotac, SensorSpec};
use tactile_force::wrench::{AxisSet, FrameTransform, Wrench};

use super::BadArgument;
use super::{Context, Result};

/// Where the data files' wrenches come from: topics of a ROS bag (MCAP)
/// and the F/T sensor's frame.
#[derive(Args)]
pub(crate) struct SourceArgs {
    /// BioTac readings topic (tactile_force_msgs/msg/BioTac) in MCAP files.
    #[arg(long, default_value = "/biotac/readings")]
    pub(crate) biotac_topic: String,
    /// F/T sensor topic (geometry_msgs/msg/WrenchStamped) in MCAP files.
    #[arg(long, default_value = "/ft_sensor/wrench")]
    pub(crate) ft_topic: String,
    /// Largest header-stamp difference between a reading and its wrench in MCAP files (s).
    #[arg(long, default_value_t = 0.005)]
    pub(crate) pair_tolerance_s: f64,
    /// Where the F/T sensor sits in the BioTac frame, `roll,pitch,yaw,x,y,z`
    /// (deg, fixed-axis x-y-z; m): its wrenches are moved to the BioTac frame
    /// and origin. Default: the files are in the BioTac frame already.
    #[arg(long, allow_hyphen_values = true)]
    pub(crate) ft_to_biotac: Option<FrameTransform>,
}

/// Reads one session's `features` and `axes` targets and tares each trial
/// on its first `tare_samples` rows (0: already tared); returns the
/// baselines too.
pub(crate) fn load_session(
    path: &Path,
    features: &[String],
    axes: &AxisSet,
    tare_samples: usize,
    source: &SourceArgs,
) -> Result<(Dataset, Vec<f64>)> {
    // Untared files hold raw counts; tared ones may go below zero.
    let counts = match tare_samples {
        0 => Counts::Tared,
        _ => Counts::Raw,
    };
    let mut ds = read_data(path, features, axes, counts, source)?;
    let baseline = match tare_samples {
        0 => vec![0.0; ds.features.len()],
        n => ds
            .tare_per_trial(n)
            .with_context(|| format!("taring {}", path.display()))?,
    };
    Ok((ds, baseline))
}

/// Reads a CSV (its BioTac channels holding `counts`) or, by its `.mcap`
/// extension, a ROS bag (raw readings); wrenches moved to the BioTac frame
/// when `--ft-to-biotac` says where the F/T sensor is.
pub(crate) fn read_data(
    path: &Path,
    features: &[String],
    axes: &AxisSet,
    counts: Counts,
    source: &SourceArgs,
) -> Result<Dataset> {
    let name = path.display().to_string();
    let to_biotac = |w: Wrench| source.ft_to_biotac.map_or(w, |t| t.apply(&w));
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
    {
        let topics = BagTopics {
            biotac: source.biotac_topic.clone(),
            ft: source.ft_topic.clone(),
            tolerance_s: source.pair_tolerance_s,
        };
        let mut bag = read_bag(path, &topics)?;
        if let Some(warning) = bag.cut_warning(path) {
            eprintln!("warning: {warning}");
        }
        eprintln!(
            "{name}: {} readings paired with a wrench; unpaired: {} readings, {} wrenches",
            bag.records.len(),
            bag.unpaired_readings,
            bag.unpaired_wrenches
        );
        for r in &mut bag.records {
            r.wrench = to_biotac(r.wrench);
        }
        return Ok(Dataset::from_records(&bag.records, features, axes, &name)?);
    }
    if source.ft_to_biotac.is_none() {
        return Ok(Dataset::read_csv(path, features, axes, counts)?);
    }
    // Every BioTac-frame component needs the whole force (and torque).
    let torques = axes.axes().iter().any(|a| a.index() >= 3);
    let read: AxisSet = if torques {
        "fx,fy,fz,tx,ty,tz"
    } else {
        "fx,fy,fz"
    }
    .parse()?;
    let mut ds = Dataset::read_csv(path, features, &read, counts)?;
    let y = ndarray::Array2::from_shape_fn((ds.len(), axes.len()), |(i, j)| {
        let row = ds.y.row(i);
        let torque = if torques {
            Vector3::new(row[3], row[4], row[5])
        } else {
            Vector3::zeros()
        };
        to_biotac(Wrench::new(Vector3::new(row[0], row[1], row[2]), torque)).get(axes.axes()[j])
    });
    ds.y = y;
    ds.axes = axes.clone();
    Ok(ds)
}

/// What training files hold: rows, the tare a model of them records, and
/// their sensor.
pub(crate) struct Sessions {
    /// One data set per file.
    pub(crate) sets: Vec<Dataset>,
    /// The baselines averaged over sessions (BioTac; none for the nail).
    pub(crate) tare: TareSpec,
    /// Their sensor (for the nail: the preprocessing they were projected with).
    pub(crate) sensor: SensorSpec,
}

impl Sessions {
    /// Every session's rows in one data set.
    pub(crate) fn pooled(&self) -> Result<Dataset> {
        let refs: Vec<&Dataset> = self.sets.iter().collect();
        Dataset::concat(&refs).ok_or_else(|| BadArgument("no data file given".into()).into())
    }
}

/// Reads sessions of either sensor, each trial tared on its first
/// `tare_samples` rows (0: already tared; None: the sensor's default).
/// BioTac files (CSV, MCAP) give the `features` channels. Nail-camera
/// directories give the principal components of their frames' nail pixels
/// (`features` does not apply), projected as `sensor` says or, without it,
/// as fitted on these directories' frames (no labels are used).
pub(crate) fn load_sessions(
    paths: &[PathBuf],
    features: &[String],
    axes: &AxisSet,
    tare_samples: Option<usize>,
    source: &SourceArgs,
    sensor: Option<&SensorSpec>,
) -> Result<Sessions> {
    let nail = paths.iter().filter(|p| is_nail_dir(p)).count();
    if nail > 0 {
        if nail < paths.len() {
            let msg = "the data files mix nail-camera directories and BioTac files";
            return Err(BadArgument(msg.into()).into());
        }
        let spec = match sensor {
            None => None,
            Some(SensorSpec::Nail(spec)) => Some(spec.as_ref()),
            Some(other) => {
                let msg = format!(
                    "nail-camera data given to a model of the {} sensor",
                    other.name()
                );
                return Err(BadArgument(msg).into());
            }
        };
        let (mut sets, spec) = read_nail_dirs(paths, axes, spec)?;
        let k = spec.projection.len();
        if sensor.is_none() {
            eprintln!(
                "nail frames: {} nail pixels of {:?} px, {k} principal components holding {:.1} % \
                 of their variance",
                spec.preprocess.n_pixels(),
                spec.preprocess.out_size(),
                spec.projection.explained * 100.0
            );
        }
        let samples = tare_samples.unwrap_or(nail::TARE_FRAMES);
        let mut mean_baseline = vec![0.0; k];
        if samples > 0 {
            for (ds, path) in sets.iter_mut().zip(paths) {
                let base = ds
                    .tare_per_trial(samples)
                    .with_context(|| format!("taring {}", path.display()))?;
                for (m, b) in mean_baseline.iter_mut().zip(base) {
                    *m += b / paths.len() as f64;
                }
            }
        }
        let tare = TareSpec {
            samples,
            mean_baseline,
        };
        return Ok(Sessions {
            sets,
            tare,
            sensor: SensorSpec::Nail(Box::new(spec)),
        });
    }
    if let Some(s @ SensorSpec::Nail(_)) = sensor {
        let msg = format!("BioTac data given to a model of the {} sensor", s.name());
        return Err(BadArgument(msg).into());
    }
    let tare_samples = tare_samples.unwrap_or(biotac::DEFAULT_TARE_SAMPLES);
    let mut sets = Vec::with_capacity(paths.len());
    let mut mean_baseline = vec![0.0; features.len()];
    for p in paths {
        let (ds, base) = load_session(p, features, axes, tare_samples, source)?;
        for (m, b) in mean_baseline.iter_mut().zip(base) {
            *m += b / paths.len() as f64;
        }
        sets.push(ds);
    }
    let tare = TareSpec {
        samples: tare_samples,
        mean_baseline,
    };
    Ok(Sessions {
        sets,
        tare,
        sensor: SensorSpec::Biotac,
    })
}
