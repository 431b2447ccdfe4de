//! The checked sections of the controller's parameters that its task is
//! built from, and the bodies the scene permits: the stiffest sets the
//! gains' prior and the safety envelope.

use crate::contact::{object_body, BodyParams, SkinParams};
use crate::control::task::TaskRegistry;
use crate::control::{
    ControllerParams, LoopDelays, OscillationParams, PdParams, SafetyParams, Task, TaskEnvelope,
    TaskLoop, UNKNOWN_OBJECT,
};
use crate::params::reference::check_ranges;
use crate::params::{Check, Checked, ParamsError};

/// The safety envelope of the task of `p`, one of `tasks`
/// (src/control/envelope.rs), against the stiffest body the scene permits.
pub fn task_envelope(
    p: &ControllerParams,
    tasks: &TaskRegistry,
) -> Result<TaskEnvelope, ParamsError> {
    Sections::check(p, tasks)?.envelope(p)
}

/// The checked sections of the parameters that the task is built from.
pub(super) struct Sections<'t> {
    skin: Checked<SkinParams>,
    pd: Checked<PdParams>,
    delays: Checked<LoopDelays>,
    oscillation: Checked<OscillationParams>,
    pub(super) safety: Checked<SafetyParams>,
    task: &'t crate::control::task::TaskEntry,
}

impl<'t> Sections<'t> {
    pub(super) fn check(
        p: &ControllerParams,
        tasks: &'t TaskRegistry,
    ) -> Result<Self, ParamsError> {
        // Every range a field declares, the tasks' sections' by their own checks.
        check_ranges(p, "")?;
        p.check_sections(tasks)?;
        let skin = p.skin.checked("skin")?;
        let pd = p.pd.checked("pd")?;
        let delays = p.loop_delays.checked("loop_delays")?;
        let oscillation = p.oscillation.checked("oscillation")?;
        let safety = p.safety.clone().checked("safety")?;
        permitted_body(p, &safety, &p.object)?;
        let task = tasks.get(&p.task)?;
        p.raw_section(task.name())?;
        Ok(Sections {
            skin,
            pd,
            delays,
            oscillation,
            safety,
            task,
        })
    }

    fn task_loop<'a>(&'a self, p: &'a ControllerParams) -> TaskLoop<'a> {
        TaskLoop {
            skin: &self.skin,
            pd: &self.pd,
            delays: &self.delays,
            oscillation: &self.oscillation,
            period_s: p.control_period_s,
            axes: &p.axes,
        }
    }

    /// The task, its gains set for `body`.
    pub(super) fn build(
        &self,
        p: &ControllerParams,
        body: &BodyParams,
    ) -> Result<Box<dyn Task>, ParamsError> {
        let raw = p.raw_section(self.task.name())?;
        self.task.build(raw, &self.task_loop(p), body)
    }

    /// The task's envelope against the stiffest body the scene permits.
    pub(super) fn envelope(&self, p: &ControllerParams) -> Result<TaskEnvelope, ParamsError> {
        let (body, name) = stiffest_permitted(p, &self.safety)?;
        let raw = p.raw_section(self.task.name())?;
        self.task.envelope(raw, &self.task_loop(p), &body, &name)
    }
}

/// The body named `name`, which the scene must permit (`safety.objects`).
fn permitted_body(
    p: &ControllerParams,
    safety: &SafetyParams,
    name: &str,
) -> Result<BodyParams, ParamsError> {
    if !safety.objects.iter().any(|o| o == name) {
        return Err(ParamsError::Invalid {
            key: "object".into(),
            value: name.into(),
            expected: format!(
                "one of the bodies this scene may touch, safety.objects = {:?}",
                safety.objects
            ),
        });
    }
    if name == UNKNOWN_OBJECT {
        return Ok(BodyParams {
            stiffness_n_per_m: safety.worst_case_stiffness_n_per_m,
            damping_n_s_per_m: 0.0,
            friction: 0.0,
        });
    }
    Ok(*object_body(&p.objects, name)?)
}

/// The stiffest body the scene permits, and its name (`safety.objects` is
/// not empty: checked).
pub(super) fn stiffest_permitted(
    p: &ControllerParams,
    safety: &SafetyParams,
) -> Result<(BodyParams, String), ParamsError> {
    let mut stiffest: Option<(BodyParams, String)> = None;
    for name in &safety.objects {
        let body = permitted_body(p, safety, name)?;
        if stiffest
            .as_ref()
            .is_none_or(|(b, _)| body.stiffness_n_per_m > b.stiffness_n_per_m)
        {
            stiffest = Some((body, name.clone()));
        }
    }
    stiffest.ok_or_else(|| ParamsError::Invalid {
        key: "safety.objects".into(),
        value: "[]".into(),
        expected: "the bodies this scene may touch".into(),
    })
}
