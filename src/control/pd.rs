//! The PD force law of one axis, on (desired - estimated) force:
//!
//! `u = K dz(F_d - F - T_d dF_f/dt)`, clamped to `+-v_max`,
//!
//! where `F_f` is the force through a first-order low-pass (time constant
//! `tau_f`), `T_d` the derivative time and `dz` a deadband that subtracts its
//! width (continuous, zero inside). `u > 0` means "move so that the force
//! rises". The derivative term acts on the measured force only, so a step of
//! the set point gives no kick, and it predicts the force `T_d` ahead: with a
//! loop delay of a few periods this brakes the approach before the force
//! overshoots.
//!
//! Gain. For a velocity-controlled arm against a contact of stiffness `k`
//! sampled with period `T`, `e[k+1] = (1 - a) e[k]` with `a = K k T`: stable
//! for `0 < a < 2`, no ringing for `a <= 1`, and with `d` periods of delay
//! stable only for `a < a_max(d) = 2 sin(pi / (2 (2 d + 1)))` (architecture
//! page, "Force control facts"). So `K = a / (k T)` with `k` the effective
//! stiffness (the BioTac skin at the target force in series with the
//! object, [`crate::contact::series_stiffness`]) and
//! `a = min(gain_ratio, 0.9 a_max(d))`, `d` the whole loop delay in periods
//! ([`LoopDelays`]): the parameter (default 0.4), lowered when the loop is
//! slower than it allows (0.4 is 0.9 a_max(3), the 30 ms of the embedded
//! loop's arm; over ROS 2 the transport adds to it).
//!
//! Derivative time. The force is predicted ahead by the arm's part of the
//! delay (command latency + servo lag), the time a command takes to show in
//! the motion. Predicting the transport delay too amplified the estimate's
//! noise into a sustained oscillation in the simulator (`demo guarded` with
//! `sim_robot.transport_delay_s`), so the gain alone answers for it.

use serde::Deserialize;

use crate::params::{invalid, non_negative, positive, Check, Checked, ParamsError};

/// Fraction of the delay's stability bound the gain ratio may reach.
const STABILITY_FRACTION: f64 = 0.9;

/// The delays of the force loop after a reading is taken
/// (`force_controller.loop_delays` in the scene files). They set the PD's
/// derivative time and cap its gain, and the safety envelope's reaction
/// time ([`crate::control::envelope`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LoopDelays {
    /// From a reading to its estimate reaching the controller, beyond the
    /// control period (s): 0 in one process; over ROS 2 the estimator, DDS
    /// and the controller's wait for its next tick.
    pub transport_delay_s: f64,
    /// Before the arm acts on a velocity command (s).
    pub command_latency_s: f64,
    /// Time constant of the arm's velocity servos (s).
    pub arm_lag_s: f64,
}

impl Check for LoopDelays {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        non_negative(&format!("{key}.transport_delay_s"), self.transport_delay_s)?;
        non_negative(&format!("{key}.command_latency_s"), self.command_latency_s)?;
        non_negative(&format!("{key}.arm_lag_s"), self.arm_lag_s)?;
        Ok(self)
    }
}

impl LoopDelays {
    /// The whole delay (s).
    pub fn total_s(&self) -> f64 {
        self.transport_delay_s + self.arm_s()
    }

    /// The arm's part: command latency and servo lag (s).
    pub fn arm_s(&self) -> f64 {
        self.command_latency_s + self.arm_lag_s
    }
}

/// The largest stable gain ratio with `d` periods of delay (architecture
/// page, "Force control facts").
pub fn max_gain_ratio(d: f64) -> f64 {
    2.0 * (std::f64::consts::PI / (2.0 * (2.0 * d.max(0.0) + 1.0))).sin()
}

/// PD settings (`force_controller.pd` in the scene files).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PdParams {
    /// Gain ratio `a = K k T`, in (0, 1); lowered for a slow loop.
    pub gain_ratio: f64,
    /// Time constant of the force low-pass feeding the derivative (s).
    pub derivative_filter_s: f64,
    /// Largest speed the law commands (m/s).
    pub max_speed_mps: f64,
}

impl Check for PdParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        if !(self.gain_ratio > 0.0 && self.gain_ratio < 1.0) {
            let key = format!("{key}.gain_ratio");
            return Err(invalid(&key, self.gain_ratio, "0 < a < 1"));
        }
        non_negative(
            &format!("{key}.derivative_filter_s"),
            self.derivative_filter_s,
        )?;
        positive(&format!("{key}.max_speed_mps"), self.max_speed_mps)?;
        Ok(self)
    }
}

/// The PD law of one axis, with its filter state.
#[derive(Debug, Clone, PartialEq)]
pub struct PdAxis {
    gain: f64,
    derivative_time_s: f64,
    filter_s: f64,
    deadband_n: f64,
    max_speed: f64,
    filtered: Option<f64>,
    rate: f64,
}

impl PdAxis {
    /// The law for a contact of effective stiffness `stiffness` (N/m) at
    /// control period `period_s`, with a deadband (N), in a loop with these
    /// delays.
    pub fn new(
        p: &Checked<PdParams>,
        stiffness: f64,
        period_s: f64,
        deadband_n: f64,
        delays: &Checked<LoopDelays>,
    ) -> Self {
        let d = delays.total_s() / period_s;
        let a = p.gain_ratio.min(STABILITY_FRACTION * max_gain_ratio(d));
        PdAxis {
            gain: a / (stiffness * period_s),
            derivative_time_s: delays.arm_s(),
            filter_s: p.derivative_filter_s,
            deadband_n,
            max_speed: p.max_speed_mps,
            filtered: None,
            rate: 0.0,
        }
    }

    /// Proportional gain K (m/s per N).
    pub fn gain(&self) -> f64 {
        self.gain
    }

    /// Filtered rate of change of the force (N/s).
    pub fn force_rate(&self) -> f64 {
        self.rate
    }

    /// Feeds the force `force` measured `dt` after the previous one and
    /// returns the speed (m/s) that moves the force towards `target`.
    pub fn step(&mut self, target: f64, force: f64, dt: f64) -> f64 {
        let filtered = match self.filtered {
            Some(prev) if dt > 0.0 => {
                let f = prev + (force - prev) * dt / (self.filter_s + dt);
                self.rate = (f - prev) / dt;
                f
            }
            Some(prev) => prev,
            None => force,
        };
        self.filtered = Some(filtered);
        let e = target - force - self.derivative_time_s * self.rate;
        let e = e.signum() * (e.abs() - self.deadband_n).max(0.0);
        (self.gain * e).clamp(-self.max_speed, self.max_speed)
    }

    /// Forgets the filter state (after a pause in the estimates).
    pub fn reset(&mut self) {
        self.filtered = None;
        self.rate = 0.0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Delays of `n` periods of 10 ms in the arm, none in the transport.
    fn arm_delay(n: usize) -> Checked<LoopDelays> {
        delays(0.0, n as f64 * 0.01)
    }

    fn delays(transport_delay_s: f64, command_latency_s: f64) -> Checked<LoopDelays> {
        LoopDelays {
            transport_delay_s,
            command_latency_s,
            arm_lag_s: 0.0,
        }
        .checked("loop_delays")
        .unwrap()
    }

    fn params() -> PdParams {
        PdParams {
            gain_ratio: 0.5,
            derivative_filter_s: 0.02,
            max_speed_mps: 1.0,
        }
    }

    fn checked(p: PdParams) -> Checked<PdParams> {
        p.checked("pd").unwrap()
    }

    /// Closes the loop on an ideal spring: F = k x, x += u T.
    fn settle(p: &Checked<PdParams>, k: f64, delay: usize) -> Vec<f64> {
        let t = 0.01;
        let mut pd = PdAxis::new(p, k, t, 0.0, &arm_delay(0));
        let (mut x, mut queue) = (0.0, vec![0.0; delay]);
        let mut forces = Vec::new();
        for _ in 0..200 {
            let f = k * x;
            forces.push(f);
            queue.push(pd.step(1.0, f, t));
            x += queue.remove(0) * t;
        }
        forces
    }

    #[test]
    fn the_gain_ratio_sets_the_contraction_per_period() {
        // Without delay the error shrinks by (1 - a) per period, for any stiffness.
        for k in [1e2, 1e3, 1e5] {
            let f = settle(&checked(params()), k, 0);
            let (e1, e2) = (1.0 - f[5], 1.0 - f[6]);
            assert!((e2 / e1 - 0.5).abs() < 1e-9, "k {k}: {e1} {e2}");
            assert!(f.iter().all(|&v| v <= 1.0 + 1e-12), "no overshoot");
        }
    }

    #[test]
    fn stability_bound_with_one_period_of_delay() {
        // a < 1 converges with one period of delay; a = 1.2 diverges.
        let ok = settle(&checked(params()), 1e3, 1);
        assert!((ok[199] - 1.0).abs() < 1e-6);
        let mut high = params();
        high.gain_ratio = 0.999;
        let mut pd = PdAxis::new(&checked(high), 1e3, 0.01, 0.0, &arm_delay(0));
        pd.gain *= 1.2;
        let (mut x, mut queue, mut last) = (0.0, vec![0.0], 0.0);
        for _ in 0..400 {
            last = 1e3 * x;
            queue.push(pd.step(1.0, last, 0.01));
            x += queue.remove(0) * 0.01;
        }
        assert!(
            (last - 1.0).abs() > 0.5,
            "a = 1.2 with a delay rings up: {last}"
        );
    }

    #[test]
    fn the_gain_is_capped_for_a_slow_loop_and_still_settles() {
        // a_max: 1 period -> 1, 2 -> 0.618, 3 -> 0.445 (architecture page).
        assert!((max_gain_ratio(1.0) - 1.0).abs() < 1e-12);
        assert!((max_gain_ratio(2.0) - 0.618).abs() < 1e-3);
        let p = checked(PdParams {
            gain_ratio: 0.9,
            ..params()
        });
        for delay in [1usize, 2, 4, 6] {
            let t = 0.01;
            // The transport's delay: no derivative, the gain alone.
            let mut pd = PdAxis::new(&p, 1e3, t, 0.0, &delays(delay as f64 * t, 0.0));
            assert_eq!(pd.derivative_time_s, 0.0);
            let a = pd.gain() * 1e3 * t;
            assert!(
                a <= 0.9 * max_gain_ratio(delay as f64) + 1e-12,
                "{delay}: {a}"
            );
            let (mut x, mut queue, mut last) = (0.0, vec![0.0; delay], 0.0);
            for _ in 0..600 {
                last = 1e3 * x;
                queue.push(pd.step(1.0, last, t));
                x += queue.remove(0) * t;
            }
            assert!((last - 1.0).abs() < 1e-3, "{delay} periods: {last}");
        }
    }

    #[test]
    fn deadband_and_clamp() {
        let mut p = params();
        p.max_speed_mps = 0.01;
        let mut pd = PdAxis::new(&checked(p), 1e3, 0.01, 0.2, &arm_delay(0));
        assert_eq!(pd.step(1.0, 0.85, 0.01), 0.0, "inside the deadband");
        let u = pd.step(1.0, 0.7, 0.01);
        assert!((u - 0.1 * pd.gain()).abs() < 1e-12, "width subtracted: {u}");
        assert_eq!(pd.step(10.0, 0.0, 0.01), 0.01, "clamped");
        assert_eq!(pd.step(-10.0, 0.0, 0.01), -0.01, "clamped");
    }

    #[test]
    fn the_derivative_brakes_a_rising_force() {
        // A 30 ms loop delay: a = min(0.5, 0.9 a_max(3)) = 0.4005, T_d = 30 ms.
        let mut pd = PdAxis::new(&checked(params()), 1e3, 0.01, 0.0, &arm_delay(3));
        let mut plain = PdAxis::new(&checked(params()), 1e3, 0.01, 0.0, &arm_delay(0));
        assert!((pd.gain() * 1e3 * 0.01 - 0.9 * max_gain_ratio(3.0)).abs() < 1e-12);
        let (mut u, mut v) = (0.0, 0.0);
        for k in 0..10 {
            let f = 0.05 * k as f64;
            u = pd.step(1.0, f, 0.01);
            v = plain.step(1.0, f, 0.01);
        }
        assert!(pd.force_rate() > 0.0 && u < v, "{u} {v}");
        assert_eq!(plain.gain() * 1e3 * 0.01, 0.5, "no delay: the parameter");
        let e = PdParams {
            gain_ratio: 1.5,
            ..params()
        }
        .checked("pd")
        .unwrap_err();
        assert!(e.to_string().contains("pd.gain_ratio"), "{e}");
    }
}
