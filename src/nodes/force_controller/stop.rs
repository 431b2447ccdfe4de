//! Stopping the arm from outside the task: a signal, the stop service, a
//! deactivation, a shutdown, a panic or a fatal error. The controller
//! stops (zero velocity on every later step), the goal running ends with
//! the reason, and the node stays idle until a new goal or a `task` set
//! asks for motion again. A real arm's velocity controller keeps the last
//! command it got, so the transport publishes a zero command at once
//! ([`ForceControllerNode::zero_command`]).

use super::ForceControllerNode;
use crate::nodes::lifecycle::State;

/// What stopped the arm; its reason is the result of the goal it ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stopped {
    /// SIGINT (Ctrl-C).
    Interrupt,
    /// SIGTERM (a supervisor, or `ros2 launch` ending).
    Terminate,
    /// The `~/stop` service.
    Service,
    /// The lifecycle's `deactivate`.
    Deactivated,
    /// The lifecycle's `shutdown`.
    Shutdown,
    /// A panic in one of the node's threads.
    Panic,
    /// A fatal error of the node.
    Error,
}

impl Stopped {
    /// The reason a goal it ended gives.
    pub fn reason(self) -> &'static str {
        match self {
            Stopped::Interrupt => "stopped: SIGINT",
            Stopped::Terminate => "stopped: SIGTERM",
            Stopped::Service => "stopped: service",
            Stopped::Deactivated => "stopped: deactivated",
            Stopped::Shutdown => "stopped: shutdown",
            Stopped::Panic => "stopped: panic",
            Stopped::Error => "stopped: error",
        }
    }
}

impl ForceControllerNode {
    /// Stops the arm for `why`: the task stops (zero velocity from now
    /// on), a goal running ends with the reason ([`Self::goal_end`]),
    /// and nothing moves until a new goal or a `task` set. The command to
    /// publish at once comes from [`Self::zero_command`].
    pub fn stop(&mut self, why: Stopped) {
        self.stop_for(why.reason().into());
    }

    /// [`Self::stop`] for a reason of the node's own (a wrench in the
    /// wrong frame, say).
    pub(super) fn stop_for(&mut self, reason: String) {
        if let Some(c) = self.controller.as_mut() {
            c.stop();
        }
        self.asked = false;
        self.withdrawing_since = None;
        tracing::warn!("{reason}: zero velocity");
        if self.goal {
            self.goal_end.get_or_insert(reason);
        }
    }

    /// The reason the goal running must end with, when the arm was stopped
    /// from outside its task or a wrench it uses came in the wrong frame.
    pub fn goal_end(&self) -> Option<&str> {
        self.goal_end.as_deref()
    }

    /// A zero velocity for each joint of the arm (none before a robot
    /// description: nothing was commanded).
    pub fn zero_command(&self) -> Option<usize> {
        self.arm.as_ref().map(|a| a.robot.dof())
    }

    /// The lifecycle state the node is in ([`crate::nodes::lifecycle`]).
    pub fn state(&self) -> State {
        self.state
    }

    /// The node as a managed node starts: unconfigured, commanding
    /// nothing ([`crate::nodes::lifecycle`]).
    pub fn managed(self) -> Self {
        ForceControllerNode {
            state: State::Unconfigured,
            ..self
        }
    }

    /// Configured: inactive, nothing commanded until activated.
    pub fn configured(&mut self) {
        self.state = State::Inactive;
    }

    /// Active: it commands as asked (a goal, a `task` set, `autostart`).
    pub fn activate(&mut self) {
        self.state = State::Active;
    }

    /// Inactive again (deactivate), or unconfigured (cleanup) or finalized
    /// (shutdown): if it was active, the arm is stopped for `why` and the
    /// goal ended, and true says a zero command is due; nothing is
    /// commanded until it is active again (a configure builds it anew).
    pub fn leave_active(&mut self, why: Stopped, to: State) -> bool {
        let was_active = self.state == State::Active;
        if was_active {
            self.stop(why);
        }
        self.state = to;
        was_active
    }

    /// The robot description it commands, once one has come.
    pub fn description(&self) -> Option<&str> {
        self.arm.as_ref().map(|a| a.description.as_str())
    }

    /// True while a goal runs (until its result is sent).
    pub fn goal_running(&self) -> bool {
        self.goal
    }

    /// Why the node takes no goal and no task now: it is not active.
    pub(super) fn not_acting(&self) -> Result<(), String> {
        let to_active = match self.state {
            State::Active => return Ok(()),
            State::Unconfigured => "configure, then activate",
            State::Inactive => "activate",
            _ => "start the node again",
        };
        Err(format!(
            "the node is {} (lifecycle): nothing moves until it is active \
             (ros2 lifecycle set NODE {to_active})",
            self.state.label()
        ))
    }
}

#[cfg(test)]
mod tests;
