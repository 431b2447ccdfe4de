//! Fixed windows of the newest samples ([`Ring`]), and what the controller
//! measures of the estimates with them: their age when stepped on
//! ([`AgeWindow`]) and how they arrive ([`Arrivals`]), from which it judges
//! when the newest is stale.
//!
//! The stale rule. Over the last 64 arrivals, `r` is the age the newest
//! estimate had reached when the next came (its age on arrival plus the
//! interval), and the stream's period `T` the median interval between
//! arrivals, at least the declared control period (the sensing period: a
//! burst of faster estimates does not shrink it). The newest estimate is
//! stale once older than
//!
//! `r50 + (n - 1) T + min(2 (r99 - r50), T)`
//!
//! with `n` the parameter `stale_periods` (>= 2): its usual age plus `n` of
//! the stream's periods, plus twice the arrival's jitter (at most one
//! period more). A stream of estimates on time, with jitter, never halts;
//! one that stops halts `n` periods after it was due, whatever the arm's
//! cycle. Until 4 intervals are measured, `r` is the `loop_delays`
//! transport bound plus `T`, and `T` the control period.

use super::tuning::LoopTiming;

/// A fixed-capacity ring of the newest `N` items.
#[derive(Debug, Clone, PartialEq)]
pub struct Ring<T: Copy, const N: usize> {
    items: [T; N],
    next: usize,
    len: usize,
}

impl<T: Copy, const N: usize> Ring<T, N> {
    /// An empty ring (`fill` only takes the slots).
    pub fn new(fill: T) -> Self {
        Ring {
            items: [fill; N],
            next: 0,
            len: 0,
        }
    }

    /// Adds the newest item, dropping the oldest when full.
    pub fn push(&mut self, item: T) {
        self.items[self.next] = item;
        self.next = (self.next + 1) % N;
        self.len = (self.len + 1).min(N);
    }

    /// Items held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The `i`-th oldest item.
    pub fn get(&self, i: usize) -> T {
        self.items[(self.next + N - self.len + i) % N]
    }

    /// The newest item.
    pub fn last(&self) -> Option<T> {
        (self.len > 0).then(|| self.get(self.len - 1))
    }

    /// Oldest first.
    pub fn iter(&self) -> impl Iterator<Item = T> + '_ {
        (0..self.len).map(|i| self.get(i))
    }

    /// Forgets everything.
    pub fn clear(&mut self) {
        self.len = 0;
    }
}

impl<const N: usize> Ring<f64, N> {
    /// The `q` quantile (0..1) of the items; None when empty.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        if self.is_empty() {
            return None;
        }
        let mut sorted = [0.0; N];
        let n = self.len;
        for (slot, a) in sorted.iter_mut().zip(self.iter()) {
            *slot = a;
        }
        sorted[..n].sort_unstable_by(f64::total_cmp);
        Some(sorted[((n - 1) as f64 * q).round() as usize])
    }
}

/// Estimates' ages when stepped on, over the last `AGES` steps.
#[derive(Debug, Clone)]
pub struct AgeWindow {
    ages: Ring<f64, AGES>,
}

/// Ages kept.
const AGES: usize = 64;

impl Default for AgeWindow {
    fn default() -> Self {
        AgeWindow {
            ages: Ring::new(0.0),
        }
    }
}

impl AgeWindow {
    /// An estimate `age_s` old when stepped on; not finite: not kept.
    pub fn push(&mut self, age_s: f64) {
        if age_s.is_finite() {
            self.ages.push(age_s.max(0.0));
        }
    }

    /// The `q` quantile (0..1) of the ages kept; None when none is.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        self.ages.quantile(q)
    }
}

/// Arrivals kept.
const ARRIVALS: usize = 64;
/// Intervals measured before their figures replace the priors.
const MIN_ARRIVALS: usize = 4;
/// The stale bound's margin, in spreads of `r` (p99 - p50).
const JITTER_MARGIN: f64 = 2.0;

/// How the estimates arrive, over the last `ARRIVALS`: the intervals
/// between arrivals, and the age the newest estimate had reached when the
/// next one came.
#[derive(Debug, Clone)]
pub struct Arrivals {
    /// The newest arrival: when, and its estimate's stamp (s).
    last: Option<(f64, f64)>,
    intervals: Ring<f64, ARRIVALS>,
    replaced_at: Ring<f64, ARRIVALS>,
}

impl Default for Arrivals {
    fn default() -> Self {
        Arrivals {
            last: None,
            intervals: Ring::new(0.0),
            replaced_at: Ring::new(0.0),
        }
    }
}

impl Arrivals {
    /// The estimate stamped `stamp_s` seen at `now` (s); the one seen last
    /// is not counted again, nor a time that is not finite.
    pub fn on_arrival(&mut self, now: f64, stamp_s: f64) {
        if !(now.is_finite() && stamp_s.is_finite()) {
            return;
        }
        if let Some((t, s)) = self.last {
            if s == stamp_s {
                return;
            }
            self.intervals.push((now - t).max(0.0));
            self.replaced_at.push((now - s).max(0.0));
        }
        self.last = Some((now, stamp_s));
    }

    /// The `q` quantile (0..1) of the intervals between arrivals (s), once
    /// 4 are measured.
    pub fn interval_s(&self, q: f64) -> Option<f64> {
        self.measured(&self.intervals, q)
    }

    fn measured(&self, ring: &Ring<f64, ARRIVALS>, q: f64) -> Option<f64> {
        (ring.len() >= MIN_ARRIVALS)
            .then(|| ring.quantile(q))
            .flatten()
    }

    /// How old the newest estimate may be before the arm halts (s), with
    /// `periods` the stream's periods allowed beyond its usual age (the
    /// module's rule); `prior`: the control period, and the age until
    /// measured.
    pub fn stale_after_s(&self, periods: f64, prior: &LoopTiming) -> f64 {
        let t = self
            .interval_s(0.5)
            .map_or(prior.period_s, |i| i.max(prior.period_s));
        let r = |q| self.measured(&self.replaced_at, q);
        let (r50, r99) = match (r(0.5), r(0.99)) {
            (Some(r50), Some(r99)) => (r50, r99),
            _ => (prior.transport_s + t, prior.transport_s + t),
        };
        r50 + (periods - 1.0) * t + (JITTER_MARGIN * (r99 - r50)).min(t)
    }
}

#[cfg(test)]
mod tests;
