//! The simulated arm, any number of joints: a velocity-controlled joint
//! servo. A command takes effect at the arm's next command cycle but one
//! (an arm that reads commands on its own cycle `C`: `C` to `2 C` after it
//! arrives; none when `C` is 0), then after a latency, and each joint
//! tracks it with a first-order lag `tau dqdot/dt = qdot_cmd - qdot`. The
//! hardware stops are the joint ranges. Commands in flight reuse their
//! vectors, so a running arm does no heap work.

use std::collections::VecDeque;

use crate::kinematics::{JointLimits, JointVector};

/// The arm plant.
#[derive(Debug, Clone)]
pub struct ArmPlant {
    q: JointVector,
    qdot: JointVector,
    active: JointVector,
    pending: VecDeque<(f64, JointVector)>,
    spare: Vec<JointVector>,
    cycle_s: f64,
    latency_s: f64,
    lag_s: f64,
    min: JointVector,
    max: JointVector,
}

impl ArmPlant {
    /// An arm at rest at `q0`, with its command cycle, latency and velocity
    /// lag (s).
    pub fn new(
        q0: JointVector,
        limits: &JointLimits,
        cycle_s: f64,
        latency_s: f64,
        lag_s: f64,
    ) -> Self {
        let n = q0.len();
        ArmPlant {
            q: q0,
            qdot: JointVector::zeros(n),
            active: JointVector::zeros(n),
            // A few control periods of commands in flight at most.
            pending: VecDeque::with_capacity(64),
            spare: Vec::with_capacity(64),
            cycle_s,
            latency_s,
            lag_s,
            min: limits.min.clone(),
            max: limits.max.clone(),
        }
    }

    /// Joint positions (rad).
    pub fn q(&self) -> &JointVector {
        &self.q
    }

    /// Joint velocities (rad/s).
    pub fn qdot(&self) -> &JointVector {
        &self.qdot
    }

    /// Sends a velocity command at time `now` (one value per joint); it
    /// takes effect at the cycle after the next, then the latency.
    pub fn command(&mut self, now: f64, qdot: &JointVector) {
        let mut slot = self
            .spare
            .pop()
            .unwrap_or_else(|| JointVector::zeros(qdot.len()));
        slot.copy_from(qdot);
        let read = if self.cycle_s > 0.0 {
            // The first cycle at or after `now` reads it; the next applies it.
            ((now / self.cycle_s - 1e-9).ceil() + 1.0) * self.cycle_s
        } else {
            now
        };
        self.pending.push_back((read + self.latency_s, slot));
    }

    /// Advances from `now` by `dt`.
    pub fn step(&mut self, now: f64, dt: f64) {
        while let Some((at, _)) = self.pending.front() {
            if *at > now + 1e-12 {
                break;
            }
            if let Some((_, cmd)) = self.pending.pop_front() {
                self.spare.push(std::mem::replace(&mut self.active, cmd));
            }
        }
        let alpha = if self.lag_s > 0.0 {
            1.0 - (-dt / self.lag_s).exp()
        } else {
            1.0
        };
        self.qdot
            .zip_apply(&self.active, |v, a| *v += (a - *v) * alpha);
        self.q.zip_apply(&self.qdot, |q, v| *q += v * dt);
        for i in 0..self.q.len() {
            if self.q[i] <= self.min[i] || self.q[i] >= self.max[i] {
                self.q[i] = self.q[i].clamp(self.min[i], self.max[i]);
                self.qdot[i] = 0.0;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::Robot;

    #[test]
    fn a_command_acts_after_the_latency_then_with_the_lag() {
        let robot = Robot::pa10();
        let mut arm = ArmPlant::new(JointVector::zeros(7), &robot.limits, 0.0, 0.01, 0.02);
        let cmd = JointVector::repeat(7, 0.1);
        arm.command(0.0, &cmd);
        let dt = 1e-3;
        for k in 0..10 {
            arm.step(k as f64 * dt, dt);
        }
        assert_eq!(*arm.qdot(), JointVector::zeros(7), "nothing before 10 ms");
        for k in 10..30 {
            arm.step(k as f64 * dt, dt);
        }
        // After one lag time constant the speed is 1 - 1/e of the command.
        let frac = arm.qdot()[0] / 0.1;
        assert!((frac - (1.0 - (-1.0f64).exp())).abs() < 1e-9, "{frac}");
        for k in 30..300 {
            arm.step(k as f64 * dt, dt);
        }
        assert!((arm.qdot()[3] - 0.1).abs() < 1e-6);
    }

    #[test]
    fn the_hardware_stops_hold() {
        let robot = Robot::pa10();
        let mut q0 = JointVector::zeros(7);
        q0[1] = robot.limits.max[1] - 1e-3;
        let mut arm = ArmPlant::new(q0, &robot.limits, 0.0, 0.0, 0.0);
        arm.command(0.0, &JointVector::repeat(7, 1.0));
        for k in 0..100 {
            arm.step(k as f64 * 1e-3, 1e-3);
        }
        assert_eq!(arm.q()[1], robot.limits.max[1]);
        assert_eq!(arm.qdot()[1], 0.0);
    }

    #[test]
    fn a_command_acts_at_the_cycle_after_the_one_it_arrives_in() {
        let robot = Robot::pa10();
        // A 8 ms cycle: sent at 10 ms, read at 16, acting at 24 ms.
        for (sent, acts) in [(0.010, 0.024), (0.016, 0.024), (0.017, 0.032)] {
            let mut arm = ArmPlant::new(JointVector::zeros(7), &robot.limits, 0.008, 0.0, 0.0);
            let dt = 1e-3;
            let mut k = 0;
            while (k as f64) * dt < sent - 1e-9 {
                arm.step(k as f64 * dt, dt);
                k += 1;
            }
            arm.command(sent, &JointVector::repeat(7, 0.1));
            while arm.qdot()[0] == 0.0 {
                arm.step(k as f64 * dt, dt);
                k += 1;
            }
            let at = (k - 1) as f64 * dt;
            assert!((at - acts).abs() < 1e-9, "sent {sent}: acts at {at}");
        }
    }
}
