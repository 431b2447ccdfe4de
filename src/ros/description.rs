//! The robot description (URDF) as ROS users give it: the
//! `robot_description` parameter, or else the `/robot_description` topic
//! (std_msgs/String, transient local: robot_state_publisher's), and the
//! names the arm's joints go by on `joint_states`.

use futures::stream::BoxStream;
use futures::StreamExt;
use r2r::std_msgs::msg::String as StringMsg;
use r2r::QosProfile;

use super::RosError;
use crate::kinematics::Robot;
use crate::params::ParamsError;

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
/// transient local: a late subscriber gets the latest description).
pub fn robot_description(node: &mut r2r::Node) -> Result<Description, RosError> {
    let text = super::own_string(
        node,
        "robot_description",
        "",
        "The robot's URDF; empty: taken from /robot_description (std_msgs/String, transient local).",
    )?;
    if !text.is_empty() {
        return Ok(Description::Given(text));
    }
    let qos = QosProfile::default()
        .keep_last(1)
        .reliable()
        .transient_local();
    let topic = node.subscribe::<StringMsg>(DESCRIPTION_TOPIC, qos)?;
    Ok(Description::Topic(topic.map(|m| m.data).boxed()))
}

/// The `joint_names` parameter: the names of the arm's joints on
/// `joint_states`, in chain order; empty: the URDF's names.
pub fn joint_names_param(node: &r2r::Node) -> Result<Vec<String>, RosError> {
    super::own_strings(
        node,
        "joint_names",
        &[],
        "The arm's joints on joint_states, in chain order; empty: the URDF's names.",
    )
}

/// The arm's joint names: `remap` (one per joint of the chain), or the
/// URDF's when `remap` is empty.
pub fn joint_names(robot: &Robot, remap: &[String]) -> Result<Vec<String>, ParamsError> {
    if remap.is_empty() {
        return Ok(robot.joint_names());
    }
    if remap.len() != robot.dof() {
        return Err(ParamsError::Invalid {
            key: "joint_names".into(),
            value: format!("{remap:?}"),
            expected: format!(
                "one name per joint of the chain, {} in order ({}), or none",
                robot.dof(),
                robot.joint_names().join(", ")
            ),
        });
    }
    Ok(remap.to_vec())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::ShippedRobot;

    #[test]
    fn joint_names_come_from_the_chain_unless_remapped_one_to_one() {
        let ur5 = ShippedRobot::Ur5.robot().unwrap();
        assert_eq!(joint_names(&ur5, &[]).unwrap()[0], "shoulder_pan_joint");
        let remap: Vec<String> = (1..=6).map(|i| format!("j{i}")).collect();
        assert_eq!(joint_names(&ur5, &remap).unwrap(), remap);
        let e = joint_names(&ur5, &remap[..5]).unwrap_err().to_string();
        assert!(e.contains("6 in order (shoulder_pan_joint,"), "{e}");
    }
}
