//! A calibration goal (the `force_controller/calibrate` action of the ROS 2
//! node, `demo calibrate`): the start-up parameters with the calibration
//! task on the surface to press, checked like any scene (its safety
//! envelope) when the controller is built.

use std::path::PathBuf;
use std::time::{SystemTime, UNIX_EPOCH};

use super::pattern::CalibrateParams;
use crate::control::{ControllerParams, Goal, TaskSection};
use crate::params::ParamsError;
use crate::wrench::AxisSet;

/// The surface pressed when a goal names none: the world's calibration block.
pub const DEFAULT_SURFACE: &str = "calibration_block";

/// A calibration goal: the surface to press (empty: [`DEFAULT_SURFACE`])
/// and where the model and the recording go.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct CalibrateGoal {
    /// An object of the world file.
    pub surface: String,
    /// The model file to write (empty: a new file in the model cache).
    pub model_file: String,
    /// The recording, a rosbag2 MCAP file (empty: the model file's path
    /// with the extension .mcap).
    pub session_file: String,
}

impl CalibrateGoal {
    /// Where the goal writes the model and the recording.
    pub fn outputs(&self) -> Result<(PathBuf, PathBuf), String> {
        let model = match self.model_file.as_str() {
            "" => {
                let dir = crate::learn::default_model::cache_dir()
                    .ok_or("no model cache folder ($HOME unset): give model_file")?;
                let unix = SystemTime::now()
                    .duration_since(UNIX_EPOCH)
                    .map_or(0, |d| d.as_secs());
                dir.join(format!("calibration_{unix}.json"))
            }
            f => PathBuf::from(f),
        };
        let session = match self.session_file.as_str() {
            "" => model.with_extension("mcap"),
            f => PathBuf::from(f),
        };
        Ok((model, session))
    }
}

impl Goal for CalibrateGoal {
    /// The start-up parameters with the calibration task on the goal's
    /// surface: every force axis (the F/T sensor gives them all), the
    /// surface as the one body the envelope allows for.
    fn apply(&self, base: &ControllerParams) -> Result<ControllerParams, ParamsError> {
        let mut p = base.clone();
        p.raw_section(CalibrateParams::NAME)?;
        let surface = match self.surface.as_str() {
            "" => DEFAULT_SURFACE,
            s => s,
        };
        p.task = CalibrateParams::NAME.into();
        p.axes = AxisSet::forces();
        p.object = surface.to_string();
        p.safety.objects = vec![surface.to_string()];
        Ok(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::TaskKind;
    use crate::kinematics::Robot;
    use crate::nodes::ForceController;
    use crate::runtime::scene::Scene;

    #[test]
    fn a_goal_presses_its_surface_on_every_force_axis_and_is_checked() {
        // A node launched for the guarded move, with every task's section.
        let guarded = Scene::builtin(TaskKind::Guarded).unwrap().controller;
        let calibrate = Scene::builtin(TaskKind::Calibrate).unwrap().controller;
        let mut base = guarded.clone();
        base.set_section(&calibrate.section::<CalibrateParams>().unwrap());
        let e = CalibrateGoal::default()
            .apply(&guarded)
            .unwrap_err()
            .to_string();
        assert!(e.contains("calibrate"), "{e}");
        let p = CalibrateGoal::default().apply(&base).unwrap();
        assert_eq!(p.task, "calibrate");
        assert_eq!(
            (p.object.as_str(), &p.safety.objects[..]),
            (DEFAULT_SURFACE, &[DEFAULT_SURFACE.to_string()][..])
        );
        assert_eq!(p.axes, AxisSet::forces());
        ForceController::for_goal(&CalibrateGoal::default(), &base, Robot::pa10()).unwrap();
        let granite = CalibrateGoal {
            surface: "granite".into(),
            ..Default::default()
        };
        let e = ForceController::for_goal(&granite, &base, Robot::pa10())
            .unwrap_err()
            .to_string();
        assert!(e.contains("granite"), "{e}");
    }

    #[test]
    fn the_outputs_default_to_the_model_cache_and_the_model_s_name() {
        let goal = CalibrateGoal {
            model_file: "/tmp/u2.json".into(),
            ..Default::default()
        };
        let (model, session) = goal.outputs().unwrap();
        assert_eq!(model, PathBuf::from("/tmp/u2.json"));
        assert_eq!(session, PathBuf::from("/tmp/u2.mcap"));
        let goal = CalibrateGoal {
            session_file: "/data/s.mcap".into(),
            ..Default::default()
        };
        let (model, session) = goal.outputs().unwrap();
        let name = model.file_name().unwrap().to_str().unwrap();
        assert!(
            name.starts_with("calibration_") && name.ends_with(".json"),
            "{name}"
        );
        assert_eq!(session, PathBuf::from("/data/s.mcap"));
    }
}
