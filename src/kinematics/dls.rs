//! Damped least-squares inverse kinematics with joint limits, for any
//! number of joints.
//!
//! `qdot = J^T (J J^T + lambda^2 I)^-1 xdot` (Nakamura & Hanafusa 1986),
//! computed from the eigen-decomposition of the 6 x 6 matrix `J J^T`, so the
//! same code serves 6 joints, more (redundant), and fewer: with n < 6 joints
//! `J J^T` has 6 - n structural zero eigenvalues, which are left out, and the
//! result is the least-squares motion `J^+ xdot` (exact when the twist is
//! one the arm can make). Damping only near singularity: with sigma the
//! smallest of the min(n, 6) singular values of J and t the threshold,
//! `lambda^2 = 0` for `sigma >= t`, else `lambda^2 = (1 - (sigma / t)^2)
//! lambda_max^2` (Maciejewski & Klein 1988). A joint inside its limit
//! margin and moving towards the limit is halted: its Jacobian column is
//! removed and the rest is solved again, so the other joints take over.
//! Finally all joint velocities are scaled by one common factor to respect
//! the speed limits, which keeps the direction of motion. The optional
//! posture term `(I - J^+ J) k (q_rest - q)` uses a redundant arm's extra
//! degrees of freedom without disturbing the tool.
//!
//! [`Dls`] holds its work space: after [`Dls::new`] a solve allocates nothing.

use nalgebra::{Matrix6, SymmetricEigen, Vector6};

use super::{Jacobian, JointVector, Robot, Twist};

use crate::exit::{Classify, ExitClass};

/// Joint position and speed limits (rad or m, rad/s or m/s), one per joint.
#[derive(Debug, Clone, PartialEq)]
pub struct JointLimits {
    /// Lower position limits (-inf: none).
    pub min: JointVector,
    /// Upper position limits (+inf: none).
    pub max: JointVector,
    /// Speed limits.
    pub speed_max: JointVector,
    /// Margin inside the limits where motion towards the limit is halted.
    pub margin: JointVector,
}

/// Damped least-squares settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DlsParams {
    /// Smallest singular value below which damping switches on.
    pub sigma_threshold: f64,
    /// Damping factor at a singular value of zero.
    pub lambda_max: f64,
}

/// How a solve limited the motion (the joint velocities are in [`Dls::qdot`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Common factor applied for the speed limits (1: none).
    pub scale: f64,
    /// Damping factor lambda used (0 away from singularity).
    pub damping: f64,
    /// Smallest singular value of the Jacobian of the joints not halted.
    pub sigma_min: f64,
    /// Joints halted at their limit margin.
    pub halted: usize,
}

/// Inputs that the inverse cannot use.
#[derive(Debug, Clone, Copy, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum KinematicsError {
    /// NaN or infinite values.
    #[error("{0} contain a non-finite value")]
    NonFinite(&'static str),
}

/// A joint state or twist that is not finite: refused input.
impl Classify for KinematicsError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// The damped least-squares solver and its work space for one robot.
#[derive(Debug, Clone)]
pub struct Dls {
    j: Jacobian,
    jh: Jacobian,
    qdot: JointVector,
    posture: JointVector,
    halted: Vec<bool>,
}

/// `J J^T` of a 6 x n matrix, with no heap work.
fn gram(j: &Jacobian) -> Matrix6<f64> {
    let mut a = Matrix6::zeros();
    for c in j.column_iter() {
        let c = Vector6::from_iterator(c.iter().copied());
        a += c * c.transpose();
    }
    a
}

/// `J v`, with no heap work.
fn times(j: &Jacobian, v: &JointVector) -> Vector6<f64> {
    j.column_iter()
        .zip(v.iter())
        .fold(Vector6::zeros(), |acc, (c, x)| {
            acc + Vector6::from_iterator(c.iter().map(|e| e * x))
        })
}

/// Writes `J^T w` into `out`.
fn transpose_times(j: &Jacobian, w: &Vector6<f64>, out: &mut JointVector) {
    for (o, c) in out.iter_mut().zip(j.column_iter()) {
        *o = c.iter().zip(w.iter()).map(|(a, b)| a * b).sum();
    }
}

/// The damped inverse `(J J^T + lambda^2 I)^+` of `J J^T` restricted to its
/// `rank` largest eigenvalues, the damping lambda and the smallest of the
/// `rank` singular values.
fn damped_inverse(a: Matrix6<f64>, rank: usize, p: &DlsParams) -> (Matrix6<f64>, f64, f64) {
    let eig = SymmetricEigen::new(a);
    let mut order = [0, 1, 2, 3, 4, 5];
    order.sort_by(|&x, &y| eig.eigenvalues[y].total_cmp(&eig.eigenvalues[x]));
    let kept = &order[..rank];
    let sigma = eig.eigenvalues[kept[rank - 1]].max(0.0).sqrt();
    let t = p.sigma_threshold;
    let lambda2 = if sigma >= t {
        0.0
    } else {
        (1.0 - (sigma / t).powi(2)) * p.lambda_max.powi(2)
    };
    // Eigenvalues at rounding level are zeros (an exact singularity).
    let floor = 1e-12 * eig.eigenvalues[kept[0]].max(0.0);
    let mut inv = Matrix6::zeros();
    for &k in kept {
        let d = eig.eigenvalues[k].max(0.0) + lambda2;
        if d > floor {
            let v = eig.eigenvectors.column(k);
            inv += v * v.transpose() / d;
        }
    }
    (inv, lambda2.sqrt(), sigma)
}

impl Dls {
    /// A solver for `robot`'s number of joints.
    pub fn new(robot: &Robot) -> Self {
        let n = robot.dof();
        Dls {
            j: Jacobian::zeros(n),
            jh: Jacobian::zeros(n),
            qdot: JointVector::zeros(n),
            posture: JointVector::zeros(n),
            halted: vec![false; n],
        }
    }

    /// The joint velocities of the last solve (rad/s or m/s).
    pub fn qdot(&self) -> &JointVector {
        &self.qdot
    }

    /// Which joints the last solve halted at their limit margin.
    pub fn halted(&self) -> &[bool] {
        &self.halted
    }

    /// Joint velocities that move the tool with `twist` (base frame), within
    /// `robot`'s limits, into [`Dls::qdot`]. `posture` = (rest pose, gain
    /// 1/s) adds the null-space term.
    pub fn solve(
        &mut self,
        robot: &Robot,
        q: &JointVector,
        twist: &Twist,
        posture: Option<(&JointVector, f64)>,
    ) -> Result<Motion, KinematicsError> {
        if q.iter().any(|v| !v.is_finite()) {
            return Err(KinematicsError::NonFinite("joint positions"));
        }
        if twist.iter().any(|v| !v.is_finite()) {
            return Err(KinematicsError::NonFinite("the twist"));
        }
        let lim = &robot.limits;
        let n = robot.dof();
        let rank = n.min(6);
        robot.chain.jacobian_into(q, &mut self.j);
        self.halted.fill(false);
        loop {
            self.jh.copy_from(&self.j);
            for (i, _) in self.halted.iter().enumerate().filter(|(_, h)| **h) {
                self.jh.column_mut(i).fill(0.0);
            }
            let (inv, damping, sigma_min) = damped_inverse(gram(&self.jh), rank, &robot.dls);
            transpose_times(&self.jh, &(inv * twist), &mut self.qdot);
            if let Some((rest, gain)) = posture {
                for i in 0..n {
                    let free = !self.halted[i];
                    self.posture[i] = if free { (rest[i] - q[i]) * gain } else { 0.0 };
                }
                let through = inv * times(&self.jh, &self.posture);
                self.qdot += &self.posture;
                for (o, c) in self.qdot.iter_mut().zip(self.jh.column_iter()) {
                    *o -= c
                        .iter()
                        .zip(through.iter())
                        .map(|(a, b)| a * b)
                        .sum::<f64>();
                }
            }
            let into_limit = |i: usize, v: f64| {
                (q[i] >= lim.max[i] - lim.margin[i] && v > 0.0)
                    || (q[i] <= lim.min[i] + lim.margin[i] && v < 0.0)
            };
            let mut changed = false;
            for i in 0..n {
                if !self.halted[i] && into_limit(i, self.qdot[i]) {
                    self.halted[i] = true;
                    changed = true;
                }
            }
            if !changed {
                let scale = self
                    .qdot
                    .iter()
                    .zip(lim.speed_max.iter())
                    .map(|(v, m)| if v.abs() > *m { m / v.abs() } else { 1.0 })
                    .fold(1.0, f64::min);
                self.qdot *= scale;
                return Ok(Motion {
                    scale,
                    damping,
                    sigma_min,
                    halted: self.halted.iter().filter(|h| **h).count(),
                });
            }
        }
    }

    /// How much of a unit twist the arm cannot make at `q`: the norm of the
    /// part of `twist` outside the range of J (0: the arm can make it
    /// exactly). Used to refuse a task an arm with fewer than six joints
    /// cannot do.
    pub fn unmade(&mut self, robot: &Robot, q: &JointVector, twist: &Twist) -> f64 {
        robot.chain.jacobian_into(q, &mut self.j);
        let exact = DlsParams {
            sigma_threshold: f64::MIN_POSITIVE,
            lambda_max: 0.0,
        };
        let (inv, _, _) = damped_inverse(gram(&self.j), robot.dof().min(6), &exact);
        transpose_times(&self.j, &(inv * twist), &mut self.qdot);
        (twist - times(&self.j, &self.qdot)).norm() / twist.norm()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_pose(rng: &mut ChaCha8Rng, robot: &Robot, inset: f64) -> JointVector {
        JointVector::from_fn(robot.dof(), |i, _| {
            let (lo, hi) = (robot.limits.min[i] + inset, robot.limits.max[i] - inset);
            rng.random_range(lo..hi)
        })
    }

    fn pa10_q(deg: [f64; 7]) -> JointVector {
        JointVector::from_iterator(7, deg.iter().map(|d| d.to_radians()))
    }

    #[test]
    fn jacobian_equals_finite_differences_of_forward_kinematics() {
        let robot = Robot::pa10();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let h = 1e-6;
        for _ in 0..20 {
            let q = random_pose(&mut rng, &robot, 0.0);
            let j = robot.chain.jacobian(&q);
            for c in 0..robot.dof() {
                let mut dq = JointVector::zeros(robot.dof());
                dq[c] = h;
                let (plus, minus) = (
                    robot.chain.forward(&(&q + &dq)),
                    robot.chain.forward(&(&q - &dq)),
                );
                let v = (plus.translation.vector - minus.translation.vector) / (2.0 * h);
                let rot: UnitQuaternion<f64> = plus.rotation * minus.rotation.inverse();
                let w = rot.scaled_axis() / (2.0 * h);
                let col = j.column(c);
                for k in 0..3 {
                    assert!((col[k] - v[k]).abs() < 1e-7, "joint {c} v{k}");
                    assert!((col[k + 3] - w[k]).abs() < 1e-7, "joint {c} w{k}");
                }
            }
        }
    }

    #[test]
    fn away_from_singularity_the_twist_is_tracked_exactly() {
        let robot = Robot::pa10();
        let mut dls = Dls::new(&robot);
        let q = JointVector::from_column_slice(&[0.2, 0.5, -0.1, 1.2, 0.3, 0.8, -0.4]);
        let twist = Twist::new(0.01, -0.02, 0.015, 0.0, 0.02, -0.01);
        let m = dls.solve(&robot, &q, &twist, None).unwrap();
        assert_eq!((m.scale, m.damping, m.halted), (1.0, 0.0, 0));
        let plain = dls.qdot().clone();
        let achieved = robot.chain.jacobian(&q) * &plain;
        assert!((achieved - twist).norm() < 1e-12, "{achieved}");
        // The posture term moves the elbow without moving the tool.
        let rest = JointVector::from_column_slice(&[0.0, 0.3, 0.5, 1.0, 0.0, 0.5, 0.0]);
        dls.solve(&robot, &q, &twist, Some((&rest, 0.5))).unwrap();
        assert!((dls.qdot() - &plain).norm() > 1e-3);
        assert!((robot.chain.jacobian(&q) * dls.qdot() - twist).norm() < 1e-9);
    }

    #[test]
    fn at_the_stretched_singular_pose_velocities_stay_bounded_and_finite() {
        let robot = Robot::pa10();
        let mut dls = Dls::new(&robot);
        let q = JointVector::zeros(7); // arm straight up: shoulder and wrist axes align
        for twist in [
            Twist::new(0.0, 0.0, 0.05, 0.0, 0.0, 0.0), // along the stretched arm
            Twist::new(0.05, 0.05, 0.0, 0.0, 0.0, 0.3),
            Twist::new(0.0, 0.0, 1.0, 1.0, 1.0, 1.0),
        ] {
            let m = dls.solve(&robot, &q, &twist, None).unwrap();
            assert!(m.damping > 0.0 && m.sigma_min < robot.dls.sigma_threshold);
            for (v, max) in dls.qdot().iter().zip(robot.limits.speed_max.iter()) {
                assert!(v.is_finite() && v.abs() <= max + 1e-12, "{v}");
            }
        }
    }

    #[test]
    fn speed_scaling_keeps_the_direction() {
        let robot = Robot::pa10();
        let mut dls = Dls::new(&robot);
        let q = JointVector::from_column_slice(&[0.2, 0.5, -0.1, 1.2, 0.3, 0.8, -0.4]);
        let small = Twist::new(0.001, 0.002, -0.001, 0.0, 0.0, 0.001);
        let fast = dls.solve(&robot, &q, &(small * 1000.0), None).unwrap();
        let fast_qdot = dls.qdot().clone();
        let slow = dls.solve(&robot, &q, &small, None).unwrap();
        assert!(fast.scale < 1.0 && slow.scale == 1.0);
        let expected = dls.qdot() * (1000.0 * fast.scale);
        assert!((&fast_qdot - &expected).norm() < 1e-9 * expected.norm());
        let reached = fast_qdot.iter().zip(robot.limits.speed_max.iter());
        assert!(reached.clone().any(|(v, m)| (v.abs() - m).abs() < 1e-12));
        assert!(reached.clone().all(|(v, m)| v.abs() <= m + 1e-12));
    }

    #[test]
    fn joint_limits_are_never_exceeded_and_joints_at_the_margin_halt() {
        let robot = Robot::pa10();
        let mut dls = Dls::new(&robot);
        let lim = &robot.limits;
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let dt = 0.01;
        let mut halts = 0;
        for _ in 0..20 {
            let mut q = random_pose(&mut rng, &robot, lim.margin[0]);
            let twist = Twist::from_fn(|_, _| rng.random_range(-0.3..0.3));
            for _ in 0..600 {
                let m = dls.solve(&robot, &q, &twist, None).unwrap();
                halts += m.halted;
                let qdot = dls.qdot();
                for i in 0..robot.dof() {
                    let at_max = q[i] >= lim.max[i] - lim.margin[i] && qdot[i] > 0.0;
                    let at_min = q[i] <= lim.min[i] + lim.margin[i] && qdot[i] < 0.0;
                    assert!(!at_max && !at_min, "joint {i} pushed into its limit");
                    assert!(qdot[i].abs() <= lim.speed_max[i] + 1e-12);
                }
                q += qdot * dt;
                for i in 0..robot.dof() {
                    assert!(
                        q[i] >= lim.min[i] && q[i] <= lim.max[i],
                        "joint {i}: {}",
                        q[i]
                    );
                }
            }
        }
        // The runs did drive joints into their margins.
        assert!(halts > 100, "only {halts} halts");
    }

    #[test]
    fn the_eigen_form_equals_the_cholesky_solve_it_replaces() {
        // J^T (J J^T + lambda^2 I)^-1 xdot by Cholesky, at a pose near the
        // stretched singularity where damping is on.
        let robot = Robot::pa10();
        let mut dls = Dls::new(&robot);
        let q = pa10_q([0.0, 2.0, 0.0, 3.0, 0.0, 1.0, 0.0]);
        let twist = Twist::new(0.01, 0.0, -0.02, 0.0, 0.0, 0.0);
        let m = dls.solve(&robot, &q, &twist, None).unwrap();
        assert!(m.damping > 0.0);
        let j = robot.chain.jacobian(&q);
        let a = &j * j.transpose() + Matrix6::identity() * m.damping.powi(2);
        let expected = j.transpose() * a.cholesky().unwrap().solve(&twist);
        assert!((dls.qdot() - expected).norm() < 1e-12 * dls.qdot().norm());
    }

    #[test]
    fn non_finite_input_is_refused() {
        let robot = Robot::pa10();
        let mut dls = Dls::new(&robot);
        let mut q = JointVector::zeros(7);
        q[3] = f64::NAN;
        let twist = Twist::zeros();
        assert_eq!(
            dls.solve(&robot, &q, &twist, None),
            Err(KinematicsError::NonFinite("joint positions"))
        );
        let bad = Twist::new(0.0, f64::INFINITY, 0.0, 0.0, 0.0, 0.0);
        assert_eq!(
            dls.solve(&robot, &JointVector::zeros(7), &bad, None),
            Err(KinematicsError::NonFinite("the twist"))
        );
    }
}
