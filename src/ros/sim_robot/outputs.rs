//! What `sim_robot` publishes each period.

use r2r::geometry_msgs::msg::{TwistStamped, WrenchStamped};
use r2r::rosgraph_msgs::msg::Clock as ClockMsg;
use r2r::sensor_msgs::msg::JointState as JointStateMsg;
use r2r::QosProfile;

use super::settings::Settings;
use crate::biotac::msg::{self as biotac_msg, BioTacMeta, BIOTAC_MSG_TYPE};
use crate::control::JointState;
use crate::nodes::SimRobot;
use crate::ros::{convert, RosError};

/// What the node publishes.
pub struct Outputs {
    joints: r2r::Publisher<JointStateMsg>,
    ft: r2r::Publisher<WrenchStamped>,
    readings: r2r::PublisherUntyped,
    biotac_twist: r2r::Publisher<TwistStamped>,
    finger_twist: r2r::Publisher<TwistStamped>,
    clock: r2r::Publisher<ClockMsg>,
}

impl Outputs {
    /// Advertises every topic.
    pub fn create(node: &mut r2r::Node) -> Result<Self, RosError> {
        let qos = QosProfile::default;
        Ok(Outputs {
            joints: node.create_publisher("joint_states", qos())?,
            ft: node.create_publisher("ft_sensor/wrench", qos())?,
            readings: node.create_publisher_untyped(
                "biotac/readings",
                BIOTAC_MSG_TYPE,
                QosProfile::sensor_data(),
            )?,
            biotac_twist: node.create_publisher("~/biotac_twist", qos())?,
            finger_twist: node.create_publisher("~/finger_twist", qos())?,
            clock: node.create_publisher("/clock", qos())?,
        })
    }
}

/// One period's messages.
pub struct Step<'a> {
    /// The node's settings.
    pub settings: &'a Settings,
    /// Where to publish.
    pub outputs: &'a Outputs,
    /// The joints' names in chain order.
    pub names: &'a [String],
    /// The readings' frame and serial.
    pub meta: BioTacMeta,
    /// The ground truth twists' frame: the BioTac's at the start.
    pub start_frame: String,
}

impl Step<'_> {
    /// Publishes simulated time `t` on /clock and returns it.
    pub fn tick_clock(&self, t: f64) -> f64 {
        let msg = ClockMsg {
            clock: convert::time_msg(t),
        };
        if let Err(e) = self.outputs.clock.publish(&msg) {
            tracing::warn!("/clock: {e}");
        }
        t
    }

    /// Samples `sim` and publishes what it measured, stamped `now`.
    pub fn publish(&self, sim: &mut SimRobot, now: f64) {
        let (o, frame_id, start_frame) = (self.outputs, &self.settings.frame_id, &self.start_frame);
        let mut s = sim.sample();
        s.reading.stamp_s = now;
        let js = JointState {
            stamp_s: now,
            q: s.joints.q,
        };
        let sent = o
            .joints
            .publish(&convert::joint_state_msg(&js, self.names))
            .and_then(|()| o.ft.publish(&convert::wrench_stamped(now, frame_id, &s.ft)))
            .and_then(|()| {
                o.readings
                    .publish(biotac_msg::to_json(&s.reading, &self.meta))
            })
            .and_then(|()| {
                let v = &s.velocity;
                o.biotac_twist
                    .publish(&convert::linear_twist_msg(now, start_frame, v))
            })
            .and_then(|()| match &s.finger {
                Some(f) => {
                    let v = &f.velocity;
                    o.finger_twist
                        .publish(&convert::linear_twist_msg(now, start_frame, v))
                }
                None => Ok(()),
            });
        if let Err(e) = sent {
            tracing::warn!("publish: {e}");
        }
    }
}
