//! The in-process runner: every control period the simulated robot is
//! sampled, the estimator and the controller step in turn (the estimate
//! through a [`Link`] that may delay it, as a transport would), and the
//! command goes back to the robot, whose physics then runs for one period. The clock
//! is simulated, so a run is deterministic from its seed and as fast as the
//! CPU allows; [`Pacing::Realtime`] sleeps so that simulated time keeps pace
//! with the wall clock.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::biotac::BioTacReading;
use crate::control::{ControlOutput, ForceController, Phase};
use crate::nodes::wrench_estimator::EstimatorError;
use crate::nodes::{EstimatorNode, SimRobot, SimSample};
use crate::report::TraceRow;
use crate::wrench::WrenchEstimate;

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
    /// The estimator -> controller transport.
    pub link: Link,
}

/// The estimator -> controller transport of the embedded loop. With no
/// delay an estimate reaches the controller in the period of its reading;
/// with a delay `d` (plus a uniform jitter up to `j`) it is due `d + U(0, j)`
/// after its reading, and the controller takes it at its first tick from
/// then on, as a ROS 2 node on a timer takes a message that arrived over DDS
/// (`sim_robot.transport_delay_s`, `transport_jitter_s`). Order is kept.
#[derive(Debug, Clone)]
pub struct Link {
    delay_s: f64,
    jitter_s: f64,
    rng: ChaCha8Rng,
    in_flight: VecDeque<(f64, WrenchEstimate)>,
}

impl Link {
    /// A link with the delay and jitter (s); `seed` drives the jitter.
    pub fn new(delay_s: f64, jitter_s: f64, seed: u64) -> Self {
        Link {
            delay_s,
            jitter_s,
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x114e_de1a),
            // Enough for a delay of many periods without growing.
            in_flight: VecDeque::with_capacity(64),
        }
    }

    /// Sends an estimate at time `now` (s).
    pub fn send(&mut self, now: f64, e: WrenchEstimate) {
        let jitter = if self.jitter_s > 0.0 {
            self.rng.random_range(0.0..self.jitter_s)
        } else {
            0.0
        };
        let due = self
            .in_flight
            .back()
            .map_or(f64::NEG_INFINITY, |(t, _)| *t)
            .max(now + self.delay_s + jitter);
        self.in_flight.push_back((due, e));
    }

    /// The next estimate due by `now` (s), oldest first.
    pub fn receive(&mut self, now: f64) -> Option<WrenchEstimate> {
        // Half a microsecond absorbs rounding in sums of periods.
        let (due, _) = self.in_flight.front()?;
        if *due > now + 5e-7 {
            return None;
        }
        self.in_flight.pop_front().map(|(_, e)| e)
    }
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
            damping: out.damping,
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
        let mut sent = estimate;
        tamper(sample.t, &mut sent);
        if let Some(e) = sent {
            self.link.send(sample.t, e);
        }
        while let Some(e) = self.link.receive(sample.t) {
            // A rejected estimate is counted by the controller, whose
            // watchdog then stops the arm.
            let _ = self.controller.on_estimate(e);
        }
        let _ = self.controller.on_joint_state(&sample.joints);
        let output = self.controller.tick(sample.t);
        self.sim.command(self.controller.command());
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
        if row.phase == Phase::STOPPED {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wrench::Wrench;

    fn estimate(stamp_s: f64, seq: u16) -> WrenchEstimate {
        WrenchEstimate {
            stamp_s,
            seq,
            mean: Wrench::default(),
            std: Wrench::default(),
            estimated: [true; 6],
            pdc_rise: 0.0,
        }
    }

    /// The sequence numbers each tick of 10 ms receives, one sent per tick.
    fn received(link: &mut Link, ticks: u16) -> Vec<Vec<u16>> {
        (0..ticks)
            .map(|k| {
                let now = f64::from(k) * 0.01;
                link.send(now, estimate(now, k));
                std::iter::from_fn(|| link.receive(now).map(|e| e.seq)).collect()
            })
            .collect()
    }

    #[test]
    fn without_delay_an_estimate_arrives_in_its_own_period() {
        let got = received(&mut Link::new(0.0, 0.0, 1), 5);
        assert_eq!(got, (0..5).map(|k| vec![k]).collect::<Vec<_>>());
    }

    #[test]
    fn a_delay_holds_estimates_back_to_the_next_tick_after_it_in_order() {
        // 1 ms + up to 9 ms of jitter: always the next tick.
        let got = received(&mut Link::new(0.001, 0.009, 7), 50);
        assert!(got[0].is_empty());
        for (k, seqs) in got.iter().enumerate().skip(1) {
            assert_eq!(seqs, &vec![k as u16 - 1], "tick {k}");
        }
        // 15 ms + up to 10 ms: two or three ticks late, never reordered,
        // never lost, and the queue does not grow.
        let mut link = Link::new(0.015, 0.01, 7);
        let got = received(&mut link, 500);
        let flat: Vec<u16> = got.concat();
        assert_eq!(flat, (0..flat.len() as u16).collect::<Vec<_>>());
        assert!(flat.len() >= 497 && link.in_flight.len() <= 3);
        assert!(got.iter().any(|g| g.len() == 2), "jitter bunches some");
    }
}
