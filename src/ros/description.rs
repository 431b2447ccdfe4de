//! The robot description (URDF) as ROS users give it: the
//! `robot_description` parameter, or else the `/robot_description` topic
//! (std_msgs/String, transient local: robot_state_publisher's), and the
//! names the arm's joints go by on `joint_states`. A description over
//! [`DESCRIPTION_MAX_BYTES`] is refused before it is decoded and counted
//! by the node's [`InputGuard`].

use std::sync::Arc;

use futures::stream::BoxStream;
use futures::StreamExt;
use r2r::std_msgs::msg::String as StringMsg;
use r2r::QosProfile;

use super::{bounded, RosError};
use crate::nodes::bounds::{InputGuard, DESCRIPTION_MAX_BYTES};
use crate::nodes::own_params;

/// The topic robot_state_publisher publishes the description on.
pub const DESCRIPTION_TOPIC: &str = "/robot_description";

/// Where the node's robot description comes from.
pub enum Description {
    /// The `robot_description` parameter.
    Given(String),
    /// The `/robot_description` topic: each description published on it.
    Topic(BoxStream<'static, String>),
}

/// The `robot_description` parameter, or, when it is empty, a subscription
/// to `/robot_description` with robot_state_publisher's QoS (reliable,
/// transient local: a late subscriber gets the latest description), its
/// messages bounded by `guard`.
pub fn robot_description(
    node: &mut r2r::Node,
    guard: &Arc<InputGuard>,
) -> Result<Description, RosError> {
    let text = super::own_string(node, &own_params::ROBOT_DESCRIPTION)?;
    if !text.is_empty() {
        return Ok(Description::Given(text));
    }
    let qos = QosProfile::default()
        .keep_last(1)
        .reliable()
        .transient_local();
    let topic = bounded::typed::<StringMsg>(
        node,
        DESCRIPTION_TOPIC,
        "std_msgs/msg/String",
        qos,
        DESCRIPTION_MAX_BYTES,
        guard,
    )?;
    Ok(Description::Topic(topic.map(|m| m.data).boxed()))
}

/// The `joint_names` parameter: the names of the arm's joints on
/// `joint_states`, in chain order; empty: the URDF's names.
pub fn joint_names_param(node: &impl super::HasParams) -> Result<Vec<String>, RosError> {
    super::own_strings(node, &own_params::JOINT_NAMES)
}

/// The first description on `topic` that `build` takes (each refused one
/// logged), then the topic dropped: r2r removes the subscription at the
/// next message, so later descriptions (a 50 MB one a peer publishes too)
/// are not copied into the node again. None if the topic ends first.
pub async fn first_taken<T>(
    mut topic: BoxStream<'static, String>,
    build: impl Fn(&str) -> Result<T, RosError>,
) -> Option<T> {
    loop {
        let text = topic.next().await?;
        match build(&text) {
            Ok(built) => return Some(built),
            Err(e) => tracing::error!("robot description refused: {e}"),
        }
    }
}
