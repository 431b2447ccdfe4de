//! Conversions between our types and the standard ROS 2 messages (r2r's
//! typed structs). Frames and units: wrenches in the BioTac frame (N, Nm),
//! joint positions and velocities in rad and rad/s, stamps in seconds of the
//! node's clock.

use r2r::builtin_interfaces::msg::Time;
use r2r::diagnostic_msgs::msg::{DiagnosticArray, DiagnosticStatus, KeyValue};
use r2r::geometry_msgs::msg::{
    Quaternion, Transform, TransformStamped, Twist, TwistStamped, Vector3, Wrench as WrenchMsg,
    WrenchStamped,
};
use r2r::sensor_msgs::msg::{Image, JointState as JointStateMsg};
use r2r::std_msgs::msg::{Float64MultiArray, Header, MultiArrayDimension, MultiArrayLayout};
use r2r::tf2_msgs::msg::TFMessage;

use crate::biotac::msg::{join_stamp, split_stamp};
use crate::control::JointState;
use crate::exit::{Classify, ExitClass};
use crate::kinematics::{JointVector, Twist as TwistVector};
use crate::nail::NailFrame;
use crate::nodes::force_controller::tool_frame::StaticTransform;
use crate::nodes::status::{Level, Status};
use crate::wrench::{Wrench, WrenchEstimate};

/// Why a message was refused (the adapters count these and drop the message).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ConvertError {
    /// A NaN or an infinity.
    #[error("{0}: a value is not finite")]
    NonFinite(&'static str),
    /// A message the conversion needs has not arrived yet.
    #[error("no {0} received yet")]
    Missing(&'static str),
    /// A joint the controller needs is absent from `joint_states`.
    #[error("joint_states: joint `{0}` is missing or has no position")]
    MissingJoint(String),
    /// An image encoding the node does not read.
    #[error("sensor_msgs/Image encoding {0:?}: expected mono8, rgb8 or bgr8")]
    Encoding(String),
    /// An array of the wrong length.
    #[error("{what}: {found} values, expected {expected}")]
    Length {
        /// Which message.
        what: &'static str,
        /// Values found.
        found: usize,
        /// Values expected.
        expected: usize,
    },
}

/// A message that does not convert: refused input.
impl Classify for ConvertError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// Seconds -> `builtin_interfaces/Time`.
pub fn time_msg(stamp_s: f64) -> Time {
    let (sec, nanosec) = split_stamp(stamp_s);
    Time { sec, nanosec }
}

/// `builtin_interfaces/Time` -> seconds.
pub fn time_s(t: &Time) -> f64 {
    join_stamp(t.sec, t.nanosec)
}

fn header(stamp_s: f64, frame_id: &str) -> Header {
    Header {
        stamp: time_msg(stamp_s),
        frame_id: frame_id.to_string(),
    }
}

fn wrench_msg(w: &Wrench) -> WrenchMsg {
    let v = |a: &nalgebra::Vector3<f64>| Vector3 {
        x: a.x,
        y: a.y,
        z: a.z,
    };
    WrenchMsg {
        force: v(&w.force),
        torque: v(&w.torque),
    }
}

fn wrench_of(m: &WrenchMsg) -> Wrench {
    let v = |a: &Vector3| nalgebra::Vector3::new(a.x, a.y, a.z);
    Wrench::new(v(&m.force), v(&m.torque))
}

/// A nail-camera frame from `sensor_msgs/Image`: mono8 as it is, rgb8 or
/// bgr8 by the green channel (as Watanabe et al. 2023 use it); rows `step`
/// bytes apart. `seq` numbers it (ROS 2 headers carry none).
pub fn nail_frame(msg: &Image, seq: u16) -> Result<NailFrame, ConvertError> {
    let (channels, green) = match msg.encoding.as_str() {
        "mono8" => (1, 0),
        "rgb8" | "bgr8" => (3, 1),
        other => return Err(ConvertError::Encoding(other.to_string())),
    };
    let (w, h, step) = (msg.width as usize, msg.height as usize, msg.step as usize);
    let needed = step * h.saturating_sub(1) + w * channels;
    if w == 0 || h == 0 || step < w * channels || msg.data.len() < needed {
        return Err(ConvertError::Length {
            what: "sensor_msgs/Image data",
            found: msg.data.len(),
            expected: needed.max(1),
        });
    }
    let pixels = (0..h)
        .flat_map(|v| (0..w).map(move |u| msg.data[v * step + u * channels + green]))
        .collect();
    let mut frame = NailFrame::new(w, h, pixels).map_err(|_| ConvertError::Length {
        what: "sensor_msgs/Image data",
        found: msg.data.len(),
        expected: needed,
    })?;
    frame.stamp_s = time_s(&msg.header.stamp);
    frame.seq = seq;
    Ok(frame)
}

/// `biotac/wrench` (mean) and `biotac/wrench_stddev` (1-sigma) for an
/// estimate, in `frame_id` (the BioTac frame). None when a number is not
/// finite: nothing is published for it.
pub fn estimate_msgs(e: &WrenchEstimate, frame_id: &str) -> Option<(WrenchStamped, WrenchStamped)> {
    if !e.is_finite() {
        return None;
    }
    let mean = WrenchStamped {
        header: header(e.stamp_s, frame_id),
        wrench: wrench_msg(&e.mean),
    };
    let std = WrenchStamped {
        header: header(e.stamp_s, frame_id),
        wrench: wrench_msg(&e.std),
    };
    Some((mean, std))
}

/// A wrench with a stamp (N, Nm); refuses NaN and infinities.
pub fn wrench_from_msg(
    m: &WrenchStamped,
    what: &'static str,
) -> Result<(f64, Wrench), ConvertError> {
    let w = wrench_of(&m.wrench);
    let stamp = time_s(&m.header.stamp);
    if !(w.force.iter().chain(w.torque.iter()).all(|x| x.is_finite())) {
        return Err(ConvertError::NonFinite(what));
    }
    Ok((stamp, w))
}

/// What decides whether a publisher of `q` reaches a subscription (a
/// publisher the graph lists has its actual policies, not defaults).
pub fn qos(q: &r2r::QosProfile) -> crate::nodes::input_watch::Qos {
    crate::nodes::input_watch::Qos {
        reliable: q.reliability == r2r::qos::ReliabilityPolicy::Reliable,
        transient_local: q.durability == r2r::qos::DurabilityPolicy::TransientLocal,
    }
}

/// A wrench as `WrenchStamped` (e.g. `ft_sensor/wrench`).
pub fn wrench_stamped(stamp_s: f64, frame_id: &str, w: &Wrench) -> WrenchStamped {
    WrenchStamped {
        header: header(stamp_s, frame_id),
        wrench: wrench_msg(w),
    }
}

/// `joint_states` for our joint positions, named `names` in chain order.
pub fn joint_state_msg(js: &JointState, names: &[String]) -> JointStateMsg {
    JointStateMsg {
        header: header(js.stamp_s, ""),
        name: names.to_vec(),
        position: js.q.iter().copied().collect(),
        velocity: Vec::new(),
        effort: Vec::new(),
    }
}

/// Our joint positions from `joint_states`: the joints `names` (the arm's,
/// in chain order) are picked by name (the message may list them in any
/// order, and list others too).
pub fn joint_state_from_msg(
    m: &JointStateMsg,
    names: &[String],
) -> Result<JointState, ConvertError> {
    let mut q = JointVector::zeros(names.len());
    for (i, name) in names.iter().enumerate() {
        let k = m
            .name
            .iter()
            .position(|n| n == name)
            .filter(|&k| k < m.position.len())
            .ok_or_else(|| ConvertError::MissingJoint(name.clone()))?;
        q[i] = m.position[k];
    }
    let stamp_s = time_s(&m.header.stamp);
    if !q.iter().all(|v| v.is_finite()) {
        return Err(ConvertError::NonFinite("joint_states"));
    }
    Ok(JointState { stamp_s, q })
}

/// `velocity_controller/commands`: one velocity per joint (rad/s), in the
/// order of the JointGroupVelocityController's `joints` parameter (which
/// must list the arm's joints in chain order). A non-finite command becomes
/// zeros: the arm stops.
pub fn commands_msg(qdot: &JointVector) -> Float64MultiArray {
    let n = qdot.len();
    let finite = qdot.iter().all(|v| v.is_finite());
    let data = if finite {
        qdot.iter().copied().collect()
    } else {
        vec![0.0; n]
    };
    Float64MultiArray {
        layout: MultiArrayLayout {
            dim: vec![MultiArrayDimension {
                label: "joints".into(),
                size: n as u32,
                stride: n as u32,
            }],
            data_offset: 0,
        },
        data,
    }
}

/// Joint velocities from a `velocity_controller/commands` message (the
/// simulated arm's input), one per joint of an arm of `joints` joints.
pub fn qdot_from_msg(m: &Float64MultiArray, joints: usize) -> Result<JointVector, ConvertError> {
    if m.data.len() != joints {
        return Err(ConvertError::Length {
            what: "velocity_controller/commands",
            found: m.data.len(),
            expected: joints,
        });
    }
    if !m.data.iter().all(|v| v.is_finite()) {
        return Err(ConvertError::NonFinite("velocity_controller/commands"));
    }
    Ok(JointVector::from_column_slice(&m.data))
}

/// A twist (m/s, rad/s) as a TwistStamped in `frame_id`; a non-finite twist
/// becomes zero (the arm stops).
pub fn twist_msg(stamp_s: f64, frame_id: &str, t: &TwistVector) -> TwistStamped {
    let t = if t.iter().all(|v| v.is_finite()) {
        *t
    } else {
        TwistVector::zeros()
    };
    let v = |i: usize| Vector3 {
        x: t[i],
        y: t[i + 1],
        z: t[i + 2],
    };
    TwistStamped {
        header: header(stamp_s, frame_id),
        twist: Twist {
            linear: v(0),
            angular: v(3),
        },
    }
}

/// A static transform as the one TransformStamped of a TFMessage.
pub fn tf_msg(stamp_s: f64, t: &StaticTransform) -> TFMessage {
    let [x, y, z] = t.translation;
    let [qx, qy, qz, qw] = t.rotation;
    TFMessage {
        transforms: vec![TransformStamped {
            header: header(stamp_s, &t.parent),
            child_frame_id: t.child.clone(),
            transform: Transform {
                translation: Vector3 { x, y, z },
                rotation: Quaternion {
                    x: qx,
                    y: qy,
                    z: qz,
                    w: qw,
                },
            },
        }],
    }
}

/// A linear velocity (m/s) as a TwistStamped with zero angular part.
pub fn linear_twist_msg(stamp_s: f64, frame_id: &str, v: &nalgebra::Vector3<f64>) -> TwistStamped {
    TwistStamped {
        header: Header {
            stamp: time_msg(stamp_s),
            frame_id: frame_id.into(),
        },
        twist: Twist {
            linear: Vector3 {
                x: v.x,
                y: v.y,
                z: v.z,
            },
            angular: Vector3::default(),
        },
    }
}

/// Diagnostic levels (diagnostic_msgs/DiagnosticStatus).
pub mod level {
    /// All is well.
    pub const OK: u8 = 0;
    /// Working, with something to look at.
    pub const WARN: u8 = 1;
    /// Not working.
    pub const ERROR: u8 = 2;
}

/// One status on `/diagnostics`: `name` says who, `values` the figures.
pub fn diagnostics_msg(
    stamp_s: f64,
    level: u8,
    name: &str,
    message: String,
    hardware_id: &str,
    values: Vec<(&str, String)>,
) -> DiagnosticArray {
    let values = values
        .into_iter()
        .map(|(key, value)| KeyValue {
            key: key.into(),
            value,
        })
        .collect();
    DiagnosticArray {
        header: Header {
            stamp: time_msg(stamp_s),
            frame_id: String::new(),
        },
        status: vec![DiagnosticStatus {
            level,
            name: name.into(),
            message,
            hardware_id: hardware_id.into(),
            values,
        }],
    }
}

/// A node's status on `/diagnostics` (`hardware_id` names its device).
pub fn status_msg(stamp_s: f64, name: &str, hardware_id: &str, s: Status) -> DiagnosticArray {
    let level = match s.level {
        Level::Ok => level::OK,
        Level::Warn => level::WARN,
        Level::Error => level::ERROR,
    };
    let values = s
        .values
        .iter()
        .map(|(k, v)| (k.as_str(), v.clone()))
        .collect();
    diagnostics_msg(stamp_s, level, name, s.message, hardware_id, values)
}
