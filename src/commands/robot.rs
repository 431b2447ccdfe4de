//! `robot`: check an arm's description before driving it. Prints the chain
//! between two links of a URDF (joints, types, limits) and, at a joint
//! configuration, the tip's pose in the base frame, the 6 x N Jacobian of
//! the tip origin in the base frame (rows vx vy vz wx wy wz; Pinocchio's
//! LOCAL_WORLD_ALIGNED) and its smallest singular value.

use std::path::PathBuf;

use clap::Args;
use serde::Serialize;

use super::Result;
use tactile_force::kinematics::{JointVector, Robot, RobotParams};
use tactile_force::params::{ParamsError, WORLD_YAML};

#[derive(Args)]
pub struct RobotArgs {
    /// The robot description (URDF file).
    #[arg(long)]
    urdf: PathBuf,
    /// First link of the chain.
    #[arg(long)]
    base: String,
    /// Last link of the chain.
    #[arg(long)]
    tip: String,
    /// Joint positions, one per joint of the chain in order (rad, m for a
    /// prismatic joint). Default: the middle of each joint's range (0 for a
    /// continuous joint).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    q: Option<Vec<f64>>,
    /// Print the figures as one JSON object on the last line.
    #[arg(long)]
    json: bool,
}

/// The `--json` line.
#[derive(Serialize)]
struct Report {
    joints: Vec<String>,
    q: Vec<f64>,
    position_m: [f64; 3],
    quaternion_xyzw: [f64; 4],
    jacobian: Vec<Vec<f64>>,
    sigma_min: f64,
}

pub fn run_robot(a: RobotArgs) -> Result<()> {
    let text = std::fs::read_to_string(&a.urdf).map_err(|error| ParamsError::Io {
        role: "URDF file",
        path: a.urdf.clone(),
        error,
    })?;
    let mut params = RobotParams::from_layers(&[WORLD_YAML])?;
    params.base_link = a.base.clone();
    params.tip_link = a.tip.clone();
    let robot = Robot::from_urdf(&text, &params)?;
    let q = match &a.q {
        Some(values) => {
            let q = JointVector::from_column_slice(values);
            robot.check_positions("--q", &q, values)?
        }
        None => robot.middle(),
    };

    print_joints(&robot);
    let pose = robot.chain.forward(&q);
    let jac = robot.chain.jacobian(&q);
    let sv = jac.singular_values();
    let sigma_min = sv.iter().copied().fold(f64::INFINITY, f64::min);
    let (p, r) = (pose.translation.vector, pose.rotation);
    let (roll, pitch, yaw) = r.euler_angles();
    println!("at q = {:?}", q.as_slice());
    println!(
        "  tip position (m)          [{:.6}, {:.6}, {:.6}]",
        p.x, p.y, p.z
    );
    println!(
        "  tip quaternion (x y z w)  [{:.6}, {:.6}, {:.6}, {:.6}]",
        r.i, r.j, r.k, r.w
    );
    println!(
        "  tip roll-pitch-yaw (deg)  [{:.3}, {:.3}, {:.3}]",
        roll.to_degrees(),
        pitch.to_degrees(),
        yaw.to_degrees()
    );
    println!("  Jacobian of the tip origin, base frame (rows vx vy vz wx wy wz):");
    for (row, name) in jac.row_iter().zip(["vx", "vy", "vz", "wx", "wy", "wz"]) {
        let cells: Vec<String> = row.iter().map(|v| format!("{v:>9.4}")).collect();
        println!("    {name} {}", cells.join(" "));
    }
    println!("  smallest singular value   {sigma_min:.6}");
    if a.json {
        let report = Report {
            joints: robot.joint_names(),
            q: q.iter().copied().collect(),
            position_m: [p.x, p.y, p.z],
            quaternion_xyzw: [r.i, r.j, r.k, r.w],
            jacobian: jac
                .row_iter()
                .map(|row| row.iter().copied().collect())
                .collect(),
            sigma_min,
        };
        println!("{}", serde_json::to_string(&report)?);
    }
    Ok(())
}

/// The arm's name, links and joints with their limits.
fn print_joints(robot: &Robot) {
    println!(
        "{}: {} -> {}, {} joints",
        robot.name,
        robot.links.0,
        robot.links.1,
        robot.dof()
    );
    println!(
        "  {:>2}  {:<28} {:<10} {:>10} {:>10} {:>10}",
        "#", "joint", "type", "lower", "upper", "velocity"
    );
    let l = &robot.limits;
    for (i, j) in robot.chain.joints().iter().enumerate() {
        let unit = if j.kind.turns() { "rad" } else { "m" };
        let bound = |v: f64| {
            if v.is_finite() {
                format!("{v:.4}")
            } else {
                "none".into()
            }
        };
        println!(
            "  {:>2}  {:<28} {:<10} {:>10} {:>10} {:>10}  ({unit}, {unit}/s)",
            i + 1,
            j.name,
            j.kind.name(),
            bound(l.min[i]),
            bound(l.max[i]),
            format!("{:.4}", l.speed_max[i]),
        );
    }
}
