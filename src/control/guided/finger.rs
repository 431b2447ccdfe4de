//! The finger's velocity along one axis as the guided move's feedforward
//! reads it: the measured one (the arm's velocity and the force's rate
//! through the contact's stiffness) low-passed twice, then carried forward
//! by its own rate to when the command acts.
//!
//! Each first-order stage of time constant `tau` lags a velocity that
//! changes at a steady rate by `tau`, so the two stages' difference is that
//! rate times `tau`: `twice + (once - twice) (2 + ahead / tau)` is then the
//! velocity `ahead` seconds on, exact for a finger that speeds up or slows
//! down steadily. As a transfer function it is `(1 + s (2 tau + ahead)) /
//! (1 + s tau)^2`: `1 + s ahead` at a person's pushes (about 1 Hz), and
//! falling as `1/f` above `1 / tau`.
//!
//! `tau` is the loop's delay and lag, at least [`MIN_SMOOTH_S`]: at 25 Hz,
//! where a fingertip of 20 g on 300 N/m makes the contact look 2.5 times
//! stiffer than fitted (src/control/guided.rs), 0.29 of it passes on an arm
//! of 16 ms of delay and lag and 0.22 on one of 85 ms (docs/results.md
//! has what that did on MuJoCo's UR5).

/// The shortest time constant of the two stages (s).
const MIN_SMOOTH_S: f64 = 0.05;

/// One axis's finger velocity, low-passed twice (m/s).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FingerVelocity {
    once: f64,
    twice: f64,
}

impl FingerVelocity {
    /// Feeds the velocity measured `dt` after the previous one (m/s) in a
    /// loop whose delay and lag are `delay_s`; returns it predicted
    /// `delay_s` on, when a command sent now acts.
    pub fn step(&mut self, measured: f64, dt: f64, delay_s: f64) -> f64 {
        let tau = delay_s.max(MIN_SMOOTH_S);
        let share = dt / (tau + dt);
        self.once += (measured - self.once) * share;
        self.twice += (self.once - self.twice) * share;
        self.twice + (self.once - self.twice) * (2.0 + delay_s / tau)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// What [`FingerVelocity::step`] returns each 2 ms for `measured(t)`
    /// over `seconds`, with `delay_s`.
    fn run(measured: impl Fn(f64) -> f64, seconds: f64, delay_s: f64) -> Vec<(f64, f64)> {
        let (mut f, dt) = (FingerVelocity::default(), 0.002);
        (1..=(seconds / dt) as usize)
            .map(|k| {
                let t = k as f64 * dt;
                (t, f.step(measured(t), dt, delay_s))
            })
            .collect()
    }

    #[test]
    fn a_steady_speed_up_is_predicted_when_the_command_acts() {
        for delay_s in [0.016, 0.085] {
            let ramp = |t: f64| 0.1 * t;
            let (t, v) = *run(ramp, 2.0, delay_s).last().unwrap();
            assert!(
                (v - ramp(t + delay_s)).abs() < 2e-4,
                "{delay_s} s: {v} against {}",
                ramp(t + delay_s)
            );
        }
        let (_, v) = *run(|_| 0.03, 2.0, 0.04).last().unwrap();
        assert!((v - 0.03).abs() < 1e-9, "a steady speed stays: {v}");
    }

    #[test]
    fn a_ring_at_25_hz_passes_less_than_a_third() {
        for (delay_s, at_most) in [(0.016, 0.30), (0.085, 0.23)] {
            let ring = |t: f64| (2.0 * PI * 25.0 * t).sin();
            let out = run(ring, 3.0, delay_s);
            let peak = out[out.len() / 2..]
                .iter()
                .fold(0.0f64, |m, (_, v)| m.max(v.abs()));
            assert!(peak < at_most, "{delay_s} s: {peak}");
            assert!(
                peak > at_most - 0.05,
                "{delay_s} s: {peak}, not the filter asked"
            );
        }
    }
}
