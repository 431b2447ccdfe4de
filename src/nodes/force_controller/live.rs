//! The parameters an operator tunes while the arm runs: `task`, every
//! task's section (the guided move's deadband, target and limits, the
//! guarded move's goal defaults and approach speed), the speed limit
//! (`pd.max_speed_mps`) and the stability rules' thresholds
//! (`oscillation.*`, `out_of_range.*`). A new value is checked as at
//! start-up on the task it concerns, and refused with the reason; a running guided move takes it at once (keeping its start, its
//! travel and the stiffness it measured); a goal running keeps its own
//! settings, and the next goal or task start takes it.

use std::fmt;

use super::ForceControllerNode;
use crate::control::{ControllerParams, ForceController, TaskRegistry};
use crate::params::{with_flat_param, ParamsError};

/// The parameters shared by the tasks that may change while running.
const SHARED: [&str; 3] = ["pd.max_speed_mps", "oscillation.*", "out_of_range.*"];

/// The names of the parameters that may change while the node runs, a
/// group as `name.*` ([`crate::params::is_named`]).
pub fn live_params(tasks: &TaskRegistry) -> Vec<String> {
    let sections = tasks.each_name().map(|t| format!("{t}.*"));
    std::iter::once("task".to_string())
        .chain(sections)
        .chain(SHARED.map(String::from))
        .collect()
}

/// When a set took effect.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Takes {
    /// At once, in the task running.
    Now,
    /// From the next goal or task start.
    NextStart,
}

/// A parameter set while the node ran.
#[derive(Debug, Clone, PartialEq)]
pub struct LiveSet {
    /// The parameter.
    pub name: String,
    /// Its new value, as JSON (a list on one line).
    pub value: String,
    /// When it took effect.
    pub takes: Takes,
    /// The task running when it was set.
    pub task: String,
}

impl fmt::Display for LiveSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let when = match self.takes {
            Takes::Now => format!("taken at once by the running {}", self.task),
            Takes::NextStart => "taken from the next goal or task start".into(),
        };
        write!(f, "{} = {}: {when}", self.name, self.value)
    }
}

impl ForceControllerNode {
    /// Checks (`apply` false) or applies a new `value` of the live
    /// parameter `name` (`task` or another: [`live_params`]); Err says why
    /// it is refused (None: a value unset).
    pub fn set_param(
        &mut self,
        name: &str,
        value: Option<serde_yaml_ng::Value>,
        apply: bool,
    ) -> Result<(), String> {
        match (name, value) {
            (_, None) => Err("an unset value: give one".into()),
            ("task", Some(serde_yaml_ng::Value::String(task))) => self.set_task(&task, apply),
            ("task", Some(other)) => Err(format!("{other:?}: expected a task's name")),
            (_, Some(value)) => self.set_live(name, value, apply).map(|_| ()),
        }
    }

    /// Checks (`apply` false) or applies a new `value` of the live
    /// parameter `name` (not `task`: [`ForceControllerNode::set_task`]):
    /// the task it concerns is checked on it as at start-up; applied, a
    /// running guided move takes it at once, the others from their next
    /// start (one that has stopped, or not begun, from its next start).
    /// Err says why it is refused.
    pub fn set_live(
        &mut self,
        name: &str,
        value: serde_yaml_ng::Value,
        apply: bool,
    ) -> Result<Takes, String> {
        let shown = serde_json::to_string(&value).unwrap_or_default();
        let base = self.with_param(name, value).map_err(|e| e.to_string())?;
        if !apply {
            return Ok(Takes::NextStart);
        }
        let now =
            !self.goal && self.running() && owner(&self.tasks, name).is_none_or(|t| t == self.task);
        let p = self
            .outside_goal(&self.task, &base)
            .map_err(|e| e.to_string())?
            .params;
        let takes = match &mut self.controller {
            Some(c) if now => match c.retune(&p, &self.tasks).map_err(|e| e.to_string())? {
                true => Takes::Now,
                false => Takes::NextStart,
            },
            _ => Takes::NextStart,
        };
        self.base = base;
        let set = LiveSet {
            name: name.into(),
            value: shown,
            takes,
            task: self.task.clone(),
        };
        tracing::info!("parameter {set}");
        self.live_set = Some(set);
        Ok(takes)
    }

    /// The last parameter set while the node ran.
    pub fn live_set(&self) -> Option<&LiveSet> {
        self.live_set.as_ref()
    }

    /// The parameters with `name` set to `value`, checked as the task it
    /// concerns would start on them: the task of its section, or for a
    /// shared setting the task the node runs (another task is checked
    /// when it is switched to, a goal when it comes).
    fn with_param(
        &self,
        name: &str,
        value: serde_yaml_ng::Value,
    ) -> Result<ControllerParams, ParamsError> {
        let base = with_flat_param(&self.base, name, value, "force_controller")?;
        let task = owner(&self.tasks, name).unwrap_or(&self.task);
        let p = self.outside_goal(task, &base)?.params;
        ForceController::check(&p, &self.tasks)?;
        Ok(base)
    }
}

/// The task whose section holds the parameter `name`; None for a setting
/// the tasks share.
fn owner<'t>(tasks: &'t TaskRegistry, name: &str) -> Option<&'t str> {
    tasks.each_name().find(|t| {
        name.strip_prefix(t)
            .is_some_and(|rest| rest.starts_with('.'))
    })
}

#[cfg(test)]
mod tests;
