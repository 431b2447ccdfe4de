//! The parameters the ROS adapters declare themselves, beside those of the
//! shared files: each one's name, default and description, here once. The
//! adapters declare them from these (`ros::own_*`), and
//! docs/parameters.md lists them ([`super::param_reference`]).

use super::force_controller::tool_frame;
use super::wrench_estimator::reading_source::INPUTS;
use crate::params::reference::ParamDoc;

/// A parameter an adapter declares itself.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OwnParam<T: 'static> {
    /// Its name.
    pub name: &'static str,
    /// Its value when not given.
    pub default: T,
    /// What it is.
    pub description: &'static str,
}

/// The type of a default, as the reference names it.
pub trait Kind {
    /// `string`, `number`, ...
    const KIND: &'static str;
}

impl Kind for &str {
    const KIND: &'static str = "string";
}

impl Kind for f64 {
    const KIND: &'static str = "number";
}

impl Kind for u32 {
    const KIND: &'static str = "integer";
}

impl Kind for bool {
    const KIND: &'static str = "boolean";
}

impl Kind for &[&str] {
    const KIND: &'static str = "list of string";
}

impl<T: Kind + std::fmt::Debug> OwnParam<T> {
    /// Its row in the reference, and its default as shown.
    pub fn row(&self) -> (ParamDoc, String) {
        let doc = ParamDoc {
            key: self.name.into(),
            kind: T::KIND.into(),
            description: self.description.into(),
            range: String::new(),
        };
        (doc, format!("`{:?}`", self.default))
    }
}

/// `robot_description` (force_controller, sim_robot).
pub const ROBOT_DESCRIPTION: OwnParam<&str> = OwnParam {
    name: "robot_description",
    default: "",
    description:
        "The robot's URDF; empty: taken from /robot_description (std_msgs/String, transient local).",
};
/// `joint_names` (force_controller, sim_robot).
pub const JOINT_NAMES: OwnParam<&[&str]> = OwnParam {
    name: "joint_names",
    default: &[],
    description: "The arm's joints on joint_states, in chain order; empty: the URDF's names.",
};
/// `models_dir` (force_controller, wrench_estimator).
pub const MODELS_DIR: OwnParam<&str> = OwnParam {
    name: "models_dir",
    default: "",
    description: "The folder of the files a calibration goal writes and of a model_file set while running: names inside it, nothing outside, no `..`, no symlink leading out; empty: the model cache folder.",
};

/// `start_state` (force_controller, biotac_driver): where the managed
/// node's lifecycle goes at start.
pub const START_STATE: OwnParam<&str> = OwnParam {
    name: "start_state",
    default: "active",
    description: "The lifecycle state the node goes to at start: active (as a plain node), inactive (configured, waiting for `ros2 lifecycle set NODE activate`) or unconfigured.",
};
/// `silent_input_s` (force_controller, wrench_estimator).
pub const SILENT_INPUT: OwnParam<f64> = OwnParam {
    name: "silent_input_s",
    default: 2.0,
    description: "An input the node needs with no message for this long is named, with what the ROS graph shows of its publishers, in the log and on /diagnostics (s).",
};

/// `force_controller`'s `command_interface`.
pub const COMMAND_INTERFACE: OwnParam<&str> = OwnParam {
    name: "command_interface",
    default: "joint_velocities",
    description: "joint_velocities (velocity_controller/commands) or twist (twist_commands).",
};
/// `force_controller`'s `ft_to_biotac`.
pub const FT_TO_BIOTAC: OwnParam<&str> = OwnParam {
    name: "ft_to_biotac",
    default: "",
    description: "Where the F/T sensor sits in the BioTac frame, roll,pitch,yaw,x,y,z (deg, fixed-axis x-y-z; m): its wrenches are moved to the BioTac frame for the calibration; empty: they are in it already.",
};
/// `force_controller`'s `ft_frame`.
pub const FT_FRAME: OwnParam<&str> = OwnParam {
    name: "ft_frame",
    default: "",
    description: "The frame_id the F/T sensor's wrenches must carry; a wrench in another frame is refused. Empty: the BioTac frame (biotac_frame); must be named when ft_to_biotac is set.",
};
/// `force_controller`'s `estimator_node`.
pub const ESTIMATOR_NODE: OwnParam<&str> = OwnParam {
    name: "estimator_node",
    default: "wrench_estimator",
    description:
        "The estimator whose model the calibration adapts and then sets (its model_file parameter).",
};
/// `force_controller`'s `biotac_frame`.
pub const BIOTAC_FRAME: OwnParam<&str> = OwnParam {
    name: "biotac_frame",
    default: tool_frame::BIOTAC_FRAME,
    description: "The BioTac frame, published on /tf_static in the tip link from robot.tool_*: the estimator's frame_id must name it too.",
};

/// `wrench_estimator`'s `model_file`.
pub const MODEL_FILE: OwnParam<&str> = OwnParam {
    name: "model_file",
    default: "",
    description: "Model file from `tactile_force train` (a GP, or with --family ensemble an ensemble of networks); empty: the demos' default model (trained on first use, cached), and the node then sets it to that model's cache file. May be set while running (BioTac, out of contact): estimates come from the new model from the next reading.",
};
/// `wrench_estimator`'s `frame_id`.
pub const ESTIMATE_FRAME: OwnParam<&str> = OwnParam {
    name: "frame_id",
    default: "biotac",
    description: "Frame of the published wrenches (the BioTac frame).",
};
/// `wrench_estimator`'s `stale_timeout_s`.
pub const STALE_TIMEOUT: OwnParam<f64> = OwnParam {
    name: "stale_timeout_s",
    default: 0.03,
    description: "Readings older than this are not estimated (s).",
};
/// `wrench_estimator`'s `tare_file`.
pub const TARE_FILE: OwnParam<&str> = OwnParam {
    name: "tare_file",
    default: "",
    description:
        "Where the tare is saved; empty: wrench_estimator_tare.json in the model cache folder.",
};
/// `wrench_estimator`'s `tare_max_age_s`.
pub const TARE_MAX_AGE: OwnParam<f64> = OwnParam {
    name: "tare_max_age_s",
    default: 60.0,
    description: "A saved tare younger than this is taken up at start (s); 0: always tare anew. An older one of the same sensor is kept as a check: no new tare while PDC shows the finger pressed against it.",
};
/// `wrench_estimator`'s `input`.
pub const INPUT: OwnParam<&str> = OwnParam {
    name: "input",
    default: INPUTS[0],
    description: "The readings: biotac (tactile_force_msgs/BioTac on biotac/readings) or biotac_all (a Shadow hand's sr_robot_msgs/BiotacAll on /rh/tactile, one finger).",
};
/// `wrench_estimator`'s `finger`.
pub const FINGER: OwnParam<f64> = OwnParam {
    name: "finger",
    default: 0.0,
    description: "With input biotac_all: the hand's BioTac, 0 first finger, 1 middle, 2 ring, 3 little, 4 thumb.",
};

/// `sim_robot`'s `frame_id`.
pub const SIM_FRAME: OwnParam<&str> = OwnParam {
    name: "frame_id",
    default: "biotac",
    description: "The BioTac frame (F/T wrench and readings).",
};
/// `sim_robot`'s `seed`.
pub const SEED: OwnParam<u32> = OwnParam {
    name: "seed",
    default: 1,
    description: "Seed of the simulated noise.",
};
/// `sim_robot`'s `use_sim_time`.
pub const USE_SIM_TIME: OwnParam<bool> = OwnParam {
    name: "use_sim_time",
    default: false,
    description: "Publish the simulated time on /clock and stamp with it.",
};
/// `sim_robot`'s `real_time_factor`.
pub const REAL_TIME_FACTOR: OwnParam<f64> = OwnParam {
    name: "real_time_factor",
    default: 1.0,
    description: "Simulated seconds per wall-clock second (with use_sim_time:=true); at least 1.",
};

/// `sim_robot`'s `command_timeout_s`.
pub const COMMAND_TIMEOUT: OwnParam<f64> = OwnParam {
    name: "command_timeout_s",
    default: 0.0,
    description: "With no command for this long the simulated arm stops (s); 0: it holds the last command for ever, as ros2_control's forward command controllers do.",
};

/// `biotac_driver`'s `frame_id`.
pub const READINGS_FRAME: OwnParam<&str> = OwnParam {
    name: "frame_id",
    default: "biotac",
    description: "Frame of the readings (the BioTac frame).",
};
/// `biotac_driver`'s `serial`.
pub const SERIAL: OwnParam<&str> = OwnParam {
    name: "serial",
    default: "",
    description: "Sensor serial number, copied into every message.",
};
/// `biotac_driver`'s `tare_samples`.
pub const TARE_SAMPLES: OwnParam<f64> = OwnParam {
    name: "tare_samples",
    default: 50.0,
    description: "Readings averaged by a ~/tare request.",
};
/// `biotac_driver`'s `port`.
pub const PORT: OwnParam<&str> = OwnParam {
    name: "port",
    default: "/dev/ttyACM0",
    description: "Serial device of the BioTac bridge.",
};
/// `biotac_driver`'s `interface`.
pub const LINK: OwnParam<&str> = OwnParam {
    name: "interface",
    default: "serial",
    description: "serial (the bridge at `port`) or cheetah (a board on a Cheetah adapter).",
};
/// `biotac_driver`'s `cheetah`.
pub const CHEETAH: OwnParam<&str> = OwnParam {
    name: "cheetah",
    default: "0",
    description: "Cheetah adapter: port number (0, 1, ...) or serial number (1364-123456).",
};
/// `biotac_driver`'s `cheetah_library`.
pub const CHEETAH_LIBRARY: OwnParam<&str> = OwnParam {
    name: "cheetah_library",
    default: "",
    description: "Total Phase's cheetah.so (file or directory); empty: searched.",
};
/// `biotac_driver`'s `sensors`.
pub const SENSORS: OwnParam<&[&str]> = OwnParam {
    name: "sensors",
    default: &[],
    description: "Board positions (0, 1, 2) to sample; empty: every BioTac that answers.",
};
/// `biotac_driver`'s `electrodes`.
pub const ELECTRODES: OwnParam<f64> = OwnParam {
    name: "electrodes",
    default: 19.0,
    description: "Electrodes of the BioTacs: 19 (BioTac) or 24 (BioTac SP).",
};
