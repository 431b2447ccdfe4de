//! Training data files for `train`, `eval`, `adapt` and `tradeoff`: BioTac
//! CSV files, rosbag2 MCAP or ROS 1 bags (cut into trials), each a session
//! tared on its own, wrenches moved to the BioTac frame; or nail-camera
//! directories.

use std::path::{Path, PathBuf};

use clap::Args;
use nalgebra::Vector3;

use tactile_force::biotac::hand::HandKind;
use tactile_force::biotac::ElectrodeLayout;
use tactile_force::learn::data::bag::{read_bag, Bag, BagTopics};
use tactile_force::learn::data::nail::read_nail_dirs;
use tactile_force::learn::data::ros1::{is_ros1_bag, read_ros1_bag};
use tactile_force::learn::data::trials::{split_trials, TrialSplit, TrialsArg};
use tactile_force::learn::data::{channel_columns, Channel, Counts, Dataset, DatasetError};
use tactile_force::learn::models::wrench_gp::TareSpec;
use tactile_force::nail::collect::is_nail_dir;
use tactile_force::sensor::nail;
use tactile_force::sensor::{biotac, SensorSpec};
use tactile_force::wrench::{AxisSet, FrameTransform, Wrench};

use super::BadArgument;
use super::{Context, Result};

/// Where the data files' wrenches come from: topics of a ROS bag (rosbag2
/// MCAP or ROS 1), the sensor of a hand message, how a bag is cut into
/// trials, and the F/T sensor's frame.
#[derive(Args)]
pub(crate) struct SourceArgs {
    /// BioTac readings topic in bags: tactile_force_msgs/msg/BioTac, or a
    /// hand's sr_robot_msgs/BiotacAll or biotac_sensors/BioTacHand (ROS 1
    /// or ROS 2).
    #[arg(long, default_value = "/biotac/readings")]
    pub(crate) biotac_topic: String,
    /// F/T sensor topic (geometry_msgs/WrenchStamped) in bags.
    #[arg(long, default_value = "/ft_sensor/wrench")]
    pub(crate) ft_topic: String,
    /// Largest header-stamp difference between a reading and its wrench in bags (s).
    #[arg(long, default_value_t = 0.005)]
    pub(crate) pair_tolerance_s: f64,
    /// Which sensor of a hand message is read (index into tactiles[] or bt_data[]).
    #[arg(long, default_value_t = 0)]
    pub(crate) finger: usize,
    /// How a bag is cut into trials: `rests` (in the middle of each rest out
    /// of contact), `whole` (one trial), times in s from the first paired
    /// reading where trials 2, 3, ... start (`9.6,15.4`), or `auto`: rests
    /// for hand messages, whole for tactile_force_msgs/msg/BioTac.
    #[arg(long, default_value = "auto", allow_hyphen_values = true)]
    pub(crate) trials: TrialsArg,
    /// At rest: the force within this of the first 50 readings' mean (N).
    #[arg(long, default_value_t = 0.1, value_parser = positive)]
    pub(crate) rest_force_n: f64,
    /// The shortest rest between two presses (s).
    #[arg(long, default_value_t = 0.5, value_parser = positive)]
    pub(crate) rest_min_s: f64,
    /// Where the F/T sensor sits in the BioTac frame, `roll,pitch,yaw,x,y,z`
    /// (deg, fixed-axis x-y-z; m): its wrenches are moved to the BioTac frame
    /// and origin. Default: the files are in the BioTac frame already.
    #[arg(long, allow_hyphen_values = true)]
    pub(crate) ft_to_biotac: Option<FrameTransform>,
}

impl SourceArgs {
    /// The bag topics and pairing to read.
    fn topics(&self) -> BagTopics {
        BagTopics {
            biotac: self.biotac_topic.clone(),
            ft: self.ft_topic.clone(),
            tolerance_s: self.pair_tolerance_s,
            finger: self.finger,
        }
    }

    /// Whether pooled retraining (`learn::pooled`), which reads files with
    /// the default topics, whole trials and no frame change, reads them as
    /// these options do.
    pub(crate) fn pooling_repeats(&self) -> bool {
        self.topics() == BagTopics::default()
            && matches!(self.trials, TrialsArg::Auto | TrialsArg::Whole)
            && self.ft_to_biotac.is_none()
    }
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
/// extension, a rosbag2 bag, or a ROS 1 bag (`.bag`, or a file that starts
/// as one) (raw readings, cut into trials); wrenches moved to the BioTac
/// frame when `--ft-to-biotac` says where the F/T sensor is.
pub(crate) fn read_data(
    path: &Path,
    features: &[String],
    axes: &AxisSet,
    counts: Counts,
    source: &SourceArgs,
) -> Result<Dataset> {
    let name = path.display().to_string();
    let to_biotac = |w: Wrench| source.ft_to_biotac.map_or(w, |t| t.apply(&w));
    let extension = |ext: &str| {
        path.extension()
            .is_some_and(|e| e.eq_ignore_ascii_case(ext))
    };
    let (mcap, ros1) = (extension("mcap"), extension("bag") || is_ros1_bag(path));
    if mcap || ros1 {
        let topics = source.topics();
        let mut bag = match mcap {
            true => read_bag(path, &topics)?,
            false => read_ros1_bag(path, &topics)?,
        };
        if let Some(warning) = bag.cut_warning(path) {
            eprintln!("warning: {warning}");
        }
        let trials = split_bag(&mut bag, source);
        eprintln!(
            "{name}: {} readings of {} paired with a wrench; unpaired: {} readings, {} \
             wrenches; trials: {trials}",
            bag.records.len(),
            bag.reading_type,
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

/// A positive, finite number.
fn positive(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("expected a positive number, got {s}")),
    }
}

/// Cuts a bag's records into trials as `--trials` says; the number of trials.
fn split_bag(bag: &mut Bag, source: &SourceArgs) -> usize {
    let rests = TrialSplit::Rests {
        force_n: source.rest_force_n,
        min_rest_s: source.rest_min_s,
        rest_samples: biotac::DEFAULT_TARE_SAMPLES,
    };
    let how = match &source.trials {
        TrialsArg::Auto if HandKind::of(&bag.reading_type).is_some() => rests,
        TrialsArg::Auto | TrialsArg::Whole => TrialSplit::Whole,
        TrialsArg::Rests => rests,
        TrialsArg::Starts(times) => TrialSplit::Starts(times.clone()),
    };
    split_trials(&mut bag.records, &how)
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

/// The BioTac features to read from data files.
#[derive(Clone, Copy)]
pub(crate) enum Features<'a> {
    /// These channels, of the electrodes the files hold (19, or 24 from a
    /// BioTac SP).
    Channels(&'a [Channel]),
    /// A model's features by name: the files must hold its sensor's layout.
    Model(&'a [String]),
}

/// The electrode layout of BioTac data files: a BioTac SP's when they hold
/// `e20`; refused when they mix layouts.
fn data_layout(paths: &[PathBuf], axes: &AxisSet, source: &SourceArgs) -> Result<ElectrodeLayout> {
    let mut layouts = Vec::with_capacity(paths.len());
    for path in paths {
        let sp = ["e20".to_string()];
        let layout = match read_data(path, &sp, axes, Counts::Tared, source) {
            Ok(_) => ElectrodeLayout::BiotacSp,
            Err(e) if matches!(e.cause(), Some(DatasetError::MissingColumn { column, .. }) if column == "e20") => {
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
        Some((other, l)) => Err(BadArgument(format!(
            "the data files mix sensors: {} holds {layout}, {} holds {l}",
            first.display(),
            other.display()
        ))
        .into()),
        None => Ok(layout),
    }
}

/// Reads sessions of either sensor, each trial tared on its first
/// `tare_samples` rows (0: already tared; None: the sensor's default).
/// BioTac files (CSV, MCAP) give the `features`. Nail-camera
/// directories give the principal components of their frames' nail pixels
/// (`features` does not apply), projected as `sensor` says or, without it,
/// as fitted on these directories' frames (no labels are used).
pub(crate) fn load_sessions(
    paths: &[PathBuf],
    features: Features,
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
    let layout = data_layout(paths, axes, source)?;
    if let Some(&SensorSpec::Biotac { electrodes }) = sensor {
        if electrodes != layout {
            let msg = format!("model trained on {electrodes}, readings have {layout}");
            return Err(BadArgument(msg).into());
        }
    }
    let features = match features {
        Features::Channels(channels) => channel_columns(channels, layout),
        Features::Model(names) => names.to_vec(),
    };
    let features = &features[..];
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
        sensor: SensorSpec::biotac(layout),
    })
}
