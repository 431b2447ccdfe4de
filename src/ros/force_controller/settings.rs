//! `force_controller`'s parameters: its own and the controller's. They are
//! read at start (a refused one ends the process with exit code 2) and
//! again at each lifecycle `configure`; those that name the node's topics,
//! services and frames are read at start only ([`START_ONLY`]).

use std::sync::{Arc, Mutex};

use crate::control::{ControllerParams, TaskRegistry};
use crate::nodes::bounds::InputGuard;
use crate::nodes::force_controller::frames::Frames;
use crate::nodes::force_controller::live::live_params;
use crate::nodes::force_controller::{
    ft_to_biotac, tool_frame::biotac_frame, CommandInterface, ForceControllerNode,
};
use crate::nodes::lifecycle::State;
use crate::nodes::own_params;
use crate::nodes::param_reference::RosNode;
use crate::outputs::models_dir::ModelsDir;
use crate::ros::description::joint_names_param;
use crate::ros::params::{to_yaml, RuntimeParams};
use crate::ros::{self, lock, HasParams, RosError};
use crate::wrench::FrameTransform;

/// The parameters read at start only: they shape the node's topics,
/// services and published frame.
pub const START_ONLY: &[&str] = &[
    own_params::COMMAND_INTERFACE.name,
    own_params::ESTIMATOR_NODE.name,
    own_params::MODELS_DIR.name,
    own_params::BIOTAC_FRAME.name,
    own_params::START_STATE.name,
    own_params::SILENT_INPUT.name,
    own_params::ROBOT_DESCRIPTION.name,
];

/// What the node reads.
pub struct Settings {
    /// The joints' names, as the arm's driver calls them (`joint_names`).
    pub remap: Vec<String>,
    /// Joint velocities or a twist.
    pub interface: CommandInterface,
    /// Where the F/T sensor sits in the BioTac frame.
    pub ft_to_biotac: Option<FrameTransform>,
    /// The F/T sensor's frame (`ft_frame`).
    pub ft_frame: String,
    /// The estimator node whose model a calibration sets.
    pub estimator: String,
    /// Where calibrations may write.
    pub models: ModelsDir,
    /// The BioTac frame's name on /tf_static.
    pub child: String,
    /// Where the lifecycle goes at start.
    pub start: State,
    /// An input silent this long is named (s).
    pub silent_after_s: f64,
    /// The controller's parameters.
    pub base: ControllerParams,
}

/// Declares the node's parameters (those of `tasks`' sections too) and reads them.
pub fn declare(node: &impl HasParams, tasks: &TaskRegistry) -> Result<Settings, RosError> {
    let remap = joint_names_param(node)?;
    let interface: CommandInterface =
        ros::own_string(node, &own_params::COMMAND_INTERFACE)?.parse()?;
    let ft_to_biotac = ft_to_biotac(&ros::own_string(node, &own_params::FT_TO_BIOTAC)?)?;
    let ft_frame = ros::own_string(node, &own_params::FT_FRAME)?;
    let estimator = ros::own_string(node, &own_params::ESTIMATOR_NODE)?;
    let models = ros::models_dir(node)?;
    let child = biotac_frame(&ros::own_string(node, &own_params::BIOTAC_FRAME)?)?;
    let start = ros::own_string(node, &own_params::START_STATE)?;
    let start =
        State::start(&start).map_err(|expected| ros::invalid("start_state", &start, expected))?;
    let silent_after_s = ros::own_f64(node, &own_params::SILENT_INPUT)?;
    let base: ControllerParams = ros::node_params(node, RosNode::ForceController, tasks)?;
    Ok(Settings {
        remap,
        interface,
        ft_to_biotac,
        ft_frame,
        estimator,
        models,
        child,
        start,
        silent_after_s,
        base,
    })
}

impl Settings {
    /// The node they make (its wrenches' frames checked), sharing the
    /// input bounds of `guard`.
    pub fn node(
        &self,
        tasks: TaskRegistry,
        guard: &Arc<InputGuard>,
    ) -> Result<ForceControllerNode, RosError> {
        let frames = Frames::new(&self.child, &self.ft_frame, self.ft_to_biotac.is_some())?;
        let n = ForceControllerNode::new(
            self.base.clone(),
            tasks,
            self.remap.clone(),
            self.ft_to_biotac,
        )?;
        Ok(n.with_frames(frames).with_guard(guard.clone()))
    }
}

/// How the node answers a parameter set while it runs: `task` switches
/// the task, the other live parameters ([`live_params`]) retune it; each
/// checked as at start-up, or refused with the reason. While unconfigured,
/// any parameter but those read at start only, for the next `configure`.
pub(super) fn live(
    shared: &Arc<Mutex<ForceControllerNode>>,
    guard: &Arc<InputGuard>,
    declared: ros::ParamMap,
) -> RuntimeParams {
    let s = shared.clone();
    let names = live_params(lock(&s).tasks());
    let live = RuntimeParams::new(
        &names,
        Box::new(move |name, value, apply| {
            lock(&s)
                .set_param(name, to_yaml(value), apply)
                .inspect_err(|e| tracing::warn!("{name} refused: {e}"))
        }),
        guard,
    );
    let s = shared.clone();
    live.unless_unconfigured(
        Box::new(move || lock(&s).state() == State::Unconfigured),
        START_ONLY,
        declared,
    )
}
