//! Subscriptions bounded in size ([`crate::nodes::bounds`]): each message
//! is taken as CDR bytes and its length put to the node's [`InputGuard`]
//! before it is decoded; one over its bound is counted there and dropped,
//! never decoded. r2r copies a message's bytes on the spin thread either
//! way; decoding happens on the task that takes the stream.

use std::sync::Arc;

use futures::future::ready;
use futures::{Stream, StreamExt};
use r2r::{QosProfile, WrappedTypesupport};

use super::RosError;
use crate::nodes::bounds::InputGuard;

/// A stream of messages a node takes.
pub trait Messages<T>: Stream<Item = T> + Unpin + Send + 'static {}
impl<T, S: Stream<Item = T> + Unpin + Send + 'static> Messages<T> for S {}

/// The messages on `topic` (of `type_name`, "std_msgs/msg/String", say)
/// as CDR bytes, those over `max_bytes` refused.
pub fn raw(
    node: &mut r2r::Node,
    topic: &str,
    type_name: &str,
    qos: QosProfile,
    max_bytes: usize,
    guard: &Arc<InputGuard>,
) -> Result<impl Messages<Vec<u8>>, RosError> {
    let messages = node.subscribe_raw(topic, type_name, qos)?;
    let (guard, topic) = (guard.clone(), topic.to_string());
    Ok(messages.filter(move |m| ready(guard.admit_size(&topic, m.len(), max_bytes).is_ok())))
}

/// The messages on `topic` decoded as `T` (of `type_name`), those over
/// `max_bytes` refused before decoding.
pub fn typed<T: WrappedTypesupport + Send + 'static>(
    node: &mut r2r::Node,
    topic: &str,
    type_name: &str,
    qos: QosProfile,
    max_bytes: usize,
    guard: &Arc<InputGuard>,
) -> Result<impl Messages<T>, RosError> {
    let name = topic.to_string();
    let messages = raw(node, topic, type_name, qos, max_bytes, guard)?;
    Ok(messages.filter_map(move |m| {
        let decoded = T::from_serialized_bytes(&m);
        ready(
            decoded
                .inspect_err(|e| tracing::debug!("{name}: not decoded: {e}"))
                .ok(),
        )
    }))
}

/// The goal requests that `guard` admits, drained from r2r's queue on a
/// task of their own (r2r drops a request, unanswered, when its queue of
/// ten is full); the others are rejected at the request, which makes no
/// goal: r2r 0.9.7 keeps every goal it accepted for the node's life (r2r
/// issue #136), so accepting a flood to abort it with a reason would grow
/// the node without bound. `guard` logs the reason and counts it for
/// `/diagnostics`.
#[cfg(not(feature = "ros2-doc-only"))]
pub fn goals<T: r2r::WrappedActionTypeSupport + 'static>(
    mut requests: impl Messages<r2r::ActionServerGoalRequest<T>>,
    guard: &Arc<InputGuard>,
) -> impl Messages<r2r::ActionServerGoalRequest<T>> {
    // Unbounded, as the rate bounds what enters it.
    let (admitted, out) = futures::channel::mpsc::unbounded();
    let guard = guard.clone();
    tokio::spawn(async move {
        while let Some(req) = requests.next().await {
            if guard.admit_goal().is_err() {
                let _ = req.reject();
            } else if admitted.unbounded_send(req).is_err() {
                return;
            }
        }
    });
    out
}
