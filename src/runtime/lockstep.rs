//! The in-process runner: every control period the simulated robot is
//! sampled, the estimator and the controller step in turn, and the command
//! goes back to the robot, whose physics then runs for one period. The clock
//! is simulated, so a run is deterministic from its seed and as fast as the
//! CPU allows; [`Pacing::Realtime`] sleeps so that simulated time keeps pace
//! with the wall clock.

use std::time::{Duration, Instant};

use crate::control::Phase;
use crate::nodes::estimator::EstimatorError;
use crate::nodes::{EstimatorNode, ForceController, SimRobot};
use crate::report::TraceRow;

/// Time a run goes on after its task stopped (s), to show the arm at rest.
const AFTER_STOP_S: f64 = 0.5;

/// How the loop keeps time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pacing {
    /// As fast as possible.
    Lockstep,
    /// One simulated second per wall-clock second.
    Realtime,
}

/// The nodes of one embedded run.
#[derive(Debug, Clone)]
pub struct Nodes {
    /// Simulated arm, body, F/T sensor and BioTac.
    pub sim: SimRobot,
    /// GP wrench estimator.
    pub estimator: EstimatorNode,
    /// Force controller.
    pub controller: ForceController,
}

/// Runs until the robot's duration, or shortly after the task stopped;
/// `on_row` sees every period as it happens.
pub fn run(
    nodes: &mut Nodes,
    pacing: Pacing,
    on_row: &mut dyn FnMut(&TraceRow),
) -> Result<Vec<TraceRow>, EstimatorError> {
    let period = nodes.sim.period_s();
    let periods = (nodes.sim.duration_s() / period).round() as usize;
    let mut rows = Vec::with_capacity(periods + 1);
    let wall_start = Instant::now();
    let mut stopped_at = None;
    for _ in 0..=periods {
        let s = nodes.sim.sample();
        let estimate = nodes.estimator.on_reading(&s.reading)?;
        if let Some(e) = estimate {
            // A rejected estimate is counted by the controller, whose
            // watchdog then stops the arm.
            let _ = nodes.controller.on_estimate(e);
        }
        let _ = nodes.controller.on_joint_state(s.joints);
        let out = nodes.controller.tick(s.t);
        nodes.sim.command(out.qdot);
        let row = TraceRow {
            t: s.t,
            phase: out.phase,
            reason: out.reason,
            halted: out.halt.is_some(),
            estimate: estimate.map(|e| (e.mean.force, e.std.force)),
            pdc_rise: estimate.map(|e| e.pdc_rise),
            measured: s.ft.force,
            targets: out.targets,
            offset: s.offset,
            velocity: s.velocity,
            commanded: out.velocity,
            finger: s.finger,
        };
        on_row(&row);
        rows.push(row);
        if out.phase == Phase::Stopped {
            let at = *stopped_at.get_or_insert(s.t);
            if s.t - at >= AFTER_STOP_S {
                break;
            }
        }
        nodes.sim.advance();
        if pacing == Pacing::Realtime {
            let due = wall_start + Duration::from_secs_f64(nodes.sim.time());
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
        }
    }
    Ok(rows)
}
