//! Safety checks of the controller: an input older than a few sensor periods,
//! or one that is not finite, stops the arm (zero joint velocities) until a
//! fresh, finite one arrives (MoveIt Servo halts on a stale command; FZI's
//! controller drops NaN wrenches: architecture page, "anchors' safety habits").

use crate::kinematics::KinematicsError;

/// Why the controller commands zero velocity this cycle.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Halt {
    /// No input of this kind received yet.
    #[error("no {0} received yet")]
    Missing(&'static str),
    /// The newest input is too old.
    #[error("{what} is stale: {age_s:.3} s old, limit {max_age_s:.3} s")]
    Stale {
        /// Which input.
        what: &'static str,
        /// Its age (s).
        age_s: f64,
        /// The limit (s).
        max_age_s: f64,
    },
    /// An input held NaN or infinity and was rejected.
    #[error("{0} is not finite")]
    NonFinite(&'static str),
    /// A joint state with another number of joints than the arm's.
    #[error("the joint state has {found} positions, the arm {expected} joints")]
    JointCount {
        /// The arm's joints.
        expected: usize,
        /// Positions received.
        found: usize,
    },
    /// The inverse kinematics refused the motion.
    #[error("inverse kinematics: {0}")]
    Kinematics(#[from] KinematicsError),
}

/// Rejects inputs older than `max_age_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Watchdog {
    max_age_s: f64,
}

impl Watchdog {
    /// A watchdog allowing `periods` sensor periods of `period_s` seconds.
    pub fn new(periods: f64, period_s: f64) -> Self {
        // A hair above the limit so an input exactly `periods` old passes
        // despite rounding of the clock.
        Watchdog {
            max_age_s: periods * period_s * (1.0 + 1e-9),
        }
    }

    /// A watchdog allowing `max_age_s` seconds.
    pub fn seconds(max_age_s: f64) -> Self {
        Watchdog {
            max_age_s: max_age_s * (1.0 + 1e-9),
        }
    }

    /// Ok when `stamp` (s) is at most the limit older than `now` (s).
    pub fn check(&self, what: &'static str, now: f64, stamp: Option<f64>) -> Result<(), Halt> {
        let stamp = stamp.ok_or(Halt::Missing(what))?;
        self.check_age(what, now - stamp)
    }

    /// Ok when `age_s` (s) is at most the limit.
    pub fn check_age(&self, what: &'static str, age_s: f64) -> Result<(), Halt> {
        // A NaN age fails this test too.
        if age_s <= self.max_age_s {
            Ok(())
        } else {
            Err(Halt::Stale {
                what,
                age_s,
                max_age_s: self.max_age_s,
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_periods_pass_a_fourth_halts() {
        let w = Watchdog::new(3.0, 0.01);
        assert!(w.check("estimate", 1.03, Some(1.0)).is_ok());
        let err = w.check("estimate", 1.0301, Some(1.0)).unwrap_err();
        assert!(matches!(err, Halt::Stale { .. }), "{err}");
        assert_eq!(
            w.check("estimate", 1.0, None),
            Err(Halt::Missing("estimate"))
        );
        assert!(w.check("estimate", f64::NAN, Some(1.0)).is_err());
    }
}
