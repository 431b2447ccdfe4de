//! The parameters of the nodes read from the shared files, each declared
//! once by the field that reads it ([`crate::params::reference`]): what
//! the ROS nodes describe them with, and docs/parameters.md
//! ([`markdown`]; tests/param_reference.rs keeps it current).

use serde_yaml_ng::Value;

use super::estimator::EstimatorParams;
use super::force_controller::shipped_defaults;
use super::sim_robot::SimRobotParams;
use crate::control::{ControllerParams, TaskKind, TaskRegistry};
use crate::params::reference::{describe, params_of, ParamDoc};
use crate::params::{layered_flat_params, FlatParams, ParamsError, WORLD_YAML};

/// A node whose parameters come from the shared files.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SharedNode {
    /// `force_controller`.
    ForceController,
    /// `wrench_estimator`.
    WrenchEstimator,
    /// `sim_robot`.
    SimRobot,
}

impl SharedNode {
    /// Every one, in the order docs/parameters.md lists them.
    pub const ALL: [SharedNode; 3] = [
        SharedNode::ForceController,
        SharedNode::WrenchEstimator,
        SharedNode::SimRobot,
    ];

    /// Its name in the parameter files.
    pub fn name(self) -> &'static str {
        match self {
            SharedNode::ForceController => "force_controller",
            SharedNode::WrenchEstimator => "wrench_estimator",
            SharedNode::SimRobot => "sim_robot",
        }
    }

    /// The parameters it reads (the controller's with those of `tasks`).
    pub fn params(self, tasks: &TaskRegistry) -> Vec<ParamDoc> {
        match self {
            SharedNode::ForceController => {
                let mut docs = params_of::<ControllerParams>("");
                docs.extend(tasks.params());
                docs
            }
            SharedNode::WrenchEstimator => params_of::<EstimatorParams>(""),
            SharedNode::SimRobot => params_of::<SimRobotParams>(""),
        }
    }

    /// The shipped files' values of its parameters (the guarded scene's,
    /// and every task's section for the controller).
    pub fn defaults(self) -> Result<FlatParams, ParamsError> {
        match self {
            SharedNode::ForceController => shipped_defaults(),
            _ => layered_flat_params(&[WORLD_YAML, TaskKind::Guarded.scene_yaml()], self.name()),
        }
    }

    /// The description of its parameter `name`: its own, or else that of a
    /// key of the world's `/**` meant for another node.
    pub fn describe(self, tasks: &TaskRegistry, name: &str) -> String {
        let own = self.params(tasks);
        let other = || SharedNode::ALL.map(|n| n.params(tasks)).concat();
        let said = describe(&own, name).map(str::to_string);
        said.or_else(|| describe(&other(), name).map(str::to_string))
            .unwrap_or_else(|| "See the config/ files.".into())
    }
}

/// docs/parameters.md: each node's parameters with their type, shipped
/// value and description.
pub fn markdown(tasks: &TaskRegistry) -> Result<String, ParamsError> {
    let mut out = String::from(
        "# Parameters\n\n\
         Generated from the structs that read them (their doc comments) and the\n\
         shipped files (config/world.yaml, then config/guarded_move.yaml; a task's\n\
         section from its own scene): `cargo test --test param_reference` fails\n\
         when this page is stale, and `TACTILE_FORCE_WRITE_DOCS=1 cargo test --test\n\
         param_reference` writes it again. `accepts`: the range its field declares,\n\
         checked when the node starts (a value outside is refused, named with\n\
         what it expects); rules between fields are the struct's own checks.\n\
         `<name>`: any key (an object's name, a joint's name).\n",
    );
    for node in SharedNode::ALL {
        let defaults = node.defaults()?;
        out.push_str(&format!(
            "\n## {}\n\n| parameter | type | accepts | shipped | description |\n|---|---|---|---|---|\n",
            node.name()
        ));
        for doc in node.params(tasks) {
            let value = defaults
                .iter()
                .find(|(k, _)| *k == doc.key)
                .map_or(String::new(), |(_, v)| shown(v));
            out.push_str(&format!(
                "| `{}` | {} | {} | {} | {} |\n",
                doc.key,
                doc.kind,
                doc.range,
                value,
                doc.description.replace('|', "\\|")
            ));
        }
    }
    Ok(out)
}

/// A shipped value as the table shows it (JSON).
fn shown(v: &Value) -> String {
    let text = serde_json::to_string(v).unwrap_or_default();
    format!("`{}`", text.replace(',', ", ").replace('|', "\\|"))
}
