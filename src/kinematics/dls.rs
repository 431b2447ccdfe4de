//! Damped least-squares inverse kinematics with joint limits.
//!
//! `qdot = J^T (J J^T + lambda^2 I)^-1 xdot` (Nakamura & Hanafusa 1986), with
//! damping only near singularity: with sigma the smallest singular value of
//! J and t the threshold, `lambda^2 = 0` for `sigma >= t`, else
//! `lambda^2 = (1 - (sigma / t)^2) lambda_max^2` (Maciejewski & Klein 1988).
//! A joint inside its limit margin and moving towards the limit is halted:
//! its Jacobian column is removed and the rest is solved again, so the other
//! joints take over. Finally all joint velocities are scaled by one common
//! factor to respect the speed limits, which keeps the direction of motion.
//! The optional posture term `(I - J^+ J) k (q_rest - q)` uses the redundant
//! 7th degree of freedom without disturbing the tool.

use nalgebra::Matrix6;

use super::{JointVector, Robot, Twist, N_JOINTS};

/// Joint position and speed limits (rad, rad/s).
#[derive(Debug, Clone, PartialEq)]
pub struct JointLimits {
    /// Lower position limits (rad).
    pub min: JointVector,
    /// Upper position limits (rad).
    pub max: JointVector,
    /// Speed limits (rad/s).
    pub speed_max: JointVector,
    /// Margin inside the limits where motion towards the limit is halted (rad).
    pub margin: f64,
}

/// Damped least-squares settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DlsParams {
    /// Smallest singular value below which damping switches on.
    pub sigma_threshold: f64,
    /// Damping factor at a singular value of zero.
    pub lambda_max: f64,
}

/// Joint velocities for a twist, and how they were limited.
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    /// Joint velocities (rad/s), within the speed limits.
    pub qdot: JointVector,
    /// Common factor applied for the speed limits (1: none).
    pub scale: f64,
    /// Damping factor lambda used (0 away from singularity).
    pub damping: f64,
    /// Joints halted at their limit margin.
    pub halted: [bool; N_JOINTS],
}

/// Inputs that the inverse cannot use.
#[derive(Debug, Clone, Copy, thiserror::Error, PartialEq)]
#[non_exhaustive]
pub enum KinematicsError {
    /// NaN or infinite values.
    #[error("{0} contain a non-finite value")]
    NonFinite(&'static str),
}

/// Joint velocities that move the tool with `twist` (base frame), within the
/// robot's limits. `posture` = (rest pose, gain 1/s) adds the null-space term.
pub fn joint_velocities(
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
    let j = robot.chain.jacobian(q);
    let mut halted = [false; N_JOINTS];
    loop {
        let mut jh = j;
        for (i, _) in halted.iter().enumerate().filter(|(_, h)| **h) {
            jh.column_mut(i).fill(0.0);
        }
        let sigma = jh.singular_values().min();
        let t = robot.dls.sigma_threshold;
        let lambda2 = if sigma >= t {
            0.0
        } else {
            (1.0 - (sigma / t).powi(2)) * robot.dls.lambda_max.powi(2)
        };
        let a = jh * jh.transpose() + Matrix6::identity() * lambda2;
        let Some(chol) = a.cholesky() else {
            // Only when every joint is halted: no motion can be justified.
            return Ok(Motion {
                qdot: JointVector::zeros(),
                scale: 0.0,
                damping: lambda2.sqrt(),
                halted,
            });
        };
        let mut qdot = jh.transpose() * chol.solve(twist);
        if let Some((rest, gain)) = posture {
            let mut z = (rest - q) * gain;
            for (i, _) in halted.iter().enumerate().filter(|(_, h)| **h) {
                z[i] = 0.0;
            }
            qdot += z - jh.transpose() * chol.solve(&(jh * z));
        }
        let into_limit = |i: usize| {
            (q[i] >= lim.max[i] - lim.margin && qdot[i] > 0.0)
                || (q[i] <= lim.min[i] + lim.margin && qdot[i] < 0.0)
        };
        let mut changed = false;
        for (i, h) in halted.iter_mut().enumerate() {
            if !*h && into_limit(i) {
                *h = true;
                changed = true;
            }
        }
        if !changed {
            let scale = qdot
                .iter()
                .zip(lim.speed_max.iter())
                .map(|(v, m)| if v.abs() > *m { m / v.abs() } else { 1.0 })
                .fold(1.0, f64::min);
            return Ok(Motion {
                qdot: qdot * scale,
                scale,
                damping: lambda2.sqrt(),
                halted,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_pose(rng: &mut ChaCha8Rng, robot: &Robot, inset: f64) -> JointVector {
        JointVector::from_fn(|i, _| {
            let (lo, hi) = (robot.limits.min[i] + inset, robot.limits.max[i] - inset);
            rng.random_range(lo..hi)
        })
    }

    #[test]
    fn jacobian_equals_finite_differences_of_forward_kinematics() {
        let robot = Robot::pa10();
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let h = 1e-6;
        for _ in 0..20 {
            let q = random_pose(&mut rng, &robot, 0.0);
            let j = robot.chain.jacobian(&q);
            for c in 0..N_JOINTS {
                let mut dq = JointVector::zeros();
                dq[c] = h;
                let (plus, minus) = (
                    robot.chain.forward(&(q + dq)),
                    robot.chain.forward(&(q - dq)),
                );
                let v = (plus.translation.vector - minus.translation.vector) / (2.0 * h);
                let rot: UnitQuaternion<f64> = plus.rotation * minus.rotation.inverse();
                let w = rot.scaled_axis() / (2.0 * h);
                let col = j.column(c);
                for k in 0..3 {
                    assert!(
                        (col[k] - v[k]).abs() < 1e-7,
                        "joint {c} v{k}: {} vs {}",
                        col[k],
                        v[k]
                    );
                    assert!((col[k + 3] - w[k]).abs() < 1e-7, "joint {c} w{k}");
                }
            }
        }
    }

    #[test]
    fn away_from_singularity_the_twist_is_tracked_exactly() {
        let robot = Robot::pa10();
        let q = JointVector::from_column_slice(&[0.2, 0.5, -0.1, 1.2, 0.3, 0.8, -0.4]);
        let twist = Twist::new(0.01, -0.02, 0.015, 0.0, 0.02, -0.01);
        let m = joint_velocities(&robot, &q, &twist, None).unwrap();
        assert_eq!(
            (m.scale, m.damping, m.halted),
            (1.0, 0.0, [false; N_JOINTS])
        );
        let achieved = robot.chain.jacobian(&q) * m.qdot;
        assert!((achieved - twist).norm() < 1e-12, "{achieved}");
        // The posture term moves the elbow without moving the tool.
        let rest = JointVector::from_column_slice(&[0.0, 0.3, 0.5, 1.0, 0.0, 0.5, 0.0]);
        let mp = joint_velocities(&robot, &q, &twist, Some((&rest, 0.5))).unwrap();
        assert!((mp.qdot - m.qdot).norm() > 1e-3);
        assert!((robot.chain.jacobian(&q) * mp.qdot - twist).norm() < 1e-9);
    }

    #[test]
    fn at_the_stretched_singular_pose_velocities_stay_bounded_and_finite() {
        let robot = Robot::pa10();
        let q = JointVector::zeros(); // arm straight up: shoulder and wrist axes align
        for twist in [
            Twist::new(0.0, 0.0, 0.05, 0.0, 0.0, 0.0), // along the stretched arm
            Twist::new(0.05, 0.05, 0.0, 0.0, 0.0, 0.3),
            Twist::new(0.0, 0.0, 1.0, 1.0, 1.0, 1.0),
        ] {
            let m = joint_velocities(&robot, &q, &twist, None).unwrap();
            assert!(m.damping > 0.0);
            for (v, max) in m.qdot.iter().zip(robot.limits.speed_max.iter()) {
                assert!(v.is_finite() && v.abs() <= max + 1e-12, "{v}");
            }
        }
    }

    #[test]
    fn speed_scaling_keeps_the_direction() {
        let robot = Robot::pa10();
        let q = JointVector::from_column_slice(&[0.2, 0.5, -0.1, 1.2, 0.3, 0.8, -0.4]);
        let small = Twist::new(0.001, 0.002, -0.001, 0.0, 0.0, 0.001);
        let fast = joint_velocities(&robot, &q, &(small * 1000.0), None).unwrap();
        let slow = joint_velocities(&robot, &q, &small, None).unwrap();
        assert!(fast.scale < 1.0 && slow.scale == 1.0);
        let expected = slow.qdot * (1000.0 * fast.scale);
        assert!((fast.qdot - expected).norm() < 1e-9 * expected.norm());
        let reached = fast.qdot.iter().zip(robot.limits.speed_max.iter());
        assert!(reached.clone().any(|(v, m)| (v.abs() - m).abs() < 1e-12));
        assert!(reached.clone().all(|(v, m)| v.abs() <= m + 1e-12));
    }

    #[test]
    fn joint_limits_are_never_exceeded_and_joints_at_the_margin_halt() {
        let robot = Robot::pa10();
        let lim = &robot.limits;
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let dt = 0.01;
        let mut halts = 0;
        for _ in 0..20 {
            let mut q = random_pose(&mut rng, &robot, lim.margin);
            let twist = Twist::from_fn(|_, _| rng.random_range(-0.3..0.3));
            for _ in 0..600 {
                let m = joint_velocities(&robot, &q, &twist, None).unwrap();
                halts += m.halted.iter().filter(|h| **h).count();
                for i in 0..N_JOINTS {
                    let at_max = q[i] >= lim.max[i] - lim.margin && m.qdot[i] > 0.0;
                    let at_min = q[i] <= lim.min[i] + lim.margin && m.qdot[i] < 0.0;
                    assert!(!at_max && !at_min, "joint {i} pushed into its limit");
                    assert!(m.qdot[i].abs() <= lim.speed_max[i] + 1e-12);
                }
                q += m.qdot * dt;
                for i in 0..N_JOINTS {
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
    fn non_finite_input_is_refused() {
        let robot = Robot::pa10();
        let mut q = JointVector::zeros();
        q[3] = f64::NAN;
        let twist = Twist::zeros();
        assert_eq!(
            joint_velocities(&robot, &q, &twist, None),
            Err(KinematicsError::NonFinite("joint positions"))
        );
        let bad = Twist::new(0.0, f64::INFINITY, 0.0, 0.0, 0.0, 0.0);
        assert_eq!(
            joint_velocities(&robot, &JointVector::zeros(), &bad, None),
            Err(KinematicsError::NonFinite("the twist"))
        );
    }
}
