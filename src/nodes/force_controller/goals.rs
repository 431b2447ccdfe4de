//! The goals of the node's actions and their life cycle: a guarded move
//! (`~/guarded_move`) or a calibration (`~/calibrate`) starts the
//! controller of its task, or is refused with the reason (no robot
//! description yet, another goal running, a value out of range, a speed
//! beyond the safety envelope); while it runs, its feedback; when the task
//! holds or stops, its outcome; a cancel withdraws the pad out of contact
//! before the goal ends ([`ForceControllerNode::withdrawn`]), so that the
//! next goal starts clean; once ended, a task switch or a new goal may come.

use super::ForceControllerNode;
use crate::calibration::{CalibrateGoal, CalibrateMove, CalibrationRecorder, Ended};
use crate::control::{ForceController, Phase, TaskKind};
use crate::learn::data::bag::SessionWriter;
use crate::nodes::guarded_goal::{guarded_outcome, GuardedGoal};

/// How long a canceled goal's pad may take to leave contact before it is
/// stopped where it is (s): a retract of a few millimetres and a turn back
/// take 1-3 s.
pub const WITHDRAW_S: f64 = 10.0;

/// Where a guarded move is.
#[derive(Debug, Clone, PartialEq)]
pub struct GuardedProgress {
    /// The force along the controlled axis (N).
    pub force_n: f64,
    /// The task's phase.
    pub phase: Phase,
    /// How it ended ("hold", a stop reason), None while it runs.
    pub outcome: Option<&'static str>,
    /// The force's standard deviation over the settling window (N).
    pub settled_sd_n: Option<f64>,
    /// The contact's stiffness along the approach, as the gain used it (N/m).
    pub stiffness_n_per_m: Option<f64>,
    /// The loop's delay as measured: age, latency and lag (s).
    pub loop_delay_s: f64,
    /// The proportional gain along the approach (m/s per N).
    pub gain_m_per_s_per_n: Option<f64>,
}

/// Where a calibration is.
#[derive(Debug, Clone, PartialEq)]
pub enum CalibrationProgress {
    /// Not stepped yet.
    Starting,
    /// Pressing.
    Running {
        /// The push running, from 1.
        push: u32,
        /// The pushes of the pattern.
        pushes: u32,
        /// The task's phase.
        phase: Phase,
        /// The F/T force's magnitude (N).
        force_n: f64,
    },
    /// The arm has stopped.
    Ended(Ended),
}

impl ForceControllerNode {
    /// The controller of a goal, if no other goal runs and a description
    /// has come.
    fn goal_controller(
        &self,
        build: impl FnOnce(&Self, crate::kinematics::Robot) -> Result<ForceController, String>,
    ) -> Result<ForceController, String> {
        self.not_acting()?;
        if self.goal {
            return Err("a goal is running: cancel it first".into());
        }
        let robot = self
            .arm
            .as_ref()
            .ok_or("no robot description yet")?
            .robot
            .clone();
        build(self, robot)
    }

    /// Starts a guarded move, or says why not.
    pub fn start_guarded(&mut self, goal: &GuardedGoal) -> Result<(), String> {
        let c = self.goal_controller(|n, robot| {
            ForceController::for_goal(goal, &n.base, robot, &n.tasks).map_err(|e| e.to_string())
        })?;
        self.begin(c, TaskKind::Guarded);
        Ok(())
    }

    /// Starts a calibration at `now` (the F/T sensor's silence is counted
    /// from then), its records written to `session` as they come (opened
    /// by [`crate::calibration::open_outputs`]), or says why not.
    pub fn start_calibration(
        &mut self,
        goal: &CalibrateGoal,
        now: f64,
        session: Option<SessionWriter>,
    ) -> Result<(), String> {
        let c = self.goal_controller(|n, robot| {
            ForceController::for_goal(goal, &n.base, robot, &n.tasks).map_err(|e| e.to_string())
        })?;
        self.begin(c, TaskKind::Calibrate);
        let recorder = CalibrationRecorder::new(now);
        self.calibration = Some(match session {
            Some(w) => recorder.with_session(w),
            None => recorder,
        });
        tracing::info!("calibrating: pressing the {}", self.base.object);
        Ok(())
    }

    /// Runs `c` for a goal; it goes on from what the controller it
    /// replaces measured of the loop (the same arm).
    fn begin(&mut self, mut c: ForceController, task: TaskKind) {
        if let Some(before) = &self.controller {
            c.measured_from(before);
        }
        self.asked = true;
        self.controller = Some(c);
        self.task = task.name().into();
        self.goal = true;
        self.goal_end = None;
        self.last = None;
        self.withdrawing_since = None;
    }

    /// The guarded move's feedback and outcome, with what it measured;
    /// None before its first step.
    pub fn guarded_progress(&self) -> Option<GuardedProgress> {
        let out = self.last.as_ref()?;
        let c = self.controller.as_ref()?;
        // The estimated force on the controlled axis.
        let axis = out.targets.iter().position(Option::is_some).unwrap_or(2);
        let (f, t) = (c.task().figures(), c.timing());
        Some(GuardedProgress {
            force_n: self.force[axis],
            phase: out.phase,
            outcome: guarded_outcome(out),
            settled_sd_n: f.settled_sd_n,
            stiffness_n_per_m: f.stiffness_n_per_m[axis],
            loop_delay_s: t.transport_s + t.latency_s + t.lag_s,
            gain_m_per_s_per_n: c.gains()[axis],
        })
    }

    /// The calibration's feedback, or how its motion ended: a silent F/T
    /// sensor halts it at `now`.
    pub fn calibration_progress(&mut self, now: f64) -> CalibrationProgress {
        let (Some(c), Some(rec)) = (self.controller.as_mut(), self.calibration.as_ref()) else {
            return CalibrationProgress::Ended(Ended::Canceled);
        };
        if rec.ft_stale(now) {
            c.stop();
            return CalibrationProgress::Ended(Ended::FtStale(rec.motion_s()));
        }
        let Some(out) = &self.last else {
            return CalibrationProgress::Starting;
        };
        if out.phase == Phase::STOPPED {
            return CalibrationProgress::Ended(Ended::from_stop(out.reason));
        }
        let calibration = CalibrateMove::of(c.task());
        CalibrationProgress::Running {
            push: calibration
                .and_then(CalibrateMove::current)
                .map_or(0, |(i, _)| i as u32 + 1),
            pushes: calibration.map_or(0, |m| m.pushes().len() as u32),
            phase: out.phase,
            force_n: rec.last_force().force.norm(),
        }
    }

    /// A goal canceled at `now`: the task leaves contact, then stops
    /// ([`crate::control::Task::withdraw`]); [`ForceControllerNode::withdrawn`]
    /// says when.
    pub fn cancel_goal(&mut self, now: f64) {
        if let Some(c) = self.controller.as_mut() {
            c.withdraw();
            self.withdrawing_since.get_or_insert(now);
        }
    }

    /// After a cancel: None while the pad withdraws; Ok once the task has
    /// stopped; Err when it has not within [`WITHDRAW_S`] of the cancel
    /// (inputs stale, an arm that does not follow): it then stops where
    /// it is, and the reason says so.
    pub fn withdrawn(&mut self, now: f64) -> Option<Result<(), String>> {
        let since = self.withdrawing_since?;
        let c = self.controller.as_mut()?;
        if c.task().phase() == Phase::STOPPED {
            return Some(Ok(()));
        }
        if now - since < WITHDRAW_S {
            return None;
        }
        c.stop();
        Some(Err(format!(
            "the pad did not leave contact within {WITHDRAW_S} s: stopped where it is"
        )))
    }

    /// The calibration's recording, once its arm has stopped: estimates
    /// are the force again. The goal runs on (its fit) until
    /// [`ForceControllerNode::end_goal`].
    pub fn take_recording(&mut self) -> Option<CalibrationRecorder> {
        self.calibration.take()
    }

    /// The goal is over (done, aborted, canceled, or never accepted): a
    /// task switch or a new goal may come.
    pub fn end_goal(&mut self) {
        self.goal = false;
        self.goal_end = None;
        self.calibration = None;
        self.withdrawing_since = None;
    }
}
