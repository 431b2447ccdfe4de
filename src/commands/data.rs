//! The data-source flags of `train`, `eval`, `adapt` and `tradeoff`, and
//! their sessions read ([`tactile_force::learn::data::sessions`]), what the
//! reader says printed.

use std::path::PathBuf;

use clap::Args;

use tactile_force::learn::data::bag::BagTopics;
use tactile_force::learn::data::sessions::{self, Features, Request, Sessions};
use tactile_force::learn::data::source::{Source, DEFAULT_REST_FORCE_N, DEFAULT_REST_MIN_S};
use tactile_force::learn::data::trials::TrialsArg;
use tactile_force::sensor::SensorSpec;
use tactile_force::wrench::{AxisSet, FrameTransform};

use super::Result;

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
    #[arg(long, default_value_t = DEFAULT_REST_FORCE_N, value_parser = positive)]
    pub(crate) rest_force_n: f64,
    /// The shortest rest between two presses (s).
    #[arg(long, default_value_t = DEFAULT_REST_MIN_S, value_parser = positive)]
    pub(crate) rest_min_s: f64,
    /// Where the F/T sensor sits in the BioTac frame, `roll,pitch,yaw,x,y,z`
    /// (deg, fixed-axis x-y-z; m): its wrenches are moved to the BioTac frame
    /// and origin. Default: the files are in the BioTac frame already.
    #[arg(long, allow_hyphen_values = true)]
    pub(crate) ft_to_biotac: Option<FrameTransform>,
}

impl SourceArgs {
    /// Where the files' wrenches come from, as the flags say.
    pub(crate) fn source(&self) -> Source {
        Source {
            topics: BagTopics {
                biotac: self.biotac_topic.clone(),
                ft: self.ft_topic.clone(),
                tolerance_s: self.pair_tolerance_s,
                finger: self.finger,
            },
            trials: self.trials.clone(),
            rest_force_n: self.rest_force_n,
            rest_min_s: self.rest_min_s,
            ft_to_biotac: self.ft_to_biotac,
        }
    }

    /// Whether pooled retraining (`learn::pooled`), which reads files as
    /// the defaults say, reads them as these options do.
    pub(crate) fn pooling_repeats(&self) -> bool {
        self.source() == Source::default()
    }
}

/// A positive, finite number.
fn positive(s: &str) -> std::result::Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("expected a positive number, got {s}")),
    }
}

/// [`sessions::load_sessions`] with the source the flags give, what the
/// reader says printed.
pub(crate) fn load_sessions(
    paths: &[PathBuf],
    features: Features,
    axes: &AxisSet,
    tare_samples: Option<usize>,
    source: &SourceArgs,
    sensor: Option<&SensorSpec>,
) -> Result<Sessions> {
    let request = Request {
        paths,
        features,
        axes,
        tare_samples,
        source: &source.source(),
        sensor,
    };
    let say = &mut |s: String| eprintln!("{s}");
    Ok(sessions::load_sessions(&request, say)?)
}
