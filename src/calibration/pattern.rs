//! The calibration's pattern (`force_controller.calibrate` in
//! config/calibrate.yaml): normal presses up a force ladder and slides in
//! every direction at each shear force, spread among each other, each push
//! at the next turn of the BioTac about its axis; and the set each push's
//! rows are labelled with (the thesis' sets).

use serde::{Deserialize, Serialize};

use crate::params::reference::check_ranges;
use crate::params::{invalid, Check, ParamsError};

/// Calibration settings (`force_controller.calibrate` in the scene files).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize, schemars::JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CalibrateParams {
    /// Normal forces of the ladder's presses (N), in order.
    pub ladder_n: Vec<f64>,
    /// Normal forces held while the pad slides, one round of slides each (N).
    pub shear_force_n: Vec<f64>,
    /// Directions of the slides in the pad's plane (deg; 0 = +x, 90 = +y).
    pub shear_directions_deg: Vec<f64>,
    /// How far the pad slides along the block in a shear push (m).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub shear_distance_m: f64,
    /// How fast it slides (m/s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub shear_speed_mps: f64,
    /// Turns of the BioTac about its axis from the start, one per push in
    /// turn (deg).
    pub roll_deg: Vec<f64>,
    /// How fast it turns (deg/s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub roll_rate_deg_s: f64,
    /// Approach and retract speed (m/s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub approach_speed_mps: f64,
    /// Force that means contact (N).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub contact_force_n: f64,
    /// Time each press holds its force once settled (s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub hold_s: f64,
    /// Time out of contact before each press: its tare (s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub rest_s: f64,
    /// How far above where it touched the pad backs off between pushes (m).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub clearance_m: f64,
    /// Force above which the calibration retracts and stops (N).
    pub force_limit_n: f64,
    /// Approach distance of a press with no contact: the calibration stops (m).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_distance_m: f64,
    /// The longest the calibration may move the arm (s).
    #[schemars(extend("exclusiveMinimum" = 0.0))]
    pub max_duration_s: f64,
}

impl Check for CalibrateParams {
    fn check(self, key: &str) -> Result<Self, ParamsError> {
        let name = |field: &str| format!("{key}.{field}");
        check_ranges(&self, key)?;
        if self.ladder_n.is_empty() {
            return Err(invalid(&name("ladder_n"), 0.0, "at least one force"));
        }
        let forces = self
            .ladder_n
            .iter()
            .map(|f| ("ladder_n", *f))
            .chain(self.shear_force_n.iter().map(|f| ("shear_force_n", *f)));
        for (field, f) in forces {
            if !(f > self.contact_force_n && f < self.force_limit_n) {
                return Err(invalid(
                    &name(field),
                    f,
                    &format!(
                        "between the contact force {} N and the force limit {} N",
                        self.contact_force_n, self.force_limit_n
                    ),
                ));
            }
        }
        if let Some(d) = self.shear_directions_deg.iter().find(|d| !d.is_finite()) {
            return Err(invalid(&name("shear_directions_deg"), *d, "a finite angle"));
        }
        if self.roll_deg.is_empty() {
            return Err(invalid(
                &name("roll_deg"),
                0.0,
                "at least one turn (0: none)",
            ));
        }
        if let Some(t) = self.roll_deg.iter().find(|t| t.is_nan() || t.abs() > 30.0) {
            return Err(invalid(&name("roll_deg"), *t, "turns within +-30 deg"));
        }
        Ok(self)
    }
}

/// What a push does, and the set it is labelled with in the recording (the
/// thesis' sets: 1 mainly x, 2 mainly y, 3 mainly z, 4 combined).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PushKind {
    /// A normal press.
    Normal,
    /// A press that slides in the pad's plane along a direction (rad; 0 =
    /// +x of the BioTac frame, pi/2 = +y).
    Shear(f64),
}

impl PushKind {
    /// The set number of its rows: a slide within 22.5 deg of x is set 1,
    /// of y set 2, between them set 4; a press set 3.
    pub fn set(self) -> u32 {
        match self {
            PushKind::Shear(a) => {
                let (s, c) = a.sin_cos();
                let axis = std::f64::consts::FRAC_PI_8.cos();
                if c.abs() >= axis {
                    1
                } else if s.abs() >= axis {
                    2
                } else {
                    4
                }
            }
            PushKind::Normal => 3,
        }
    }
}

/// One push of the pattern.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Push {
    /// What it does.
    pub kind: PushKind,
    /// Its normal force (N).
    pub target_n: f64,
    /// The BioTac's turn about its axis from the start (rad).
    pub roll_rad: f64,
}

/// The pattern: the ladder's presses and the slides (every direction, each
/// at every shear force), spread evenly among each other, each push at the
/// next turn of `roll_deg`.
pub fn pattern(p: &CalibrateParams) -> Vec<Push> {
    let presses = p.ladder_n.iter().map(|&f| (PushKind::Normal, f));
    // Direction by direction, each at every shear force: the pushes held
    // out for validation (every fourth) leave a twin of each in training.
    let slides = p.shear_directions_deg.iter().flat_map(|&d| {
        p.shear_force_n
            .iter()
            .map(move |&f| (PushKind::Shear(d.to_radians()), f))
    });
    // Each kind's pushes at (i + 1/2) / n of the way through: merged in
    // that order, neither kind bunches at one end.
    let spread = |n: usize| move |(i, push)| ((i as f64 + 0.5) / n as f64, push);
    let (np, ns) = (
        p.ladder_n.len(),
        p.shear_force_n.len() * p.shear_directions_deg.len(),
    );
    let mut order: Vec<(f64, (PushKind, f64))> = presses
        .enumerate()
        .map(spread(np))
        .chain(slides.enumerate().map(spread(ns)))
        .collect();
    order.sort_by(|a, b| a.0.total_cmp(&b.0));
    order
        .into_iter()
        .zip(p.roll_deg.iter().cycle())
        .map(|((_, (kind, target_n)), roll)| Push {
            kind,
            target_n,
            roll_rad: roll.to_radians(),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{node_params, CALIBRATE_YAML};

    fn shipped() -> CalibrateParams {
        #[derive(Deserialize)]
        struct Section {
            calibrate: CalibrateParams,
        }
        node_params::<Section>(CALIBRATE_YAML, "force_controller")
            .unwrap()
            .calibrate
    }

    #[test]
    fn the_pattern_interleaves_every_kind_and_labels_it_with_the_thesis_sets() {
        let p = shipped().checked("calibrate").unwrap();
        let pushes = pattern(&p);
        let n = p.ladder_n.len() + p.shear_force_n.len() * p.shear_directions_deg.len();
        assert_eq!(pushes.len(), n);
        // Presses and slides spread among each other: in every window of
        // four pushes, both kinds.
        for w in pushes.windows(4) {
            assert!(w.iter().any(|p| p.kind == PushKind::Normal), "{w:?}");
            assert!(w.iter().any(|p| p.kind != PushKind::Normal), "{w:?}");
        }
        // Each push at the next turn, in order.
        for (push, roll) in pushes.iter().zip(p.roll_deg.iter().cycle()) {
            assert_eq!(push.roll_rad, roll.to_radians());
        }
        // Every slide direction at each of its forces.
        for f in &p.shear_force_n {
            for d in &p.shear_directions_deg {
                let kind = PushKind::Shear(d.to_radians());
                assert!(pushes.iter().any(|p| p.kind == kind && p.target_n == *f));
            }
        }
        // Every push held out for validation has a twin in training: a
        // press, or a slide the same way at another force.
        let every = crate::learn::calibration::HELD_OUT_EVERY as usize;
        let (out, kept): (Vec<_>, Vec<_>) = pushes
            .iter()
            .enumerate()
            .partition(|(i, _)| (i + 1) % every == 0);
        for (i, push) in out {
            assert!(
                kept.iter().any(|(_, k)| k.kind == push.kind),
                "push {}",
                i + 1
            );
        }
        // Labelled as the thesis' sets: along x 1, along y 2, between 4, presses 3.
        let set = |deg: f64| PushKind::Shear(f64::to_radians(deg)).set();
        assert_eq!([set(0.0), set(180.0), set(-20.0)], [1, 1, 1]);
        assert_eq!([set(90.0), set(270.0), set(110.0)], [2, 2, 2]);
        assert_eq!([set(45.0), set(135.0), set(-45.0)], [4, 4, 4]);
        assert_eq!(PushKind::Normal.set(), 3);
        // The ladder in order, up to its top.
        let ladder: Vec<f64> = pushes
            .iter()
            .filter(|p| p.kind == PushKind::Normal)
            .map(|p| p.target_n)
            .collect();
        assert_eq!(ladder, p.ladder_n);
    }

    #[test]
    fn forces_at_or_beyond_the_limit_and_wild_turns_are_refused_by_name() {
        let mut p = shipped();
        p.ladder_n.push(12.0);
        let e = p.checked("calibrate").unwrap_err().to_string();
        assert!(
            e.contains("calibrate.ladder_n = 12") && e.contains("force limit 12"),
            "{e}"
        );
        let mut p = shipped();
        p.shear_force_n = vec![0.1];
        let e = p.checked("calibrate").unwrap_err().to_string();
        assert!(e.contains("calibrate.shear_force_n"), "{e}");
        let mut p = shipped();
        p.roll_deg = vec![45.0];
        let e = p.checked("calibrate").unwrap_err().to_string();
        assert!(e.contains("calibrate.roll_deg = 45"), "{e}");
        let mut p = shipped();
        p.rest_s = 0.0;
        assert!(p.checked("calibrate").is_err());
    }
}
