//! BioTac geometry: electrode positions and normals, and the skin surface.
//!
//! Frame: the BioTac core frame, in mm, +x towards the tip, -z is the pad
//! (the side that touches objects), y completes a right-handed frame.
//!
//! Facts (docs/ARCHITECTURE.md, "Reference facts / BioTac", after SynTouch's
//! product manual): electrode positions and normals from the table there;
//! electrodes 11..16 mirror 1..6 with y -> -y; the skin is a capsule of radius
//! ~7 mm (a hemisphere for x > 0, a cylinder about the x axis for x <= 0) and
//! the electrodes sit ~1.9 mm under it.

use nalgebra::Vector3;

use super::{ElectrodeLayout, MAX_ELECTRODES, N_ELECTRODES};

/// Radius of the skin capsule (mm). Architecture page, "Reference facts / BioTac".
pub const SKIN_RADIUS_MM: f64 = 7.0;

/// Nominal depth of the electrodes under the skin surface (mm). Architecture page.
pub const ELECTRODE_DEPTH_MM: f64 = 1.9;

/// One impedance electrode on the core.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Electrode {
    /// Position in the core frame (mm).
    pub position_mm: [f64; 3],
    /// Outward unit normal in the core frame.
    pub normal: [f64; 3],
}

impl Electrode {
    /// Position as a vector (mm, core frame).
    pub fn position(&self) -> Vector3<f64> {
        Vector3::from(self.position_mm)
    }

    /// Outward unit normal as a vector (core frame).
    pub fn normal(&self) -> Vector3<f64> {
        Vector3::from(self.normal)
    }
}

const fn electrode(position_mm: [f64; 3], normal: [f64; 3]) -> Electrode {
    Electrode {
        position_mm,
        normal,
    }
}

/// The electrode mirrored in the x-z plane (y -> -y), as 11..16 mirror 1..6.
const fn mirror_y(e: Electrode) -> Electrode {
    let [x, y, z] = e.position_mm;
    let [nx, ny, nz] = e.normal;
    electrode([x, -y, z], [nx, -ny, nz])
}

// Architecture page table (SynTouch BioTac product manual, electrode layout).
const E1: Electrode = electrode([0.993, -4.855, -1.116], [0.196, -0.956, -0.220]);
const E2: Electrode = electrode([-2.700, -3.513, -3.670], [0.0, -0.692, -0.722]);
const E3: Electrode = electrode([-6.200, -3.513, -3.670], [0.0, -0.692, -0.722]);
const E4: Electrode = electrode([-8.000, -4.956, -1.116], [0.0, -0.976, -0.220]);
const E5: Electrode = electrode([-10.500, -3.513, -3.670], [0.0, -0.692, -0.722]);
const E6: Electrode = electrode([-13.400, -4.956, -1.116], [0.0, -0.976, -0.220]);
const E7: Electrode = electrode([4.763, 0.0, -2.330], [0.5, 0.0, -0.866]);
const E8: Electrode = electrode([3.031, -1.950, -3.330], [0.5, 0.0, -0.866]);
const E9: Electrode = electrode([3.031, 1.950, -3.330], [0.5, 0.0, -0.866]);
const E10: Electrode = electrode([1.299, 0.0, -4.330], [0.5, 0.0, -0.866]);
const E17: Electrode = electrode([-2.800, 0.0, -5.080], [0.0, 0.0, -1.0]);
const E18: Electrode = electrode([-9.800, 0.0, -5.080], [0.0, 0.0, -1.0]);
const E19: Electrode = electrode([-13.600, 0.0, -5.080], [0.0, 0.0, -1.0]);

/// Electrodes E1..E19 (index 0 is E1), core frame, mm.
///
/// E1..E6 run along the -y flank, E7..E10 sit at the tip, E11..E16 mirror
/// E1..E6 on the +y flank, E17..E19 lie on the pad midline.
pub const ELECTRODES: [Electrode; N_ELECTRODES] = [
    E1,
    E2,
    E3,
    E4,
    E5,
    E6,
    E7,
    E8,
    E9,
    E10,
    mirror_y(E1),
    mirror_y(E2),
    mirror_y(E3),
    mirror_y(E4),
    mirror_y(E5),
    mirror_y(E6),
    E17,
    E18,
    E19,
];

/// The simulator's E20..E24 of a BioTac SP: a modelling choice, not
/// SynTouch's SP layout (which we have not found published). Five more
/// electrodes on the pad, where forces on the pad fall, so 24-electrode
/// readings carry more than 19: E20 on the midline between E17 and E18,
/// E21..E24 at 2.5 mm either side of the midline, at E17..E18 and E18..E19's
/// midpoints, on the core (radius 5.08 mm, E17..E19's depth).
pub const SP_EXTRA: [Electrode; MAX_ELECTRODES - N_ELECTRODES] = [
    electrode([-6.300, 0.0, -5.080], [0.0, 0.0, -1.0]),
    electrode([-6.300, -2.500, -4.422], [0.0, -0.492, -0.870]),
    mirror_y(electrode([-6.300, -2.500, -4.422], [0.0, -0.492, -0.870])),
    electrode([-11.700, -2.500, -4.422], [0.0, -0.492, -0.870]),
    mirror_y(electrode([-11.700, -2.500, -4.422], [0.0, -0.492, -0.870])),
];

/// The electrodes of `layout`, E1 first: [`ELECTRODES`], then [`SP_EXTRA`]
/// for a BioTac SP.
pub fn electrodes(layout: ElectrodeLayout) -> impl Iterator<Item = &'static Electrode> {
    ELECTRODES.iter().chain(&SP_EXTRA).take(layout.count())
}

/// A point on the skin capsule with its outward unit normal (core frame, mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// The point (mm).
    pub point_mm: Vector3<f64>,
    /// Outward unit normal of the skin at the point.
    pub normal: Vector3<f64>,
}

impl SurfacePoint {
    /// The skin point at `x_mm` along the axis and `angle_rad` about +x.
    ///
    /// Angle 0 is the pad midline (-z); positive angles turn right-handed
    /// about +x, towards +y. `x_mm` is clamped to at most the tip
    /// ([`SKIN_RADIUS_MM`]); on the hemisphere (x > 0) the ring radius shrinks
    /// as sqrt(R^2 - x^2).
    pub fn at(x_mm: f64, angle_rad: f64) -> Self {
        let x = x_mm.min(SKIN_RADIUS_MM);
        let ring = if x > 0.0 {
            (SKIN_RADIUS_MM * SKIN_RADIUS_MM - x * x).max(0.0).sqrt()
        } else {
            SKIN_RADIUS_MM
        };
        let (s, c) = angle_rad.sin_cos();
        let point_mm = Vector3::new(x, ring * s, -ring * c);
        let normal = if x > 0.0 {
            point_mm / SKIN_RADIUS_MM
        } else {
            Vector3::new(0.0, s, -c)
        };
        SurfacePoint { point_mm, normal }
    }

    /// Radial projection of `p` (mm) onto the capsule: along the ray from the
    /// axis for x <= 0, from the hemisphere centre (the origin) for x > 0.
    ///
    /// On the axis, where that ray is undefined, the pad direction (-z) is used.
    pub fn project(p: &Vector3<f64>) -> Self {
        let radial = if p.x > 0.0 {
            *p
        } else {
            Vector3::new(0.0, p.y, p.z)
        };
        let len = radial.norm();
        let normal = if len > 1e-9 {
            radial / len
        } else {
            -Vector3::z()
        };
        let point_mm = if p.x > 0.0 {
            normal * SKIN_RADIUS_MM
        } else {
            Vector3::new(p.x, 0.0, 0.0) + normal * SKIN_RADIUS_MM
        };
        SurfacePoint { point_mm, normal }
    }

    /// Two unit tangents `(t1, t2)` at the point: `t1` points as close to +x
    /// as the surface allows, `t2 = t1 x normal` (towards +y on the pad).
    ///
    /// A tangential direction at angle `theta` is `cos(theta) t1 + sin(theta) t2`,
    /// so on the pad theta = 0 is +x and theta = 90 deg is +y.
    pub fn tangents(&self) -> (Vector3<f64>, Vector3<f64>) {
        let n = self.normal;
        let along_x = Vector3::x() - n * n.x;
        let t1 = if along_x.norm() > 1e-6 {
            along_x.normalize()
        } else {
            // At the very tip +x is the normal: use -z (towards the pad) instead.
            let down = -Vector3::z() - n * -n.z;
            down.normalize()
        };
        (t1, t1.cross(&n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn electrode_normals_are_unit_vectors() {
        for (i, e) in electrodes(ElectrodeLayout::BiotacSp).enumerate() {
            let n = e.normal().norm();
            assert!((n - 1.0).abs() < 0.01, "E{} normal has norm {n}", i + 1);
        }
    }

    #[test]
    fn electrodes_11_to_16_mirror_1_to_6_in_y() {
        for i in 0..6 {
            let (a, b) = (ELECTRODES[i], ELECTRODES[i + 10]);
            assert_eq!(b.position_mm[0], a.position_mm[0]);
            assert_eq!(b.position_mm[1], -a.position_mm[1]);
            assert_eq!(b.normal[1], -a.normal[1]);
            assert_eq!(b.normal[2], a.normal[2]);
        }
    }

    #[test]
    fn electrodes_sit_about_1_9_mm_under_the_skin_and_on_the_pad_side() {
        assert_eq!(electrodes(ElectrodeLayout::Biotac).count(), 19);
        assert_eq!(electrodes(ElectrodeLayout::BiotacSp).count(), 24);
        for (i, e) in electrodes(ElectrodeLayout::BiotacSp).enumerate() {
            let p = e.position();
            let s = SurfacePoint::project(&p);
            let depth = (s.point_mm - p).norm();
            assert!(
                (depth - ELECTRODE_DEPTH_MM).abs() < 0.7,
                "E{} depth {depth} mm",
                i + 1
            );
            assert!(p.z < 0.0, "E{} is not on the pad half", i + 1);
            // The electrode normal faces outwards, roughly along the skin normal.
            assert!(e.normal().dot(&s.normal) > 0.5, "E{}", i + 1);
        }
    }

    #[test]
    fn surface_points_lie_on_the_capsule_with_outward_normals() {
        for &(x, a) in &[
            (-8.0, 0.0),
            (-3.0, 0.7),
            (0.0, -1.2),
            (3.0, 0.3),
            (6.5, 2.0),
        ] {
            let s = SurfacePoint::at(x, a);
            let p = s.point_mm;
            let r = if p.x > 0.0 { p.norm() } else { p.yz().norm() };
            assert!((r - SKIN_RADIUS_MM).abs() < 1e-9, "x {x}: radius {r}");
            assert!((s.normal.norm() - 1.0).abs() < 1e-12);
            let (t1, t2) = s.tangents();
            assert!(t1.dot(&s.normal).abs() < 1e-12 && t2.dot(&s.normal).abs() < 1e-12);
            assert!(t1.dot(&t2).abs() < 1e-12);
        }
        let pad = SurfacePoint::at(-5.0, 0.0);
        assert!((pad.point_mm - Vector3::new(-5.0, 0.0, -7.0)).norm() < 1e-12);
        let (t1, t2) = pad.tangents();
        assert!((t1 - Vector3::x()).norm() < 1e-12 && (t2 - Vector3::y()).norm() < 1e-12);
        let side = SurfacePoint::at(-5.0, std::f64::consts::FRAC_PI_2);
        assert!((side.point_mm - Vector3::new(-5.0, 7.0, 0.0)).norm() < 1e-12);
        let on_axis = SurfacePoint::project(&Vector3::new(-3.0, 0.0, 0.0));
        assert!((on_axis.point_mm - Vector3::new(-3.0, 0.0, -7.0)).norm() < 1e-12);
        let tip = SurfacePoint::at(20.0, 0.0);
        assert!((tip.point_mm - Vector3::new(7.0, 0.0, 0.0)).norm() < 1e-12);
        assert!((tip.tangents().0 + Vector3::z()).norm() < 1e-12);
    }
}
