//! ROS 2 parameter files (`node: ros__parameters: ...`). The embedded runtime
//! reads the same files as the ROS nodes, so one file configures both.

pub mod reference;

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::Serialize;

use crate::exit::{Classify, ExitClass};

/// The shipped world file.
pub const WORLD_YAML: &str = include_str!("../config/world.yaml");
/// The shipped guarded-move scene.
pub const GUARDED_YAML: &str = include_str!("../config/guarded_move.yaml");
/// The shipped guided-move scene.
pub const GUIDED_YAML: &str = include_str!("../config/guided_move.yaml");
/// The shipped calibration scene.
pub const CALIBRATE_YAML: &str = include_str!("../config/calibrate.yaml");

/// Errors reading a parameter file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ParamsError {
    /// The file could not be read.
    #[error("{role} {path}: {error}")]
    Io {
        /// What the file is ("parameter file", "scene file", "URDF file").
        role: &'static str,
        /// File path.
        path: PathBuf,
        /// Underlying error (in the message, not a source: said once).
        error: std::io::Error,
    },
    /// Not YAML, or a key missing, unknown or of the wrong type.
    #[error("parameters of {node}: {error}")]
    Yaml {
        /// Node whose parameters were read.
        node: String,
        /// Parser error, naming the key (in the message, not a source).
        error: serde_yaml_ng::Error,
    },
    /// The file has no `node: ros__parameters:` section.
    #[error("no `{node}: ros__parameters:` section")]
    MissingNode {
        /// Node looked for.
        node: String,
    },
    /// A value outside its range.
    #[error("parameter {key} = {value}: expected {expected}")]
    Invalid {
        /// Dotted parameter name.
        key: String,
        /// Offending value.
        value: String,
        /// What is accepted.
        expected: String,
    },
}

/// A parameter file or value refused: refused input.
impl Classify for ParamsError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// Deserialises the `ros__parameters` of `node` from a YAML text. As in ROS 2,
/// parameters under the wildcard `/**` apply to every node; the node's own
/// section overrides them key by key.
pub fn node_params<T: DeserializeOwned>(yaml: &str, node: &str) -> Result<T, ParamsError> {
    layered_node_params(&[yaml], node)
}

/// Like [`node_params`] for several files given in order, as `ros2 run
/// --params-file a --params-file b`: later files override earlier ones key by
/// key. At least one file must have a section for `node`.
pub fn layered_node_params<T: DeserializeOwned>(
    yamls: &[&str],
    node: &str,
) -> Result<T, ParamsError> {
    let yaml_err = |error| ParamsError::Yaml {
        node: node.into(),
        error,
    };
    let mut params = serde_yaml_ng::Value::Null;
    let mut found = false;
    for yaml in yamls {
        let doc: serde_yaml_ng::Value = serde_yaml_ng::from_str(yaml).map_err(yaml_err)?;
        let section = |name: &str| doc.get(name).and_then(|n| n.get("ros__parameters"));
        if let Some(all) = section("/**") {
            merge(&mut params, all);
        }
        if let Some(own) = section(node) {
            merge(&mut params, own);
            found = true;
        }
    }
    if !found {
        return Err(ParamsError::MissingNode { node: node.into() });
    }
    serde_yaml_ng::from_value(params).map_err(yaml_err)
}

/// Overlays `top` on `base`: mappings merge key by key, anything else replaces.
fn merge(base: &mut serde_yaml_ng::Value, top: &serde_yaml_ng::Value) {
    match (base, top) {
        (serde_yaml_ng::Value::Mapping(b), serde_yaml_ng::Value::Mapping(t)) => {
            for (k, v) in t {
                match b.get_mut(k) {
                    Some(slot) => merge(slot, v),
                    None => {
                        b.insert(k.clone(), v.clone());
                    }
                }
            }
        }
        (b, t) => *b = t.clone(),
    }
}

/// The parameters of one node as ROS 2 holds them: flat, dotted names
/// (`objects.wooden_box.stiffness_n_per_m`), leaf values only. This is what
/// a ROS 2 node gets from its `--params-file`s and overrides.
pub type FlatParams = Vec<(String, serde_yaml_ng::Value)>;

/// Flattens the merged `ros__parameters` of `node` in `yamls` (layered as in
/// [`layered_node_params`]) into dotted names, as ROS 2 loads them. Used to
/// declare a ROS node's parameters with the shipped files' defaults.
pub fn layered_flat_params(yamls: &[&str], node: &str) -> Result<FlatParams, ParamsError> {
    let params: serde_yaml_ng::Value = layered_node_params(yamls, node)?;
    let mut out = Vec::new();
    flatten("", &params, &mut out);
    Ok(out)
}

fn flatten(prefix: &str, value: &serde_yaml_ng::Value, out: &mut FlatParams) {
    match value {
        serde_yaml_ng::Value::Mapping(m) if !m.is_empty() => {
            for (k, v) in m {
                let key = match k {
                    serde_yaml_ng::Value::String(s) => s.clone(),
                    other => serde_yaml_ng::to_string(other)
                        .unwrap_or_default()
                        .trim()
                        .to_string(),
                };
                let name = if prefix.is_empty() {
                    key
                } else {
                    format!("{prefix}.{key}")
                };
                flatten(&name, v, out);
            }
        }
        leaf => out.push((prefix.to_string(), leaf.clone())),
    }
}

/// True when `name` is one of `names`, where `g.*` stands for every
/// parameter of the group `g`.
pub fn is_named(names: &[String], name: &str) -> bool {
    names.iter().any(|n| match n.strip_suffix('*') {
        Some(group) => name.starts_with(group),
        None => n == name,
    })
}

/// `params` with the flat, dotted parameter `name` set to `value`, read
/// back by the same path as a node's start-up parameters
/// ([`from_flat_params`]); an error names a parameter `params` lacks.
pub fn with_flat_param<T: Serialize + DeserializeOwned>(
    params: &T,
    name: &str,
    value: serde_yaml_ng::Value,
    node: &str,
) -> Result<T, ParamsError> {
    let tree = serde_yaml_ng::to_value(params).map_err(|error| ParamsError::Yaml {
        node: node.into(),
        error,
    })?;
    let mut flat = Vec::new();
    flatten("", &tree, &mut flat);
    let slot = flat
        .iter_mut()
        .find(|(n, _)| n == name)
        .ok_or_else(|| ParamsError::Invalid {
            key: name.into(),
            value: "an unknown parameter".into(),
            expected: format!("a parameter of {node}"),
        })?;
    slot.1 = value;
    from_flat_params(&flat, node)
}

/// Deserialises flat, dotted parameters (as a ROS 2 node holds them) into
/// the node's checked parameter type: the names are nested back into
/// mappings, so the same serde structs (and their `deny_unknown_fields`)
/// check a ROS node's parameters and the embedded runtime's files.
pub fn from_flat_params<T: DeserializeOwned>(
    params: &[(String, serde_yaml_ng::Value)],
    node: &str,
) -> Result<T, ParamsError> {
    let mut root = serde_yaml_ng::Mapping::new();
    for (name, value) in params {
        let mut parts = name.split('.').peekable();
        let mut map = &mut root;
        while let Some(part) = parts.next() {
            let key = serde_yaml_ng::Value::String(part.to_string());
            if parts.peek().is_none() {
                map.insert(key, value.clone());
                break;
            }
            let slot = map
                .entry(key)
                .or_insert_with(|| serde_yaml_ng::Value::Mapping(Default::default()));
            if !slot.is_mapping() {
                return Err(ParamsError::Invalid {
                    key: name.clone(),
                    value: "a value and a group of parameters".into(),
                    expected: format!("either `{part}` or `{part}.*`, not both"),
                });
            }
            map = match slot {
                serde_yaml_ng::Value::Mapping(m) => m,
                _ => unreachable!("checked above"),
            };
        }
    }
    serde_yaml_ng::from_value(serde_yaml_ng::Value::Mapping(root)).map_err(|error| {
        ParamsError::Yaml {
            node: node.into(),
            error,
        }
    })
}

/// Reads a parameter file and deserialises the `ros__parameters` of `node`.
pub fn read_node_params<T: DeserializeOwned>(path: &Path, node: &str) -> Result<T, ParamsError> {
    let yaml = std::fs::read_to_string(path).map_err(|error| ParamsError::Io {
        role: "parameter file",
        path: path.to_path_buf(),
        error,
    })?;
    node_params(&yaml, node)
}

/// Parameters whose values passed their range check: made only by
/// [`Check::checked`], so a function taking `Checked<T>` needs no check of
/// its own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Checked<T>(T);

impl<T> std::ops::Deref for Checked<T> {
    type Target = T;

    fn deref(&self) -> &T {
        &self.0
    }
}

/// Parameters with a range check.
pub trait Check: Sized {
    /// Checks the values (`key`: the section's dotted name, which errors
    /// name) and may normalise them.
    fn check(self, key: &str) -> Result<Self, ParamsError>;

    /// The checked parameters, or the first value out of range.
    fn checked(self, key: &str) -> Result<Checked<Self>, ParamsError> {
        self.check(key).map(Checked)
    }
}

/// `v` finite and > 0, or an error naming `key`.
pub(crate) fn positive(key: &str, v: f64) -> Result<(), ParamsError> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(invalid(key, v, "a finite value > 0"))
    }
}

/// `Ok` when `ok`, else the error for `key`.`name` = `value`, which is not
/// `expected`.
pub(crate) fn require(
    key: &str,
    name: &str,
    value: impl std::fmt::Display,
    ok: bool,
    expected: &str,
) -> Result<(), ParamsError> {
    if ok {
        return Ok(());
    }
    Err(ParamsError::Invalid {
        key: format!("{key}.{name}"),
        value: value.to_string(),
        expected: expected.into(),
    })
}

/// An edit that puts one field of parameters out of range.
#[cfg(test)]
pub(crate) type Edit<T> = fn(&mut T);

/// Asserts that each edit of `T::default()` in `cases` (the field it puts
/// out of range, the edit) is refused naming `key`.field.
#[cfg(test)]
pub(crate) fn assert_each_refused<T>(key: &str, cases: &[(&str, Edit<T>)])
where
    T: Check + Default + std::fmt::Debug,
{
    for (field, edit) in cases {
        let mut p = T::default();
        edit(&mut p);
        match p.checked(key) {
            Err(ParamsError::Invalid { key: k, .. }) => assert_eq!(k, format!("{key}.{field}")),
            other => panic!("{field}: {other:?}"),
        }
    }
}

/// The error for `key` = `v`, which is not `expected`.
pub(crate) fn invalid(key: &str, v: f64, expected: &str) -> ParamsError {
    ParamsError::Invalid {
        key: key.into(),
        value: v.to_string(),
        expected: expected.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize, PartialEq)]
    struct Gains {
        kp: f64,
        kd: f64,
    }

    #[derive(Debug, Deserialize, PartialEq)]
    struct Section {
        rate_hz: f64,
        gains: Gains,
    }

    #[test]
    fn wildcard_parameters_apply_to_every_node_and_the_node_overrides_them() {
        let yaml = "
/**:
  ros__parameters:
    rate_hz: 100.0
    gains: {kp: 1.0, kd: 0.1}
ctrl:
  ros__parameters:
    gains: {kd: 0.5}
";
        let s: Section = node_params(yaml, "ctrl").unwrap();
        assert_eq!(
            s,
            Section {
                rate_hz: 100.0,
                gains: Gains { kp: 1.0, kd: 0.5 }
            }
        );
        let err = node_params::<Section>(yaml, "other").unwrap_err();
        assert!(matches!(err, ParamsError::MissingNode { .. }), "{err}");
    }

    #[test]
    fn later_files_override_earlier_ones() {
        let base = "ctrl:\n  ros__parameters:\n    rate_hz: 100.0\n    gains: {kp: 1.0, kd: 0.1}\n";
        let scene = "/**:\n  ros__parameters:\n    gains: {kp: 2.0}\n";
        let s: Section = layered_node_params(&[base, scene], "ctrl").unwrap();
        assert_eq!(s.gains, Gains { kp: 2.0, kd: 0.1 });
        let err = layered_node_params::<Section>(&[scene], "ctrl").unwrap_err();
        assert!(matches!(err, ParamsError::MissingNode { .. }), "{err}");
    }

    #[test]
    fn a_missing_key_is_named() {
        let yaml = "ctrl:\n  ros__parameters:\n    rate_hz: 100.0\n";
        let err = node_params::<Section>(yaml, "ctrl")
            .unwrap_err()
            .to_string();
        assert!(err.contains("gains"), "{err}");
    }

    #[test]
    fn flat_parameters_nest_back_into_the_same_struct() {
        let yaml = "
/**:
  ros__parameters:
    rate_hz: 100.0
ctrl:
  ros__parameters:
    gains: {kp: 1.0, kd: 0.5}
";
        let flat = layered_flat_params(&[yaml], "ctrl").unwrap();
        let names: Vec<&str> = flat.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["rate_hz", "gains.kp", "gains.kd"]);
        let s: Section = from_flat_params(&flat, "ctrl").unwrap();
        assert_eq!(s, node_params::<Section>(yaml, "ctrl").unwrap());
        // An integer where a double is expected is accepted, as ROS may
        // hand `kp: 2` over as an integer parameter.
        let mut flat = flat;
        flat[1].1 = serde_yaml_ng::Value::Number(2.into());
        let s: Section = from_flat_params(&flat, "ctrl").unwrap();
        assert_eq!(s.gains.kp, 2.0);
    }

    #[test]
    fn a_name_that_is_both_a_value_and_a_group_is_refused() {
        let flat = vec![
            ("gains".to_string(), serde_yaml_ng::Value::Number(1.into())),
            (
                "gains.kp".to_string(),
                serde_yaml_ng::Value::Number(1.into()),
            ),
        ];
        let err = from_flat_params::<Section>(&flat, "ctrl").unwrap_err();
        assert!(matches!(err, ParamsError::Invalid { .. }), "{err}");
    }
}
