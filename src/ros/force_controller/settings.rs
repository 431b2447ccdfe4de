//! `force_controller`'s parameters: its own and the controller's.

use crate::control::{ControllerParams, TaskRegistry};
use crate::nodes::force_controller::{ft_to_biotac, tool_frame::biotac_frame, CommandInterface};
use crate::nodes::own_params;
use crate::nodes::param_reference::RosNode;
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
    let interface: CommandInterface =
        ros::own_string(node, &own_params::COMMAND_INTERFACE)?.parse()?;
    let ft_to_biotac = ft_to_biotac(&ros::own_string(node, &own_params::FT_TO_BIOTAC)?)?;
    let estimator = ros::own_string(node, &own_params::ESTIMATOR_NODE)?;
    let models = ros::models_dir(node)?;
    let child = biotac_frame(&ros::own_string(node, &own_params::BIOTAC_FRAME)?)?;
    let base: ControllerParams = ros::node_params(node, RosNode::ForceController, tasks)?;
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
