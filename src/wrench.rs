//! Wrench (force and torque) and the axes a scene controls or estimates.
//!
//! Conventions: 6-vectors are linear then angular, `[fx, fy, fz, tx, ty, tz]`;
//! forces in N, torques in Nm, expressed in the BioTac core frame (+x towards
//! the tip, -z is the pad).

use std::fmt;
use std::str::FromStr;

use nalgebra::Vector3;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::exit::{Classify, ExitClass};

/// One component of a wrench.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize, JsonSchema,
)]
#[serde(rename_all = "lowercase")]
pub enum Axis {
    /// Force along x (N).
    Fx,
    /// Force along y (N).
    Fy,
    /// Force along z (N).
    Fz,
    /// Torque about x (Nm).
    Tx,
    /// Torque about y (Nm).
    Ty,
    /// Torque about z (Nm).
    Tz,
}

impl Axis {
    /// All six axes in wrench order.
    pub const ALL: [Axis; 6] = [Axis::Fx, Axis::Fy, Axis::Fz, Axis::Tx, Axis::Ty, Axis::Tz];

    /// Position in the 6-vector `[fx, fy, fz, tx, ty, tz]`.
    pub fn index(self) -> usize {
        self as usize
    }

    /// Column name used in data files (`fx` .. `tz`).
    pub fn name(self) -> &'static str {
        match self {
            Axis::Fx => "fx",
            Axis::Fy => "fy",
            Axis::Fz => "fz",
            Axis::Tx => "tx",
            Axis::Ty => "ty",
            Axis::Tz => "tz",
        }
    }

    /// Unit of this component.
    pub fn unit(self) -> &'static str {
        if self.is_force() {
            "N"
        } else {
            "Nm"
        }
    }

    /// True for the three force components.
    pub fn is_force(self) -> bool {
        self.index() < 3
    }
}

impl fmt::Display for Axis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An axis name that is not one of `fx, fy, fz, tx, ty, tz`.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("unknown axis {0:?}: expected a comma-separated subset of fx,fy,fz,tx,ty,tz")]
pub struct UnknownAxis(pub String);

/// An axis name refused: refused input.
impl Classify for UnknownAxis {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

impl FromStr for Axis {
    type Err = UnknownAxis;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Axis::ALL
            .into_iter()
            .find(|a| a.name() == s.trim().to_ascii_lowercase())
            .ok_or_else(|| UnknownAxis(s.to_string()))
    }
}

/// A non-empty set of axes without repeats, kept in wrench order.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(try_from = "Vec<Axis>", into = "Vec<Axis>")]
pub struct AxisSet(Vec<Axis>);

/// Why a list of axes is not a valid [`AxisSet`].
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum AxisSetError {
    /// A name is not an axis.
    #[error(transparent)]
    Unknown(#[from] UnknownAxis),
    /// No axis given.
    #[error("no axis given: expected a comma-separated subset of fx,fy,fz,tx,ty,tz")]
    Empty,
    /// The same axis twice.
    #[error("axis {0} given twice")]
    Repeated(Axis),
}

/// A list of axes refused: refused input.
impl Classify for AxisSetError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

impl AxisSet {
    /// Builds a set from axes; order does not matter, repeats are an error.
    pub fn new(mut axes: Vec<Axis>) -> Result<Self, AxisSetError> {
        if axes.is_empty() {
            return Err(AxisSetError::Empty);
        }
        axes.sort();
        if let Some(w) = axes.windows(2).find(|w| w[0] == w[1]) {
            return Err(AxisSetError::Repeated(w[0]));
        }
        Ok(AxisSet(axes))
    }

    /// The three force axes.
    pub fn forces() -> Self {
        AxisSet(vec![Axis::Fx, Axis::Fy, Axis::Fz])
    }

    /// All six axes.
    pub fn wrench() -> Self {
        AxisSet(Axis::ALL.to_vec())
    }

    /// The axes in wrench order.
    pub fn axes(&self) -> &[Axis] {
        &self.0
    }

    /// Number of axes.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Always false: a set holds at least one axis.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl TryFrom<Vec<Axis>> for AxisSet {
    type Error = AxisSetError;
    fn try_from(v: Vec<Axis>) -> Result<Self, Self::Error> {
        AxisSet::new(v)
    }
}

impl From<AxisSet> for Vec<Axis> {
    fn from(s: AxisSet) -> Self {
        s.0
    }
}

impl FromStr for AxisSet {
    type Err = AxisSetError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let axes = s
            .split(',')
            .filter(|p| !p.trim().is_empty())
            .map(Axis::from_str)
            .collect::<Result<Vec<_>, _>>()?;
        AxisSet::new(axes)
    }
}

impl fmt::Display for AxisSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = self.0.iter().map(|a| a.name()).collect();
        f.write_str(&names.join(","))
    }
}

/// Where the F/T sensor sits in the BioTac frame: a wrench it measures,
/// expressed in the BioTac frame about the BioTac origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameTransform {
    /// Rotation from the F/T frame to the BioTac frame.
    pub rotation: nalgebra::Rotation3<f64>,
    /// The F/T frame's origin in the BioTac frame (m).
    pub origin_m: Vector3<f64>,
}

impl FrameTransform {
    /// The wrench `w` (F/T frame, about its origin) in the BioTac frame,
    /// about the BioTac origin: `F = R f`, `T = R t + p x F`.
    pub fn apply(&self, w: &Wrench) -> Wrench {
        let force = self.rotation * w.force;
        Wrench::new(
            force,
            self.rotation * w.torque + self.origin_m.cross(&force),
        )
    }
}

impl FromStr for FrameTransform {
    type Err = String;
    /// `roll,pitch,yaw,x,y,z`: the F/T frame's orientation in the BioTac
    /// frame (deg, fixed-axis x-y-z) and its origin (m).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let v: Vec<f64> = s
            .split(',')
            .map(|p| p.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
            .collect::<Option<_>>()
            .filter(|v: &Vec<f64>| v.len() == 6)
            .ok_or_else(|| {
                format!("{s:?}: expected six finite numbers roll,pitch,yaw (deg),x,y,z (m)")
            })?;
        let [r, p, y] = [v[0], v[1], v[2]].map(f64::to_radians);
        Ok(FrameTransform {
            rotation: nalgebra::Rotation3::from_euler_angles(r, p, y),
            origin_m: Vector3::new(v[3], v[4], v[5]),
        })
    }
}

/// A force (N) and a torque (Nm) in one frame.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Wrench {
    /// Force in N.
    pub force: Vector3<f64>,
    /// Torque in Nm.
    pub torque: Vector3<f64>,
}

impl Wrench {
    /// A wrench from a force and a torque.
    pub fn new(force: Vector3<f64>, torque: Vector3<f64>) -> Self {
        Wrench { force, torque }
    }

    /// The component along `axis`.
    pub fn get(&self, axis: Axis) -> f64 {
        match axis.index() {
            i @ 0..=2 => self.force[i],
            i => self.torque[i - 3],
        }
    }

    /// Sets the component along `axis`.
    pub fn set(&mut self, axis: Axis, value: f64) {
        match axis.index() {
            i @ 0..=2 => self.force[i] = value,
            i => self.torque[i - 3] = value,
        }
    }

    /// True when every component is finite.
    pub fn is_finite(&self) -> bool {
        self.force
            .iter()
            .chain(self.torque.iter())
            .all(|v| v.is_finite())
    }
}

/// One estimate (the `biotac/wrench_estimate` topic).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WrenchEstimate {
    /// Time of the reading it came from (s).
    pub stamp_s: f64,
    /// Sequence number of that reading.
    pub seq: u16,
    /// Posterior mean, BioTac frame (N, Nm); 0 on axes the model lacks.
    pub mean: Wrench,
    /// Posterior standard deviation (N, Nm); 0 on axes the model lacks.
    pub std: Wrench,
    /// Which axes (in [`Axis::ALL`] order) the model estimates.
    pub estimated: [bool; 6],
    /// PDC above its tare (counts): a contact indicator; 0 for a sensor
    /// without PDC.
    pub pdc_rise: f64,
}

impl WrenchEstimate {
    /// True when every number is finite.
    pub fn is_finite(&self) -> bool {
        let w = |w: &Wrench| w.force.iter().chain(w.torque.iter()).all(|v| v.is_finite());
        self.stamp_s.is_finite() && w(&self.mean) && w(&self.std) && self.pdc_rise.is_finite()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ft_wrench_moves_to_the_biotac_frame() {
        // Turned half a turn about x, 20 mm below the BioTac origin along its z.
        let t: FrameTransform = "180,0,0,0,0,-0.02".parse().unwrap();
        let w = Wrench::new(Vector3::new(0.5, 0.0, -2.0), Vector3::new(0.01, 0.0, 0.0));
        let b = t.apply(&w);
        assert!(
            (b.force - Vector3::new(0.5, 0.0, 2.0)).norm() < 1e-12,
            "{b:?}"
        );
        // T = R t + p x F = (0.01, 0, 0) + (0, 0, -0.02) x (0.5, 0, 2) = (0.01, -0.01, 0).
        assert!(
            (b.torque - Vector3::new(0.01, -0.01, 0.0)).norm() < 1e-12,
            "{b:?}"
        );
        for bad in ["180,0,0", "a,0,0,0,0,0", "0,0,0,0,0,nan"] {
            let e = bad.parse::<FrameTransform>().unwrap_err();
            assert!(e.contains("six finite numbers"), "{e}");
        }
    }

    #[test]
    fn axis_set_parses_sorts_and_rejects_bad_lists() {
        let s: AxisSet = "fz, fx".parse().unwrap();
        assert_eq!(s.axes(), &[Axis::Fx, Axis::Fz]);
        assert_eq!(s.to_string(), "fx,fz");
        assert_eq!("".parse::<AxisSet>(), Err(AxisSetError::Empty));
        assert_eq!(
            "fx,fx".parse::<AxisSet>(),
            Err(AxisSetError::Repeated(Axis::Fx))
        );
        assert!(matches!(
            "fx,fw".parse::<AxisSet>(),
            Err(AxisSetError::Unknown(UnknownAxis(s))) if s == "fw"
        ));
    }

    #[test]
    fn wrench_get_set_follow_wrench_order() {
        let mut w = Wrench::default();
        for (i, a) in Axis::ALL.into_iter().enumerate() {
            w.set(a, i as f64 + 1.0);
        }
        assert_eq!(w.force, Vector3::new(1.0, 2.0, 3.0));
        assert_eq!(w.torque, Vector3::new(4.0, 5.0, 6.0));
        assert_eq!(w.get(Axis::Ty), 5.0);
        w.set(Axis::Tz, f64::NAN);
        assert!(!w.is_finite());
    }
}
