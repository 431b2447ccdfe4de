//! The loop of `force_controller`: it steps the node on each force message
//! and publishes the command; when no estimate comes before the newest goes
//! stale (as the node judges from the delay it measures), it halts the arm,
//! every period. Once a second, on a task of its own, the node's status
//! goes to `/diagnostics` ([`report`]).
//!
//! It runs on the thread the node started on (tokio's `block_on`), apart
//! from every other input: r2r takes messages off DDS on a thread of its
//! own (`spin`), and joint states, the robot description,
//! goals and parameter sets are handled on tokio's worker threads. Those
//! share the node with this loop only for the moment they hand it a
//! message; an input over its bound ([`crate::nodes::bounds`]) never
//! reaches it.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use futures::StreamExt;
use r2r::geometry_msgs::msg::WrenchStamped;

use r2r::diagnostic_msgs::msg::DiagnosticArray;

use super::commands::Commands;
use super::lock;
use super::markers::Markers;
use crate::nodes::bounds::{InputGuard, MESSAGE_MAX_BYTES};
use crate::nodes::estimate_msg::{self as msg, ESTIMATE_MSG_TYPE};
use crate::nodes::force_controller::{Force, ForceControllerNode, ForcePart};
use crate::nodes::markers::task_phase;
use crate::ros::inputs::Inputs;
use crate::ros::{bounded, convert, ending, Graph, RosClock, RosError};

/// A force message as the node takes it: its topic, its frame, and the
/// force (or why it could not be read).
pub(super) type ForceMsg = (ForcePart, String, Result<Force, String>);

/// The control loop's topics: the forces it steps on ([`forces`]), the
/// markers it draws.
pub(super) fn topics(
    node: &mut r2r::Node,
    guard: &Arc<InputGuard>,
) -> Result<(impl futures::Stream<Item = ForceMsg> + Unpin, Markers), RosError> {
    Ok((forces(node, guard)?, Markers::create(node)?))
}

/// The estimate and the F/T sensor's wrench, merged into one stream of the
/// forces the node steps on.
fn forces(
    node: &mut r2r::Node,
    guard: &Arc<InputGuard>,
) -> Result<impl futures::Stream<Item = ForceMsg> + Unpin, RosError> {
    let (qos, max) = (crate::ros::input_qos, MESSAGE_MAX_BYTES);
    let part = ForcePart::Estimate;
    let estimates =
        bounded::raw(node, part.topic(), ESTIMATE_MSG_TYPE, qos(), max, guard)?.map(move |bytes| {
            match msg::from_cdr(&bytes) {
                Ok((e, frame)) => (part, frame, Ok(Force::Estimate(e))),
                Err(why) => (part, String::new(), Err(why.to_string())),
            }
        });
    let part = ForcePart::Ft;
    let wrench_type = "geometry_msgs/msg/WrenchStamped";
    let ft = bounded::typed(node, part.topic(), wrench_type, qos(), max, guard)?.map(
        move |m: WrenchStamped| {
            let read = convert::wrench_from_msg(&m, part.topic()).map_err(|e| e.to_string());
            (part, m.header.frame_id, read.map(Force::Ft))
        },
    );
    Ok(futures::stream::select(estimates.boxed(), ft.boxed()))
}

/// The node's inputs watched for silence, after `silent_after_s`.
pub(super) fn watched(silent_after_s: f64) -> Arc<Inputs> {
    let qos = crate::ros::input_qos();
    Inputs::new(
        &ForceControllerNode::INPUTS.map(|t| (t, &qos)),
        silent_after_s,
    )
}

/// Once a second, the node's status on `/diagnostics`, its silent inputs
/// named with what `graph` shows: on a task of its own, apart from the
/// control loop (the graph's answer takes up to a spin of its thread).
pub(super) async fn report(
    shared: Arc<Mutex<ForceControllerNode>>,
    inputs: Arc<Inputs>,
    diagnostics: r2r::Publisher<DiagnosticArray>,
    graph: Graph,
    clock: RosClock,
) {
    let mut every = tokio::time::interval(Duration::from_secs(1));
    loop {
        every.tick().await;
        let (mut status, needed) = {
            let mut n = lock(&shared);
            let needed: Vec<&str> = ForceControllerNode::INPUTS
                .into_iter()
                .filter(|t| n.needs(t))
                .collect();
            (n.status(), needed)
        };
        inputs
            .report(&mut status, &graph, |t| needed.contains(&t))
            .await;
        let msg = convert::status_msg(clock.now_s(), "force_controller", "", status);
        if let Err(e) = diagnostics.publish(&msg) {
            tracing::warn!("diagnostics: {e}");
        }
    }
}

/// Steps the node until the force topics end, each estimate then drawn
/// (`markers`, when due) with the phase it led to; a test may make it
/// panic ([`ending::injected_panic`]).
pub(super) async fn run(
    shared: &Mutex<ForceControllerNode>,
    mut forces: impl futures::Stream<Item = ForceMsg> + Unpin,
    commands: &Commands,
    mut markers: Markers,
    inputs: &Inputs,
    clock: &RosClock,
    period: Duration,
) -> Result<(), RosError> {
    let mut deadline = tokio::time::Instant::now() + period;
    let injected = ending::injected_panic("control");
    tokio::pin!(injected);
    loop {
        // Each step publishes under the lock it ran in, so that a goal or
        // a task switch in between cannot see the old command.
        tokio::select! {
            part = forces.next() => {
                let Some((part, frame, msg)) = part else { return Ok(()) };
                inputs.heard(part.topic());
                let estimate = match &msg {
                    Ok(Force::Estimate(e)) => Some(*e),
                    _ => None,
                };
                let now = clock.now_s();
                let phase = {
                    let mut n = lock(shared);
                    if n.on_force_msg(part, &frame, msg, now) {
                        deadline = tokio::time::Instant::now()
                            + Duration::from_secs_f64(n.until_stale_s(now));
                        commands.publish(&n, now);
                    }
                    task_phase(&n)
                };
                // After the command, outside the lock.
                if let Some(e) = estimate {
                    markers.on_estimate(&e, &frame, phase);
                }
            }
            // No estimate in time: once the newest is stale, zero velocity,
            // every period.
            _ = tokio::time::sleep_until(deadline) => {
                let now = clock.now_s();
                let mut n = lock(shared);
                deadline = tokio::time::Instant::now()
                    + Duration::from_secs_f64(n.until_stale_s(now));
                if n.on_late(now).is_some() {
                    commands.publish(&n, now);
                }
            }
            () = &mut injected => panic!("injected panic (TACTILE_FORCE_INJECT_PANIC=control)"),
        }
    }
}
