//! `force_controller/markers` (visualization_msgs/MarkerArray; reliable,
//! volatile, keep last 1: a viewer wants the newest set): the markers
//! [`crate::nodes::markers`] decides for an estimate and the task's phase,
//! in the estimate's frame and at its stamp, for one estimate in each
//! [`MARKER_PERIOD_S`](crate::nodes::markers::MARKER_PERIOD_S) of stamps.

use r2r::builtin_interfaces::msg::Duration;
use r2r::geometry_msgs::msg::{Point, Pose, Quaternion, Vector3 as Vector3Msg};
use r2r::std_msgs::msg::{ColorRGBA, Header};
use r2r::visualization_msgs::msg::{Marker as MarkerMsg, MarkerArray};
use r2r::QosProfile;

use crate::nodes::markers::{
    self, Marker, MarkerRate, Shape, TaskPhase, HEAD_M, LIFETIME_S, SHAFT_M, TEXT_HEIGHT_M,
};
use crate::ros::{convert, RosError};
use crate::wrench::WrenchEstimate;

/// The markers' namespace.
const NS: &str = "biotac";

/// The publisher, and which estimates it draws.
pub(super) struct Markers {
    publisher: r2r::Publisher<MarkerArray>,
    rate: MarkerRate,
}

impl Markers {
    /// Advertises `~/markers`.
    pub(super) fn create(node: &mut r2r::Node) -> Result<Self, RosError> {
        let qos = QosProfile::default().keep_last(1).reliable().volatile();
        Ok(Markers {
            publisher: node.create_publisher("~/markers", qos)?,
            rate: MarkerRate::default(),
        })
    }

    /// Publishes the markers of `e` (in `frame`) with the task's `phase`
    /// when they are due.
    pub(super) fn on_estimate(
        &mut self,
        e: &WrenchEstimate,
        frame: &str,
        phase: Option<TaskPhase>,
    ) {
        if !self.rate.due(e.stamp_s) {
            return;
        }
        let header = Header {
            stamp: convert::time_msg(e.stamp_s),
            frame_id: frame.into(),
        };
        let array = MarkerArray {
            markers: markers::markers(e, phase)
                .iter()
                .map(|m| marker_msg(m, &header))
                .collect(),
        };
        if let Err(err) = self.publisher.publish(&array) {
            tracing::warn!("markers: {err}");
        }
    }
}

fn point(v: &nalgebra::Vector3<f64>) -> Point {
    Point {
        x: v.x,
        y: v.y,
        z: v.z,
    }
}

/// One marker as its message: an arrow by its two points (shaft and head
/// diameters in `scale.x`, `scale.y`), an ellipsoid (SPHERE) by its pose and
/// diameters, text by its pose and height (`scale.z`).
fn marker_msg(m: &Marker, header: &Header) -> MarkerMsg {
    let [r, g, b, a] = m.rgba;
    let (lifetime_sec, lifetime_ns) = (LIFETIME_S.trunc(), LIFETIME_S.fract() * 1e9);
    let mut msg = MarkerMsg {
        header: header.clone(),
        ns: NS.into(),
        id: m.id,
        action: MarkerMsg::ADD as i32,
        pose: Pose {
            orientation: Quaternion {
                w: 1.0,
                ..Default::default()
            },
            ..Default::default()
        },
        color: ColorRGBA { r, g, b, a },
        lifetime: Duration {
            sec: lifetime_sec as i32,
            nanosec: lifetime_ns as u32,
        },
        ..Default::default()
    };
    let scale = |x, y, z| Vector3Msg { x, y, z };
    match &m.shape {
        Shape::Arrow { tip } => {
            msg.type_ = MarkerMsg::ARROW as i32;
            msg.points = vec![Point::default(), point(tip)];
            msg.scale = scale(SHAFT_M, HEAD_M, 0.0);
        }
        Shape::Ellipsoid { centre, size } => {
            msg.type_ = MarkerMsg::SPHERE as i32;
            msg.pose.position = point(centre);
            msg.scale = scale(size.x, size.y, size.z);
        }
        Shape::Text { at, text } => {
            msg.type_ = MarkerMsg::TEXT_VIEW_FACING as i32;
            msg.pose.position = point(at);
            msg.scale = scale(0.0, 0.0, TEXT_HEIGHT_M);
            msg.text.clone_from(text);
        }
        Shape::Deleted => {
            msg.type_ = MarkerMsg::SPHERE as i32;
            msg.action = MarkerMsg::DELETE as i32;
        }
    }
    msg
}
