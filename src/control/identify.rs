//! What the controller measures of its loop while it runs, so that nobody
//! has to declare it:
//!
//! - [`ArmTrack`]: the BioTac's commanded velocity and its position (from
//!   `joint_states`), recent enough to fit the arm's response: a pure
//!   latency `L` then a first-order lag `tau`,
//!   `tau dv/dt = v_cmd(t - L) - v`, by least squares on the positions
//!   (grid search, coarse then fine), whenever the commands vary enough;
//!   and the position at any recent time (a reading's stamp);
//! - [`LoopMeter`]: the loop's timing from it and the estimates' ages
//!   and arrivals (src/control/window.rs), and how late an estimate may be
//!   before the arm halts;
//! - [`ContactStiffness`]: force against the approach in contact. The
//!   BioTac's skin, `x_s(F) = x0 ln(1 + F / A)` (src/contact.rs), is in
//!   series with an unknown body of compliance `c = 1 / k`, so the
//!   position along the approach is `x = x_c + x_s(F) + c F`: a line in `F`
//!   whose slope, fitted over a sliding window, is `c`. Each sample is the
//!   mean of 40 ms of readings (a body with mass rings against the skin;
//!   the line is the quasi-static part), and a window far from a line is
//!   no fit.
//!
//! Buffers are fixed at construction: nothing here allocates while the
//! controller runs.

use nalgebra::Vector3;

use super::tuning::LoopTiming;
use super::window::{AgeWindow, Arrivals, Ring};
use crate::contact::SkinParams;

/// The arm's response to a velocity command.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmResponse {
    /// Pure latency (s).
    pub latency_s: f64,
    /// Time constant of the velocity lag (s).
    pub lag_s: f64,
    /// Share of the positions' motion the fit explains (0..1).
    pub r2: f64,
}

/// Positions kept (spaced at least [`POSITION_SPACING_S`]).
const POSITIONS: usize = 128;
/// Commands kept.
const COMMANDS: usize = 128;
/// The span of a velocity from positions (s).
const VELOCITY_SPAN_S: f64 = 0.02;
/// Closer positions are not kept (s): a fast joint_states stream.
const POSITION_SPACING_S: f64 = 0.004;
/// The window a fit reads (s).
const FIT_WINDOW_S: f64 = 0.4;
/// Largest latency and lag a fit considers (s).
const MAX_LATENCY_S: f64 = 0.1;
const MAX_LAG_S: f64 = 0.08;
/// Least motion a fit needs (m).
const MIN_TRAVEL_M: f64 = 3e-4;
/// Least share of the motion's changes a fit must explain.
const MIN_R2: f64 = 0.8;
/// Least change of the commanded velocity in a fit's window (m/s).
const MIN_SPEED_CHANGE_MPS: f64 = 0.002;

/// The BioTac's recent commands and positions (base frame).
#[derive(Debug, Clone)]
pub struct ArmTrack {
    positions: Ring<(f64, Vector3<f64>), POSITIONS>,
    commands: Ring<(f64, Vector3<f64>), COMMANDS>,
}

impl Default for ArmTrack {
    fn default() -> Self {
        ArmTrack {
            positions: Ring::new((0.0, Vector3::zeros())),
            commands: Ring::new((0.0, Vector3::zeros())),
        }
    }
}

impl ArmTrack {
    /// The BioTac's position `p` (m) measured at `t` (s).
    pub fn on_position(&mut self, t: f64, p: Vector3<f64>) {
        match self.positions.last() {
            Some((last, _)) if t < last + POSITION_SPACING_S => {}
            _ => self.positions.push((t, p)),
        }
    }

    /// The BioTac's velocity `v` (m/s) commanded at `t` (s).
    pub fn on_command(&mut self, t: f64, v: Vector3<f64>) {
        self.commands.push((t, v));
    }

    /// Forgets the history (a new task, or a pause in the inputs).
    pub fn clear(&mut self) {
        self.positions.clear();
        self.commands.clear();
    }

    /// The position at `t`, interpolated between the two measured around
    /// it; None outside what is kept.
    pub fn position_at(&self, t: f64) -> Option<Vector3<f64>> {
        let n = self.positions.len();
        let (t_last, p_last) = self.positions.last()?;
        if t >= t_last {
            return (t - t_last <= POSITION_SPACING_S * 2.0).then_some(p_last);
        }
        for i in (0..n.saturating_sub(1)).rev() {
            let ((t0, p0), (t1, p1)) = (self.positions.get(i), self.positions.get(i + 1));
            if t0 <= t {
                let f = if t1 > t0 { (t - t0) / (t1 - t0) } else { 0.0 };
                return Some(p0 + (p1 - p0) * f);
            }
        }
        None
    }

    /// The velocity at `t`, from the positions `VELOCITY_SPAN_S` apart
    /// that end there; None outside what is kept.
    pub fn velocity_at(&self, t: f64) -> Option<Vector3<f64>> {
        let (p1, p0) = (self.position_at(t)?, self.position_at(t - VELOCITY_SPAN_S)?);
        Some((p1 - p0) / VELOCITY_SPAN_S)
    }

    /// The arm's latency and lag fitted on the last `FIT_WINDOW_S`, when
    /// the commands moved the arm enough and the fit explains most of it.
    pub fn fit(&self) -> Option<ArmResponse> {
        let (t_end, _) = self.positions.last()?;
        let from = t_end - FIT_WINDOW_S;
        let first = self.positions.iter().position(|(t, _)| t >= from)?;
        let oldest_command = self.commands.get(0).0;
        // The lag's state is simulated from the oldest command: the window
        // starts well after it.
        if self.commands.is_empty() || oldest_command > from - MAX_LATENCY_S - MAX_LAG_S {
            return None;
        }
        let steps = self.positions.len() - first - 1;
        let (mut travel, mut total) = (0.0, 0.0);
        let mean = (self.positions.get(self.positions.len() - 1).1 - self.positions.get(first).1)
            / steps.max(1) as f64;
        for j in first..self.positions.len() - 1 {
            let d = self.positions.get(j + 1).1 - self.positions.get(j).1;
            travel += d.norm();
            total += (d - mean).norm_squared();
        }
        // A steady motion shows no delay: the commands must change within
        // the window, early enough that the positions show the response
        // (a change before it, its response over, fits any delay).
        let (lo, hi) = self
            .commands
            .iter()
            .filter(|(t, _)| (from..=t_end - MAX_LATENCY_S).contains(t))
            .fold(
                (
                    Vector3::repeat(f64::INFINITY),
                    Vector3::repeat(f64::NEG_INFINITY),
                ),
                |(lo, hi), (_, v)| (lo.inf(&v), hi.sup(&v)),
            );
        if steps < 8 || travel < MIN_TRAVEL_M || (hi - lo).norm() < MIN_SPEED_CHANGE_MPS {
            return None;
        }
        // Coarse, then fine around the best.
        let mut best = (f64::INFINITY, 0.0, 0.0);
        for (l0, tau0, step, n) in [(0.0, 0.0, 0.004, 26), (f64::NAN, f64::NAN, 0.001, 9)] {
            let (l0, tau0) = if l0.is_nan() {
                (best.1 - 0.004, best.2 - 0.004)
            } else {
                (l0, tau0)
            };
            for i in 0..n {
                for k in 0..n {
                    let (l, tau) = (l0 + i as f64 * step, tau0 + k as f64 * step);
                    if !(0.0..=MAX_LATENCY_S).contains(&l) || !(0.0..=MAX_LAG_S).contains(&tau) {
                        continue;
                    }
                    let e = self.residual(first, l, tau);
                    if e < best.0 {
                        best = (e, l, tau);
                    }
                }
            }
        }
        let r2 = 1.0 - best.0 / total.max(f64::MIN_POSITIVE);
        (r2 >= MIN_R2).then_some(ArmResponse {
            latency_s: best.1,
            lag_s: best.2,
            r2,
        })
    }

    /// Sum of squared differences between the measured displacements from
    /// position `first` on and those the model (latency `l`, lag `tau`)
    /// predicts from the commands.
    fn residual(&self, first: usize, l: f64, tau: f64) -> f64 {
        let (mut t, mut v) = (self.commands.get(0).0 + l, self.commands.get(0).1);
        let mut c = 0; // the command acting from t on: commands[c]
        let mut moved = Vector3::zeros();
        let mut err = 0.0;
        let at = |t1: f64,
                  t: &mut f64,
                  v: &mut Vector3<f64>,
                  c: &mut usize,
                  moved: &mut Vector3<f64>| {
            while *t < t1 {
                let next = if *c + 1 < self.commands.len() {
                    self.commands.get(*c + 1).0 + l
                } else {
                    f64::INFINITY
                };
                let until = next.min(t1);
                let u = self.commands.get(*c).1;
                let dt = until - *t;
                if tau > 0.0 {
                    let decay = (-dt / tau).exp();
                    *moved += u * dt + (*v - u) * tau * (1.0 - decay);
                    *v = u + (*v - u) * decay;
                } else {
                    *moved += u * dt;
                    *v = u;
                }
                *t = until;
                if until == next {
                    *c += 1;
                }
            }
        };
        let (t_first, _) = self.positions.get(first);
        at(t_first, &mut t, &mut v, &mut c, &mut moved);
        for j in first..self.positions.len() - 1 {
            let ((_, p0), (t1, p1)) = (self.positions.get(j), self.positions.get(j + 1));
            moved = Vector3::zeros();
            at(t1, &mut t, &mut v, &mut c, &mut moved);
            err += ((p1 - p0) - moved).norm_squared();
        }
        err
    }
}

/// Samples of the stiffness fit.
const CONTACT_SAMPLES: usize = 24;
/// Least spread of the force in the window for a fit (N), and least
/// samples (two more than the line's parameters, for its residual).
const MIN_FORCE_SPREAD_N: f64 = 0.1;
const MIN_SAMPLES: usize = 4;
/// The span (s) a guarded move's samples average the readings over: a
/// cycle of the 25 Hz at which a 50 g plate rings between the skin and its
/// spring, so that the fit sees the quasi-static force, not the ring.
pub const SAMPLE_SPAN_S: f64 = 0.04;
/// A sample joins the window once the BioTac moved this far (m) or the
/// force changed this much (N, six times a 5 mN estimate noise) since the
/// last that joined: a slow press into a soft body still spans the force.
const SAMPLE_STEP_M: f64 = 2.5e-4;
const SAMPLE_STEP_N: f64 = 0.03;
/// A window whose forces stray from its line by more than this (N, rms)
/// is no spring: the fit is rejected and the last one stands.
const MAX_RESIDUAL_N: f64 = 0.1;

/// The compliance of the body the BioTac presses, from force against
/// position along the approach.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactStiffness {
    skin: SkinParams,
    /// The span each sample averages (s).
    span_s: f64,
    samples: Ring<(f64, f64), CONTACT_SAMPLES>,
    /// The readings of the sample being averaged: time, sum of positions
    /// and forces, count.
    block: (f64, f64, f64, u32),
    /// The position and force of the last sample that joined (m, N).
    last: Option<(f64, f64)>,
    /// The line fitted last: a point on it (N, m) and its slope, the
    /// body's compliance (m/N; below 0 where the skin is not quite its
    /// law).
    line: Option<(f64, f64, f64)>,
}

impl ContactStiffness {
    /// A fit through the BioTac's `skin`, each sample the mean of the
    /// readings over `span_s` (0: each reading).
    pub fn new(skin: SkinParams, span_s: f64) -> Self {
        ContactStiffness {
            skin,
            span_s,
            samples: Ring::new((0.0, 0.0)),
            block: (0.0, 0.0, 0.0, 0),
            last: None,
            line: None,
        }
    }

    /// Takes the position along the approach `x` (m) at the reading whose
    /// pressing force is `f` (N), in contact, `dt` (s) after the reading
    /// before; averages the readings over the span, and keeps
    /// their mean when it moved or pressed enough since the last it kept;
    /// refits when the window's forces spread enough. The body's stiffness
    /// when (re)fitted and the fit stands.
    pub fn push(&mut self, dt: f64, x: f64, f: f64) -> Option<f64> {
        if !(x.is_finite() && f.is_finite() && f > 0.0 && dt.is_finite()) {
            return None;
        }
        let (span, sx, sf, n) = self.block;
        self.block = (span + dt.max(0.0), sx + x, sf + f, n + 1);
        let (span, sx, sf, n) = self.block;
        if span < self.span_s {
            return None;
        }
        self.block = (0.0, 0.0, 0.0, 0);
        let (x, f) = (sx / f64::from(n), sf / f64::from(n));
        if let Some((x1, f1)) = self.last {
            if (x - x1).abs() < SAMPLE_STEP_M && (f - f1).abs() < SAMPLE_STEP_N {
                return None;
            }
        }
        self.last = Some((x, f));
        let y = x - self.skin_squeeze(f);
        self.samples.push((f, y));
        tracing::trace!("stiffness sample: x {x:.6} m, f {f:.4} N, y {y:.6} m");
        let (lo, hi) = self
            .samples
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), (f, _)| {
                (lo.min(f), hi.max(f))
            });
        if hi - lo < MIN_FORCE_SPREAD_N || self.samples.len() < MIN_SAMPLES {
            return None;
        }
        let (c, (mf, my), residual_n) = self.line();
        if residual_n > MAX_RESIDUAL_N {
            tracing::debug!(
                "stiffness fit rejected: the forces stray {residual_n:.3} N rms from a spring"
            );
            return None;
        }
        // A negative compliance is noise on a rigid body.
        let k = if c > 1e-7 { 1.0 / c } else { f64::INFINITY };
        tracing::trace!("stiffness fit: body {k:.1} N/m");
        self.line = Some((mf, my, c));
        Some(k)
    }

    /// The skin's squeeze at force `f` (m).
    fn skin_squeeze(&self, f: f64) -> f64 {
        self.skin.length_scale_mm * 1e-3 * (f / self.skin.force_scale_n).ln_1p()
    }

    /// The window's line `y = y0 + c f` by least squares: the compliance
    /// `c` (m/N), the samples' mean (N, m) and the rms of their distance
    /// from it along the force (N), through the local stiffness of skin and
    /// body in series.
    fn line(&self) -> (f64, (f64, f64), f64) {
        let n = self.samples.len() as f64;
        let (mf, my) = self
            .samples
            .iter()
            .fold((0.0, 0.0), |(a, b), (f, y)| (a + f / n, b + y / n));
        let (sfy, sff) = self.samples.iter().fold((0.0, 0.0), |(a, b), (f, y)| {
            (a + (f - mf) * (y - my), b + (f - mf).powi(2))
        });
        let c = sfy / sff;
        let compliance = 1.0 / self.skin.stiffness_at(mf) + c.max(0.0);
        let sq = self
            .samples
            .iter()
            .map(|(f, y)| (y - my - c * (f - mf)).powi(2))
            .sum::<f64>();
        (c, (mf, my), (sq / (n - 2.0)).sqrt() / compliance)
    }

    /// The body's stiffness (N/m; infinite: rigid), once fitted.
    pub fn body(&self) -> Option<f64> {
        let (_, _, c) = self.line?;
        Some(if c > 1e-7 { 1.0 / c } else { f64::INFINITY })
    }

    /// Where along the approach the pressing force is `f` (m), by the last
    /// fit: its line as fitted, and the skin's squeeze at `f`.
    pub fn position_of(&self, f: f64) -> Option<f64> {
        let (mf, my, c) = self.line?;
        Some(my + c * (f - mf) + self.skin_squeeze(f))
    }

    /// The stiffness of skin and body in series at force `f` (N/m), with
    /// `prior` (N/m) for the body until it is fitted.
    pub fn effective(&self, f: f64, prior: f64) -> f64 {
        let body = self.body().unwrap_or(prior);
        1.0 / (1.0 / self.skin.stiffness_at(f) + 1.0 / body)
    }
}

/// Steps between two fits of the arm's response.
const FIT_EVERY: usize = 25;

/// The loop's timing as the controller measures it: the estimates' ages
/// (their 90th percentile), the arm's latency and lag (the last fit that
/// explained the motion); the bounds of `loop_delays` until measured.
#[derive(Debug, Clone)]
pub struct LoopMeter {
    prior: LoopTiming,
    track: ArmTrack,
    ages: AgeWindow,
    arrivals: Arrivals,
    arm: Option<ArmResponse>,
    since_fit: usize,
    timing: LoopTiming,
}

impl LoopMeter {
    /// A meter that assumes `prior` until it has measured.
    pub fn new(prior: LoopTiming) -> Self {
        LoopMeter {
            prior,
            track: ArmTrack::default(),
            ages: AgeWindow::default(),
            arrivals: Arrivals::default(),
            arm: None,
            since_fit: 0,
            timing: prior,
        }
    }

    /// The BioTac's position `p` measured at `t`.
    pub fn on_position(&mut self, t: f64, p: Vector3<f64>) {
        self.track.on_position(t, p);
    }

    /// A control step at `now` commanding the BioTac's velocity `v` (base
    /// frame), on an estimate `age_s` old when it is a new one.
    pub fn on_step(&mut self, now: f64, v: Vector3<f64>, age_s: Option<f64>) {
        self.track.on_command(now, v);
        if let Some(age) = age_s {
            self.ages.push(age);
        }
        self.since_fit += 1;
        if self.since_fit >= FIT_EVERY {
            self.since_fit = 0;
            if let Some(fit) = self.track.fit() {
                self.arm = Some(fit);
            }
        }
        self.timing = LoopTiming {
            transport_s: self.ages.quantile(0.9).unwrap_or(self.prior.transport_s),
            latency_s: self.arm.map_or(self.prior.latency_s, |a| a.latency_s),
            lag_s: self.arm.map_or(self.prior.lag_s, |a| a.lag_s),
            period_s: self.prior.period_s,
        };
    }

    /// Goes on from what `before` measured of the same arm and link (the
    /// controller a goal replaces): its history, so that the step from
    /// rest to the approach speed at a goal's start is fitted, and its fit.
    pub fn carry_on(&mut self, before: &LoopMeter) {
        self.track = before.track.clone();
        self.ages = before.ages.clone();
        self.arrivals = before.arrivals.clone();
        self.arm = before.arm;
    }

    /// The timing as measured so far.
    pub fn timing(&self) -> &LoopTiming {
        &self.timing
    }

    /// The arm's response, once fitted.
    pub fn arm(&self) -> Option<ArmResponse> {
        self.arm
    }

    /// The BioTac's position at `t`, when recent.
    pub fn position_at(&self, t: f64) -> Option<Vector3<f64>> {
        self.track.position_at(t)
    }

    /// The BioTac's velocity at `t`, when recent.
    pub fn velocity_at(&self, t: f64) -> Option<Vector3<f64>> {
        self.track.velocity_at(t)
    }

    /// An estimate stamped `stamp_s` seen at `now` (s).
    pub fn on_arrival(&mut self, now: f64, stamp_s: f64) {
        self.arrivals.on_arrival(now, stamp_s);
    }

    /// How the estimates arrive.
    pub fn arrivals(&self) -> &Arrivals {
        &self.arrivals
    }

    /// How old the newest estimate may be before the arm halts (s): its
    /// usual age and `periods` of the stream's own (src/control/window.rs).
    pub fn stale_after_s(&self, periods: f64) -> f64 {
        self.arrivals.stale_after_s(periods, &self.prior)
    }
}

#[cfg(test)]
mod tests;
