//! The in-process runner: every control period the simulated robot is
//! sampled, the estimator and the controller step in turn, and the command
//! goes back to the robot, whose physics then runs for one period. The clock
//! is simulated, so a run is deterministic from its seed and as fast as the
//! CPU allows; [`Pacing::Realtime`] sleeps so that simulated time keeps pace
//! with the wall clock.

use std::time::{Duration, Instant};

use crate::biotac::BioTacReading;
use crate::control::Phase;
use crate::nodes::estimator::EstimatorError;
use crate::nodes::{
    ControlOutput, EstimatorNode, ForceController, SimRobot, SimSample, WrenchEstimate,
};
use crate::report::TraceRow;

/// Time a run goes on after its task stopped (s), to show the arm at rest.
const AFTER_STOP_S: f64 = 1.0;

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

/// A change made to an estimate between the estimator and the controller,
/// for fault-injection tests: sees the time (s) and the estimate, if any.
pub type Tamper<'a> = &'a mut dyn FnMut(f64, &mut Option<WrenchEstimate>);

/// A change made to a BioTac reading between the sensor and the estimator
/// (the driver's output), for fault-injection tests: sees the time (s) and
/// the reading; setting it to None loses it, as a stopped driver would.
pub type ReadingTamper<'a> = &'a mut dyn FnMut(f64, &mut Option<BioTacReading>);

/// What one control period saw and did.
#[derive(Debug, Clone, PartialEq)]
pub struct Period {
    /// The robot's sensors at the start of the period (before any tampering).
    pub sample: SimSample,
    /// The estimator's output for the reading it got, if any (before the
    /// estimate is tampered with).
    pub estimate: Option<WrenchEstimate>,
    /// The controller's command.
    pub output: ControlOutput,
}

impl Period {
    /// The period as a trace row.
    pub fn row(&self) -> TraceRow {
        let (s, out) = (&self.sample, &self.output);
        TraceRow {
            t: s.t,
            phase: out.phase,
            reason: out.reason,
            halted: out.halt.is_some(),
            estimate: self.estimate.map(|e| (e.mean.force, e.std.force)),
            pdc_rise: self.estimate.map(|e| e.pdc_rise),
            measured: s.ft.force,
            targets: out.targets,
            offset: s.offset,
            velocity: s.velocity,
            commanded: out.velocity,
            finger: s.finger,
        }
    }
}

impl Nodes {
    /// One control period: sample the robot, estimate, control, command,
    /// then run the physics for a period. `reading_tamper` may alter or drop
    /// the reading on its way to the estimator, `tamper` the estimate on its
    /// way to the controller.
    pub fn step_period(
        &mut self,
        reading_tamper: ReadingTamper,
        tamper: Tamper,
    ) -> Result<Period, EstimatorError> {
        let sample = self.sim.sample();
        let mut reading = Some(sample.reading);
        reading_tamper(sample.t, &mut reading);
        let estimate = match reading {
            Some(r) => self.estimator.on_reading(&r)?,
            None => None,
        };
        let mut delivered = estimate;
        tamper(sample.t, &mut delivered);
        if let Some(e) = delivered {
            // A rejected estimate is counted by the controller, whose
            // watchdog then stops the arm.
            let _ = self.controller.on_estimate(e);
        }
        let _ = self.controller.on_joint_state(sample.joints);
        let output = self.controller.tick(sample.t);
        self.sim.command(output.qdot);
        self.sim.advance();
        Ok(Period {
            sample,
            estimate,
            output,
        })
    }
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
        let row = nodes.step_period(&mut |_, _| {}, &mut |_, _| {})?.row();
        on_row(&row);
        rows.push(row);
        if row.phase == Phase::Stopped {
            let at = *stopped_at.get_or_insert(row.t);
            if row.t - at >= AFTER_STOP_S {
                break;
            }
        }
        if pacing == Pacing::Realtime {
            let due = wall_start + Duration::from_secs_f64(nodes.sim.time());
            std::thread::sleep(due.saturating_duration_since(Instant::now()));
        }
    }
    Ok(rows)
}
