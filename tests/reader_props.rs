//! Property tests of the readers of a user's robot files: the URDF (the
//! robot description) and the parameter files (ROS 2 YAML: the world, the
//! robot's, a scene). Arbitrary bytes, cut files, flipped bytes and valid
//! files with one value replaced: the reader answers without a panic, a
//! robot or a scene it accepts can be used, and an error says what it
//! refused. (The model file and the MCAP reader have theirs beside their
//! unit tests; the wire decoder in tests/wire_props.rs, the ROS 1 reader in
//! tests/ros1_bags.rs.)

use proptest::prelude::*;
use serde_yaml_ng::Value;
use tactile_force::control::TaskKind;
use tactile_force::kinematics::{Robot, ShippedRobot};
use tactile_force::runtime::Scene;

fn pa10() -> &'static str {
    ShippedRobot::Pa10.urdf()
}

/// The robot of a URDF text, with the PA10's parameters but the URDF's own
/// root and leaf (so a changed link name is still looked for).
fn robot(text: &str) -> Result<Robot, String> {
    let mut p = ShippedRobot::Pa10.robot_params().unwrap();
    p.base_link.clear();
    p.tip_link.clear();
    Robot::from_urdf(text, &p).map_err(|e| e.to_string())
}

/// A robot the reader accepted moves without a panic: its pose and
/// Jacobian at the middle of its joints' ranges.
fn usable(r: &Robot) {
    let q = r.middle();
    let _ = r.chain.forward(&q);
    let _ = r.chain.jacobian(&q);
}

/// The byte ranges of the attribute values of a URDF text (`="..."`).
fn attribute_values(text: &str) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(i) = text[from..].find("=\"") {
        let start = from + i + 2;
        let Some(len) = text[start..].find('"') else {
            break;
        };
        out.push((start, start + len));
        from = start + len + 1;
    }
    out
}

/// Odd attribute values: not numbers, not finite, too few or too many
/// numbers, another link's name (a joint that loops, or a second parent),
/// a joint type the chain cannot hold.
static ODD_ATTRIBUTES: [&str; 14] = [
    "nan",
    "inf",
    "-inf",
    "-1",
    "0",
    "1e308",
    "",
    "0 0 0",
    "1 2",
    "1 2 3 4",
    "base_link",
    "link3",
    "floating",
    "planar",
];

fn any_attribute() -> impl Strategy<Value = String> {
    prop_oneof![
        proptest::sample::select(&ODD_ATTRIBUTES[..]).prop_map(str::to_string),
        any::<f64>().prop_map(|v| v.to_string()),
        "[a-z0-9 .<>&-]{0,8}",
    ]
}

/// The text of the shipped scene layers of `task` with the PA10.
fn layers(task: TaskKind) -> [&'static str; 3] {
    task.shipped_layers(ShippedRobot::Pa10)
}

/// Every leaf of a YAML tree, by its path of keys.
fn leaves(v: &Value, at: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    match v {
        Value::Mapping(m) if !m.is_empty() => {
            for (k, c) in m {
                at.push(k.clone());
                leaves(c, at, out);
                at.pop();
            }
        }
        _ => out.push(at.clone()),
    }
}

fn any_value() -> impl Strategy<Value = Value> {
    prop_oneof![
        Just(Value::Null),
        Just(Value::from(f64::NAN)),
        Just(Value::from(f64::INFINITY)),
        Just(Value::from(-1.0)),
        Just(Value::from(0)),
        Just(Value::from(1e300)),
        Just(Value::from("wooden_box")),
        Just(Value::Sequence(Vec::new())),
        Just(Value::Mapping(Default::default())),
        any::<bool>().prop_map(Value::from),
        any::<f64>().prop_map(Value::from),
        "[a-z_]{0,8}".prop_map(Value::from),
    ]
}

/// The scene of `texts`, checked as `demo` checks it before any work.
fn scene(texts: &[&str]) -> Result<(), String> {
    let s = Scene::layered(texts, pa10()).map_err(|e| e.to_string())?;
    s.check().map_err(|e| e.to_string())
}

/// A refused scene's message says which parameter, or which node's file.
fn names_a_parameter(msg: &str) -> bool {
    msg.starts_with("parameter ")
        || msg.starts_with("parameters of ")
        || msg.starts_with("no `")
        || msg.starts_with("robot description: ")
        || msg.contains("sim_robot.")
        || msg.contains("the model estimates")
}

/// Found by the property tests below: a settle time of 1e300 s and a
/// control period of 2.3e-68 s passed their checks and overflowed the
/// allocator when the window of estimates was made (a panic, "capacity
/// overflow"); a physics rate of 1e300 Hz would have stepped the simulator
/// for ever. Each is refused, naming it.
#[test]
fn windows_and_steps_beyond_reason_are_refused_before_they_are_made() {
    let [world, robot_file, own] = layers(TaskKind::Guarded);
    for (extra, key) in [
        (
            "/**:\n  ros__parameters:\n    control_period_s: 2.3e-68\n",
            "parameter control_period_s = ",
        ),
        (
            "sim_robot:\n  ros__parameters:\n    physics_rate_hz: 1.0e300\n",
            "parameter physics_rate_hz = ",
        ),
        (
            "force_controller:\n  ros__parameters:\n    guarded:\n      settle_time_s: 1.0e300\n",
            "parameter guarded.settle_time_s = ",
        ),
    ] {
        let e = scene(&[world, robot_file, own, extra]).unwrap_err();
        assert!(e.starts_with(key), "{e}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn arbitrary_text_is_not_a_robot(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes);
        let e = robot(&text).expect_err("arbitrary text is not a URDF");
        prop_assert!(e.starts_with("robot description: "), "{}", e);
    }

    #[test]
    fn a_cut_urdf_is_refused(cut in 0.0..1.0f64) {
        // Short of the closing `>`: trailing whitespace is no loss.
        let text = pa10().trim_end();
        let mut at = (cut * text.len() as f64) as usize;
        while !text.is_char_boundary(at) {
            at -= 1;
        }
        let e = robot(&text[..at]).expect_err("a cut URDF is not a robot");
        prop_assert!(e.starts_with("robot description: "), "{}", e);
    }

    #[test]
    fn a_flipped_byte_gives_a_usable_robot_or_an_error(at in 0.0..1.0f64, bit in 0u8..7) {
        let mut bytes = pa10().as_bytes().to_vec();
        let i = (at * bytes.len() as f64) as usize;
        bytes[i] ^= 1 << bit;
        match robot(&String::from_utf8_lossy(&bytes)) {
            Ok(r) => usable(&r),
            Err(e) => prop_assert!(!e.is_empty()),
        }
    }

    #[test]
    fn an_attribute_replaced_gives_a_usable_robot_or_says_why(which in 0.0..1.0f64, by in any_attribute()) {
        let text = pa10();
        let spans = attribute_values(text);
        let (a, b) = spans[(which * spans.len() as f64) as usize];
        let changed = format!("{}{}{}", &text[..a], by, &text[b..]);
        match robot(&changed) {
            Ok(r) => usable(&r),
            Err(e) => prop_assert!(
                e.starts_with("robot description: ") || e.starts_with("parameter robot."),
                "{}", e
            ),
        }
    }

    #[test]
    fn arbitrary_text_in_a_scene_file_is_refused_naming_the_file(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let text = String::from_utf8_lossy(&bytes);
        let [world, robot_file, _] = layers(TaskKind::Guarded);
        let e = scene(&[world, robot_file, &text]).err();
        // Text without a node's section is no scene: the world's defaults
        // and the robot's file alone have no task section.
        if let Some(e) = e {
            prop_assert!(names_a_parameter(&e), "{}", e);
        }
    }

    #[test]
    fn a_cut_or_flipped_scene_file_is_taken_or_refused_saying_why(cut in 0.0..1.0f64,
                                                                  flip in proptest::option::of((0.0..1.0f64, 0u8..7))) {
        let [world, robot_file, own] = layers(TaskKind::Guarded);
        let mut bytes = own.as_bytes()[..(cut * own.len() as f64) as usize].to_vec();
        if let (Some((at, bit)), false) = (flip, bytes.is_empty()) {
            let i = (at * bytes.len() as f64) as usize;
            bytes[i] ^= 1 << bit;
        }
        let text = String::from_utf8_lossy(&bytes);
        if let Err(e) = scene(&[world, robot_file, &text]) {
            prop_assert!(names_a_parameter(&e), "{}", e);
        }
    }

    #[test]
    fn a_parameter_replaced_is_taken_or_refused_naming_it(task in 0usize..3, layer in 0usize..3,
                                                          which in 0.0..1.0f64, by in any_value()) {
        let task = [TaskKind::Guarded, TaskKind::Guided, TaskKind::Calibrate][task];
        let mut texts: Vec<String> = layers(task).iter().map(|t| t.to_string()).collect();
        let mut doc: Value = serde_yaml_ng::from_str(&texts[layer]).unwrap();
        let mut all = Vec::new();
        leaves(&doc, &mut Vec::new(), &mut all);
        let path = &all[(which * all.len() as f64) as usize];
        let slot = path.iter().fold(&mut doc, |v, k| v.get_mut(k).unwrap());
        *slot = by;
        texts[layer] = serde_yaml_ng::to_string(&doc).unwrap();
        let refs: Vec<&str> = texts.iter().map(String::as_str).collect();
        if let Err(e) = scene(&refs) {
            prop_assert!(names_a_parameter(&e), "{} (changed {:?})", e, path);
        }
    }
}
