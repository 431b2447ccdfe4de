//! `force_controller` as a managed node ([`crate::ros::lifecycle`]):
//! `configure` reads its parameters again (any set while unconfigured but
//! those read at start only, [`settings::START_ONLY`]) and builds the node
//! anew on the robot description it has; `activate` lets it command;
//! `deactivate`, `cleanup` and `shutdown` stop the arm (a zero command on
//! every output, the goal running ended with the reason) and command
//! nothing more until it is active again.

use std::sync::{Arc, Mutex};

use super::commands::Commands;
use super::settings;
use super::tool_frame::ToolFrame;
use crate::control::TaskRegistry;
use crate::nodes::bounds::InputGuard;
use crate::nodes::force_controller::stop::Stopped;
use crate::nodes::force_controller::ForceControllerNode;
use crate::nodes::lifecycle::{Managed, State};
use crate::ros::{lock, ParamMap, RosClock};

/// What the lifecycle's callbacks act on.
pub(super) struct Controller {
    pub(super) params: ParamMap,
    pub(super) tasks: TaskRegistry,
    pub(super) guard: Arc<InputGuard>,
    pub(super) shared: Arc<Mutex<ForceControllerNode>>,
    pub(super) commands: Arc<Commands>,
    pub(super) tf: ToolFrame,
    pub(super) clock: RosClock,
}

impl Controller {
    /// Leaves the active state for `to`: the arm stopped, a zero sent.
    fn stop(&self, why: Stopped, to: State) {
        let mut n = lock(&self.shared);
        if n.leave_active(why, to) {
            self.commands.zero(&n, self.clock.now_s(), false);
        }
    }
}

impl Managed for Controller {
    fn on_configure(&mut self) -> Result<(), String> {
        if lock(&self.shared).goal_running() {
            return Err(
                "a goal is still ending (its result goes out within a period): \
                        configure again"
                    .into(),
            );
        }
        let s = settings::declare(&self.params, &self.tasks).map_err(|e| e.to_string())?;
        let mut fresh = s
            .node(self.tasks.clone(), &self.guard)
            .map_err(|e| e.to_string())?;
        let mut n = lock(&self.shared);
        if let Some(text) = n.description() {
            fresh.take_description(text).map_err(|e| e.to_string())?;
        }
        fresh.configured();
        *n = fresh;
        self.tf.publish(&n);
        tracing::info!("{}", n.summary().map_err(|e| e.to_string())?);
        Ok(())
    }

    fn on_cleanup(&mut self) {
        self.stop(Stopped::Deactivated, State::Unconfigured);
    }

    fn on_activate(&mut self) -> Result<(), String> {
        lock(&self.shared).activate();
        Ok(())
    }

    fn on_deactivate(&mut self) {
        self.stop(Stopped::Deactivated, State::Inactive);
    }

    fn on_shutdown(&mut self, _from: State) {
        self.stop(Stopped::Shutdown, State::Finalized);
    }
}
