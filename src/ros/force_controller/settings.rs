//! `force_controller`'s parameters: its own and the controller's.

use crate::control::{ControllerParams, TaskRegistry};
use crate::nodes::force_controller::{
    ft_to_biotac, tool_frame::biotac_frame, tool_frame::BIOTAC_FRAME, CommandInterface,
};
use crate::nodes::param_reference::SharedNode;
use crate::outputs::models_dir::ModelsDir;
use crate::ros::description::joint_names_param;
use crate::ros::{self, RosError};
use crate::wrench::FrameTransform;

/// What the node reads at start-up.
pub struct Settings {
    /// The joints' names, as the arm's driver calls them (`joint_names`).
    pub remap: Vec<String>,
    /// Joint velocities or a twist.
    pub interface: CommandInterface,
    /// Where the F/T sensor sits in the BioTac frame.
    pub ft_to_biotac: Option<FrameTransform>,
    /// The estimator node whose model a calibration sets.
    pub estimator: String,
    /// Where calibrations may write.
    pub models: ModelsDir,
    /// The BioTac frame's name on /tf_static.
    pub child: String,
    /// The controller's parameters.
    pub base: ControllerParams,
}

/// Declares the node's parameters (those of `tasks`' sections too) and reads them.
pub fn declare(node: &r2r::Node, tasks: &TaskRegistry) -> Result<Settings, RosError> {
    let remap = joint_names_param(node)?;
    let interface: CommandInterface = ros::own_string(
        node,
        "command_interface",
        "joint_velocities",
        "joint_velocities (velocity_controller/commands) or twist (twist_commands).",
    )?
    .parse()?;
    let ft_to_biotac = ft_to_biotac(&ros::own_string(
        node,
        "ft_to_biotac",
        "",
        "Where the F/T sensor sits in the BioTac frame, roll,pitch,yaw,x,y,z (deg, fixed-axis x-y-z; m): its wrenches are moved to the BioTac frame for the calibration; empty: they are in it already.",
    )?)?;
    let estimator = ros::own_string(
        node,
        "estimator_node",
        "wrench_estimator",
        "The estimator whose model the calibration adapts and then sets (its model_file parameter).",
    )?;
    let models = ros::models_dir(node)?;
    let child = biotac_frame(&ros::own_string(
        node,
        "biotac_frame",
        BIOTAC_FRAME,
        "The BioTac frame, published on /tf_static in the tip link from robot.tool_*: the estimator's frame_id must name it too.",
    )?)?;
    let skip = [
        "biotac_frame",
        "joint_names",
        "robot_description",
        "command_interface",
        "ft_to_biotac",
        "estimator_node",
        "models_dir",
    ];
    let base: ControllerParams = ros::node_params(node, SharedNode::ForceController, tasks, &skip)?;
    Ok(Settings {
        remap,
        interface,
        ft_to_biotac,
        estimator,
        models,
        child,
        base,
    })
}
