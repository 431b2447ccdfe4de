//! The chain between two links of a URDF (parsed by the `urdf-rs` crate):
//! its moving joints with their limits, fixed joints folded in. Joints off
//! the chain are ignored, whatever their type; on the chain a floating,
//! planar or spherical joint, or a mimic joint, is refused with its name.

use std::collections::HashMap;

use nalgebra::{Isometry3, Translation3, Unit, UnitQuaternion, Vector3};

use super::chain::{ChainJoint, JointKind, SerialChain};

use crate::exit::{Classify, ExitClass};

/// Why a chain could not be read from a URDF.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum UrdfError {
    /// Not a URDF the parser reads (invalid XML, a malformed element).
    #[error("not a valid URDF: {0}")]
    Parse(String),
    /// A link that is not in the URDF.
    #[error("the URDF has no link `{name}` (its links: {})", links.join(", "))]
    NoLink {
        /// The link asked for.
        name: String,
        /// The URDF's links.
        links: Vec<String>,
    },
    /// The tip is not below the base in the URDF's tree.
    #[error("no chain from `{base}` down to `{tip}`: `{base}` is not above it ({})", match above.as_slice() {
        [] => format!("`{tip}` is the root link"),
        a => format!("above `{tip}`: {}", a.join(" <- ")),
    })]
    NoChain {
        /// The base link.
        base: String,
        /// The tip link.
        tip: String,
        /// The tip's ancestors, its parent first.
        above: Vec<String>,
    },
    /// A joint type the chain cannot hold.
    #[error("joint `{joint}` on the chain is {kind}: only revolute, continuous, prismatic and fixed joints can be driven")]
    Unsupported {
        /// The joint.
        joint: String,
        /// Its type.
        kind: &'static str,
    },
    /// A mimic joint on the chain.
    #[error(
        "joint `{joint}` on the chain mimics `{mimics}`: a chain of mimic joints is not supported"
    )]
    Mimic {
        /// The joint.
        joint: String,
        /// The joint it follows.
        mimics: String,
    },
    /// A number that is not finite, or an axis of length zero.
    #[error("joint `{joint}`: {what}")]
    Invalid {
        /// The joint.
        joint: String,
        /// What is wrong.
        what: String,
    },
    /// No moving joint between the links.
    #[error("no moving joint between `{base}` and `{tip}`")]
    NoJoint {
        /// The base link.
        base: String,
        /// The tip link.
        tip: String,
    },
    /// No tip link given, and the tree does not end in one leaf.
    #[error("which link is the tip? the URDF's tree ends in several: {}", leaves.join(", "))]
    AmbiguousTip {
        /// The leaf links.
        leaves: Vec<String>,
    },
}

/// A URDF refused: refused input.
impl Classify for UrdfError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// A joint's `<limit>` as the URDF gives it (rad or m, rad/s or m/s); None
/// where the URDF gives none (a continuous joint's positions).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UrdfLimit {
    /// Lower and upper position limits.
    pub position: Option<(f64, f64)>,
    /// Velocity limit (0 when the URDF has no `<limit>`).
    pub velocity: f64,
}

/// The chain between two links and each joint's limit.
#[derive(Debug, Clone, PartialEq)]
pub struct UrdfChain {
    /// The chain, base link to tip link.
    pub chain: SerialChain,
    /// The limits, one per moving joint.
    pub limits: Vec<UrdfLimit>,
    /// The base and tip links.
    pub links: (String, String),
    /// The robot's name in the URDF.
    pub name: String,
}

/// Reads the chain from `base` to `tip` in a URDF text. An empty `base` is
/// the root link; an empty `tip` is the one leaf of the tree (refused when
/// there are several, listing them).
pub fn read_chain(urdf: &str, base: &str, tip: &str) -> Result<UrdfChain, UrdfError> {
    let robot = urdf_rs::read_from_string(urdf).map_err(|e| UrdfError::Parse(e.to_string()))?;
    let links: Vec<String> = robot.links.iter().map(|l| l.name.clone()).collect();
    // Each link's joint to its parent.
    let up: HashMap<&str, &urdf_rs::Joint> = robot
        .joints
        .iter()
        .map(|j| (j.child.link.as_str(), j))
        .collect();
    let known = |name: &str| -> Result<String, UrdfError> {
        if links.iter().any(|l| l == name) {
            Ok(name.to_string())
        } else {
            Err(UrdfError::NoLink {
                name: name.into(),
                links: links.clone(),
            })
        }
    };
    let base = if base.is_empty() {
        root(&links, &up)?
    } else {
        known(base)?
    };
    let tip = if tip.is_empty() {
        leaf(&robot, &links)?
    } else {
        known(tip)?
    };
    let on_chain = joints_between(&up, links.len(), &base, &tip)?;
    let (chain, limits) = chain_of(&on_chain)?;
    if limits.is_empty() {
        return Err(UrdfError::NoJoint { base, tip });
    }
    Ok(UrdfChain {
        chain,
        limits,
        links: (base, tip),
        name: robot.name.clone(),
    })
}

/// The joints from `base` down to `tip`, walking up from the tip through
/// each link's joint to its parent (`up`; `links`: how many the URDF has).
fn joints_between<'a>(
    up: &HashMap<&str, &'a urdf_rs::Joint>,
    links: usize,
    base: &str,
    tip: &str,
) -> Result<Vec<&'a urdf_rs::Joint>, UrdfError> {
    let mut above = Vec::new();
    let mut on_chain = Vec::new();
    let mut link = tip;
    while link != base {
        let Some(joint) = up.get(link) else {
            return Err(UrdfError::NoChain {
                base: base.to_string(),
                tip: tip.to_string(),
                above,
            });
        };
        on_chain.push(*joint);
        link = joint.parent.link.as_str();
        above.push(link.to_string());
        if above.len() > links {
            return Err(UrdfError::Parse(format!(
                "the joints form a loop at `{link}`"
            )));
        }
    }
    on_chain.reverse();
    Ok(on_chain)
}

/// The chain of the moving joints of `on_chain` (base first), each fixed
/// joint folded into the next one's origin (or the tip's), and their limits.
fn chain_of(on_chain: &[&urdf_rs::Joint]) -> Result<(SerialChain, Vec<UrdfLimit>), UrdfError> {
    let mut joints = Vec::new();
    let mut limits = Vec::new();
    let mut fixed = Isometry3::identity();
    for j in on_chain {
        let origin = fixed * pose(j)?;
        let kind = match j.joint_type {
            urdf_rs::JointType::Fixed => {
                fixed = origin;
                continue;
            }
            urdf_rs::JointType::Revolute => JointKind::Revolute,
            urdf_rs::JointType::Continuous => JointKind::Continuous,
            urdf_rs::JointType::Prismatic => JointKind::Prismatic,
            urdf_rs::JointType::Floating => return Err(unsupported(j, "floating")),
            urdf_rs::JointType::Planar => return Err(unsupported(j, "planar")),
            urdf_rs::JointType::Spherical => return Err(unsupported(j, "spherical")),
        };
        if let Some(m) = &j.mimic {
            return Err(UrdfError::Mimic {
                joint: j.name.clone(),
                mimics: m.joint.clone(),
            });
        }
        let axis = Vector3::from(j.axis.xyz.0);
        let norm = axis.norm();
        if !(norm.is_finite() && norm > 1e-9) {
            return Err(invalid(
                j,
                format!("axis {:?} has no direction", j.axis.xyz.0),
            ));
        }
        fixed = Isometry3::identity();
        limits.push(limit(j, kind)?);
        joints.push(ChainJoint {
            name: j.name.clone(),
            kind,
            origin,
            axis: Unit::new_normalize(axis),
        });
    }
    Ok((SerialChain::new(joints, fixed), limits))
}

/// The link without a parent joint (a URDF has exactly one).
fn root(links: &[String], up: &HashMap<&str, &urdf_rs::Joint>) -> Result<String, UrdfError> {
    let roots: Vec<&String> = links
        .iter()
        .filter(|l| !up.contains_key(l.as_str()))
        .collect();
    match roots.as_slice() {
        [one] => Ok((*one).clone()),
        _ => Err(UrdfError::Parse(format!(
            "expected one root link, found {}",
            roots.len()
        ))),
    }
}

/// The link without a child joint, when there is one.
fn leaf(robot: &urdf_rs::Robot, links: &[String]) -> Result<String, UrdfError> {
    let leaves: Vec<String> = links
        .iter()
        .filter(|l| !robot.joints.iter().any(|j| &j.parent.link == *l))
        .cloned()
        .collect();
    match leaves.as_slice() {
        [one] => Ok(one.clone()),
        _ => Err(UrdfError::AmbiguousTip { leaves }),
    }
}

fn unsupported(j: &urdf_rs::Joint, kind: &'static str) -> UrdfError {
    UrdfError::Unsupported {
        joint: j.name.clone(),
        kind,
    }
}

fn invalid(j: &urdf_rs::Joint, what: String) -> UrdfError {
    UrdfError::Invalid {
        joint: j.name.clone(),
        what,
    }
}

/// A joint's `<origin>`: translation, then roll-pitch-yaw about the fixed
/// x, y, z axes (URDF: R = Rz(yaw) Ry(pitch) Rx(roll)).
fn pose(j: &urdf_rs::Joint) -> Result<Isometry3<f64>, UrdfError> {
    let ([x, y, z], [r, p, w]) = (j.origin.xyz.0, j.origin.rpy.0);
    if ![x, y, z, r, p, w].iter().all(|v| v.is_finite()) {
        return Err(invalid(j, "origin has a value that is not finite".into()));
    }
    Ok(Isometry3::from_parts(
        Translation3::new(x, y, z),
        UnitQuaternion::from_euler_angles(r, p, w),
    ))
}

/// A moving joint's limits: a continuous joint has no position limits; a
/// URDF 1.2 infinite bound means none either.
fn limit(j: &urdf_rs::Joint, kind: JointKind) -> Result<UrdfLimit, UrdfError> {
    let l = &j.limit;
    let position = match kind {
        JointKind::Continuous => None,
        _ if l.lower.is_infinite() && l.upper.is_infinite() => None,
        _ => {
            if !(l.lower.is_finite() && l.upper.is_finite() && l.lower < l.upper) {
                return Err(invalid(
                    j,
                    format!(
                        "{} joint needs <limit lower upper> with lower < upper (found {} and {})",
                        kind.name(),
                        l.lower,
                        l.upper
                    ),
                ));
            }
            Some((l.lower, l.upper))
        }
    };
    if l.velocity.is_nan() || l.velocity < 0.0 {
        return Err(invalid(
            j,
            format!("velocity limit {} is negative", l.velocity),
        ));
    }
    Ok(UrdfLimit {
        position,
        velocity: l.velocity,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A two-link arm with a gripper finger (prismatic, mimic) off the chain
    /// and a fixed flange; `extra` goes into the robot element.
    fn arm(extra: &str) -> String {
        format!(
            r#"<robot name="test">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="flange"/>
  <link name="finger_a"/><link name="finger_b"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.3"/><axis xyz="0 0 2"/>
    <limit lower="-2" upper="2" velocity="1.5" effort="10"/></joint>
  <joint name="j2" type="continuous"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.4 0 0" rpy="1.5707963267948966 0 0"/><axis xyz="0 0 1"/>
    <limit velocity="2" effort="10"/></joint>
  <joint name="flange_joint" type="fixed"><parent link="l2"/><child link="flange"/>
    <origin xyz="0 0 0.1"/></joint>
  <joint name="finger_a" type="prismatic"><parent link="flange"/><child link="finger_a"/>
    <axis xyz="0 1 0"/><limit lower="0" upper="0.04" velocity="0.2" effort="10"/></joint>
  <joint name="finger_b" type="prismatic"><parent link="flange"/><child link="finger_b"/>
    <axis xyz="0 -1 0"/><limit lower="0" upper="0.04" velocity="0.2" effort="10"/>
    <mimic joint="finger_a"/></joint>
  {extra}
</robot>"#
        )
    }

    #[test]
    fn the_chain_folds_fixed_joints_and_ignores_joints_off_it() {
        let c = read_chain(&arm(""), "base", "flange").unwrap();
        let names: Vec<&str> = c.chain.joints().iter().map(|j| j.name.as_str()).collect();
        assert_eq!(names, ["j1", "j2"]);
        assert_eq!(c.chain.joints()[0].axis.into_inner(), Vector3::z());
        assert_eq!(c.limits[0].position, Some((-2.0, 2.0)));
        assert_eq!(c.limits[1].position, None, "continuous");
        assert_eq!(c.limits[1].velocity, 2.0);
        // j1 up 0.3, j2 out 0.4, the flange 0.1 along j2's z (turned to -y).
        let p = c
            .chain
            .forward(&nalgebra::DVector::zeros(2))
            .translation
            .vector;
        assert!((p - Vector3::new(0.4, -0.1, 0.3)).norm() < 1e-12, "{p}");
        // The finger is a chain of its own; its mimic twin is not on it.
        let finger = read_chain(&arm(""), "l1", "finger_a").unwrap();
        assert_eq!(finger.chain.dof(), 2);
        assert_eq!(finger.chain.joints()[1].kind, JointKind::Prismatic);
    }

    #[test]
    fn what_cannot_be_driven_is_refused_by_name() {
        let e = read_chain(&arm(""), "base", "finger_b").unwrap_err();
        assert!(
            matches!(&e, UrdfError::Mimic { joint, .. } if joint == "finger_b"),
            "{e}"
        );
        // A joint that cannot be driven, on the chain and off it.
        for kind in ["floating", "planar"] {
            let odd = arm(&format!(
                r#"<link name="cam"/><joint name="odd" type="{kind}"><parent link="flange"/>
                <child link="cam"/></joint>"#
            ));
            let e = read_chain(&odd, "base", "cam").unwrap_err().to_string();
            assert!(e.contains("`odd`") && e.contains(kind), "{e}");
            read_chain(&odd, "base", "flange").expect("off the chain");
        }

        let e = read_chain(&arm(""), "base", "flang")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no link `flang`") && e.contains("base, l1, l2, flange"),
            "{e}"
        );
        let e = read_chain(&arm(""), "flange", "l1")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("no chain from `flange`") && e.contains("above `l1`: base"),
            "{e}"
        );
        let e = read_chain(&arm(""), "l2", "flange").unwrap_err();
        assert!(matches!(e, UrdfError::NoJoint { .. }), "{e}");
        let e = read_chain("<robot", "a", "b").unwrap_err();
        assert!(matches!(e, UrdfError::Parse(_)), "{e}");
        let no_range = arm("").replace(r#"lower="-2" upper="2""#, "");
        let e = read_chain(&no_range, "base", "flange")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`j1`") && e.contains("lower < upper"), "{e}");
        let no_axis = arm("").replace(r#"<axis xyz="0 0 2"/>"#, r#"<axis xyz="0 0 0"/>"#);
        let e = read_chain(&no_axis, "base", "flange")
            .unwrap_err()
            .to_string();
        assert!(e.contains("`j1`") && e.contains("no direction"), "{e}");
    }

    #[test]
    fn empty_links_mean_the_root_and_the_one_leaf() {
        let e = read_chain(&arm(""), "", "").unwrap_err().to_string();
        assert!(e.contains("several: finger_a, finger_b"), "{e}");
        let c = read_chain(&arm(""), "", "finger_a").unwrap();
        assert_eq!(c.links.0, "base");
        let single = r#"<robot name="one"><link name="a"/><link name="b"/>
          <joint name="j" type="prismatic"><parent link="a"/><child link="b"/>
          <limit lower="0" upper="1" velocity="1" effort="1"/></joint></robot>"#;
        let c = read_chain(single, "", "").unwrap();
        assert_eq!(c.links, ("a".to_string(), "b".to_string()));
    }
}
