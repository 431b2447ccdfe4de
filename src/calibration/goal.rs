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
use crate::outputs::models_dir::{ModelsDir, NameRefused};
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
/// and where the model and the recording go, names inside the node's
/// models folder ([`ModelsDir`]).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct CalibrateGoal {
    /// An object of the world file.
    pub surface: String,
    /// The model file to write (empty: a new file in the models folder).
    pub model_file: String,
    /// The recording, a rosbag2 MCAP file (empty: the model file's path
    /// with the extension .mcap).
    pub session_file: String,
    /// Replace a model file or recording that exists.
    pub overwrite: bool,
}

impl CalibrateGoal {
    /// Where the goal writes the model and the recording, both in `dir`
    /// ([`ModelsDir::output`]: a name leading out of it, or naming a file
    /// that exists without `overwrite`, is refused with the reason).
    pub fn outputs(&self, dir: &ModelsDir) -> Result<(PathBuf, PathBuf), NameRefused> {
        let model = match self.model_file.as_str() {
            "" => {
                let unix = SystemTime::now()
                    .duration_since(UNIX_EPOCH)
                    .map_or(0, |d| d.as_secs());
                format!("calibration_{unix}.json")
            }
            f => f.to_string(),
        };
        let model = dir.output("model_file", &model, self.overwrite)?;
        let session = match self.session_file.as_str() {
            "" => model.with_extension("mcap").display().to_string(),
            f => f.to_string(),
        };
        let session = dir.output("session_file", &session, self.overwrite)?;
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
    use crate::control::{ForceController, TaskKind};
    use crate::kinematics::Robot;
    use crate::nodes::tasks::shipped;
    use crate::outputs::models_dir::Refusal;
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
        ForceController::for_goal(&CalibrateGoal::default(), &base, Robot::pa10(), &shipped())
            .unwrap();
        let granite = CalibrateGoal {
            surface: "granite".into(),
            ..Default::default()
        };
        let e = ForceController::for_goal(&granite, &base, Robot::pa10(), &shipped())
            .unwrap_err()
            .to_string();
        assert!(e.contains("granite"), "{e}");
    }

    #[test]
    fn the_outputs_default_to_the_models_folder_and_the_model_s_name() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = ModelsDir::new(tmp.path()).unwrap();
        let goal = CalibrateGoal {
            model_file: "u2.json".into(),
            ..Default::default()
        };
        let (model, session) = goal.outputs(&dir).unwrap();
        assert_eq!(model, dir.path().join("u2.json"));
        assert_eq!(session, dir.path().join("u2.mcap"));
        let goal = CalibrateGoal {
            session_file: "s.mcap".into(),
            ..Default::default()
        };
        let (model, session) = goal.outputs(&dir).unwrap();
        let name = model.file_name().unwrap().to_str().unwrap();
        assert!(
            name.starts_with("calibration_") && name.ends_with(".json"),
            "{name}"
        );
        assert_eq!(session, dir.path().join("s.mcap"));
    }

    #[test]
    fn outputs_out_of_the_folder_or_existing_are_refused_by_role() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = ModelsDir::new(&tmp.path().join("models")).unwrap();
        let goal = |model: &str, session: &str, overwrite| CalibrateGoal {
            model_file: model.into(),
            session_file: session.into(),
            overwrite,
            ..Default::default()
        };
        let e = goal("/tmp/outside/x.json", "", false).outputs(&dir);
        assert!(e
            .unwrap_err()
            .to_string()
            .starts_with("model_file \"/tmp/outside/x.json\": is outside"));
        let e = goal("u2.json", "../s.mcap", false)
            .outputs(&dir)
            .unwrap_err();
        assert_eq!(e.role, "session_file");
        // The session named after the model exists: refused, unless asked.
        std::fs::write(dir.path().join("u2.mcap"), "old").unwrap();
        let e = goal("u2.json", "", false).outputs(&dir).unwrap_err();
        assert_eq!((e.role, e.why), ("session_file", Refusal::Exists));
        goal("u2.json", "", true).outputs(&dir).unwrap();
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "nothing written"
        );
    }
}
