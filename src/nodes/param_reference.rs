//! The parameters of the ROS nodes: those of the shared files, each
//! declared once by the field that reads it ([`crate::params::reference`]),
//! and the adapters' own ([`super::own_params`]): what the nodes describe
//! them with, and docs/parameters.md ([`markdown`]; tests/param_reference.rs
//! keeps it current).

use serde_yaml_ng::Value;

use super::force_controller::live::live_params;
use super::force_controller::shipped_defaults;
use super::sim_robot::SimRobotParams;
use super::wrench_estimator::EstimatorParams;
use crate::control::{ControllerParams, TaskKind, TaskRegistry};
use crate::params::reference::{describe, params_of, ParamDoc};
use crate::params::{layered_flat_params, FlatParams, ParamsError, WORLD_YAML};

/// A ROS node of the package.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RosNode {
    /// `force_controller`.
    ForceController,
    /// `wrench_estimator`.
    WrenchEstimator,
    /// `sim_robot`.
    SimRobot,
    /// `biotac_driver` (its own parameters only).
    BiotacDriver,
}

impl RosNode {
    /// Every one, in the order docs/parameters.md lists them.
    pub const ALL: [RosNode; 4] = [
        RosNode::ForceController,
        RosNode::WrenchEstimator,
        RosNode::SimRobot,
        RosNode::BiotacDriver,
    ];

    /// Its name in the parameter files.
    pub fn name(self) -> &'static str {
        match self {
            RosNode::ForceController => "force_controller",
            RosNode::WrenchEstimator => "wrench_estimator",
            RosNode::SimRobot => "sim_robot",
            RosNode::BiotacDriver => "biotac_driver",
        }
    }

    /// Its adapter's own parameters, each with its default as shown.
    pub fn own(self) -> Vec<(ParamDoc, String)> {
        use super::own_params::*;
        match self {
            RosNode::ForceController => vec![
                ROBOT_DESCRIPTION.row(),
                JOINT_NAMES.row(),
                MODELS_DIR.row(),
                COMMAND_INTERFACE.row(),
                FT_TO_BIOTAC.row(),
                FT_FRAME.row(),
                ESTIMATOR_NODE.row(),
                BIOTAC_FRAME.row(),
                START_STATE.row(),
                SILENT_INPUT.row(),
            ],
            RosNode::WrenchEstimator => vec![
                MODEL_FILE.row(),
                MODELS_DIR.row(),
                ESTIMATE_FRAME.row(),
                STALE_TIMEOUT.row(),
                TARE_FILE.row(),
                TARE_MAX_AGE.row(),
                INPUT.row(),
                FINGER.row(),
                SILENT_INPUT.row(),
            ],
            RosNode::SimRobot => vec![
                ROBOT_DESCRIPTION.row(),
                JOINT_NAMES.row(),
                SIM_FRAME.row(),
                SEED.row(),
                USE_SIM_TIME.row(),
                REAL_TIME_FACTOR.row(),
                COMMAND_TIMEOUT.row(),
            ],
            RosNode::BiotacDriver => vec![
                READINGS_FRAME.row(),
                SERIAL.row(),
                TARE_SAMPLES.row(),
                PORT.row(),
                LINK.row(),
                CHEETAH.row(),
                CHEETAH_LIBRARY.row(),
                SENSORS.row(),
                ELECTRODES.row(),
                START_STATE.row(),
            ],
        }
    }

    /// The names of its adapter's own parameters (not read from the
    /// shared files).
    pub fn own_names(self) -> Vec<String> {
        self.own().into_iter().map(|(doc, _)| doc.key).collect()
    }

    /// The parameters it reads (the controller's with those of `tasks`).
    pub fn params(self, tasks: &TaskRegistry) -> Vec<ParamDoc> {
        match self {
            RosNode::ForceController => {
                let mut docs = params_of::<ControllerParams>("");
                docs.extend(tasks.params());
                docs
            }
            RosNode::WrenchEstimator => params_of::<EstimatorParams>(""),
            RosNode::SimRobot => params_of::<SimRobotParams>(""),
            RosNode::BiotacDriver => Vec::new(),
        }
    }

    /// Its parameters that may change while it runs (`ros2 param set`), a
    /// group as `name.*`, and when a set takes effect.
    pub fn live(self, tasks: &TaskRegistry) -> (Vec<String>, &'static str) {
        match self {
            RosNode::ForceController => (
                live_params(tasks),
                "checked as at start-up on the task it concerns (its section's \
                 task; for a shared one, the task running), a refused set saying \
                 why; a running guided move takes it at once, \
                 keeping its start, its travel and what it measured; a goal running \
                 keeps its own settings and the next goal or task start takes it. \
                 `/diagnostics` shows the last set and when it took effect \
                 (`last_parameter_set`)",
            ),
            RosNode::WrenchEstimator => (
                vec![super::own_params::MODEL_FILE.name.into()],
                "the model is loaded, checked and swapped between two estimates \
                 (a BioTac model; a nail model is read at start-up only)",
            ),
            RosNode::SimRobot | RosNode::BiotacDriver => (Vec::new(), ""),
        }
    }

    /// The shipped files' values of its parameters (the guarded scene's,
    /// and every task's section for the controller).
    pub fn defaults(self) -> Result<FlatParams, ParamsError> {
        match self {
            RosNode::ForceController => shipped_defaults(),
            RosNode::BiotacDriver => Ok(Vec::new()),
            _ => layered_flat_params(&[WORLD_YAML, TaskKind::Guarded.scene_yaml()], self.name()),
        }
    }

    /// The description of its parameter `name`: its own, or else that of a
    /// key of the world's `/**` meant for another node.
    pub fn describe(self, tasks: &TaskRegistry, name: &str) -> String {
        self.descriptions(tasks)(name)
    }

    /// [`RosNode::describe`] for every parameter it declares, the fields
    /// read once.
    pub fn descriptions(self, tasks: &TaskRegistry) -> impl Fn(&str) -> String {
        let own = self.params(tasks);
        let all = RosNode::ALL.map(|n| n.params(tasks)).concat();
        move |name| {
            let said = describe(&own, name).or_else(|| describe(&all, name));
            said.map_or_else(|| "See the config/ files.".into(), str::to_string)
        }
    }
}

/// docs/parameters.md: each node's parameters with their type, shipped
/// value and description.
pub fn markdown(tasks: &TaskRegistry) -> Result<String, ParamsError> {
    let mut out = String::from(
        "# Parameters\n\n\
         Every parameter of the ROS nodes, generated from where each is declared:\n\
         the fields of the structs that read the shared files (type, doc comment,\n\
         range), with their values in the shipped files (config/world.yaml, then\n\
         config/guarded_move.yaml; a task's section from its own scene), and the\n\
         adapters' own (src/nodes/own_params.rs). `cargo test --test\n\
         param_reference` fails when this page is stale;\n\
         `TACTILE_FORCE_WRITE_DOCS=1 cargo test --test param_reference` writes it\n\
         again. `accepts`: the range a field declares, checked when the node\n\
         starts (a value outside is refused, named with what it expects); rules\n\
         between fields are the struct's own checks. `<name>`: any key (an\n\
         object's name, a joint's name).\n",
    );
    for node in RosNode::ALL {
        let defaults = node.defaults()?;
        out.push_str(&format!("\n## {}\n", node.name()));
        out.push_str(&live_line(node, tasks));
        let shared = node.params(tasks).into_iter().map(|doc| {
            let value = defaults.iter().find(|(k, _)| *k == doc.key);
            let shown = value.map_or(String::new(), |(_, v)| shown(v));
            (doc, shown)
        });
        let tables = [
            ("From the shared files", shared.collect::<Vec<_>>()),
            ("Its own", node.own()),
        ];
        for (title, rows) in tables.into_iter().filter(|(_, rows)| !rows.is_empty()) {
            out.push_str(&format!(
                "\n{title}:\n\n| parameter | type | accepts | default | description |\n\
                 |---|---|---|---|---|\n"
            ));
            for (doc, value) in rows {
                out.push_str(&row(&doc, &value));
            }
        }
    }
    Ok(out)
}

/// What may change while `node` runs: the rest is read at start-up (and
/// by a managed node at each `configure`).
fn live_line(node: RosNode, tasks: &TaskRegistry) -> String {
    let (names, when) = node.live(tasks);
    let managed = matches!(node, RosNode::ForceController | RosNode::BiotacDriver);
    let rest = match managed {
        true => {
            "read at start-up and at each lifecycle `configure` (set them while \
                 the node is unconfigured)"
        }
        false => "read at start-up: restart the node to change them",
    };
    if names.is_empty() {
        return format!("\nNone may change while the node runs: all are {rest}.\n");
    }
    let names: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    format!(
        "\nLive, may change while the node runs (`ros2 param set`): {}: {when}. \
         The others are {rest}.\n",
        names.join(", ")
    )
}

/// A table row.
fn row(doc: &ParamDoc, value: &str) -> String {
    let cell = |s: &str| s.replace('|', "\\|");
    format!(
        "| `{}` | {} | {} | {} | {} |\n",
        doc.key,
        doc.kind,
        doc.range,
        cell(value),
        cell(&doc.description)
    )
}

/// A shipped value as the table shows it (JSON).
fn shown(v: &Value) -> String {
    let text = serde_json::to_string(v).unwrap_or_default();
    format!("`{}`", text.replace(',', ", "))
}
