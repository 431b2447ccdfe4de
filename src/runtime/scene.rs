//! Scenes: the robot description and the parameter files that configure
//! one run, layered as ROS 2 does with several `--params-file`s (later files
//! override earlier ones): the world (`config/world.yaml`: skin law,
//! objects, every robot's defaults, arm plant, sensors), the robot's file
//! (`config/pa10.yaml`, `ur5.yaml`, `panda.yaml`; none for a user's URDF),
//! then the task's scene (`config/guarded_move.yaml` or
//! `config/guided_move.yaml`, or a user's file). The shipped files are
//! embedded, so the demo runs from anywhere.

use std::path::{Path, PathBuf};

use crate::biotac::BioTacSimConfig;
use crate::contact::BodyParams;
use crate::control::{
    ControllerParams, ForceController, GuardedParams, Rule, RuleChain, TaskKind, TaskRegistry,
};
use crate::exit::{Classify, ExitClass};
use crate::kinematics::{Robot, RobotError, ShippedRobot};
use crate::learn::models::wrench_model::WrenchModel;
use crate::nodes::wrench_estimator::{EstimatorError, EstimatorParams};
use crate::nodes::{tasks, EstimatorNode, SimRobot, SimRobotParams};
use crate::params::{layered_node_params, ParamsError, WORLD_YAML};
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
    /// The robot description or the robot's parameters.
    #[error(transparent)]
    Robot(#[from] RobotError),
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

/// A scene refused, by the part that refused it.
impl Classify for SceneError {
    fn class(&self) -> ExitClass {
        match self {
            SceneError::Params(e) => e.class(),
            SceneError::Robot(e) => e.class(),
            SceneError::Estimator(e) => e.class(),
            SceneError::Axes { .. } => ExitClass::Refused,
        }
    }
}

/// The robot of a run: a shipped one (its URDF and parameter file), or a
/// user's URDF file (the world's robot defaults: the chain from the root
/// link to the one leaf, the BioTac frame at the tip link, the start pose
/// in the middle of every joint's range; a scene file may set them).
#[derive(Debug, Clone, PartialEq)]
pub enum RobotChoice {
    /// `pa10`, `ur5` or `panda`.
    Shipped(ShippedRobot),
    /// A URDF file and its text.
    Urdf {
        /// The file.
        path: PathBuf,
        /// Its text.
        text: String,
    },
}

impl RobotChoice {
    /// A shipped robot's name or a URDF file's path.
    pub fn parse(name_or_path: &str) -> Result<Self, ParamsError> {
        if let Ok(r) = name_or_path.parse::<ShippedRobot>() {
            return Ok(RobotChoice::Shipped(r));
        }
        let path = PathBuf::from(name_or_path);
        if path.extension().is_none_or(|e| e != "urdf") && !path.exists() {
            // Neither a robot's name nor a file: say both.
            return Err(name_or_path.parse::<ShippedRobot>().unwrap_err());
        }
        let text = std::fs::read_to_string(&path).map_err(|error| ParamsError::Io {
            role: "URDF file",
            path: path.clone(),
            error,
        })?;
        Ok(RobotChoice::Urdf { path, text })
    }

    /// The robot description (URDF text).
    pub fn description(&self) -> &str {
        match self {
            RobotChoice::Shipped(r) => r.urdf(),
            RobotChoice::Urdf { text, .. } => text,
        }
    }

    /// The robot's parameter file, if it has one.
    fn yaml(&self) -> Option<&'static str> {
        match self {
            RobotChoice::Shipped(r) => Some(r.yaml()),
            RobotChoice::Urdf { .. } => None,
        }
    }
}

/// The parameters of one run, parsed once from their layers, and the robot
/// description every node reads.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The force controller's.
    pub controller: ControllerParams,
    /// The wrench estimator's.
    pub estimator: EstimatorParams,
    /// The simulated robot's.
    pub sim: SimRobotParams,
    /// The robot description (URDF text).
    pub description: String,
    /// The tasks the controller may run: the shipped ones unless
    /// [`Scene::with_tasks`] says otherwise.
    pub tasks: TaskRegistry,
    /// Stability rules the controller runs after the shipped ones (none
    /// unless [`Scene::with_rule`] adds one).
    pub rules: RuleChain,
}

impl Scene {
    /// The shipped scene of a task on the PA10.
    pub fn builtin(task: TaskKind) -> Result<Self, ParamsError> {
        Scene::shipped(task, ShippedRobot::Pa10)
    }

    /// The shipped scene of a task on a shipped robot.
    pub fn shipped(task: TaskKind, robot: ShippedRobot) -> Result<Self, ParamsError> {
        Scene::layered(&task.shipped_layers(robot), robot.urdf())
    }

    /// The world, `robot`'s file and the scene text `scene` (a task's
    /// shipped scene, or a user's file read with [`Scene::read_scene`]).
    pub fn with_robot(robot: &RobotChoice, scene: &str) -> Result<Self, ParamsError> {
        let mut layers = vec![WORLD_YAML];
        layers.extend(robot.yaml());
        layers.push(scene);
        Scene::layered(&layers, robot.description())
    }

    /// The scene of parameter texts given in order, as `--params-file`s
    /// (later ones override earlier ones key by key), on the robot
    /// `description`.
    pub fn layered(texts: &[&str], description: &str) -> Result<Self, ParamsError> {
        Ok(Scene {
            controller: layered_node_params(texts, "force_controller")?,
            estimator: layered_node_params(texts, "wrench_estimator")?,
            sim: layered_node_params(texts, "sim_robot")?,
            description: description.to_string(),
            tasks: tasks::shipped(),
            rules: RuleChain::default(),
        })
    }

    /// Sets the chain's links for every node (empty: the URDF's root, its
    /// one leaf).
    pub fn with_links(mut self, base: Option<&str>, tip: Option<&str>) -> Self {
        for robot in [&mut self.controller.robot, &mut self.sim.robot] {
            if let Some(b) = base {
                robot.base_link = b.into();
            }
            if let Some(t) = tip {
                robot.tip_link = t.into();
            }
        }
        self
    }

    /// Reads a user's scene file (to layer with [`Scene::with_robot`]).
    pub fn read_scene(path: &Path) -> Result<String, ParamsError> {
        std::fs::read_to_string(path).map_err(|error| ParamsError::Io {
            role: "scene file",
            path: path.to_path_buf(),
            error,
        })
    }

    /// Lets the controller run the tasks of `tasks` (a task of its own).
    pub fn with_tasks(mut self, tasks: TaskRegistry) -> Self {
        self.tasks = tasks;
        self
    }

    /// Lets the controller run `rule` after the shipped stability rules (a
    /// rule of its own).
    pub fn with_rule(mut self, rule: impl Rule + 'static) -> Self {
        self.rules = self.rules.with(rule);
        self
    }

    /// Sets the object for every node (as the launch argument `object` does).
    pub fn with_object(mut self, name: &str) -> Self {
        self.controller.object = name.into();
        self.sim.object = name.into();
        self
    }

    /// Sets the guarded move's approach speed (m/s); the scene must have a
    /// guarded section.
    pub fn with_approach_speed(mut self, mps: f64) -> Result<Self, ParamsError> {
        self.controller
            .edit_section(|g: &mut GuardedParams| g.approach_speed_mps = mps)?;
        Ok(self)
    }

    /// Sets the object for every node and permits only it
    /// (`force_controller.safety.objects`): the speed limit is then that
    /// object's own (the speed sweep, tests).
    pub fn with_only_object(mut self, name: &str) -> Self {
        self.controller.safety.objects = vec![name.into()];
        self.with_object(name)
    }

    /// Adds a body that every node knows (as `/**: objects: name:` does).
    pub fn with_body(mut self, name: &str, body: BodyParams) -> Self {
        self.controller.objects.insert(name.into(), body);
        self.sim.objects.insert(name.into(), body);
        self
    }

    /// Checks every parameter of the controller and the simulated robot
    /// (before an expensive step such as training a model).
    pub fn check(&self) -> Result<(), SceneError> {
        let (controller, _, _) = self.controller_and_sim(&BioTacSimConfig::default(), 0)?;
        missing_axes(&self.estimator.default_model.axes, controller.axes())
    }

    /// The controller, the simulated robot and the estimate's link, checked,
    /// and checked against each other: the bounds of the loop's delays that
    /// the safety envelope assumes must cover the simulated arm and
    /// transport (the gains need no declaration: they are measured).
    pub fn controller_and_sim(
        &self,
        sensor: &BioTacSimConfig,
        seed: u64,
    ) -> Result<(ForceController, SimRobot, Link), SceneError> {
        let (cp, sp) = (self.controller.clone(), self.sim.clone());
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
                sp.command_latency_s + 2.0 * sp.command_cycle_s,
                "sim_robot.command_latency_s + 2 command_cycle_s",
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
                        "at least {actual} s, the simulated {what}: the safety envelope \
                         must not assume a faster loop than the one it runs in"
                    ),
                }));
            }
        }
        let robot = Robot::from_urdf(&self.description, &cp.robot)?;
        let sim_robot = Robot::from_urdf(&self.description, &sp.robot)?;
        let mut controller = ForceController::new(cp, robot, &self.tasks)?.with_rules(&self.rules);
        let link = Link::new(sp.transport_delay_s, sp.transport_jitter_s, seed);
        let sim = SimRobot::new(sp, sim_robot, sensor, seed)?;
        controller.check_start(sim.joints())?;
        Ok((controller, sim, link))
    }

    /// Builds the nodes of a run with `model`; `seed` drives the noise.
    pub fn build(
        &self,
        model: Box<dyn WrenchModel>,
        sensor: &BioTacSimConfig,
        seed: u64,
    ) -> Result<Nodes, SceneError> {
        let (controller, sim, link) = self.controller_and_sim(sensor, seed)?;
        missing_axes(model.axes(), controller.axes())?;
        let estimator = EstimatorNode::new(model, self.estimator.with_std)?;
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
    use crate::params::GUARDED_YAML;

    #[test]
    fn the_shipped_scenes_parse_and_the_object_can_be_chosen() {
        for task in TaskKind::ALL {
            assert_eq!(Scene::builtin(task).unwrap().controller.task, task.name());
        }
        let guided = Scene::builtin(TaskKind::Guided).unwrap();
        assert_eq!(guided.sim.object, "fingertip");
        assert!(guided.sim.finger_path.is_some());
        let e = guided.with_approach_speed(0.01).unwrap_err().to_string();
        assert!(e.contains("`guarded` section"), "{e}");
        let s = Scene::builtin(TaskKind::Guarded)
            .unwrap()
            .with_object("carton_box");
        assert_eq!(s.controller.object, "carton_box");
        assert_eq!(s.sim.object, "carton_box");
        let s = s.with_approach_speed(0.025).unwrap();
        let g: GuardedParams = s.controller.section().unwrap();
        assert_eq!(g.approach_speed_mps, 0.025);
    }

    #[test]
    fn unknown_objects_and_keys_are_named() {
        let s = Scene::builtin(TaskKind::Guarded)
            .unwrap()
            .with_object("teapot");
        let e = ForceController::new(s.controller, Robot::pa10(), &s.tasks)
            .unwrap_err()
            .to_string();
        assert!(e.contains("teapot") && e.contains("wooden_box"), "{e}");
        let pa10 = ShippedRobot::Pa10;
        let layers =
            |top: &str| Scene::layered(&[WORLD_YAML, pa10.yaml(), GUARDED_YAML, top], pa10.urdf());
        let e = layers("sim_robot:\n  ros__parameters:\n    gap_mm: 3.0\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("gap_mm"), "{e}");
        let s = layers("force_controller:\n  ros__parameters:\n    task: guided\n").unwrap();
        let e = ForceController::new(s.controller, Robot::pa10(), &s.tasks)
            .unwrap_err()
            .to_string();
        assert!(e.contains("guided"), "a guided task needs its section: {e}");
    }

    #[test]
    fn a_default_model_the_task_cannot_use_is_refused_before_training() {
        let recipe = |r: &str| {
            let top = format!("wrench_estimator:\n  ros__parameters:\n    default_model: {r}\n");
            let [world, robot, scene] = TaskKind::Guided.shipped_layers(ShippedRobot::Pa10);
            Scene::layered(&[world, robot, scene, &top], ShippedRobot::Pa10.urdf())
        };
        let e = recipe("{axes: [fz], gp: sparse, size: 200}")
            .unwrap()
            .check()
            .unwrap_err()
            .to_string();
        assert!(e.contains("estimates fz") && e.contains("fx,fy,fz"), "{e}");
        let e = recipe("{axes: [fx, fy, fz], gp: sprase, size: 200}")
            .unwrap_err()
            .to_string();
        assert!(e.contains("sprase"), "{e}");
        let guarded = Scene::builtin(TaskKind::Guarded).unwrap().estimator;
        assert_eq!(guarded.default_model.axes.to_string(), "fz");
        assert!(guarded.with_std);
    }
}
