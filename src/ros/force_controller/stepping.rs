//! The loop of `force_controller`: it steps the node on each force message
//! and publishes the command; when no estimate comes before the newest goes
//! stale (as the node judges from the delay it measures), it halts the arm,
//! every period; once a second it publishes the node's status.
//!
//! It runs on the thread the node started on (tokio's `block_on`), apart
//! from every other input: r2r takes messages off DDS on a thread of its
//! own (`spin`), and joint states, the PDC rise, the robot description,
//! goals and parameter sets are handled on tokio's worker threads. Those
//! share the node with this loop only for the moment they hand it a
//! message; an input over its bound ([`crate::nodes::bounds`]) never
//! reaches it.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use futures::stream::BoxStream;
use futures::StreamExt;
use r2r::diagnostic_msgs::msg::DiagnosticArray;
use r2r::geometry_msgs::msg::{TwistStamped, WrenchStamped};
use r2r::std_msgs::msg::Float64MultiArray;
use r2r::QosProfile;

use super::lock;
use crate::nodes::bounds::{InputGuard, MESSAGE_MAX_BYTES};
use crate::nodes::force_controller::{CommandInterface, ForceControllerNode, ForcePart, Stamped};
use crate::ros::{bounded, convert, RosClock, RosError};

/// A force message as the node takes it.
pub(super) type ForceMsg = (ForcePart, Result<Stamped, String>);

/// Publishes the command of the last step, in the node's interface.
pub(super) struct Commands {
    pub(super) interface: CommandInterface,
    pub(super) joints: r2r::Publisher<Float64MultiArray>,
    pub(super) twists: r2r::Publisher<TwistStamped>,
}

impl Commands {
    fn publish(&self, n: &ForceControllerNode, now: f64) {
        let Some(c) = n.controller() else { return };
        let sent = match self.interface {
            CommandInterface::JointVelocities => {
                self.joints.publish(&convert::commands_msg(c.command()))
            }
            CommandInterface::Twist => {
                let frame = &c.robot().links.0;
                self.twists
                    .publish(&convert::twist_msg(now, frame, c.twist()))
            }
        };
        if let Err(e) = sent {
            tracing::warn!("command: {e}");
        }
    }
}

/// The estimate's mean and standard deviation and the F/T sensor's wrench,
/// merged into one stream of the parts the node steps on.
pub(super) fn forces(
    node: &mut r2r::Node,
    guard: &Arc<InputGuard>,
) -> Result<impl futures::Stream<Item = ForceMsg> + Unpin, RosError> {
    let wrench_type = "geometry_msgs/msg/WrenchStamped";
    let parts = [
        ("biotac/wrench", ForcePart::Mean),
        ("biotac/wrench_stddev", ForcePart::Std),
        ("ft_sensor/wrench", ForcePart::Ft),
    ]
    .map(|(name, part)| {
        let qos = QosProfile::default();
        let topic = bounded::typed(node, name, wrench_type, qos, MESSAGE_MAX_BYTES, guard)?;
        Ok(force(topic, part, name))
    })
    .into_iter()
    .collect::<Result<Vec<_>, RosError>>()?;
    Ok(futures::stream::select_all(parts))
}

/// A force topic's messages as the node takes them.
fn force(
    topic: impl futures::Stream<Item = WrenchStamped> + Send + 'static,
    part: ForcePart,
    name: &'static str,
) -> BoxStream<'static, ForceMsg> {
    topic
        .map(move |m| {
            (
                part,
                convert::wrench_from_msg(&m, name).map_err(|e| e.to_string()),
            )
        })
        .boxed()
}

/// Steps the node until the force topics end.
pub(super) async fn run(
    shared: Arc<Mutex<ForceControllerNode>>,
    mut forces: impl futures::Stream<Item = ForceMsg> + Unpin,
    commands: Commands,
    diagnostics: r2r::Publisher<DiagnosticArray>,
    clock: RosClock,
    period: Duration,
) -> Result<(), RosError> {
    let mut deadline = tokio::time::Instant::now() + period;
    let mut report = tokio::time::interval(Duration::from_secs(1));
    loop {
        // Each step publishes under the lock it ran in, so that a goal or
        // a task switch in between cannot see the old command.
        tokio::select! {
            part = forces.next() => {
                let Some((part, msg)) = part else { return Ok(()) };
                let now = clock.now_s();
                let mut n = lock(&shared);
                if n.on_force_msg(part, msg, now) {
                    deadline = tokio::time::Instant::now()
                        + Duration::from_secs_f64(n.until_stale_s(now));
                    commands.publish(&n, now);
                }
            }
            // No estimate in time: once the newest is stale, zero velocity,
            // every period.
            _ = tokio::time::sleep_until(deadline) => {
                let now = clock.now_s();
                let mut n = lock(&shared);
                deadline = tokio::time::Instant::now()
                    + Duration::from_secs_f64(n.until_stale_s(now));
                if n.on_late(now).is_some() {
                    commands.publish(&n, now);
                }
            }
            _ = report.tick() => {
                let status = lock(&shared).status();
                let msg = convert::status_msg(clock.now_s(), "force_controller", "", status);
                if let Err(e) = diagnostics.publish(&msg) {
                    tracing::warn!("diagnostics: {e}");
                }
            }
        }
    }
}
