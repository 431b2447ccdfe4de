//! The delay the force loop actually sees, from header stamps: how old each
//! estimate's reading is when the controller steps on it, against what its
//! gains and safety envelope assume (`loop_delays.transport_delay_s`).

/// Delays of the steps since the last report.
#[derive(Debug, Clone)]
pub struct LoopDelayMonitor {
    assumed_s: f64,
    delays_s: Vec<f64>,
}

/// The delays over one reporting window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopDelayReport {
    /// Steps measured.
    pub steps: usize,
    /// Median delay (s).
    pub p50_s: f64,
    /// 99th percentile (s).
    pub p99_s: f64,
    /// Largest (s).
    pub max_s: f64,
    /// What the gains assume (s).
    pub assumed_s: f64,
}

impl LoopDelayReport {
    /// True when the 99th percentile is beyond what the gains assume: the
    /// loop may ring, and the safety envelope is too generous.
    pub fn exceeds_assumed(&self) -> bool {
        self.p99_s > self.assumed_s
    }
}

impl LoopDelayMonitor {
    /// A monitor for gains that assume `assumed_s` of delay.
    pub fn new(assumed_s: f64) -> Self {
        LoopDelayMonitor {
            assumed_s,
            delays_s: Vec::new(),
        }
    }

    /// A step at `now_s` on the reading stamped `stamp_s` (same clock).
    /// Non-finite delays are not recorded (the watchdog handles them).
    pub fn record(&mut self, stamp_s: f64, now_s: f64) {
        let d = now_s - stamp_s;
        if d.is_finite() {
            self.delays_s.push(d);
        }
    }

    /// The window's figures, and a new window; None if nothing was recorded.
    pub fn take_report(&mut self) -> Option<LoopDelayReport> {
        let mut d = std::mem::take(&mut self.delays_s);
        if d.is_empty() {
            return None;
        }
        d.sort_by(f64::total_cmp);
        let at = |q: f64| d[((d.len() - 1) as f64 * q).round() as usize];
        Some(LoopDelayReport {
            steps: d.len(),
            p50_s: at(0.5),
            p99_s: at(0.99),
            max_s: d[d.len() - 1],
            assumed_s: self.assumed_s,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percentiles_over_a_window_and_the_assumption_checked() {
        let mut m = LoopDelayMonitor::new(0.01);
        assert_eq!(m.take_report(), None);
        for i in 0..100 {
            // 1..100 ms after the stamp.
            m.record(5.0, 5.0 + (i + 1) as f64 * 1e-3);
        }
        m.record(f64::NAN, 5.0);
        let r = m.take_report().unwrap();
        assert_eq!(r.steps, 100);
        assert!((r.p50_s - 0.051).abs() < 1e-9 && (r.p99_s - 0.099).abs() < 1e-9);
        assert!((r.max_s - 0.1).abs() < 1e-9 && r.exceeds_assumed());
        m.record(5.0, 5.002);
        let r = m.take_report().unwrap();
        assert!(r.steps == 1 && !r.exceeds_assumed());
    }
}
