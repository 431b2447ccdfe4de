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
//! Gain. `K` is set for the loop the controller measures, not one the user
//! declares ([`PdAxis::tune`]): the contact's stiffness `k` (the BioTac's
//! skin in series with the body, fitted in contact) and the loop's timing
//! (the estimate's age, the arm's latency and lag, fitted from
//! `joint_states`) give the largest `K` that keeps the phase and gain
//! margins of `pd.margins` ([`super::tuning`]). Until they are measured,
//! priors stand in: the stiffest body the scene permits, and the bounds of
//! `loop_delays`. The stability watchdog may lower it further
//! ([`PdAxis::soften`]).
//!
//! Derivative time. The force is predicted ahead by half of the arm's part
//! of the delay (command latency + servo lag), the time a command takes to
//! show in the motion: the whole of it amplified the estimate's noise into a
//! sustained oscillation in the simulator when the latency was pure (an arm
//! that takes commands on a cycle of its own), half of it keeps some of the
//! phase it buys (the margins count it).

use serde::{Deserialize, Serialize};

use super::tuning::{gain, LoopTiming, Margins};
use crate::params::reference::check_ranges;
use crate::params::{Check, Checked, ParamsError};

/// The share of the arm's delay the derivative predicts.
const DERIVATIVE_SHARE: f64 = 0.5;

/// A change of the stiffness or the timing below this share keeps the gain.
const RETUNE_SHARE: f64 = 0.01;

/// The longest delays of the force loop after a reading is taken
/// (`force_controller.loop_delays` in the scene files): the bounds the
/// safety envelope assumes ([`crate::control::envelope`]), and the gains'
/// priors until the controller has measured the loop.
#[derive(Debug, Clone, Copy, Default, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LoopDelays {
    /// From a reading to its estimate reaching the controller, beyond the
    /// control period (s): 0 in one process; over ROS 2 the estimator, DDS
    /// and the controller's wait for its next tick.
    #[schemars(range(min = 0.0))]
    pub transport_delay_s: f64,
    /// Before the arm acts on a velocity command (s).
    #[schemars(range(min = 0.0))]
    pub command_latency_s: f64,
    /// Time constant of the arm's velocity servos (s).
    #[schemars(range(min = 0.0))]
    pub arm_lag_s: f64,
}

impl Check for LoopDelays {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        check_ranges(&self, key)?;
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

/// PD settings (`force_controller.pd` in the scene files).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PdParams {
    /// The margins the gain keeps on the loop the controller measures (a
    /// task may keep its own: the guided move's).
    pub margins: Margins,
    /// Time constant of the force low-pass feeding the derivative (s).
    #[schemars(range(min = 0.0))]
    pub derivative_filter_s: f64,
    /// Largest speed the law commands (m/s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_speed_mps: f64,
}

impl Check for PdParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        check_ranges(&self, key)?;
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
    margins: Margins,
    /// The product of the factors the watchdog lowered the gain by.
    softened: f64,
    /// The stiffnesses and timing the gain was tuned for.
    tuned: Option<(f64, f64, LoopTiming)>,
    filtered: Option<f64>,
    rate: f64,
}

impl PdAxis {
    /// The law with a deadband (N) and the margins its gain keeps, its
    /// gain zero until [`PdAxis::tune`]d.
    pub fn new(p: &Checked<PdParams>, margins: Margins, deadband_n: f64) -> Self {
        PdAxis {
            gain: 0.0,
            derivative_time_s: 0.0,
            filter_s: p.derivative_filter_s,
            deadband_n,
            max_speed: p.max_speed_mps,
            margins,
            softened: 1.0,
            tuned: None,
            filtered: None,
            rate: 0.0,
        }
    }

    /// Sets the gain and the derivative time for a contact of effective
    /// stiffness `stiffness` (N/m) that may look as stiff as `fast` (N/m)
    /// at the loop's phase crossover ([`gain`]), in a loop of timing `t`; a
    /// change of under 1 % keeps them.
    pub fn tune(&mut self, stiffness: f64, fast: f64, t: &LoopTiming) {
        let near = |a: f64, b: f64| (a - b).abs() <= RETUNE_SHARE * a.abs().max(b.abs());
        if let Some((k, k_fast, old)) = &self.tuned {
            let same = near(*k, stiffness)
                && near(*k_fast, fast)
                && near(old.dead_s(), t.dead_s())
                && near(old.lag_s + 1e-4, t.lag_s + 1e-4);
            if same {
                return;
            }
        }
        self.derivative_time_s = DERIVATIVE_SHARE * t.arm_s();
        self.gain = self.softened
            * gain(
                stiffness,
                fast,
                t,
                self.derivative_time_s,
                self.filter_s,
                &self.margins,
            );
        self.tuned = Some((stiffness, fast, *t));
    }

    /// Takes the settings of `other` (its deadband, speed limit, filter and
    /// margins) and keeps its own state: the filter's, what the watchdog
    /// lowered; other margins retune the gain at the next [`PdAxis::tune`].
    pub fn take_settings(&mut self, other: &PdAxis) {
        if other.margins != self.margins {
            self.tuned = None;
        }
        self.deadband_n = other.deadband_n;
        self.max_speed = other.max_speed;
        self.filter_s = other.filter_s;
        self.margins = other.margins;
    }

    /// Lowers the gain by `factor` (0..1) for the rest of the task (the
    /// stability watchdog).
    pub fn soften(&mut self, factor: f64) {
        self.softened *= factor;
        self.gain *= factor;
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

    fn params() -> Checked<PdParams> {
        PdParams {
            margins: Margins {
                phase_deg: 60.0,
                gain: 2.5,
            },
            derivative_filter_s: 0.01,
            max_speed_mps: 1.0,
        }
        .checked("pd")
        .unwrap()
    }

    /// `n` periods of 10 ms of pure latency in the arm, no lag.
    fn timing(n: usize) -> LoopTiming {
        LoopTiming {
            transport_s: 0.0,
            latency_s: n as f64 * 0.01,
            lag_s: 0.0,
            period_s: 0.01,
        }
    }

    /// Closes the loop on an ideal spring, F = k x, x += u T, the command
    /// acting `delay` periods late; the forces.
    fn settle(pd: &mut PdAxis, k: f64, delay: usize) -> Vec<f64> {
        let t = 0.01;
        let (mut x, mut queue) = (0.0, vec![0.0; delay]);
        let mut forces = Vec::new();
        for _ in 0..400 {
            let f = k * x;
            forces.push(f);
            queue.push(pd.step(1.0, f, t));
            x += queue.remove(0) * t;
        }
        forces
    }

    #[test]
    fn a_tuned_law_settles_without_ringing_on_any_stiffness_and_delay() {
        for k in [50.0, 1e3, 1e5] {
            for delay in [0usize, 2, 4] {
                let mut pd = PdAxis::new(&params(), params().margins, 0.0);
                pd.tune(k, k, &timing(delay));
                let f = settle(&mut pd, k, delay);
                let peak = f.iter().copied().fold(0.0, f64::max);
                assert!(peak < 1.1, "k {k}, {delay} periods: peak {peak}");
                assert!((f[399] - 1.0).abs() < 1e-3, "k {k}, {delay}: {}", f[399]);
            }
        }
    }

    #[test]
    fn the_gain_follows_the_stiffness_and_the_watchdog_lowers_it_for_good() {
        let mut pd = PdAxis::new(&params(), params().margins, 0.0);
        assert_eq!(pd.gain(), 0.0, "untuned");
        pd.tune(1000.0, 1000.0, &timing(2));
        let g = pd.gain();
        pd.tune(1005.0, 1005.0, &timing(2));
        assert_eq!(pd.gain(), g, "a change under 1 % keeps the gain");
        pd.tune(500.0, 500.0, &timing(2));
        assert!((pd.gain() / g - 2.0).abs() < 1e-9, "K ~ 1 / k");
        pd.soften(0.5);
        assert!((pd.gain() / g - 1.0).abs() < 1e-9);
        pd.tune(1000.0, 1000.0, &timing(2));
        assert!(
            (pd.gain() / g - 0.5).abs() < 1e-9,
            "softened after a retune too"
        );
    }

    #[test]
    fn taken_settings_keep_what_the_watchdog_lowered_and_new_margins_retune() {
        let mut pd = PdAxis::new(&params(), params().margins, 0.0);
        pd.tune(1000.0, 1000.0, &timing(2));
        let g = pd.gain();
        pd.soften(0.5);
        let mut p = *params();
        p.max_speed_mps = 0.01;
        let p = p.checked("pd").unwrap();
        // A new deadband and speed limit: the same gain, lowered.
        pd.take_settings(&PdAxis::new(&p, params().margins, 0.3));
        pd.tune(1000.0, 1000.0, &timing(2));
        assert!((pd.gain() / g - 0.5).abs() < 1e-12, "{} vs {g}", pd.gain());
        assert_eq!(pd.step(1.0, 1.25, 0.01), 0.0, "0.25 N within 0.3 N");
        assert_eq!(pd.step(1.0, -5.0, 0.01), 0.01, "clamped at 0.01 m/s");
        // Wider margins: a lower gain, still lowered by the watchdog's half.
        let wide = Margins {
            phase_deg: 70.0,
            gain: 3.0,
        };
        let mut fresh = PdAxis::new(&p, wide, 0.3);
        fresh.tune(1000.0, 1000.0, &timing(2));
        pd.take_settings(&PdAxis::new(&p, wide, 0.3));
        pd.tune(1000.0, 1000.0, &timing(2));
        assert!(fresh.gain() < g);
        assert!((pd.gain() / fresh.gain() - 0.5).abs() < 1e-12);
    }

    #[test]
    fn deadband_and_clamp() {
        let mut p = *params();
        p.max_speed_mps = 0.01;
        let mut pd = PdAxis::new(&p.checked("pd").unwrap(), p.margins, 0.2);
        pd.tune(1e5, 1e5, &timing(0));
        assert_eq!(pd.step(1.0, 0.85, 0.01), 0.0, "inside the deadband");
        let u = pd.step(1.0, 0.7, 0.01);
        assert!((u - 0.1 * pd.gain()).abs() < 1e-12, "width subtracted: {u}");
        assert_eq!(pd.step(10.0, 0.0, 0.01), 0.01, "clamped");
        assert_eq!(pd.step(-10.0, 0.0, 0.01), -0.01, "clamped");
    }

    #[test]
    fn the_derivative_brakes_a_rising_force() {
        let lagged = LoopTiming {
            lag_s: 0.02,
            ..timing(3)
        };
        let mut pd = PdAxis::new(&params(), params().margins, 0.0);
        pd.tune(1e3, 1e3, &lagged);
        assert!((pd.derivative_time_s - 0.025).abs() < 1e-12);
        let mut u = 0.0;
        for k in 0..10 {
            u = pd.step(1.0, 0.05 * k as f64, 0.01);
        }
        let proportional = pd.gain() * (1.0 - 0.45);
        assert!(
            pd.force_rate() > 0.0 && u < proportional,
            "{u} {proportional}"
        );
        let e = PdParams {
            margins: Margins {
                phase_deg: 0.0,
                gain: 2.0,
            },
            ..*params()
        }
        .checked("pd")
        .unwrap_err();
        assert!(e.to_string().contains("pd.margins.phase_deg"), "{e}");
    }
}
