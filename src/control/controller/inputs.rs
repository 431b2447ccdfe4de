//! The controller's first stage, estimate in: the newest wrench estimate
//! and joint state, each refused when not finite (the joint state also
//! when not one per joint), and read each cycle only when both are there
//! and the joint state is fresh.

use crate::control::{ControllerParams, Halt, OutOfRangeParams, Watchdog};
use crate::wrench::{Axis, WrenchEstimate};

use super::JointState;

/// The inputs the controller steps on.
#[derive(Debug, Clone)]
pub(super) struct Inputs {
    estimate: Option<WrenchEstimate>,
    /// The stamp of the estimate last stepped on.
    stepped_stamp: Option<f64>,
    joints: Option<JointState>,
    /// The joint states' age limit.
    watchdog: Watchdog,
    out_of_range: OutOfRangeParams,
    /// The force axes the task reads.
    task_axes: Vec<Axis>,
    rejected: u64,
}

/// What one cycle reads of the inputs.
#[derive(Debug, Clone, Copy)]
pub(super) struct Reading {
    /// The newest estimate.
    pub est: WrenchEstimate,
    /// True when it has not been stepped on yet.
    pub fresh: bool,
    /// True when an axis the task reads is missing or too uncertain, or
    /// PDC nearly saturated.
    pub out_of_range: bool,
}

impl Inputs {
    /// No input yet, for a task that reads the force along `task_axes`.
    pub(super) fn new(p: &ControllerParams, task_axes: Vec<Axis>) -> Self {
        Inputs {
            estimate: None,
            stepped_stamp: None,
            joints: None,
            // Inputs arrive the transport delay after their stamp.
            watchdog: Watchdog::new(
                p.stale_periods + p.loop_delays.transport_delay_s / p.control_period_s,
                p.control_period_s,
            ),
            out_of_range: p.out_of_range,
            task_axes,
            rejected: 0,
        }
    }

    /// Takes new limits of a trusted estimate.
    pub(super) fn retune(&mut self, out_of_range: OutOfRangeParams) {
        self.out_of_range = out_of_range;
    }

    /// Inputs rejected for NaN or infinity so far.
    pub(super) fn rejected(&self) -> u64 {
        self.rejected
    }

    /// The newest estimate, once one has come.
    pub(super) fn estimate(&self) -> Option<&WrenchEstimate> {
        self.estimate.as_ref()
    }

    /// Takes an estimate; a non-finite one is rejected.
    pub(super) fn on_estimate(&mut self, e: WrenchEstimate) -> Result<(), Halt> {
        if !e.is_finite() {
            self.rejected += 1;
            return Err(Halt::NonFinite("the wrench estimate"));
        }
        self.estimate = Some(e);
        Ok(())
    }

    /// Takes the joint positions of `dof` joints (copied: no heap work
    /// after the first); non-finite ones, or not one per joint, are
    /// rejected.
    pub(super) fn on_joint_state(&mut self, js: &JointState, dof: usize) -> Result<(), Halt> {
        if js.q.len() != dof {
            self.rejected += 1;
            return Err(Halt::JointCount {
                expected: dof,
                found: js.q.len(),
            });
        }
        if !(js.stamp_s.is_finite() && js.q.iter().all(|v| v.is_finite())) {
            self.rejected += 1;
            return Err(Halt::NonFinite("the joint state"));
        }
        match &mut self.joints {
            Some(j) => {
                j.stamp_s = js.stamp_s;
                j.q.copy_from(&js.q);
            }
            None => self.joints = Some(js.clone()),
        }
        Ok(())
    }

    /// The cycle's reading at `now`, or the halt: a joint state missing
    /// or stale, no estimate yet.
    pub(super) fn read(&self, now: f64) -> Result<Reading, Halt> {
        let js = self.joints.as_ref().ok_or(Halt::Missing("joint state"))?;
        self.watchdog.check("joint state", now, Some(js.stamp_s))?;
        let est = self.estimate.ok_or(Halt::Missing("wrench estimate"))?;
        Ok(Reading {
            est,
            fresh: self.stepped_stamp != Some(est.stamp_s),
            out_of_range: self.is_out_of_range(&est),
        })
    }

    /// The task steps on `r`: its estimate is no longer fresh. The joint
    /// state it steps at.
    pub(super) fn step_on(&mut self, r: &Reading) -> Result<&JointState, Halt> {
        self.stepped_stamp = Some(r.est.stamp_s);
        self.joints.as_ref().ok_or(Halt::Missing("joint state"))
    }

    /// True when an axis the task reads is not estimated (a model without
    /// it), has a std outside 0 to `max_std_n`, or PDC is nearly saturated.
    fn is_out_of_range(&self, est: &WrenchEstimate) -> bool {
        let limits = &self.out_of_range;
        let trusted = 0.0..=limits.max_std_n;
        let uncertain = self
            .task_axes
            .iter()
            .any(|a| !est.estimated[a.index()] || !trusted.contains(&est.std.get(*a)));
        uncertain || est.pdc_rise > limits.max_pdc_rise_counts
    }
}
