//! Training data files for `train`, `eval`, `adapt` and `tradeoff`: CSV or
//! rosbag2 MCAP, each a session tared on its own, wrenches moved to the
//! BioTac frame.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use clap::Args;
use nalgebra::Vector3;

use tactile_force::learn::bag::{read_bag, BagTopics};
use tactile_force::learn::dataset::Dataset;
use tactile_force::learn::model::TareSpec;
use tactile_force::wrench::{AxisSet, FrameTransform, Wrench};

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
    let mut ds = read_data(path, features, axes, source)?;
    let baseline = match tare_samples {
        0 => vec![0.0; ds.features.len()],
        n => ds
            .tare_per_trial(n)
            .with_context(|| format!("taring {}", path.display()))?,
    };
    Ok((ds, baseline))
}

/// Reads a CSV or, by its `.mcap` extension, a ROS bag; wrenches moved to
/// the BioTac frame when `--ft-to-biotac` says where the F/T sensor is.
pub(crate) fn read_data(
    path: &Path,
    features: &[String],
    axes: &AxisSet,
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
        return Ok(Dataset::read_csv(path, features, axes)?);
    }
    // Every BioTac-frame component needs the whole force (and torque).
    let torques = axes.axes().iter().any(|a| a.index() >= 3);
    let read: AxisSet = if torques {
        "fx,fy,fz,tx,ty,tz"
    } else {
        "fx,fy,fz"
    }
    .parse()?;
    let mut ds = Dataset::read_csv(path, features, &read)?;
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

/// Reads sessions, each tared on its own: their rows, and the tare spec a
/// model trained on them records (the baselines averaged over sessions).
pub(crate) fn load_sessions(
    paths: &[PathBuf],
    features: &[String],
    axes: &AxisSet,
    tare_samples: usize,
    source: &SourceArgs,
) -> Result<(Vec<Dataset>, TareSpec)> {
    let mut sessions = Vec::with_capacity(paths.len());
    let mut mean_baseline = vec![0.0; features.len()];
    for p in paths {
        let (ds, base) = load_session(p, features, axes, tare_samples, source)?;
        for (m, b) in mean_baseline.iter_mut().zip(base) {
            *m += b / paths.len() as f64;
        }
        sessions.push(ds);
    }
    let tare = TareSpec {
        samples: tare_samples,
        mean_baseline,
    };
    Ok((sessions, tare))
}

/// [`load_sessions`] with the rows of every session in one data set.
pub(crate) fn load_pooled(
    paths: &[PathBuf],
    features: &[String],
    axes: &AxisSet,
    tare_samples: usize,
    source: &SourceArgs,
) -> Result<(Dataset, TareSpec)> {
    let (sessions, tare) = load_sessions(paths, features, axes, tare_samples, source)?;
    let refs: Vec<&Dataset> = sessions.iter().collect();
    let pooled = Dataset::concat(&refs).context("no data file given")?;
    Ok((pooled, tare))
}
