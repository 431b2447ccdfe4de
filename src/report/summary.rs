//! The figures of a run, all from the force the F/T sensor measured (not the
//! estimate), in the BioTac frame.
//!
//! - Contact: the first period whose measured force along the controlled
//!   normal axis reaches [`CONTACT_N`].
//! - Guarded move: peak force, overshoot above the target, settle time (from
//!   contact until the force stays within [`SETTLE_BAND_N`] of the target),
//!   steady-state error (|mean - target| over the last [`STEADY_WINDOW_S`]),
//!   its standard deviation over the last [`SD_WINDOW_S`], RMS error from contact on, and the largest speed across the approach
//!   direction.
//! - Guided move: RMS error per controlled axis from contact on, and the
//!   largest speed along an axis the finger is not moving along, also as a
//!   ratio of the finger's peak speed in that segment.

use std::collections::BTreeMap;

use serde::Serialize;

use super::TraceRow;
use crate::control::{
    ControllerParams, ForceController, OffAxis, Phase, StopReason, TaskRegistry, TaskReport,
};
use crate::params::ParamsError;
use crate::wrench::Axis;

/// Measured force that counts as contact (N): 8 sigma of the F/T noise
/// averaged over a period (0.02 N / sqrt(10)).
pub const CONTACT_N: f64 = 0.05;
/// Band around the target that counts as settled (N).
pub const SETTLE_BAND_N: f64 = 0.05;
/// Window at the end of a run for the steady-state error (s).
pub const STEADY_WINDOW_S: f64 = 2.0;
/// Window at the end of a run for the force's standard deviation (s).
pub const SD_WINDOW_S: f64 = 2.0;
/// Window at the end of a run for the speed at rest (s).
pub const REST_WINDOW_S: f64 = 0.5;

/// What the summary needs besides the rows.
#[derive(Debug, Clone, PartialEq)]
pub struct RunInfo {
    /// The robot (its URDF's name).
    pub robot: String,
    /// The task's name.
    pub task: &'static str,
    /// The body touched.
    pub object: String,
    /// What the report reads of the task's settings.
    pub report: TaskReport,
}

impl RunInfo {
    /// The run of a controller with `params` (a task of `tasks`) on the
    /// robot named `robot`.
    pub fn new(
        params: &ControllerParams,
        tasks: &TaskRegistry,
        robot: &str,
    ) -> Result<Self, ParamsError> {
        let task = tasks.get(&params.task)?;
        Ok(RunInfo {
            robot: robot.into(),
            task: task.name(),
            object: params.object.clone(),
            report: task.report(params.raw_section(task.name())?)?,
        })
    }
}

/// The figures of one run (the `--json` line of `demo`).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Summary {
    /// The robot (its URDF's name).
    pub robot: String,
    /// "guarded" or "guided".
    pub task: &'static str,
    /// The body touched.
    pub object: String,
    /// Approach speed (m/s); null for the guided move.
    pub approach_speed_mps: Option<f64>,
    /// Time of the first measured contact (s); null if none.
    pub contact_time_s: Option<f64>,
    /// Largest measured force along the controlled normal axis (N).
    pub peak_force_n: f64,
    /// Peak force above the target (N), 0 when below.
    pub overshoot_n: f64,
    /// |mean - target| of the normal force over the last 2 s (N).
    pub steady_state_error_n: Option<f64>,
    /// Standard deviation of the normal force over the last 2 s (N), from
    /// contact on: a sustained oscillation shows here.
    pub final_sd_n: Option<f64>,
    /// From contact until the normal force stays within the band (s).
    pub settle_time_s: Option<f64>,
    /// From contact until the task first says it holds (s): its settling
    /// window included.
    pub hold_after_contact_s: Option<f64>,
    /// RMS force error from contact on, worst controlled axis (N).
    pub rms_force_error_n: Option<f64>,
    /// RMS force error from contact on, per controlled axis (N).
    pub rms_force_error_by_axis_n: BTreeMap<&'static str, f64>,
    /// Largest speed along an axis not commanded (m/s).
    pub max_off_axis_speed_mps: f64,
    /// Guided: that speed over the finger's peak speed; guarded: over the
    /// approach speed.
    pub max_off_axis_ratio: Option<f64>,
    /// Largest speed over the last half second (m/s): 0 when the arm rests.
    pub rest_speed_mps: f64,
    /// Periods the safety checks held the arm.
    pub halted_periods: usize,
    /// Periods in which the inverse kinematics damped the motion (near a
    /// singularity).
    pub damped_periods: usize,
    /// Largest damping factor lambda of the inverse kinematics.
    pub max_damping: f64,
    /// True when the task stopped on the force limit, out-of-range input
    /// or an oscillation.
    pub aborted: bool,
    /// Why the task stopped ("timeout", "force_limit", "out_of_range"), null
    /// when it did not.
    pub reason: Option<&'static str>,
    /// Phase at the end of the run.
    pub final_phase: &'static str,
    /// Simulated time covered (s).
    pub duration_s: f64,
    /// What the controller measured of the loop and chose, at the end.
    pub identified: Option<Identified>,
}

/// What the controller measured of its loop and chose, at the end of a run
/// (nothing of it was declared).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Identified {
    /// The contact's stiffness per force axis x, y, z, skin and body in
    /// series, as the gains use it (N/m).
    pub stiffness_n_per_m: [Option<f64>; 3],
    /// The body behind the skin, fitted in contact (N/m; null: rigid, or
    /// not fitted).
    pub body_n_per_m: Option<f64>,
    /// The estimates' age when stepped on, 90th percentile (s).
    pub transport_s: f64,
    /// The arm's command latency (s).
    pub arm_latency_s: f64,
    /// The arm's velocity lag (s).
    pub arm_lag_s: f64,
    /// True when the latency and lag were fitted from the arm's motion
    /// (false: the bounds of loop_delays).
    pub arm_fitted: bool,
    /// The proportional gains per force axis (m/s per N).
    pub gains_m_per_s_per_n: [Option<f64>; 3],
    /// The force's standard deviation over the settling window (N).
    pub settled_sd_n: Option<f64>,
    /// Times the stability watchdog lowered a gain.
    pub gain_lowered: u32,
    /// The task's own figures, by name.
    pub task_figures: BTreeMap<&'static str, f64>,
}

impl Identified {
    /// What `c` measured and chose.
    pub fn of(c: &ForceController) -> Self {
        let (t, f) = (c.timing(), c.task().figures());
        Identified {
            stiffness_n_per_m: f.stiffness_n_per_m,
            body_n_per_m: f.body_n_per_m.filter(|k| k.is_finite()),
            transport_s: t.transport_s,
            arm_latency_s: t.latency_s,
            arm_lag_s: t.lag_s,
            arm_fitted: c.arm_response().is_some(),
            gains_m_per_s_per_n: c.gains(),
            settled_sd_n: f.settled_sd_n,
            gain_lowered: f.softened,
            task_figures: f.own.into_iter().collect(),
        }
    }
}

const FORCE_AXES: [Axis; 3] = [Axis::Fx, Axis::Fy, Axis::Fz];

/// Computes the summary of a run.
pub fn summarize(info: &RunInfo, rows: &[TraceRow]) -> Summary {
    let last = rows.last();
    let end_t = last.map_or(0.0, |r| r.t);
    let targets = last.map_or([None; 3], |r| r.targets);
    // The normal axis: z when controlled, else the first controlled axis.
    let normal = if targets[2].is_some() {
        2
    } else {
        targets.iter().position(Option::is_some).unwrap_or(2)
    };
    let target = targets[normal].unwrap_or(0.0);
    let sign = if target < 0.0 { -1.0 } else { 1.0 };
    let pressing = |r: &TraceRow| sign * r.measured[normal];
    let contact = rows.iter().position(|r| pressing(r) >= CONTACT_N);
    let after = contact.map_or(&rows[rows.len()..], |i| &rows[i..]);
    let peak_force_n = rows.iter().map(pressing).fold(0.0, f64::max);

    let by_axis = rms_by_axis(&targets, after);
    let rms = by_axis.values().copied().reduce(f64::max);

    let window = |w: f64| rows.iter().filter(move |r| r.t > end_t - w);
    let steady: Vec<f64> = window(STEADY_WINDOW_S).map(pressing).collect();
    let steady_state_error_n = (contact.is_some() && !steady.is_empty())
        .then(|| (steady.iter().sum::<f64>() / steady.len() as f64 - target.abs()).abs());
    let last_two: Vec<f64> = window(SD_WINDOW_S).map(pressing).collect();
    let final_sd_n = (contact.is_some() && last_two.len() > 1).then(|| {
        let n = last_two.len() as f64;
        let mean = last_two.iter().sum::<f64>() / n;
        (last_two.iter().map(|f| (f - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    });
    let settle_time_s = contact.and_then(|c| {
        let outside = rows
            .iter()
            .rposition(|r| (pressing(r) - target.abs()).abs() > SETTLE_BAND_N)?;
        // The rows before contact are outside the band, so this is found;
        // settled only if the band was entered before the end.
        (outside + 1 < rows.len()).then(|| rows[outside + 1].t - rows[c].t)
    });
    let hold_after_contact_s = contact.and_then(|c| {
        let held = rows[c..].iter().find(|r| r.phase == Phase::HOLD)?;
        Some(held.t - rows[c].t)
    });
    let (off_speed, off_ratio) = off_axis(info, rows, normal);
    let rest_speed_mps = window(REST_WINDOW_S)
        .map(|r| r.velocity.norm())
        .fold(0.0, f64::max);
    let reason = last.and_then(|r| r.reason);
    Summary {
        robot: info.robot.clone(),
        task: info.task,
        object: info.object.clone(),
        approach_speed_mps: info.report.approach_speed_mps,
        contact_time_s: contact.map(|i| rows[i].t),
        peak_force_n,
        overshoot_n: (peak_force_n - target.abs()).max(0.0),
        steady_state_error_n,
        final_sd_n,
        settle_time_s,
        hold_after_contact_s,
        rms_force_error_n: rms,
        rms_force_error_by_axis_n: by_axis,
        max_off_axis_speed_mps: off_speed,
        max_off_axis_ratio: off_ratio,
        rest_speed_mps,
        halted_periods: rows.iter().filter(|r| r.halted).count(),
        damped_periods: rows.iter().filter(|r| r.damping > 0.0).count(),
        max_damping: rows.iter().map(|r| r.damping).fold(0.0, f64::max),
        aborted: reason.is_some_and(StopReason::aborted),
        reason: reason.map(|r| r.name()),
        final_phase: last.map_or("none", |r| r.phase.name()),
        duration_s: end_t,
        identified: None,
    }
}

/// The RMS error of each controlled axis (`targets`) over the rows from
/// contact on (`after`).
fn rms_by_axis(targets: &[Option<f64>; 3], after: &[TraceRow]) -> BTreeMap<&'static str, f64> {
    let mut by_axis = BTreeMap::new();
    for (i, t) in targets.iter().enumerate() {
        if let (Some(t), false) = (t, after.is_empty()) {
            let ms = after
                .iter()
                .map(|r| (t - r.measured[i]).powi(2))
                .sum::<f64>()
                / after.len() as f64;
            by_axis.insert(FORCE_AXES[i].name(), ms.sqrt());
        }
    }
    by_axis
}

/// The largest speed off the axes the task moves along (m/s), and its
/// ratio to the approach or the finger's speed, as the task's report says
/// ([`OffAxis`]).
fn off_axis(info: &RunInfo, rows: &[TraceRow], normal: usize) -> (f64, Option<f64>) {
    match info.report.off_axis {
        OffAxis::Nothing => (0.0, None),
        OffAxis::AcrossNormal => {
            let d = nalgebra::Vector3::ith(normal, 1.0);
            let s = rows
                .iter()
                .map(|r| (r.velocity - d * r.velocity.dot(&d)).norm())
                .fold(0.0, f64::max);
            (s, info.report.approach_speed_mps.map(|v| s / v))
        }
        OffAxis::Unpushed => {
            let (mut s, mut ratio) = (0.0f64, 0.0f64);
            for r in rows.iter().filter(|r| r.phase != Phase::STOPPED) {
                let Some(f) = r.finger.filter(|f| f.peak_speed_mps > 0.0) else {
                    continue;
                };
                for i in (0..3).filter(|&i| !f.pushed[i]) {
                    s = s.max(r.velocity[i].abs());
                    ratio = ratio.max(r.velocity[i].abs() / f.peak_speed_mps);
                }
            }
            (s, Some(ratio))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::Phase;
    use nalgebra::Vector3;

    /// Damped from 2 s on.
    fn k_damped(t: f64) -> bool {
        t >= 2.0 - 1e-9
    }

    fn row(t: f64, fz: f64, vx: f64) -> TraceRow {
        TraceRow {
            t,
            phase: if t >= 1.5 - 1e-9 {
                Phase::HOLD
            } else {
                Phase::REGULATE
            },
            reason: None,
            halted: false,
            estimate: None,
            pdc_rise: None,
            measured: Vector3::new(0.0, 0.0, fz),
            targets: [None, None, Some(1.0)],
            offset: Vector3::zeros(),
            velocity: Vector3::new(vx, 0.0, -0.01),
            commanded: Vector3::zeros(),
            finger: None,
            damping: if k_damped(t) { 0.01 } else { 0.0 },
        }
    }

    #[test]
    fn guarded_figures_of_a_known_force_profile() {
        // 0 N until 1 s, then 1.2 N for 0.1 s, then 1.02 N: contact 1.0 s,
        // peak 1.2 N, settled from 1.1 s, the task holding from 1.5 s,
        // steady error 0.02 N.
        let rows: Vec<TraceRow> = (0..400)
            .map(|k| {
                let t = k as f64 * 0.01;
                let fz = if t < 1.0 - 1e-9 {
                    0.0
                } else if t < 1.1 - 1e-9 {
                    1.2
                } else {
                    1.02
                };
                row(t, fz, if k == 5 { 0.002 } else { 0.0 })
            })
            .collect();
        let info = RunInfo {
            robot: "arm".into(),
            task: "guarded",
            object: "box".into(),
            report: TaskReport {
                approach_speed_mps: Some(0.01),
                off_axis: OffAxis::AcrossNormal,
            },
        };
        let s = summarize(&info, &rows);
        assert_eq!(s.contact_time_s, Some(1.0));
        assert!((s.peak_force_n - 1.2).abs() < 1e-12 && (s.overshoot_n - 0.2).abs() < 1e-12);
        assert!((s.settle_time_s.unwrap() - 0.1).abs() < 1e-9, "{s:?}");
        assert!(
            (s.hold_after_contact_s.unwrap() - 0.5).abs() < 1e-9,
            "{s:?}"
        );
        assert!((s.steady_state_error_n.unwrap() - 0.02).abs() < 1e-9);
        // RMS over 300 rows from contact: 10 at 0.2 N, 290 at 0.02 N.
        let rms = ((10.0 * 0.04 + 290.0 * 0.0004) / 300.0f64).sqrt();
        assert!((s.rms_force_error_n.unwrap() - rms).abs() < 1e-12);
        assert!((s.max_off_axis_speed_mps - 0.002).abs() < 1e-12);
        assert!((s.max_off_axis_ratio.unwrap() - 0.2).abs() < 1e-12);
        assert_eq!((s.aborted, s.reason, s.final_phase), (false, None, "hold"));
        assert_eq!((s.damped_periods, s.max_damping), (200, 0.01));
    }

    #[test]
    fn no_contact_leaves_the_contact_figures_empty() {
        let rows: Vec<TraceRow> = (0..10).map(|k| row(k as f64 * 0.01, 0.0, 0.0)).collect();
        let info = RunInfo {
            robot: "arm".into(),
            task: "guarded",
            object: "air".into(),
            report: TaskReport {
                approach_speed_mps: Some(0.01),
                off_axis: OffAxis::AcrossNormal,
            },
        };
        let s = summarize(&info, &rows);
        assert_eq!(
            (
                s.contact_time_s,
                s.settle_time_s,
                s.steady_state_error_n,
                s.rms_force_error_n
            ),
            (None, None, None, None)
        );
        assert_eq!(s.overshoot_n, 0.0);
    }
}
