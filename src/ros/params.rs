//! ROS 2 parameters <-> our checked parameter structs. A node declares its
//! parameters with the shipped files' values as defaults; r2r has already
//! loaded the `--params-file`s and overrides given at launch. The flat,
//! dotted parameters are then nested and deserialised by the same serde
//! structs the embedded runtime uses ([`crate::params::from_flat_params`]),
//! so one code path checks both. Parameters are read once, at start-up;
//! a set while the node runs is refused, except for those the node names
//! live ([`RuntimeParams`]), which it applies or refuses with a reason.
//! Sets beyond the rate of [`PARAMETER_SETS`] are refused first.

use std::sync::Arc;

use r2r::{Parameter, ParameterValue};
use serde::de::DeserializeOwned;
use serde_yaml_ng::Value;

use crate::nodes::bounds::InputGuard;
#[cfg(doc)]
use crate::nodes::bounds::PARAMETER_SETS;
use crate::params::{from_flat_params, is_named, FlatParams, ParamsError};

/// A ROS parameter value as YAML; None for an unset parameter.
pub fn to_yaml(v: &ParameterValue) -> Option<Value> {
    let seq = |it: Vec<Value>| Some(Value::Sequence(it));
    match v {
        ParameterValue::NotSet => None,
        ParameterValue::Bool(b) => Some(Value::Bool(*b)),
        ParameterValue::Integer(i) => Some(Value::Number((*i).into())),
        ParameterValue::Double(d) => Some(Value::Number((*d).into())),
        ParameterValue::String(s) => Some(Value::String(s.clone())),
        ParameterValue::BoolArray(a) => seq(a.iter().map(|b| Value::Bool(*b)).collect()),
        ParameterValue::ByteArray(a) => seq(a.iter().map(|b| Value::Number((*b).into())).collect()),
        ParameterValue::IntegerArray(a) => {
            seq(a.iter().map(|i| Value::Number((*i).into())).collect())
        }
        ParameterValue::DoubleArray(a) => {
            seq(a.iter().map(|d| Value::Number((*d).into())).collect())
        }
        ParameterValue::StringArray(a) => seq(a.iter().map(|s| Value::String(s.clone())).collect()),
    }
}

/// A YAML leaf as a ROS parameter value (what a ROS 2 parameter file gives
/// for it); None for what ROS parameters cannot hold (mixed or nested lists).
pub fn from_yaml(v: &Value) -> Option<ParameterValue> {
    match v {
        Value::Bool(b) => Some(ParameterValue::Bool(*b)),
        Value::Number(n) => match n.as_i64() {
            Some(i) => Some(ParameterValue::Integer(i)),
            None => n.as_f64().map(ParameterValue::Double),
        },
        Value::String(s) => Some(ParameterValue::String(s.clone())),
        Value::Sequence(a) => {
            if let Some(b) = a.iter().map(Value::as_bool).collect::<Option<Vec<_>>>() {
                Some(ParameterValue::BoolArray(b))
            } else if let Some(i) = a.iter().map(Value::as_i64).collect::<Option<Vec<_>>>() {
                Some(ParameterValue::IntegerArray(i))
            } else if let Some(d) = a.iter().map(Value::as_f64).collect::<Option<Vec<_>>>() {
                Some(ParameterValue::DoubleArray(d))
            } else {
                a.iter()
                    .map(|s| s.as_str().map(str::to_string))
                    .collect::<Option<Vec<_>>>()
                    .map(ParameterValue::StringArray)
            }
        }
        _ => None,
    }
}

/// Parameters every ROS node may carry that our structs do not know.
fn is_ros_internal(name: &str) -> bool {
    name == "use_sim_time"
        || name.starts_with("qos_overrides.")
        || name == "start_type_description_service"
}

/// Declares `defaults` (absent ones only: launch-time values win), each
/// with the description `describe` gives for its name, which those given
/// at launch take too (kept for the process's life, as r2r's parameters
/// hold them: once per parameter, at start-up).
pub fn declare(
    params: &mut indexmap::IndexMap<String, Parameter>,
    defaults: &FlatParams,
    describe: &dyn Fn(&str) -> String,
) {
    for (name, value) in defaults {
        let description = describe(name).leak();
        match params.get_mut(name) {
            Some(given) => given.description = description,
            None => {
                if let Some(value) = from_yaml(value) {
                    params.insert(name.clone(), Parameter { value, description });
                }
            }
        }
    }
}

/// The node's parameters, minus ROS's own and those in `skip` (the
/// adapter's, read separately), as flat YAML values.
pub fn flat(params: &indexmap::IndexMap<String, Parameter>, skip: &[&str]) -> FlatParams {
    params
        .iter()
        .filter(|(name, _)| !is_ros_internal(name) && !skip.contains(&name.as_str()))
        .filter_map(|(name, p)| to_yaml(&p.value).map(|v| (name.clone(), v)))
        .collect()
}

/// Reads the node's checked parameters.
pub fn read<T: DeserializeOwned>(
    params: &indexmap::IndexMap<String, Parameter>,
    skip: &[&str],
    node: &str,
) -> Result<T, ParamsError> {
    from_flat_params(&flat(params, skip), node)
}

/// Applies (`true`) or only checks (`false`) a new value of a live
/// parameter; an error refuses it, with the reason.
pub type ApplyParam = Box<dyn Fn(&str, &ParameterValue, bool) -> Result<(), String> + Send>;

/// How a running node answers `set_parameters`: a set beyond the rate
/// its `guard` admits is refused with the rate; the parameters named live
/// go to the node, which applies or refuses them; every other is refused
/// with "read at start-up only".
pub struct RuntimeParams {
    live: Vec<String>,
    apply: ApplyParam,
    guard: Arc<InputGuard>,
    unconfigured: Option<Unconfigured>,
}

/// A managed node's rule for sets while it is unconfigured: any parameter
/// it declared but those read at start only may be set, for its next
/// `configure` (which checks it).
struct Unconfigured {
    now: Box<dyn Fn() -> bool + Send>,
    start_only: &'static [&'static str],
    declared: super::ParamMap,
}

impl RuntimeParams {
    /// `live` parameters (a group `g` as `g.*`) go to `apply`, as `guard`
    /// admits them.
    pub fn new(live: &[impl AsRef<str>], apply: ApplyParam, guard: &Arc<InputGuard>) -> Self {
        RuntimeParams {
            live: live.iter().map(|l| l.as_ref().to_string()).collect(),
            apply,
            guard: guard.clone(),
            unconfigured: None,
        }
    }

    /// While `now` says the node is unconfigured, any parameter it
    /// `declared` but those in `start_only` may be set: the next lifecycle
    /// `configure` reads and checks it.
    pub fn unless_unconfigured(
        self,
        now: Box<dyn Fn() -> bool + Send>,
        start_only: &'static [&'static str],
        declared: super::ParamMap,
    ) -> Self {
        let unconfigured = Some(Unconfigured {
            now,
            start_only,
            declared,
        });
        RuntimeParams {
            unconfigured,
            ..self
        }
    }

    /// No parameter may change while the node runs.
    pub fn none(guard: &Arc<InputGuard>) -> Self {
        RuntimeParams::new(&[] as &[&str], Box::new(|_, _, _| Ok(())), guard)
    }

    fn answer(&self, name: &str, value: &ParameterValue, apply: bool) -> r2r::Result<()> {
        let refused = |msg: String| r2r::Error::ParameterValueConv {
            name: name.into(),
            msg,
        };
        self.guard
            .admit_parameter_set()
            .map_err(|e| refused(format!("refused: {e}")))?;
        if let Some(u) = self.unconfigured.as_ref().filter(|u| (u.now)()) {
            if !super::lock(&u.declared).contains_key(name) {
                return Err(refused("not a parameter of this node".into()));
            }
            return match u.start_only.contains(&name) {
                true => Err(refused(
                    "read at process start only: restart the node to change it".into(),
                )),
                false => Ok(()),
            };
        }
        if !is_named(&self.live, name) {
            let live = match self.live.as_slice() {
                [] => "none".to_string(),
                l => l.join(", "),
            };
            return Err(refused(format!(
                "read at start-up only: restart the node to change it \
                 (may change while running: {live})"
            )));
        }
        (self.apply)(name, value, apply).map_err(refused)
    }
}

impl r2r::RosParams for RuntimeParams {
    fn register_parameters(
        &mut self,
        _prefix: &str,
        _param: Option<Parameter>,
        _params: &mut indexmap::IndexMap<String, Parameter>,
    ) -> r2r::Result<()> {
        // Declared already, from the shipped files (declare()).
        Ok(())
    }

    fn get_parameter(&mut self, name: &str) -> r2r::Result<ParameterValue> {
        // The node's parameter map answers.
        Err(r2r::Error::InvalidParameterName { name: name.into() })
    }

    fn set_parameter(&mut self, name: &str, value: &ParameterValue) -> r2r::Result<()> {
        self.answer(name, value, true)
    }

    fn check_parameter(&self, name: &str, value: &ParameterValue) -> r2r::Result<()> {
        self.answer(name, value, false)
    }
}
