//! Subscriptions bounded in size ([`crate::nodes::bounds`]): each message
//! is taken as CDR bytes and its length put to the node's [`InputGuard`]
//! before it is decoded; one over its bound is counted there and dropped,
//! never decoded. r2r copies a message's bytes on the spin thread either
//! way; decoding happens on the task that takes the stream.

use std::sync::Arc;

use futures::future::ready;
use futures::{Stream, StreamExt};
use r2r::{QosProfile, WrappedTypesupport};

#[cfg(not(feature = "ros2-doc-only"))]
use super::action_server::{GoalRequest, Served};
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

/// The goal requests that `guard` admits; each other one is accepted and
/// at once aborted with `refused` of its reason (a result holding it), as
/// a goal the node refuses on its merits is. `guard` logs the reason and
/// counts it for `/diagnostics`.
#[cfg(not(feature = "ros2-doc-only"))]
pub fn goals<T: Served>(
    requests: impl Messages<GoalRequest<T>>,
    guard: &Arc<InputGuard>,
    refused: fn(String) -> T::Result,
) -> impl Messages<GoalRequest<T>> {
    let guard = guard.clone();
    requests.filter_map(move |req| {
        let admitted = match guard.admit_goal() {
            Ok(()) => Some(req),
            Err(e) => {
                if let Ok((mut goal, _)) = req.accept() {
                    goal.abort(refused(format!("refused: {e}")));
                }
                None
            }
        };
        ready(admitted)
    })
}
