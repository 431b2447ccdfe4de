//! What a peer may send a node: every message has a size bound, and goals
//! and parameter sets a rate. Any process on the DDS domain can publish a
//! 50 MB robot description or an image far beyond the camera's, send
//! goals and set parameters as fast as it likes; the node refuses what
//! exceeds its bound before any work on it (a message by its byte length,
//! before it is decoded), counts it for `/diagnostics` and logs it at most
//! once a second. The ROS adapters ask an [`InputGuard`] first.

use std::sync::Mutex;
use std::time::Instant;

use super::status::{Level, Status};

/// The largest robot description taken (bytes): a URDF names its meshes
/// by file, so a real arm's is tens of kilobytes (the PA10's 9 kB).
pub const DESCRIPTION_MAX_BYTES: usize = 10 << 20;

/// The largest message of any other topic (bytes): a joint state of a
/// hundred joints, a BioTac reading or a wrench is well under it.
pub const MESSAGE_MAX_BYTES: usize = 64 << 10;

/// Bytes per pixel of the widest encoding the nail camera's node reads
/// (rgb8, bgr8).
const IMAGE_BYTES_PER_PIXEL: usize = 3;
/// Padding a camera driver may add at the end of each row (bytes).
const IMAGE_ROW_PADDING: usize = 64;
/// The image message's header, encoding and frame name (bytes).
const IMAGE_HEADER: usize = 4 << 10;

/// The largest `sensor_msgs/Image` of a camera of `width` x `height`
/// pixels (the size a nail model was trained on) in bytes: its pixels in
/// the widest encoding read, each row padded, and the header.
pub fn image_max_bytes(width: usize, height: usize) -> usize {
    width
        .saturating_mul(IMAGE_BYTES_PER_PIXEL)
        .saturating_add(IMAGE_ROW_PADDING)
        .saturating_mul(height)
        .saturating_add(IMAGE_HEADER)
}

/// A rate: `burst` at once, then `per_s` a second.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rate {
    /// What is counted, in the plural.
    pub what: &'static str,
    /// How many may come at once.
    pub burst: u32,
    /// How many a second, sustained.
    pub per_s: f64,
}

/// Goals of a node's actions, together: a guarded move or a calibration
/// runs for seconds, and a new one is refused while one runs.
pub const GOALS: Rate = Rate {
    what: "goals",
    burst: 5,
    per_s: 2.0,
};

/// Parameters set (or checked) while running, each parameter of a request
/// counted: only a few may change while a node runs, and each change may
/// rebuild the controller or load a model.
pub const PARAMETER_SETS: Rate = Rate {
    what: "parameter sets",
    burst: 10,
    per_s: 5.0,
};

/// A token bucket: it holds up to `burst` tokens, gains `per_s` a second,
/// and each admission takes one.
#[derive(Debug, Clone)]
pub struct RateLimit {
    rate: Rate,
    tokens: f64,
    last_s: Option<f64>,
}

impl RateLimit {
    /// A full bucket for `rate`.
    pub fn new(rate: Rate) -> Self {
        RateLimit {
            rate,
            tokens: f64::from(rate.burst),
            last_s: None,
        }
    }

    /// Admits one at `now_s` (s, any monotonic clock), or says in how many
    /// seconds the next would be. A clock that steps back adds nothing.
    pub fn admit(&mut self, now_s: f64) -> Result<(), f64> {
        let last = self.last_s.map_or(now_s, |l| l.max(now_s));
        let gained = (now_s - self.last_s.unwrap_or(now_s)).max(0.0) * self.rate.per_s;
        self.tokens = (self.tokens + gained).min(f64::from(self.rate.burst));
        self.last_s = Some(last);
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            Ok(())
        } else {
            Err((1.0 - self.tokens) / self.rate.per_s)
        }
    }
}

/// Why a message, a goal or a parameter set was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Refusal {
    /// A message over its topic's bound.
    #[error("{topic}: a message of {bytes} bytes, over its bound of {max_bytes} bytes")]
    Oversized {
        /// The topic.
        topic: String,
        /// Its length as received (CDR bytes).
        bytes: usize,
        /// The bound.
        max_bytes: usize,
    },
    /// Over the rate.
    #[error(
        "over the rate: at most {} {} at once and {} a second; the next may come in {retry_s:.2} s",
        .rate.burst, .rate.what, .rate.per_s
    )]
    OverRate {
        /// The rate exceeded.
        rate: Rate,
        /// Seconds until one more would be admitted.
        retry_s: f64,
    },
}

/// What a node refused so far, by kind.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Refused {
    /// Messages over their topic's size bound.
    pub oversized: u64,
    /// Goals over [`GOALS`].
    pub goals: u64,
    /// Parameter sets over [`PARAMETER_SETS`].
    pub parameter_sets: u64,
}

impl Refused {
    fn total(&self) -> u64 {
        self.oversized + self.goals + self.parameter_sets
    }
}

/// A node's bounds on its input: asked before any work on a message, a
/// goal or a parameter set, from any thread. It counts what it refuses and
/// logs a refusal at most once a second (with the counts so far).
#[derive(Debug)]
pub struct InputGuard {
    start: Instant,
    takes_goals: bool,
    state: Mutex<GuardState>,
}

#[derive(Debug)]
struct GuardState {
    goals: RateLimit,
    parameter_sets: RateLimit,
    refused: Refused,
    logged_s: Option<f64>,
}

impl InputGuard {
    /// The guard of a node that takes messages and parameter sets.
    pub fn new() -> Self {
        InputGuard {
            start: Instant::now(),
            takes_goals: false,
            state: Mutex::new(GuardState {
                goals: RateLimit::new(GOALS),
                parameter_sets: RateLimit::new(PARAMETER_SETS),
                refused: Refused::default(),
                logged_s: None,
            }),
        }
    }

    /// The guard of a node that serves actions too.
    pub fn with_goals() -> Self {
        InputGuard {
            takes_goals: true,
            ..InputGuard::new()
        }
    }

    fn state(&self) -> std::sync::MutexGuard<'_, GuardState> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Admits a message of `bytes` on `topic` if it is within `max_bytes`.
    pub fn admit_size(&self, topic: &str, bytes: usize, max_bytes: usize) -> Result<(), Refusal> {
        if bytes <= max_bytes {
            return Ok(());
        }
        let refusal = Refusal::Oversized {
            topic: topic.into(),
            bytes,
            max_bytes,
        };
        let mut s = self.state();
        s.refused.oversized += 1;
        Err(self.said(&mut s, refusal))
    }

    /// Admits a goal within [`GOALS`].
    pub fn admit_goal(&self) -> Result<(), Refusal> {
        self.admit_within(GOALS, |s| (&mut s.goals, &mut s.refused.goals))
    }

    /// Admits a parameter set within [`PARAMETER_SETS`].
    pub fn admit_parameter_set(&self) -> Result<(), Refusal> {
        self.admit_within(PARAMETER_SETS, |s| {
            (&mut s.parameter_sets, &mut s.refused.parameter_sets)
        })
    }

    /// Admits one within `rate`, on the limit and the refusal count `pick`
    /// takes from the state.
    fn admit_within(
        &self,
        rate: Rate,
        pick: fn(&mut GuardState) -> (&mut RateLimit, &mut u64),
    ) -> Result<(), Refusal> {
        let now = self.start.elapsed().as_secs_f64();
        let mut s = self.state();
        let (limit, refused) = pick(&mut s);
        let retry_s = match limit.admit(now) {
            Ok(()) => return Ok(()),
            Err(retry_s) => retry_s,
        };
        *refused += 1;
        Err(self.said(&mut s, Refusal::OverRate { rate, retry_s }))
    }

    /// Logs `refusal` unless a refusal was logged within the last second.
    fn said(&self, s: &mut GuardState, refusal: Refusal) -> Refusal {
        let now = self.start.elapsed().as_secs_f64();
        if s.logged_s.is_none_or(|t| now - t >= 1.0) {
            s.logged_s = Some(now);
            let r = s.refused;
            tracing::warn!(
                "refused {refusal} (refused so far: {} oversized messages, {} goals and {} \
                 parameter sets over their rates; logged at most once a second)",
                r.oversized,
                r.goals,
                r.parameter_sets
            );
        }
        refusal
    }

    /// What was refused so far.
    pub fn refused(&self) -> Refused {
        self.state().refused
    }

    /// Adds the counts to a node's status (goals only for a node that
    /// serves actions), a warning once anything was refused.
    pub fn report(&self, status: &mut Status) {
        let r = self.refused();
        status.value("refused_oversized", r.oversized);
        if self.takes_goals {
            status.value("refused_goals_over_rate", r.goals);
        }
        status.value("refused_parameter_sets_over_rate", r.parameter_sets);
        if r.total() > 0 {
            status.raise(
                Level::Warn,
                &format!("; {} inputs refused by their bounds", r.total()),
            );
        }
    }
}

impl Default for InputGuard {
    fn default() -> Self {
        InputGuard::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_bucket_admits_its_burst_then_its_rate() {
        let mut r = RateLimit::new(GOALS);
        let admitted = (0..20).filter(|_| r.admit(10.0).is_ok()).count();
        assert_eq!(admitted, 5, "the burst at once");
        // One token back after 0.5 s at 2 a second; the next then 0.5 s on.
        let retry = r.admit(10.25).unwrap_err();
        assert!((retry - 0.25).abs() < 1e-9, "{retry}");
        assert!(r.admit(10.5).is_ok());
        assert!((r.admit(10.5).unwrap_err() - 0.5).abs() < 1e-9);
        // A minute of quiet refills the burst, not more.
        let later = (0..20).filter(|_| r.admit(70.0).is_ok()).count();
        assert_eq!(later, 5);
    }

    #[test]
    fn a_steady_stream_is_admitted_at_the_rate_whatever_it_asks() {
        let mut r = RateLimit::new(PARAMETER_SETS);
        // 100 a second for 10 s: the burst, then 5 a second.
        let admitted = (0..1000)
            .filter(|i| r.admit(f64::from(*i) * 0.01).is_ok())
            .count();
        assert!((59..=61).contains(&admitted), "{admitted}");
    }

    #[test]
    fn a_clock_that_steps_back_gains_nothing() {
        let mut r = RateLimit::new(GOALS);
        for _ in 0..5 {
            r.admit(100.0).unwrap();
        }
        assert!(r.admit(50.0).is_err());
        // Back at 100.4 s: 0.4 s after the last time seen, 0.8 of a token.
        assert!(r.admit(100.4).is_err());
        assert!(r.admit(100.6).is_ok());
    }

    #[test]
    fn sizes_over_their_bound_are_refused_with_the_figures_and_counted() {
        let g = InputGuard::new();
        assert!(g
            .admit_size("/robot_description", 9_000, DESCRIPTION_MAX_BYTES)
            .is_ok());
        let at_bound = g.admit_size(
            "/robot_description",
            DESCRIPTION_MAX_BYTES,
            DESCRIPTION_MAX_BYTES,
        );
        assert!(at_bound.is_ok());
        let e = g
            .admit_size("/robot_description", 50 << 20, DESCRIPTION_MAX_BYTES)
            .unwrap_err()
            .to_string();
        assert_eq!(
            e,
            "/robot_description: a message of 52428800 bytes, over its bound of 10485760 bytes"
        );
        assert_eq!(g.refused().oversized, 1);
    }

    #[test]
    fn an_image_is_bounded_by_its_camera_in_the_widest_encoding() {
        // The simulated nail camera's 96 x 104 frames.
        let max = image_max_bytes(96, 104);
        assert_eq!(max, (96 * 3 + 64) * 104 + 4096);
        assert!(
            max >= 96 * 104 * 3 + 104 * 64,
            "rgb8 rows padded to 64 bytes fit"
        );
        assert!(max < 2 * 96 * 104 * 3, "twice the pixels do not");
        assert_eq!(image_max_bytes(usize::MAX, 2), usize::MAX);
    }

    #[test]
    fn goals_and_parameter_sets_over_their_rates_are_refused_with_the_rate() {
        let g = InputGuard::with_goals();
        let goals: Vec<_> = (0..20).map(|_| g.admit_goal()).collect();
        assert_eq!(goals.iter().filter(|r| r.is_ok()).count(), 5);
        let why = goals[19].as_ref().unwrap_err().to_string();
        assert!(
            why.starts_with(
                "over the rate: at most 5 goals at once and 2 a second; the next may come in 0."
            ),
            "{why}"
        );
        let sets = (0..30).filter(|_| g.admit_parameter_set().is_err()).count();
        assert_eq!(sets, 20);
        assert_eq!(
            g.refused(),
            Refused {
                oversized: 0,
                goals: 15,
                parameter_sets: 20
            }
        );
    }

    #[test]
    fn the_status_carries_the_counts_and_warns_once_any_was_refused() {
        let quiet = InputGuard::new();
        let mut s = Status::ok("estimating");
        quiet.report(&mut s);
        assert_eq!(s.level, Level::Ok);
        assert_eq!(
            s.values,
            [
                ("refused_oversized".to_string(), "0".to_string()),
                ("refused_parameter_sets_over_rate".into(), "0".into()),
            ]
        );
        let g = InputGuard::with_goals();
        let _ = g.admit_size("camera/image", 100, 10);
        let mut s = Status::ok("hold");
        g.report(&mut s);
        assert_eq!(s.level, Level::Warn);
        assert_eq!(s.message, "hold; 1 inputs refused by their bounds");
        let value = |k: &str| {
            s.values
                .iter()
                .find(|(n, _)| n == k)
                .map(|(_, v)| v.as_str())
        };
        assert_eq!(value("refused_oversized"), Some("1"));
        assert_eq!(value("refused_goals_over_rate"), Some("0"));
    }
}
