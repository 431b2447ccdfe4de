//! ROS 2 parameter files (`node: ros__parameters: ...`). The embedded runtime
//! reads the same files as the ROS nodes, so one file configures both.

use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;

/// Errors reading a parameter file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ParamsError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// File path.
        path: PathBuf,
        /// Underlying error.
        source: std::io::Error,
    },
    /// Not YAML, or a key missing, unknown or of the wrong type.
    #[error("parameters of {node}: {source}")]
    Yaml {
        /// Node whose parameters were read.
        node: String,
        /// Parser error, naming the key.
        source: serde_yaml_ng::Error,
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
    let yaml_err = |source| ParamsError::Yaml {
        node: node.into(),
        source,
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

/// Reads a parameter file and deserialises the `ros__parameters` of `node`.
pub fn read_node_params<T: DeserializeOwned>(path: &Path, node: &str) -> Result<T, ParamsError> {
    let yaml = std::fs::read_to_string(path).map_err(|source| ParamsError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    node_params(&yaml, node)
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
}
