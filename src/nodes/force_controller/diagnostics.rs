//! The `force_controller` node's status on `/diagnostics`: the task, the
//! robot, the phase and a halt; the loop as measured (the estimates' age
//! and arrival, the stale bound and the halts it caused, the arm's
//! response, the gains); the loop delay against what the gains assume;
//! what its input guard refused.

use super::ForceControllerNode;
use crate::control::ForceController;
use crate::nodes::lifecycle::State;
use crate::nodes::status::{Level, Status};

impl ForceControllerNode {
    /// The topics the node takes.
    pub const INPUTS: [&'static str; 4] = [
        "biotac/wrench_estimate",
        "ft_sensor/wrench",
        "joint_states",
        "biotac/readings",
    ];

    /// True when the node needs messages on `topic` now (a silent one is
    /// named): the estimate and the joint states while configured; the
    /// F/T wrench and the BioTac readings while a calibration records.
    pub fn needs(&self, topic: &str) -> bool {
        if !matches!(self.state, State::Inactive | State::Active) {
            return false;
        }
        match topic {
            "ft_sensor/wrench" | "biotac/readings" => self.calibration.is_some(),
            "joint_states" => self.arm.is_some(),
            other => Self::INPUTS.contains(&other),
        }
    }

    /// The node's status: task, robot, phase, halt, the loop
    /// delay it sees against what the gains assume (warned once when it
    /// goes beyond, and once when it is back), messages refused.
    pub fn status(&mut self) -> Status {
        let mut s = Status::ok(self.task.clone());
        s.value("task", &self.task);
        s.value("lifecycle", self.state.label());
        if self.state != State::Active {
            s.raise(
                Level::Ok,
                &format!(", {}: commanding nothing", self.state.label()),
            );
        }
        if !self.asked {
            s.raise(Level::Ok, ", waiting to be asked (a goal or task set)");
        }
        match &self.arm {
            Some(a) => s.value("robot", &a.robot.name),
            None => s.raise(Level::Warn, ", waiting for the robot description"),
        }
        if let Some(out) = &self.last {
            s.value("phase", out.phase.name());
            s.raise(Level::Ok, &format!(", {}", out.phase.name()));
            if let Some(h) = &out.halt {
                s.raise(Level::Warn, &format!(", halted: {h}"));
                s.value("halt", h);
            }
        }
        if let Some(c) = &self.controller {
            loop_values(&mut s, c, self.stale_halts);
        }
        self.delay_values(&mut s);
        s.value("rejected", self.rejected);
        if let Some(set) = &self.live_set {
            s.value("last_parameter_set", set);
        }
        for m in self.frames.refused() {
            s.raise(Level::Error, &format!("; {m}"));
            s.push(format!("frame_refused {}", m.topic), m.to_string());
        }
        self.guard.report(&mut s);
        s
    }

    /// The loop delay's report, when one is due, against the bound the
    /// gains assume: warned once when it goes beyond and once when back.
    fn delay_values(&mut self, s: &mut Status) {
        if let Some(r) = self.delays.take_report() {
            let ms = |v: f64| format!("{:.2}", v * 1e3);
            s.value("loop_delay_steps", r.steps);
            s.value("loop_delay_p50_ms", ms(r.p50_s));
            s.value("loop_delay_p99_ms", ms(r.p99_s));
            s.value("loop_delay_max_ms", ms(r.max_s));
            s.value("loop_delay_bound_ms", ms(r.assumed_s));
            if r.exceeds_assumed() {
                s.raise(Level::Warn, "; estimates older than loop_delays bounds");
            }
            if r.exceeds_assumed() != self.delay_warned {
                self.delay_warned = r.exceeds_assumed();
                if self.delay_warned {
                    tracing::warn!(
                        "estimates are {:.1} ms old (p99) when stepped on, beyond the {:.1} ms \
                         bound the safety envelope assumes (loop_delays.transport_delay_s): an \
                         approach slows by the share its loop is slower; raise the bound to \
                         this deployment's delay",
                        r.p99_s * 1e3,
                        r.assumed_s * 1e3
                    );
                } else {
                    tracing::info!("estimates back within the loop_delays bound");
                }
            }
        }
    }
}

/// The loop as `c` measures it: the estimates' age and arrival, the stale
/// bound and its `stale_halts`, the arm's response, the gains and the
/// contact's stiffness, a gain lowered.
fn loop_values(s: &mut Status, c: &ForceController, stale_halts: u64) {
    let ms = |v: f64| format!("{:.1}", v * 1e3);
    let t = c.timing();
    s.value("transport_ms", ms(t.transport_s));
    s.value("arm_latency_ms", ms(t.latency_s));
    s.value("arm_lag_ms", ms(t.lag_s));
    s.value("arm_fitted", c.arm_response().is_some());
    s.value("stale_after_ms", ms(c.stale_after_s()));
    for (q, name) in [
        (0.5, "estimate_interval_p50_ms"),
        (0.99, "estimate_interval_p99_ms"),
    ] {
        if let Some(i) = c.arrivals().interval_s(q) {
            s.value(name, ms(i));
        }
    }
    s.value("stale_halts", stale_halts);
    let f = c.task().figures();
    let axes = ["x", "y", "z"];
    for (i, g) in c.gains().iter().enumerate() {
        if let Some(g) = g {
            s.push(
                format!("gain_{}_mm_s_per_n", axes[i]),
                format!("{:.2}", g * 1e3),
            );
        }
    }
    for (i, k) in f.stiffness_n_per_m.iter().enumerate() {
        if let Some(k) = k {
            s.push(format!("stiffness_{}_n_per_m", axes[i]), format!("{k:.0}"));
        }
    }
    for (name, value) in &f.own {
        s.value(name, value);
    }
    if f.softened > 0 {
        s.raise(
            Level::Warn,
            &format!(
                "; gain lowered {} time(s): the force oscillated",
                f.softened
            ),
        );
        s.value("gain_lowered", f.softened);
    }
}
