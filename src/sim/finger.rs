//! A person's fingertip for the guided move: a scripted path of waits,
//! straight pushes and circles, each move with a minimum-jerk profile
//! `s(u) = 10 u^3 - 15 u^4 + 6 u^5` (Flash & Hogan 1985), whose peak speed is
//! 1.875 x the mean speed. Offsets are in metres in the BioTac frame at the
//! start of the run.

use std::str::FromStr;

use nalgebra::Vector3;
use serde::Deserialize;

use crate::params::ParamsError;
use crate::params::{invalid, positive};

/// Peak over mean speed of the minimum-jerk profile.
const MIN_JERK_PEAK: f64 = 1.875;

/// One segment of the path. In a scene file each is a string (ROS 2
/// parameters hold arrays of strings, not of maps): `"wait S"` (seconds),
/// `"push DX DY DZ V"` (mm, peak speed m/s), `"circle R V"` (radius mm, peak
/// speed m/s).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(try_from = "String")]
pub enum Segment {
    /// Stay still for this long (s).
    Wait(f64),
    /// Push along a displacement (mm) with a peak speed (m/s).
    Push {
        /// Displacement (mm, BioTac frame at the start).
        mm: [f64; 3],
        /// Peak speed (m/s).
        peak_speed_mps: f64,
    },
    /// A circle in the x-y plane starting and ending at the current point.
    Circle {
        /// Radius (mm).
        radius_mm: f64,
        /// Peak speed along the circle (m/s).
        peak_speed_mps: f64,
    },
}

impl FromStr for Segment {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        let mut words = text.split_whitespace();
        let kind = words.next().unwrap_or("");
        let numbers: Vec<f64> = words
            .map(|w| {
                w.parse()
                    .map_err(|_| format!("{w:?} in {text:?} is not a number"))
            })
            .collect::<Result<_, _>>()?;
        match (kind, numbers.as_slice()) {
            ("wait", &[s]) => Ok(Segment::Wait(s)),
            ("push", &[x, y, z, v]) => Ok(Segment::Push {
                mm: [x, y, z],
                peak_speed_mps: v,
            }),
            ("circle", &[r, v]) => Ok(Segment::Circle {
                radius_mm: r,
                peak_speed_mps: v,
            }),
            _ => Err(format!(
                "{text:?}: expected \"wait S\", \"push DX DY DZ V\" or \"circle R V\""
            )),
        }
    }
}

impl TryFrom<String> for Segment {
    type Error = String;

    fn try_from(text: String) -> Result<Self, String> {
        text.parse()
    }
}

/// A segment with its start time, start point and duration.
#[derive(Debug, Clone, PartialEq)]
struct Timed {
    segment: Segment,
    start_s: f64,
    duration_s: f64,
    from: Vector3<f64>,
}

/// The finger's scripted path.
#[derive(Debug, Clone, PartialEq)]
pub struct FingerPath {
    segments: Vec<Timed>,
}

/// Where the finger is and where it is going at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FingerState {
    /// Offset from the start point (m).
    pub offset: Vector3<f64>,
    /// Velocity (m/s).
    pub velocity: Vector3<f64>,
    /// Which axes (x, y, z) the current segment moves along; the others are
    /// axes nobody pushes.
    pub pushed: [bool; 3],
    /// Peak speed of the current segment (0 when waiting) (m/s).
    pub peak_speed_mps: f64,
}

impl FingerPath {
    /// Checks the segments and lays them out in time.
    pub fn new(segments: &[Segment]) -> Result<Self, ParamsError> {
        let mut t = 0.0;
        let mut at = Vector3::zeros();
        let mut timed = Vec::with_capacity(segments.len());
        for (i, s) in segments.iter().enumerate() {
            let key = format!("finger.path[{i}]");
            let (duration_s, end) = match s {
                Segment::Wait(d) => {
                    positive(&key, *d)?;
                    (*d, at)
                }
                Segment::Push { mm, peak_speed_mps } => {
                    positive(&format!("{key}.peak_speed_mps"), *peak_speed_mps)?;
                    let d = Vector3::from(*mm) * 1e-3;
                    if !(d.norm() > 0.0 && d.norm().is_finite()) {
                        return Err(invalid(
                            &format!("{key}.mm"),
                            d.norm(),
                            "a finite, non-zero push",
                        ));
                    }
                    (MIN_JERK_PEAK * d.norm() / peak_speed_mps, at + d)
                }
                Segment::Circle {
                    radius_mm,
                    peak_speed_mps,
                } => {
                    positive(&format!("{key}.radius_mm"), *radius_mm)?;
                    positive(&format!("{key}.peak_speed_mps"), *peak_speed_mps)?;
                    let length = 2.0 * std::f64::consts::PI * radius_mm * 1e-3;
                    (MIN_JERK_PEAK * length / peak_speed_mps, at)
                }
            };
            timed.push(Timed {
                segment: s.clone(),
                start_s: t,
                duration_s,
                from: at,
            });
            t += duration_s;
            at = end;
        }
        Ok(FingerPath { segments: timed })
    }

    /// Total duration (s).
    pub fn duration_s(&self) -> f64 {
        self.segments
            .last()
            .map_or(0.0, |s| s.start_s + s.duration_s)
    }

    /// The finger at time `t` (s); before the start and after the end it rests.
    pub fn at(&self, t: f64) -> FingerState {
        let rest = |offset| FingerState {
            offset,
            velocity: Vector3::zeros(),
            pushed: [false; 3],
            peak_speed_mps: 0.0,
        };
        let Some(seg) = self
            .segments
            .iter()
            .find(|s| t >= s.start_s && t < s.start_s + s.duration_s)
        else {
            let end = self
                .segments
                .last()
                .map_or(Vector3::zeros(), |s| s.from + self.displacement(s, 1.0));
            return rest(if t <= 0.0 { Vector3::zeros() } else { end });
        };
        let u = (t - seg.start_s) / seg.duration_s;
        let (s, ds) = min_jerk(u);
        let ds_dt = ds / seg.duration_s;
        match &seg.segment {
            Segment::Wait(_) => rest(seg.from),
            Segment::Push { mm, peak_speed_mps } => {
                let d = Vector3::from(*mm) * 1e-3;
                FingerState {
                    offset: seg.from + d * s,
                    velocity: d * ds_dt,
                    pushed: [mm[0] != 0.0, mm[1] != 0.0, mm[2] != 0.0],
                    peak_speed_mps: *peak_speed_mps,
                }
            }
            Segment::Circle {
                radius_mm,
                peak_speed_mps,
            } => {
                let r = radius_mm * 1e-3;
                let th = 2.0 * std::f64::consts::PI * s;
                let dth = 2.0 * std::f64::consts::PI * ds_dt;
                // Starts at the current point, centre at -r along x.
                FingerState {
                    offset: seg.from + Vector3::new(r * (th.cos() - 1.0), r * th.sin(), 0.0),
                    velocity: Vector3::new(-r * th.sin() * dth, r * th.cos() * dth, 0.0),
                    pushed: [true, true, false],
                    peak_speed_mps: *peak_speed_mps,
                }
            }
        }
    }

    fn displacement(&self, seg: &Timed, u: f64) -> Vector3<f64> {
        match &seg.segment {
            Segment::Push { mm, .. } => Vector3::from(*mm) * 1e-3 * min_jerk(u).0,
            _ => Vector3::zeros(),
        }
    }
}

/// Minimum-jerk position and its derivative at `u` in [0, 1].
fn min_jerk(u: f64) -> (f64, f64) {
    let u = u.clamp(0.0, 1.0);
    let s = u * u * u * (10.0 - 15.0 * u + 6.0 * u * u);
    let ds = 30.0 * u * u * (1.0 - u) * (1.0 - u);
    (s, ds)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path() -> FingerPath {
        FingerPath::new(&[
            Segment::Wait(1.0),
            Segment::Push {
                mm: [30.0, 0.0, 0.0],
                peak_speed_mps: 0.05,
            },
            Segment::Circle {
                radius_mm: 20.0,
                peak_speed_mps: 0.05,
            },
        ])
        .unwrap()
    }

    #[test]
    fn pushes_reach_their_peak_speed_and_end_where_they_should() {
        let p = path();
        let push_t = 1.875 * 0.03 / 0.05;
        let circle_t = 1.875 * 2.0 * std::f64::consts::PI * 0.02 / 0.05;
        assert!((p.duration_s() - (1.0 + push_t + circle_t)).abs() < 1e-12);
        let mid = p.at(1.0 + push_t / 2.0);
        assert!((mid.velocity.x - 0.05).abs() < 1e-9 && mid.pushed == [true, false, false]);
        let mut peak: f64 = 0.0;
        let mut t = 0.0;
        while t < p.duration_s() {
            peak = peak.max(p.at(t).velocity.norm());
            t += 1e-3;
        }
        assert!(peak <= 0.05 + 1e-9 && peak > 0.0499, "{peak}");
        let end = p.at(p.duration_s() + 1.0);
        assert!((end.offset - Vector3::new(0.03, 0.0, 0.0)).norm() < 1e-9);
        assert_eq!(end.velocity, Vector3::zeros());
    }

    #[test]
    fn velocity_is_the_derivative_of_the_offset() {
        let p = path();
        for t in [0.5, 1.3, 2.0, 3.0, 4.0] {
            let h = 1e-6;
            let fd = (p.at(t + h).offset - p.at(t - h).offset) / (2.0 * h);
            assert!((fd - p.at(t).velocity).norm() < 1e-6, "t {t}");
        }
    }

    #[test]
    fn segments_parse_from_strings() {
        assert_eq!("wait 2".parse(), Ok(Segment::Wait(2.0)));
        assert_eq!(
            " push 30 0 -5  0.05 ".parse(),
            Ok(Segment::Push {
                mm: [30.0, 0.0, -5.0],
                peak_speed_mps: 0.05
            })
        );
        assert!("circle 20"
            .parse::<Segment>()
            .unwrap_err()
            .contains("expected"));
        assert!("push a 0 0 1"
            .parse::<Segment>()
            .unwrap_err()
            .contains("\"a\""));
    }

    #[test]
    fn bad_segments_are_named() {
        let err = FingerPath::new(&[Segment::Push {
            mm: [0.0; 3],
            peak_speed_mps: 0.05,
        }])
        .unwrap_err();
        assert!(err.to_string().contains("finger.path[0].mm"), "{err}");
        let err = FingerPath::new(&[Segment::Wait(-1.0)]).unwrap_err();
        assert!(err.to_string().contains("finger.path[0]"), "{err}");
    }
}
