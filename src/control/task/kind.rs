//! The shipped tasks' scene files: what the demos and the ROS nodes'
//! defaults start from, not the tasks a controller can run (those are a
//! [`super::TaskRegistry`]'s).

use std::fmt;

use serde::Deserialize;

use super::or_list;
use crate::kinematics::ShippedRobot;
use crate::params::{ParamsError, CALIBRATE_YAML, GUARDED_YAML, GUIDED_YAML, WORLD_YAML};

/// The shipped tasks, each with its scene file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TaskKind {
    /// Approach, touch, hold a force (`config/guarded_move.yaml`).
    Guarded,
    /// Follow a person's finger (`config/guided_move.yaml`).
    Guided,
    /// Press a calibration block in a pattern, the F/T sensor as the force
    /// (`config/calibrate.yaml`).
    Calibrate,
}

impl TaskKind {
    /// Every shipped task.
    pub const ALL: [TaskKind; 3] = [TaskKind::Guarded, TaskKind::Guided, TaskKind::Calibrate];

    /// The name in the parameters, the JSON output and the command line.
    pub fn name(self) -> &'static str {
        match self {
            TaskKind::Guarded => "guarded",
            TaskKind::Guided => "guided",
            TaskKind::Calibrate => "calibrate",
        }
    }

    /// The shipped scene file of the task.
    pub fn scene_yaml(self) -> &'static str {
        match self {
            TaskKind::Guarded => GUARDED_YAML,
            TaskKind::Guided => GUIDED_YAML,
            TaskKind::Calibrate => CALIBRATE_YAML,
        }
    }

    /// The shipped parameter files of a run of the task on `robot`, in
    /// order: the world, the robot, the task's scene.
    pub fn shipped_layers(self, robot: ShippedRobot) -> [&'static str; 3] {
        [WORLD_YAML, robot.yaml(), self.scene_yaml()]
    }

    /// The names of every shipped task, for messages.
    pub fn names() -> String {
        or_list(Self::ALL.iter().map(|t| t.name()))
    }
}

impl fmt::Display for TaskKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for TaskKind {
    type Err = ParamsError;

    fn from_str(s: &str) -> Result<Self, ParamsError> {
        Self::ALL
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| ParamsError::Invalid {
                key: "task".into(),
                value: s.into(),
                expected: Self::names(),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn task_names_parse_back_and_others_are_refused_with_the_list() {
        for t in TaskKind::ALL {
            assert_eq!(t.name().parse::<TaskKind>().unwrap(), t);
            assert!(!t.scene_yaml().is_empty());
        }
        let e = "joystick".parse::<TaskKind>().unwrap_err().to_string();
        assert!(e.contains("guarded, guided or calibrate"), "{e}");
    }
}
