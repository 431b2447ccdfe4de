//! Scenes: the parameter files that configure one run, layered as ROS 2
//! does with several `--params-file`s (later files override earlier ones):
//! the robot (`config/pa10.yaml`), the world (`config/world.yaml`: skin law,
//! objects, arm plant, sensors), then the task's scene
//! (`config/guarded_move.yaml` or `config/guided_move.yaml`, or a user's
//! file). The shipped files are embedded, so the demo runs from anywhere.

use std::path::Path;

use crate::biotac::BioTacSimConfig;
use crate::kinematics::robot::PA10_YAML;
use crate::learn::model::WrenchGp;
use crate::nodes::controller::TaskKind;
use crate::nodes::estimator::{EstimatorError, EstimatorParams};
use crate::nodes::{ControllerParams, EstimatorNode, ForceController, SimRobot, SimRobotParams};
use crate::params::{layered_node_params, ParamsError, GUARDED_YAML, GUIDED_YAML, WORLD_YAML};
use crate::runtime::lockstep::Link;
use crate::runtime::Nodes;
use crate::wrench::AxisSet;

/// Errors building a run from a scene.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// A parameter is missing, unknown or out of range.
    #[error(transparent)]
    Params(#[from] ParamsError),
    /// The model cannot serve the estimator or the task.
    #[error(transparent)]
    Estimator(#[from] EstimatorError),
    /// The model lacks an axis the task controls.
    #[error("the model estimates {model}; the scene's task controls {task}")]
    Axes {
        /// The model's axes.
        model: String,
        /// The task's axes.
        task: String,
    },
}

/// The parameter texts of one run, in order.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    layers: Vec<String>,
}

impl Scene {
    /// The shipped scene of a task.
    pub fn builtin(task: TaskKind) -> Self {
        let scene = match task {
            TaskKind::Guarded => GUARDED_YAML,
            TaskKind::Guided => GUIDED_YAML,
        };
        Scene {
            layers: vec![PA10_YAML.into(), WORLD_YAML.into(), scene.into()],
        }
    }

    /// The shipped robot and world with the scene file at `path`.
    pub fn from_file(path: &Path) -> Result<Self, ParamsError> {
        let text = std::fs::read_to_string(path).map_err(|source| ParamsError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Ok(Scene {
            layers: vec![PA10_YAML.into(), WORLD_YAML.into(), text],
        })
    }

    /// Adds a layer on top (a YAML parameter text).
    pub fn with_layer(mut self, yaml: String) -> Self {
        self.layers.push(yaml);
        self
    }

    /// Sets the object for every node (as the launch argument `object` does).
    pub fn with_object(self, name: &str) -> Self {
        // Quoted as a YAML string whatever the name holds.
        let quoted = serde_json::to_string(name).unwrap_or_default();
        self.with_layer(format!("/**:\n  ros__parameters:\n    object: {quoted}\n"))
    }

    /// Sets the guarded move's approach speed (m/s).
    pub fn with_approach_speed(self, mps: f64) -> Self {
        // As YAML writes it (NaN is `.nan`), so that any value reaches the check.
        let value = serde_yaml_ng::to_string(&mps).unwrap_or_default();
        self.with_layer(format!(
            "force_controller:\n  ros__parameters:\n    guarded:\n      approach_speed_mps: {}\n",
            value.trim()
        ))
    }

    /// Sets the object for every node and permits only it
    /// (`force_controller.safety.objects`): the speed limit is then that
    /// object's own (the speed sweep, tests).
    pub fn with_only_object(self, name: &str) -> Self {
        let quoted = serde_json::to_string(name).unwrap_or_default();
        self.with_object(name).with_layer(format!(
            "force_controller:\n  ros__parameters:\n    safety:\n      objects: [{quoted}]\n"
        ))
    }

    /// The controller's parameters.
    pub fn controller_params(&self) -> Result<ControllerParams, ParamsError> {
        layered_node_params(&self.texts(), "force_controller")
    }

    /// The estimator's parameters.
    pub fn estimator_params(&self) -> Result<EstimatorParams, ParamsError> {
        layered_node_params(&self.texts(), "wrench_estimator")
    }

    /// The simulated robot's parameters.
    pub fn sim_params(&self) -> Result<SimRobotParams, ParamsError> {
        layered_node_params(&self.texts(), "sim_robot")
    }

    /// The layers' texts, in order (as `--params-file`s would be given).
    pub fn texts(&self) -> Vec<&str> {
        self.layers.iter().map(String::as_str).collect()
    }

    /// Checks every parameter of the controller and the simulated robot
    /// (before an expensive step such as training a model).
    pub fn check(&self) -> Result<(), SceneError> {
        let recipe = self.estimator_params()?.default_model;
        let (controller, _, _) = self.controller_and_sim(&BioTacSimConfig::default(), 0)?;
        missing_axes(&recipe.axes, controller.axes())
    }

    /// The controller, the simulated robot and the estimate's link, checked,
    /// and checked against each other: the controller's gains and safety envelope must assume an
    /// arm and a transport no faster than the simulated ones.
    fn controller_and_sim(
        &self,
        sensor: &BioTacSimConfig,
        seed: u64,
    ) -> Result<(ForceController, SimRobot, Link), SceneError> {
        let cp = self.controller_params()?;
        let sp = self.sim_params()?;
        // The lockstep controller takes a delayed estimate at its next tick.
        let ticks = ((sp.transport_delay_s + sp.transport_jitter_s) / sp.control_period_s - 1e-9)
            .ceil()
            .max(0.0);
        let covered = [
            (
                "loop_delays.transport_delay_s",
                cp.loop_delays.transport_delay_s,
                ticks * sp.control_period_s,
                "sim_robot.transport_delay_s + transport_jitter_s, in whole periods",
            ),
            (
                "loop_delays.command_latency_s",
                cp.loop_delays.command_latency_s,
                sp.command_latency_s,
                "sim_robot.command_latency_s",
            ),
            (
                "loop_delays.arm_lag_s",
                cp.loop_delays.arm_lag_s,
                sp.velocity_lag_s,
                "sim_robot.velocity_lag_s",
            ),
        ];
        for (key, assumed, actual, what) in covered {
            if assumed < actual - 1e-12 {
                return Err(SceneError::Params(ParamsError::Invalid {
                    key: key.into(),
                    value: assumed.to_string(),
                    expected: format!(
                        "at least {actual} s, the simulated {what}: the gains and the \
                         safety envelope must not assume a faster loop than the one they run in"
                    ),
                }));
            }
        }
        let controller = ForceController::new(cp)?;
        let link = Link::new(sp.transport_delay_s, sp.transport_jitter_s, seed);
        let sim = SimRobot::new(sp, controller.robot().clone(), sensor, seed)?;
        Ok((controller, sim, link))
    }

    /// Builds the nodes of a run with `model`; `seed` drives the noise.
    pub fn build(
        &self,
        model: WrenchGp,
        sensor: &BioTacSimConfig,
        seed: u64,
    ) -> Result<Nodes, SceneError> {
        let (controller, sim, link) = self.controller_and_sim(sensor, seed)?;
        missing_axes(model.axes(), controller.axes())?;
        let estimator = EstimatorNode::new(model, self.estimator_params()?.with_std)?;
        Ok(Nodes {
            sim,
            estimator,
            controller,
            link,
        })
    }
}

/// Refuses a model (or recipe) lacking an axis the task controls.
fn missing_axes(model: &AxisSet, task: &AxisSet) -> Result<(), SceneError> {
    if task.axes().iter().all(|a| model.axes().contains(a)) {
        return Ok(());
    }
    Err(SceneError::Axes {
        model: model.to_string(),
        task: task.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_shipped_scenes_parse_and_the_object_can_be_chosen() {
        for task in [TaskKind::Guarded, TaskKind::Guided] {
            let s = Scene::builtin(task);
            assert_eq!(s.controller_params().unwrap().task, task);
            s.sim_params().unwrap();
        }
        let guided = Scene::builtin(TaskKind::Guided);
        assert_eq!(guided.sim_params().unwrap().object, "fingertip");
        assert!(guided.sim_params().unwrap().finger_path.is_some());
        let s = Scene::builtin(TaskKind::Guarded).with_object("carton_box");
        assert_eq!(s.controller_params().unwrap().object, "carton_box");
        assert_eq!(s.sim_params().unwrap().object, "carton_box");
        let s = s.with_approach_speed(0.025);
        assert_eq!(
            s.controller_params()
                .unwrap()
                .guarded
                .unwrap()
                .approach_speed_mps,
            0.025
        );
    }

    #[test]
    fn unknown_objects_and_keys_are_named() {
        let s = Scene::builtin(TaskKind::Guarded).with_object("teapot");
        let e = ForceController::new(s.controller_params().unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("teapot") && e.contains("wooden_box"), "{e}");
        let s = Scene::builtin(TaskKind::Guarded)
            .with_layer("sim_robot:\n  ros__parameters:\n    gap_mm: 3.0\n".into());
        let e = s.sim_params().unwrap_err().to_string();
        assert!(e.contains("gap_mm"), "{e}");
        let s = Scene::builtin(TaskKind::Guarded)
            .with_layer("force_controller:\n  ros__parameters:\n    task: guided\n".into());
        let e = ForceController::new(s.controller_params().unwrap())
            .unwrap_err()
            .to_string();
        assert!(e.contains("guided"), "a guided task needs its section: {e}");
    }

    #[test]
    fn a_default_model_the_task_cannot_use_is_refused_before_training() {
        let recipe = |r: &str| {
            Scene::builtin(TaskKind::Guided).with_layer(format!(
                "wrench_estimator:\n  ros__parameters:\n    default_model: {r}\n"
            ))
        };
        let e = recipe("{axes: [fz], gp: sparse, size: 200}")
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("estimates fz") && e.contains("fx,fy,fz"), "{e}");
        let e = recipe("{axes: [fx, fy, fz], gp: sprase, size: 200}")
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("sprase"), "{e}");
        let guarded = Scene::builtin(TaskKind::Guarded)
            .estimator_params()
            .unwrap();
        assert_eq!(guarded.default_model.axes.to_string(), "fz");
        assert!(guarded.with_std);
    }
}
