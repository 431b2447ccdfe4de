//! A calibration goal (the `force_controller/calibrate` action of the ROS 2
//! node, `demo calibrate`): the start-up parameters with the calibration
//! task on the surface to press, checked like any scene (its safety
//! envelope) when the controller is built. Its outputs are checked, and
//! the session file opened, before the arm moves ([`open_outputs`]).

use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use super::pattern::CalibrateParams;
use crate::control::{ControllerParams, Goal, TaskSection};
use crate::learn::data::bag::{BagError, BagTopics, SessionWriter};
use crate::outputs::{check_writable, OutputError};
use crate::params::ParamsError;
use crate::wrench::AxisSet;

/// The BioTac frame the session's wrenches are framed in.
pub const SESSION_FRAME: &str = "biotac";

/// Checks that the model file and the session can be written: their
/// folders exist and take a file, and they are not the same file.
pub fn check_outputs(model: &Path, session: &Path) -> Result<(), OutputError> {
    check_writable(model, "model file")?;
    check_writable(session, "session")?;
    let same = |a: &Path, b: &Path| std::path::absolute(a).ok() == std::path::absolute(b).ok();
    if same(model, session) {
        return Err(OutputError {
            role: "session",
            path: session.to_path_buf(),
            reason: "is the model file too: give the session its own name".into(),
        });
    }
    Ok(())
}

/// Checks the outputs before the arm moves ([`check_outputs`]) and opens
/// the session, to be written as it is recorded.
pub fn open_outputs(model: &Path, session: &Path) -> Result<SessionWriter, OutputError> {
    check_outputs(model, session)?;
    SessionWriter::create(session, &BagTopics::default(), SESSION_FRAME, 0.0).map_err(|e| {
        OutputError {
            role: "session",
            path: session.to_path_buf(),
            reason: match e {
                BagError::Write { reason, .. } => reason,
                other => other.to_string(),
            },
        }
    })
}

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
                std::fs::create_dir_all(&dir)
                    .map_err(|e| format!("model cache folder {}: {e}", dir.display()))?;
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
