//! The force controller's status: what changed (logged) and the
//! `/diagnostics` message.

use r2r::diagnostic_msgs::msg::DiagnosticArray;

use super::Shared;
use crate::nodes::ControlOutput;
use crate::ros::convert;
use crate::ros::convert::level::{OK, WARN};

/// Logs what changed and keeps `out` as the last output.
pub(super) fn keep(g: &mut Shared, out: ControlOutput) {
    let refusal = g.controller.as_ref().and_then(|c| c.refusal());
    log_change(g.last.as_ref(), &out, refusal);
    g.last = Some(out);
}

/// Logs a new phase (with the stop reason, and why a task was refused at
/// its start pose), a halt and the end of a halt.
fn log_change(before: Option<&ControlOutput>, now: &ControlOutput, refusal: Option<&str>) {
    if before.is_none() {
        if let Some(why) = refusal {
            tracing::error!("task refused at its start pose: {why}");
        }
    }
    let Some(before) = before else { return };
    if before.phase != now.phase {
        match now.reason {
            Some(r) => tracing::info!("phase {}: {}", now.phase.name(), r.name()),
            None => tracing::info!("phase {}", now.phase.name()),
        }
    }
    match (&before.halt, &now.halt) {
        (None, Some(h)) => tracing::warn!("halted, zero velocity: {h}"),
        (Some(_), None) => tracing::info!("inputs back: the task goes on"),
        _ => {}
    }
}

/// The controller's status: task, phase, halt, the loop delay it sees and
/// what it refused. Warns once when the delay goes beyond what the gains
/// assume, and once when it is back.
pub(super) fn diagnostics_msg(g: &mut Shared, now: f64, warned: &mut bool) -> DiagnosticArray {
    let mut values = vec![("task", g.task.name().to_string())];
    let (mut level, mut message) = (OK, g.task.name().to_string());
    match &g.robot {
        Some(r) => values.push(("robot", r.name.clone())),
        None => {
            level = WARN;
            message = format!("{message}, waiting for the robot description");
        }
    }
    if let Some(out) = &g.last {
        values.push(("phase", out.phase.name().to_string()));
        message = format!("{message}, {}", out.phase.name());
        if let Some(h) = &out.halt {
            (level, message) = (WARN, format!("{message}, halted: {h}"));
            values.push(("halt", h.to_string()));
        }
    }
    if let Some(r) = g.delays.take_report() {
        let ms = |s: f64| format!("{:.2}", s * 1e3);
        values.extend([
            ("loop_delay_steps", r.steps.to_string()),
            ("loop_delay_p50_ms", ms(r.p50_s)),
            ("loop_delay_p99_ms", ms(r.p99_s)),
            ("loop_delay_max_ms", ms(r.max_s)),
            ("loop_delay_assumed_ms", ms(r.assumed_s)),
        ]);
        if r.exceeds_assumed() {
            level = WARN;
            message = format!("{message}; loop delay beyond what the gains assume");
        }
        if r.exceeds_assumed() != *warned {
            *warned = r.exceeds_assumed();
            if *warned {
                tracing::warn!(
                    "estimates are {:.1} ms old (p99) when stepped on, beyond the {:.1} ms the \
                     gains and the safety envelope assume (loop_delays.transport_delay_s): \
                     the loop may ring; raise it to the delay of this deployment",
                    r.p99_s * 1e3,
                    r.assumed_s * 1e3
                );
            } else {
                tracing::info!("loop delay back within what the gains assume");
            }
        }
    }
    values.push(("rejected", g.rejected.to_string()));
    convert::diagnostics_msg(now, level, "force_controller", message, "", values)
}
