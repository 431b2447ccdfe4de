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

/// Deserialises the `ros__parameters` of `node` from a YAML text.
pub fn node_params<T: DeserializeOwned>(yaml: &str, node: &str) -> Result<T, ParamsError> {
    let yaml_err = |source| ParamsError::Yaml {
        node: node.into(),
        source,
    };
    let doc: serde_yaml_ng::Value = serde_yaml_ng::from_str(yaml).map_err(yaml_err)?;
    let params = doc
        .get(node)
        .and_then(|n| n.get("ros__parameters"))
        .ok_or_else(|| ParamsError::MissingNode { node: node.into() })?;
    serde_yaml_ng::from_value(params.clone()).map_err(yaml_err)
}

/// Reads a parameter file and deserialises the `ros__parameters` of `node`.
pub fn read_node_params<T: DeserializeOwned>(path: &Path, node: &str) -> Result<T, ParamsError> {
    let yaml = std::fs::read_to_string(path).map_err(|source| ParamsError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    node_params(&yaml, node)
}
