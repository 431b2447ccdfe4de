//! The conversions between our types and the standard messages
//! (`tactile_force::ros::convert`).

use nalgebra::Vector3 as V3;
use r2r::builtin_interfaces::msg::Time;
use r2r::geometry_msgs::msg::{Vector3, Wrench as WrenchMsg, WrenchStamped};
use r2r::sensor_msgs::msg::Image;
use r2r::std_msgs::msg::{Float64MultiArray, Header};
use tactile_force::control::JointState;
use tactile_force::kinematics::{JointVector, Twist as TwistVector};
use tactile_force::nodes::force_controller::tool_frame::StaticTransform;
use tactile_force::ros::convert::*;
use tactile_force::wrench::{Wrench, WrenchEstimate};

#[test]
fn a_static_transform_is_one_transform_from_its_parent_to_its_child() {
    let t = StaticTransform {
        parent: "link7".into(),
        child: "biotac".into(),
        translation: [0.1, -0.2, 0.09],
        rotation: [0.0, 0.6, 0.0, 0.8],
    };
    let m = tf_msg(12.25, &t);
    let [one] = m.transforms.as_slice() else {
        panic!("{m:?}")
    };
    assert_eq!(
        (one.header.stamp.sec, one.header.stamp.nanosec),
        (12, 250_000_000)
    );
    assert_eq!(
        (one.header.frame_id.as_str(), one.child_frame_id.as_str()),
        ("link7", "biotac")
    );
    let (v, q) = (&one.transform.translation, &one.transform.rotation);
    assert_eq!(
        [v.x, v.y, v.z, q.x, q.y, q.z, q.w],
        [0.1, -0.2, 0.09, 0.0, 0.6, 0.0, 0.8]
    );
}

#[test]
fn images_become_nail_frames_by_their_grey_or_green() {
    let image = |encoding: &str, step: u32, data: Vec<u8>| Image {
        header: Header {
            stamp: time_msg(1.5),
            frame_id: "nail".into(),
        },
        height: 2,
        width: 2,
        encoding: encoding.into(),
        is_bigendian: 0,
        step,
        data,
    };
    // Rows padded to 3 bytes.
    let f = nail_frame(&image("mono8", 3, vec![1, 2, 0, 3, 4, 0]), 7).unwrap();
    assert_eq!((f.pixels(), f.stamp_s, f.seq), (&[1, 2, 3, 4][..], 1.5, 7));
    let rgb = vec![9, 1, 9, 9, 2, 9, 9, 3, 9, 9, 4, 9];
    assert_eq!(
        nail_frame(&image("rgb8", 6, rgb), 0).unwrap().pixels(),
        &[1, 2, 3, 4]
    );
    let e = nail_frame(&image("16UC1", 4, vec![0; 8]), 0).unwrap_err();
    assert!(e.to_string().contains("16UC1"), "{e}");
    let e = nail_frame(&image("mono8", 2, vec![0; 3]), 0).unwrap_err();
    assert!(matches!(e, ConvertError::Length { found: 3, .. }), "{e}");
}

fn estimate() -> WrenchEstimate {
    let mean = Wrench {
        force: V3::new(0.1, -0.2, 1.5),
        torque: V3::new(0.0, 0.01, 0.0),
    };
    let std = Wrench {
        force: V3::new(0.05, 0.05, 0.04),
        torque: V3::zeros(),
    };
    WrenchEstimate {
        stamp_s: 3.5,
        seq: 9,
        mean,
        std,
        estimated: [true, true, true, false, false, false],
        pdc_rise: 42.0,
    }
}

#[test]
fn estimates_become_two_wrench_stamped_in_the_biotac_frame() {
    let (mean, std) = estimate_msgs(&estimate(), "biotac").unwrap();
    let expected = WrenchStamped {
        header: Header {
            stamp: Time {
                sec: 3,
                nanosec: 500_000_000,
            },
            frame_id: "biotac".into(),
        },
        wrench: WrenchMsg {
            force: Vector3 {
                x: 0.1,
                y: -0.2,
                z: 1.5,
            },
            torque: Vector3 {
                x: 0.0,
                y: 0.01,
                z: 0.0,
            },
        },
    };
    assert_eq!(mean, expected);
    assert_eq!(std.wrench.force.z, 0.04);
    assert_eq!(std.header, expected.header);
}

#[test]
fn nan_is_never_published_and_refused_on_input() {
    let mut e = estimate();
    e.mean.force.x = f64::NAN;
    assert!(estimate_msgs(&e, "biotac").is_none());
    let (mut m, _) = estimate_msgs(&estimate(), "biotac").unwrap();
    m.wrench.torque.y = f64::INFINITY;
    assert_eq!(
        wrench_from_msg(&m, "ft_sensor/wrench"),
        Err(ConvertError::NonFinite("ft_sensor/wrench"))
    );
    let c = commands_msg(&JointVector::from_element(6, f64::NAN));
    assert_eq!(c.data, vec![0.0; 6]);
    let t = twist_msg(1.0, "base_link", &TwistVector::repeat(f64::NAN));
    assert_eq!((t.twist.linear.x, t.twist.angular.z), (0.0, 0.0));
}

#[test]
fn joint_states_are_picked_by_name_in_any_order() {
    let names: Vec<String> = (1..=7).map(|i| format!("j{i}")).collect();
    let js = JointState {
        stamp_s: 1.25,
        q: JointVector::from_fn(7, |i, _| i as f64 * 0.1),
    };
    let m = joint_state_msg(&js, &names);
    assert_eq!(m.name, names);
    assert_eq!(
        m.header.stamp,
        Time {
            sec: 1,
            nanosec: 250_000_000
        }
    );
    assert_eq!(joint_state_from_msg(&m, &names).unwrap(), js);
    // Reversed, with an extra joint (a gripper) first.
    let mut r = m.clone();
    r.name.reverse();
    r.position.reverse();
    r.name.insert(0, "gripper".into());
    r.position.insert(0, 9.0);
    assert_eq!(joint_state_from_msg(&r, &names).unwrap(), js);
    let mut missing = m.clone();
    missing.position.pop();
    assert_eq!(
        joint_state_from_msg(&missing, &names),
        Err(ConvertError::MissingJoint("j7".into()))
    );
    let mut nan = m;
    nan.position[2] = f64::NAN;
    assert!(joint_state_from_msg(&nan, &names).is_err());
}

#[test]
fn commands_have_one_velocity_per_joint() {
    let qdot = JointVector::from_fn(7, |i, _| i as f64 - 3.0);
    let c = commands_msg(&qdot);
    assert_eq!(c.data, qdot.iter().copied().collect::<Vec<_>>());
    assert_eq!(c.layout.dim[0].size, 7);
    assert_eq!(qdot_from_msg(&c, 7).unwrap(), qdot);
    // Struct literals only: r2r's Default impls go through rcl, which
    // panics under `doc-only`.
    let short = Float64MultiArray {
        layout: c.layout.clone(),
        data: vec![0.0; 6],
    };
    assert!(matches!(
        qdot_from_msg(&short, 7),
        Err(ConvertError::Length { found: 6, .. })
    ));
    // A twist in the base frame, linear then angular.
    let t = twist_msg(
        2.5,
        "base_link",
        &TwistVector::new(0.1, 0.2, 0.3, 0.4, 0.5, 0.6),
    );
    assert_eq!(t.header.frame_id, "base_link");
    assert_eq!((t.twist.linear.z, t.twist.angular.x), (0.3, 0.4));
}
