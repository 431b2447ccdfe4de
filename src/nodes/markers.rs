//! What an operator sees of the estimate and the task, drawn in the
//! estimate's frame (the BioTac's) and published by force_controller on
//! `force_controller/markers` (visualization_msgs/MarkerArray): three
//! markers, their content decided here, the adapter only converting them.
//!
//! - [`ARROW_ID`]: the mean force, an arrow from the frame's origin to
//!   `f * METRES_PER_NEWTON` (1 N: 50 mm);
//! - [`BAND_ID`]: its 1-sigma band, a translucent ellipsoid at the arrow's
//!   tip whose full extent along each force axis is `2 sigma *
//!   METRES_PER_NEWTON` (the same scale as the arrow: the band spans mean
//!   -1 sigma to mean +1 sigma);
//! - [`TEXT_ID`]: the task's phase (and why it stopped) and each estimated
//!   axis as `fz +1.002 N +- 0.008`, facing the viewer above the BioTac.
//!
//! An axis the model does not estimate has no number to draw (the message
//! carries NaN there, which RViz refuses): the arrow is 0 along it, the
//! band is flat ([`FLAT_M`]) along it, and the text leaves it out. A band
//! with no 1-sigma on any force axis (the estimator's `with_std: false`)
//! is removed, and the text says `no std`. Every number drawn is finite.
//!
//! Markers go out for one estimate in each [`MARKER_PERIOD_S`] of their
//! stamps ([`MarkerRate`]): 20 sets a second from 100 Hz estimates, what
//! an eye follows, at a fifth of the estimates' traffic. The decision
//! reads the stamps, not a clock, so a replay draws the same.

use nalgebra::Vector3;

use crate::control::{Phase, StopReason};
use crate::nodes::force_controller::ForceControllerNode;
use crate::wrench::{Axis, WrenchEstimate};

/// Metres of arrow (and of band) per newton.
pub const METRES_PER_NEWTON: f64 = 0.05;
/// One set of markers per this much of the estimates' stamps (s).
pub const MARKER_PERIOD_S: f64 = 0.05;
/// A stamp this much early still counts as a period on (s): a driver's
/// stamps jitter.
const STAMP_SLACK_S: f64 = 1e-3;
/// The band's extent along a force axis without a 1-sigma (m): thin, not
/// zero (RViz warns on a zero scale).
pub const FLAT_M: f64 = 5e-4;
/// How long a viewer keeps a set without a newer one (s): the markers go
/// when the estimates stop.
pub const LIFETIME_S: f64 = 0.5;
/// The arrow's shaft diameter (m).
pub const SHAFT_M: f64 = 0.003;
/// The arrow's head diameter (m).
pub const HEAD_M: f64 = 0.006;
/// The text's height (m).
pub const TEXT_HEIGHT_M: f64 = 0.01;
/// Where the text stands in the BioTac frame (m): 40 mm off the back.
const TEXT_AT_M: [f64; 3] = [0.0, 0.0, 0.04];

/// The mean force's marker id.
pub const ARROW_ID: i32 = 0;
/// The 1-sigma band's marker id.
pub const BAND_ID: i32 = 1;
/// The text's marker id.
pub const TEXT_ID: i32 = 2;

const BLUE: [f32; 4] = [0.12, 0.47, 0.71, 1.0];
const BLUE_TRANSLUCENT: [f32; 4] = [0.12, 0.47, 0.71, 0.35];
const WHITE: [f32; 4] = [1.0, 1.0, 1.0, 1.0];

/// The task's phase, and why it stopped.
pub type TaskPhase = (Phase, Option<StopReason>);

/// What a marker draws, in its frame (m).
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// From the origin to `tip`.
    Arrow {
        /// The arrow's end.
        tip: Vector3<f64>,
    },
    /// An ellipsoid about `centre`, its full extent `size` along x, y, z.
    Ellipsoid {
        /// Its centre.
        centre: Vector3<f64>,
        /// Its diameters.
        size: Vector3<f64>,
    },
    /// Text facing the viewer at `at`.
    Text {
        /// Where it stands.
        at: Vector3<f64>,
        /// The lines.
        text: String,
    },
    /// Removed from the view.
    Deleted,
}

/// One marker: its id, what it draws and its colour (RGBA, 0 to 1).
#[derive(Debug, Clone, PartialEq)]
pub struct Marker {
    /// [`ARROW_ID`], [`BAND_ID`] or [`TEXT_ID`].
    pub id: i32,
    /// What it draws.
    pub shape: Shape,
    /// Red, green, blue, alpha.
    pub rgba: [f32; 4],
}

/// The phase of the task `n` runs; None before a robot description.
pub fn task_phase(n: &ForceControllerNode) -> Option<TaskPhase> {
    let task = n.controller()?.task();
    Some((task.phase(), task.reason()))
}

/// The markers of `e` with the task's `phase`: the arrow, the band, the
/// text, every number finite (see the module's page).
pub fn markers(e: &WrenchEstimate, phase: Option<TaskPhase>) -> [Marker; 3] {
    let force = Vector3::from_fn(|i, _| {
        let f = e.mean.force[i];
        if e.estimated[i] && f.is_finite() {
            f
        } else {
            0.0
        }
    });
    let tip = force * METRES_PER_NEWTON;
    let sigma =
        |i: usize| Some(e.std.force[i]).filter(|s| e.estimated[i] && s.is_finite() && *s > 0.0);
    let band = if (0..3).any(|i| sigma(i).is_some()) {
        let size =
            Vector3::from_fn(|i, _| sigma(i).map_or(FLAT_M, |s| s * (2.0 * METRES_PER_NEWTON)));
        Shape::Ellipsoid { centre: tip, size }
    } else {
        Shape::Deleted
    };
    [
        Marker {
            id: ARROW_ID,
            shape: Shape::Arrow { tip },
            rgba: BLUE,
        },
        Marker {
            id: BAND_ID,
            shape: band,
            rgba: BLUE_TRANSLUCENT,
        },
        Marker {
            id: TEXT_ID,
            shape: Shape::Text {
                at: Vector3::from(TEXT_AT_M),
                text: text(e, phase),
            },
            rgba: WHITE,
        },
    ]
}

/// The phase on the first line, then one line per estimated axis.
fn text(e: &WrenchEstimate, phase: Option<TaskPhase>) -> String {
    let mut lines = vec![match phase {
        None => "waiting for the robot description".to_string(),
        Some((p, None)) => p.name().to_string(),
        Some((p, Some(r))) => format!("{}: {}", p.name(), r.name()),
    }];
    for a in Axis::ALL.into_iter().filter(|a| e.estimated[a.index()]) {
        let (mean, sd) = (e.mean.get(a), e.std.get(a));
        let mean = if mean.is_finite() {
            format!("{mean:+.3} {}", a.unit())
        } else {
            "?".into()
        };
        lines.push(if sd.is_finite() && sd > 0.0 {
            format!("{} {mean} +- {sd:.3}", a.name())
        } else {
            format!("{} {mean} (no std)", a.name())
        });
    }
    lines.join("\n")
}

/// Which estimates get markers: the first, then the first whose stamp is
/// at least [`MARKER_PERIOD_S`] after the last one drawn (less a
/// millisecond of jitter), and at once after a stamp that goes back (a
/// replay started again).
#[derive(Debug, Clone, Default)]
pub struct MarkerRate {
    last_s: Option<f64>,
}

impl MarkerRate {
    /// True when the estimate stamped `stamp_s` is to be drawn (then
    /// remembered as the last drawn).
    pub fn due(&mut self, stamp_s: f64) -> bool {
        let due = match self.last_s {
            None => stamp_s.is_finite(),
            Some(last) => stamp_s - last >= MARKER_PERIOD_S - STAMP_SLACK_S || stamp_s < last,
        };
        if due {
            self.last_s = Some(stamp_s);
        }
        due
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wrench::Wrench;

    /// The guarded scene's estimate: fz alone, with its std.
    fn fz_only(fz: f64, sd: f64) -> WrenchEstimate {
        WrenchEstimate {
            stamp_s: 12.34,
            seq: 0,
            mean: Wrench::new(Vector3::new(0.0, 0.0, fz), Vector3::zeros()),
            std: Wrench::new(Vector3::new(0.0, 0.0, sd), Vector3::zeros()),
            estimated: [false, false, true, false, false, false],
            pdc_rise: 300.0,
        }
    }

    fn numbers(m: &Marker) -> Vec<f64> {
        match &m.shape {
            Shape::Arrow { tip } => tip.iter().copied().collect(),
            Shape::Ellipsoid { centre, size } => {
                centre.iter().chain(size.iter()).copied().collect()
            }
            Shape::Text { at, .. } => at.iter().copied().collect(),
            Shape::Deleted => Vec::new(),
        }
    }

    #[test]
    fn one_newton_along_z_is_a_50_mm_arrow_with_its_band_at_the_tip() {
        let hold = Some((Phase::HOLD, None));
        let [arrow, band, text] = markers(&fz_only(1.0, 0.008), hold);
        assert_eq!((arrow.id, band.id, text.id), (ARROW_ID, BAND_ID, TEXT_ID));
        assert_eq!(
            arrow.shape,
            Shape::Arrow {
                tip: Vector3::new(0.0, 0.0, 0.05)
            }
        );
        let Shape::Ellipsoid { centre, size } = band.shape else {
            panic!("{band:?}")
        };
        assert_eq!(centre, Vector3::new(0.0, 0.0, 0.05));
        // 2 sigma at the arrow's scale along z (0.8 mm); flat across.
        assert!((size.z - 2.0 * 0.008 * 0.05).abs() < 1e-15, "{size}");
        assert_eq!((size.x, size.y), (FLAT_M, FLAT_M));
        assert!(band.rgba[3] < 1.0, "translucent");
        let Shape::Text { text, .. } = text.shape else {
            panic!()
        };
        assert_eq!(text, "hold\nfz +1.000 N +- 0.008");
    }

    #[test]
    fn axes_not_estimated_draw_nothing_nan_whatever_the_message_held_there() {
        // As the message carries it: NaN on the axes not estimated, on
        // mean and std alike; and a NaN std on an estimated axis.
        let nan = f64::NAN;
        let mut e = fz_only(-2.5, 0.03);
        e.mean = Wrench::new(Vector3::new(nan, 0.4, -2.5), Vector3::new(nan, nan, 0.01));
        e.std = Wrench::new(Vector3::new(nan, nan, 0.03), Vector3::new(nan, nan, nan));
        e.estimated = [false, true, true, false, false, true];
        let drawn = markers(&e, Some((Phase::named("approach"), None)));
        for m in &drawn {
            assert!(numbers(m).iter().all(|v| v.is_finite()), "{m:?}");
        }
        let Shape::Arrow { tip } = drawn[0].shape else {
            panic!()
        };
        assert!(
            (tip - Vector3::new(0.0, 0.4 * 0.05, -2.5 * 0.05)).norm() < 1e-15,
            "{tip}"
        );
        let Shape::Ellipsoid { size, .. } = drawn[1].shape else {
            panic!()
        };
        // fy has no std to draw: flat like fx; fz's band 2 * 0.03 * 0.05.
        assert_eq!((size.x, size.y), (FLAT_M, FLAT_M));
        assert!((size.z - 0.003).abs() < 1e-15);
        let Shape::Text { text, .. } = &drawn[2].shape else {
            panic!()
        };
        assert_eq!(
            text,
            "approach\nfy +0.400 N (no std)\nfz -2.500 N +- 0.030\ntz +0.010 Nm (no std)"
        );
    }

    #[test]
    fn without_a_std_the_band_is_removed_and_the_text_says_so() {
        // with_std false: the decoded estimate has std 0 everywhere.
        let e = fz_only(0.7, 0.0);
        let stopped = Some((Phase::STOPPED, Some(StopReason::named("force_limit"))));
        let [arrow, band, text] = markers(&e, stopped);
        assert_eq!(
            arrow.shape,
            Shape::Arrow {
                tip: Vector3::new(0.0, 0.0, 0.7 * 0.05)
            }
        );
        assert_eq!(band.shape, Shape::Deleted);
        let Shape::Text { text, .. } = text.shape else {
            panic!()
        };
        assert_eq!(text, "stopped: force_limit\nfz +0.700 N (no std)");
        let [_, _, text] = markers(&e, None);
        let Shape::Text { text, .. } = text.shape else {
            panic!()
        };
        assert!(
            text.starts_with("waiting for the robot description\n"),
            "{text}"
        );
    }

    #[test]
    fn a_model_of_every_force_axis_draws_an_ellipsoid_of_its_three_sigmas() {
        let mut e = fz_only(1.0, 0.1);
        e.mean.force = Vector3::new(0.2, -0.4, 1.0);
        e.std.force = Vector3::new(0.05, 0.02, 0.1);
        e.estimated = [true, true, true, false, false, false];
        let [arrow, band, _] = markers(&e, None);
        let Shape::Arrow { tip } = arrow.shape else {
            panic!()
        };
        let Shape::Ellipsoid { centre, size } = band.shape else {
            panic!()
        };
        assert_eq!(centre, tip);
        assert!(
            (size - Vector3::new(0.005, 0.002, 0.01)).norm() < 1e-15,
            "{size}"
        );
    }

    #[test]
    fn markers_come_20_times_a_second_of_stamps_and_at_once_after_a_replay_restarts() {
        // 100 Hz: each 5th; the SP's 81.5 Hz: each 4th (4 frames are
        // 49.1 ms, within the slack of the period), 20.4 sets a second.
        for (hz, every) in [(100.0, 5), (81.5, 4)] {
            let mut rate = MarkerRate::default();
            let drawn: Vec<usize> = (0..200)
                .filter(|k| rate.due(1000.0 + *k as f64 / hz))
                .collect();
            assert!(
                drawn.windows(2).all(|w| w[1] - w[0] == every),
                "{hz} Hz: {drawn:?}"
            );
            assert_eq!(drawn.len(), 200 / every);
        }
        let mut rate = MarkerRate::default();
        assert!(rate.due(50.0) && !rate.due(50.02) && rate.due(50.0495));
        assert!(rate.due(3.0), "a stamp that goes back");
        assert!(!rate.due(3.01));
        assert!(!MarkerRate::default().due(f64::NAN));
    }
}
