//! Contact between the BioTac pad and a plane: the BioTac skin (nonlinear,
//! hardening) in series with a compliant body (an object, or a person's
//! fingertip), plus stick-slip friction in the tangent plane.
//!
//! Normal direction. The skin follows `F = A (exp(x / x0) - 1)` for a
//! compression `x` (modelling choice: a fluid-filled skin that stiffens as it
//! bottoms out on the core; stiffness `(F + A) / x0`). The body is a spring
//! `k` with a damper `c` in parallel. The two share the force and split the
//! penetration `delta` of the undeformed pad into the undeformed plane:
//! `F = A (exp((delta - x_b) / x0) - 1) = k x_b + c dx_b/dt`, integrated with
//! implicit Euler in the body deflection `x_b` (stable for any stiffness).
//!
//! Tangential direction. A stuck contact point is a spring `k_t` between the
//! pad point and an anchor on the plane; when `|F_t| > mu F_n` the anchor
//! slides so that `|F_t| = mu F_n`.
//!
//! Units: metres, newtons, seconds. Vectors in the world frame.

use crate::contact::{shear_stiffness, BodyParams, SkinParams};
use crate::params::Checked;
use nalgebra::Vector3;

/// State of one pad-plane contact.
#[derive(Debug, Clone)]
pub struct PlaneContact {
    skin: Checked<SkinParams>,
    body: Checked<BodyParams>,
    /// Body deflection (m).
    deflection: f64,
    /// Friction anchor relative to the plane point (world axes, m): it moves
    /// with the body. None when out of contact.
    anchor: Option<Vector3<f64>>,
}

impl PlaneContact {
    /// A contact, initially apart.
    pub fn new(skin: Checked<SkinParams>, body: Checked<BodyParams>) -> Self {
        PlaneContact {
            skin,
            body,
            deflection: 0.0,
            anchor: None,
        }
    }

    /// The body's parameters.
    pub fn body(&self) -> &BodyParams {
        &self.body
    }

    /// Advances by `dt` and returns the force on the finger (world, N).
    /// `pad` is the pad point, `plane` a point of the undeformed plane and
    /// `normal` its unit normal pointing out of the body towards the finger.
    pub fn step(
        &mut self,
        pad: &Vector3<f64>,
        plane: &Vector3<f64>,
        normal: &Vector3<f64>,
        dt: f64,
    ) -> Vector3<f64> {
        let delta = (plane - pad).dot(normal);
        let fn_ = self.normal_step(delta, dt);
        if fn_ <= 0.0 {
            self.anchor = None;
            return Vector3::zeros();
        }
        let anchor = plane + *self.anchor.get_or_insert(pad - plane);
        let slip = pad - anchor;
        let slip_t = slip - normal * slip.dot(normal);
        let k_t = shear_stiffness(&self.skin, &self.body);
        let mut ft = -slip_t * k_t;
        let limit = self.body.friction * fn_;
        let norm = ft.norm();
        if norm > limit {
            // Sliding: the anchor follows so that the force sits on the cone.
            ft *= limit / norm;
            self.anchor = Some(pad + ft / k_t - plane);
        }
        normal * fn_ + ft
    }

    /// Implicit-Euler step of the body deflection for penetration `delta`;
    /// returns the normal force (N).
    fn normal_step(&mut self, delta: f64, dt: f64) -> f64 {
        let (k, c_dt) = (
            self.body.stiffness_n_per_m,
            self.body.damping_n_s_per_m / dt,
        );
        let prev = self.deflection;
        // g(x) = c/dt (x - prev) + k x - F_skin(delta - x) rises with x;
        // g(0) <= 0 and g(max(delta, prev)) > 0 bracket the root.
        let g = |x: f64| c_dt * (x - prev) + k * x - self.skin.force(delta - x);
        let (mut lo, mut hi) = (0.0, delta.max(prev).max(0.0));
        if g(hi) <= 0.0 {
            self.deflection = hi;
        } else {
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if g(mid) > 0.0 {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            self.deflection = 0.5 * (lo + hi);
        }
        self.skin.force(delta - self.deflection)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::series_stiffness;
    use crate::params::Check;

    fn skin() -> Checked<SkinParams> {
        SkinParams {
            force_scale_n: 0.5,
            length_scale_mm: 1.2,
            shear_stiffness_n_per_m: 1000.0,
        }
        .checked("skin")
        .unwrap()
    }

    fn body(k: f64, c: f64) -> Checked<BodyParams> {
        BodyParams {
            stiffness_n_per_m: k,
            damping_n_s_per_m: c,
            friction: 1.0,
        }
        .checked("body")
        .unwrap()
    }

    /// Settled force at penetration `delta` (m) along +z.
    fn settled(c: &mut PlaneContact, delta: f64) -> Vector3<f64> {
        let pad = Vector3::new(0.0, 0.0, -delta);
        let mut f = Vector3::zeros();
        for _ in 0..5000 {
            f = c.step(&pad, &Vector3::zeros(), &Vector3::z(), 1e-3);
        }
        f
    }

    #[test]
    fn static_force_splits_the_penetration_between_skin_and_body() {
        for k in [1e2, 1e4, 1e6] {
            let mut c = PlaneContact::new(skin(), body(k, 5.0));
            let f = settled(&mut c, 2e-3);
            let fz = f.z;
            // Compressions of the skin and the body add up to the penetration.
            let x_skin = 1.2e-3 * (1.0 + fz / 0.5).ln();
            assert!((x_skin + fz / k - 2e-3).abs() < 1e-9, "k {k}: F {fz}");
            assert!(f.x == 0.0 && f.y == 0.0);
        }
        let mut hard = PlaneContact::new(skin(), body(1e6, 5.0));
        let mut soft = PlaneContact::new(skin(), body(1e2, 5.0));
        assert!(settled(&mut hard, 2e-3).z > 10.0 * settled(&mut soft, 2e-3).z);
    }

    #[test]
    fn apart_means_no_force_and_the_skin_hardens() {
        let mut c = PlaneContact::new(skin(), body(1e5, 5.0));
        assert_eq!(settled(&mut c, -1e-3), Vector3::zeros());
        let s = skin();
        assert!(s.stiffness_at(10.0) > 10.0 * s.stiffness_at(0.0));
        // Stiffness is the slope of the force law.
        let x = 1.5e-3;
        let slope = (s.force(x + 1e-9) - s.force(x - 1e-9)) / 2e-9;
        assert!((slope / s.stiffness_at(s.force(x)) - 1.0).abs() < 1e-5);
        let k = series_stiffness(&s, &body(1e2, 0.0), 1.0);
        assert!(k < 1e2 && k > 90.0, "{k}");
    }

    #[test]
    fn damping_resists_fast_penetration_and_stiff_bodies_stay_stable() {
        let mut slow = PlaneContact::new(skin(), body(1e4, 0.0));
        let mut damped = PlaneContact::new(skin(), body(1e4, 50.0));
        let pad = Vector3::new(0.0, 0.0, -1e-3);
        let a = slow.step(&pad, &Vector3::zeros(), &Vector3::z(), 1e-3).z;
        let b = damped.step(&pad, &Vector3::zeros(), &Vector3::z(), 1e-3).z;
        assert!(
            b > a,
            "the damper carries force while the body moves: {a} {b}"
        );
        // 1e6 N/m with a 1 ms step: implicit Euler stays bounded and settles.
        let mut stiff = PlaneContact::new(skin(), body(1e6, 100.0));
        let f = settled(&mut stiff, 1e-3).z;
        assert!(f.is_finite() && (f - skin().force(1e-3 - f / 1e6)).abs() < 1e-6);
    }

    #[test]
    fn a_moving_body_drags_the_skin_along() {
        let mut c = PlaneContact::new(skin(), body(1e4, 0.0));
        settled(&mut c, 2e-3);
        let pad = Vector3::new(0.0, 0.0, -2e-3);
        let f = c.step(&pad, &Vector3::new(1e-4, 0.0, 0.0), &Vector3::z(), 1e-3);
        assert!(f.x > 0.0, "the body moved +x and pulls the finger +x: {f}");
    }

    #[test]
    fn friction_sticks_below_the_cone_and_slides_on_it() {
        let mut c = PlaneContact::new(skin(), body(1e4, 0.0));
        let fz = settled(&mut c, 2e-3).z;
        // Move the pad 0.1 mm sideways: stuck, the shear spring pulls back.
        let pad = Vector3::new(1e-4, 0.0, -2e-3);
        let f = c.step(&pad, &Vector3::zeros(), &Vector3::z(), 1e-3);
        assert!(f.x < 0.0 && f.x.abs() < fz, "{f}");
        // Move it 10 mm: it slides, the tangential force is mu F_n.
        let pad = Vector3::new(1e-2, 0.0, -2e-3);
        let f = c.step(&pad, &Vector3::zeros(), &Vector3::z(), 1e-3);
        assert!((f.x.abs() - f.z).abs() < 1e-9, "{f}");
        // Back by 0.1 mm from the slid position: stuck again, force drops.
        let pad2 = Vector3::new(9.9e-3, 0.0, -2e-3);
        let f2 = c.step(&pad2, &Vector3::zeros(), &Vector3::z(), 1e-3);
        assert!(f2.x.abs() < f.x.abs());
    }
}
