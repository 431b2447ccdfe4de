//! `sim_robot`'s parameters: its own and the scene's.

use crate::nodes::own_params;
use crate::nodes::param_reference::RosNode;
use crate::nodes::sim_robot::check_real_time_factor;
use crate::nodes::tasks;
use crate::nodes::SimRobotParams;
use crate::ros::description::joint_names_param;
use crate::ros::{self, RosError};

/// The node's settings: its own parameters and the scene's.
pub struct Settings {
    /// The joints' names, as the arm's driver calls them (`joint_names`).
    pub remap: Vec<String>,
    /// The BioTac frame.
    pub frame_id: String,
    /// Seed of the simulated noise.
    pub seed: u64,
    /// Publishes `/clock` and stamps with it.
    pub sim_time: bool,
    /// Simulated seconds per wall-clock second.
    pub speed: f64,
    /// With no command this long the arm stops (s); 0: it holds.
    pub command_timeout_s: f64,
    /// The scene's parameters.
    pub p: SimRobotParams,
}

/// Declares the node's parameters and reads them.
pub fn declare(node: &impl ros::HasParams) -> Result<Settings, RosError> {
    let remap = joint_names_param(node)?;
    let frame_id = ros::own_string(node, &own_params::SIM_FRAME)?;
    let seed = ros::own_u64(node, &own_params::SEED)?;
    let sim_time = ros::own_bool(node, &own_params::USE_SIM_TIME)?;
    let speed = ros::own_f64(node, &own_params::REAL_TIME_FACTOR)?;
    check_real_time_factor(speed, sim_time)?;
    let command_timeout_s = ros::own_f64(node, &own_params::COMMAND_TIMEOUT)?;
    let p: SimRobotParams = ros::node_params(node, RosNode::SimRobot, &tasks::shipped())?;
    Ok(Settings {
        remap,
        frame_id,
        seed,
        sim_time,
        speed,
        command_timeout_s,
        p,
    })
}

impl Settings {
    /// Logs what it simulates.
    pub fn log(&self) {
        tracing::info!(
            "object {}, BioTac unit {}, noise seed {}, period {} s, {}, {}",
            self.p.object,
            self.p.sensor_unit,
            self.seed,
            self.p.control_period_s,
            if self.sim_time {
                format!("simulated time on /clock, {}x real time", self.speed)
            } else {
                "system time".to_string()
            },
            match self.command_timeout_s {
                0.0 => "the last command held until another comes".to_string(),
                t => format!("no command for {t} s stops the arm"),
            }
        );
    }
}
