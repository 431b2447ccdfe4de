//! ROS 2 adapters (feature `ros2`), in the style of openrr's `arci-ros2`:
//! one small file per node, each moving messages between r2r and the
//! transport-free node structs of [`crate::nodes`], which stay unchanged.
//!
//! A tokio runtime drives every node: the subscriptions, services and timers
//! are tasks; one blocking task spins the r2r node. Each node reads its
//! parameters once, at start-up, into the same checked structs as the
//! embedded runtime ([`params`]).
//!
//! - [`wrench_estimator`]: `biotac/readings` -> `biotac/wrench_estimate` (and its mean on `biotac/wrench`);
//! - [`force_controller`]: estimates + `joint_states` -> `velocity_controller/commands`;
//! - [`biotac_driver`]: serial port -> `biotac/readings`, diagnostics, `~/tare`;
//! - [`sim_robot`]: simulated arm, object or finger, F/T sensor and BioTac.

#[cfg(not(feature = "ros2-doc-only"))]
pub mod action_server;
pub mod biotac_driver;
pub mod bounded;
pub mod convert;
pub mod description;
pub mod ending;
pub mod force_controller;
pub mod inputs;
pub mod lifecycle;
pub mod log;
pub mod params;
pub mod sim_robot;
pub mod wrench_estimator;

use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::control::TaskRegistry;
use crate::exit::{Classify, ExitClass};
use crate::kinematics::RobotError;
use crate::learn::default_model::DefaultModelError;
use crate::learn::models::wrench_gp::ModelError;
use crate::nodes::input_watch::Publisher;
use crate::nodes::own_params::{self, OwnParam};
use crate::nodes::param_reference::RosNode;
use crate::nodes::wrench_estimator::EstimatorError;
use crate::outputs::models_dir::ModelsDir;
use crate::params::ParamsError;
use params::RuntimeParams;

// `use_sim_time` works only if r2r was built with rosgraph_msgs/Clock. r2r
// 0.9.7's build script says so only when it generates its bindings, not when
// it reuses them from an earlier run in the same target/: r2r is then built
// without simulated time and ignores `use_sim_time:=true`. A build error
// instead ("'rosgraph_msgs' dependency is missing"); `cargo clean -p r2r
// --release` then builds it whole.
#[cfg(not(feature = "ros2-doc-only"))]
r2r::assert_compiled_with_use_sim_time_support!();

/// The main of a node executable: logs through ROS logging ([`log`]), runs
/// `node` on a tokio runtime, hearing signals and panics from its start
/// ([`ending`]), and turns its end into the exit code (0 after SIGINT or
/// SIGTERM; 1, with the reason, on an error). Threads still blocked at the
/// end are not waited for.
pub fn main<F, Fut>(name: &str, node: F) -> std::process::ExitCode
where
    F: FnOnce(ending::Endings) -> Fut,
    Fut: std::future::Future<Output = Result<(), RosError>>,
{
    log::init(name);
    let ended = match tokio::runtime::Runtime::new() {
        Ok(rt) => {
            let ended = rt.block_on(async { node(ending::Endings::listen()?).await });
            rt.shutdown_timeout(Duration::from_millis(500));
            ended
        }
        Err(e) => Err(RosError::Runtime(e)),
    };
    match ended {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            tracing::error!("{e}");
            std::process::ExitCode::from(e.class().code())
        }
    }
}

/// Errors starting or running a ROS node.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RosError {
    /// From r2r (rcl): node, topic, service or clock.
    #[error("ROS: {0}")]
    R2r(#[from] r2r::Error),
    /// A parameter is missing, unknown or out of range.
    #[error(transparent)]
    Params(#[from] ParamsError),
    /// The robot description given as a parameter, or the robot's parameters.
    #[error(transparent)]
    Robot(#[from] RobotError),
    /// The model file cannot be read or is not a model.
    #[error(transparent)]
    Model(#[from] ModelError),
    /// The default model could not be made.
    #[error(transparent)]
    DefaultModel(#[from] DefaultModelError),
    /// The model cannot serve the estimator.
    #[error(transparent)]
    Estimator(#[from] EstimatorError),
    /// The estimator's `input` names no source it can read.
    #[error(transparent)]
    Source(#[from] crate::nodes::wrench_estimator::reading_source::SourceError),
    /// The tokio runtime could not start.
    #[error("tokio runtime: {0}")]
    Runtime(std::io::Error),
    /// A task of the node ended abnormally.
    #[error("node task: {0}")]
    Join(#[from] tokio::task::JoinError),
    /// The BioTac driver stopped on a fatal error (a missing Cheetah
    /// library, a sensor the reading type cannot hold).
    #[error("BioTac driver: {0}")]
    Driver(String),
    /// A thread of the node panicked (Rust's report of it came first).
    #[error("a thread panicked: the node ended")]
    Panicked,
}

impl From<crate::nodes::force_controller::DescriptionError> for RosError {
    fn from(e: crate::nodes::force_controller::DescriptionError) -> Self {
        use crate::nodes::force_controller::DescriptionError as D;
        match e {
            D::Robot(r) => RosError::Robot(r),
            D::Params(p) => RosError::Params(p),
            other => RosError::Params(ParamsError::Invalid {
                key: "robot_description".into(),
                value: "a new description".into(),
                expected: other.to_string(),
            }),
        }
    }
}

/// The process's exit code ([`crate::exit`]): each wrapped error says its
/// own (a refused parameter, robot or model file exits 2 before anything
/// starts, as on the command line); rcl, tokio and a node task that ended
/// abnormally are failures.
impl Classify for RosError {
    fn class(&self) -> ExitClass {
        match self {
            RosError::Params(e) => e.class(),
            RosError::Robot(e) => e.class(),
            RosError::Model(e) => e.class(),
            RosError::DefaultModel(e) => e.class(),
            RosError::Estimator(e) => e.class(),
            RosError::Source(e) => e.class(),
            RosError::R2r(_) | RosError::Runtime(_) | RosError::Join(_) | RosError::Panicked => {
                ExitClass::Failure
            }
            // Only configuration stops the driver: refused input.
            RosError::Driver(_) => ExitClass::Refused,
        }
    }
}

/// Creates the node `name`; r2r reads `--ros-args` (parameter files,
/// overrides, remappings) from the process arguments.
pub fn create_node(name: &str) -> Result<r2r::Node, RosError> {
    let ctx = r2r::Context::create()?;
    let mut node = r2r::Node::create(ctx, name, "")?;
    log::attach(&mut node)?;
    Ok(node)
}

/// The node's ROS clock: system time, or `/clock` when `use_sim_time` is true.
#[derive(Clone)]
pub struct RosClock(Arc<Mutex<r2r::Clock>>);

impl RosClock {
    /// The clock of `node` (it follows `/clock` under `use_sim_time:=true`).
    pub fn of(node: &r2r::Node) -> Self {
        RosClock(node.get_ros_clock())
    }

    /// Seconds on the clock; NaN if it cannot be read (the controller's
    /// watchdog then halts) or if `/clock` has not ticked yet (0).
    pub fn now_s(&self) -> f64 {
        let mut clock = lock(&self.0);
        match clock.get_now().map(|d| d.as_secs_f64()) {
            Ok(t) if t > 0.0 => t,
            _ => f64::NAN,
        }
    }
}

/// Serves the node's parameter services, answering a set while running as
/// `live` says, and returns the node's clock (which follows `/clock` when
/// the node was started with `use_sim_time:=true`).
pub fn serve_parameters(node: &mut r2r::Node, live: RuntimeParams) -> Result<RosClock, RosError> {
    let (handler, _events) = node.make_derived_parameter_handler(Arc::new(Mutex::new(live)))?;
    tokio::spawn(handler);
    Ok(RosClock::of(node))
}

/// A node's parameter map, as r2r keeps it.
pub type ParamMap = Arc<Mutex<indexmap::IndexMap<String, r2r::Parameter>>>;

/// What holds a node's parameters: the node, or its map kept to read them
/// again later (a lifecycle `configure`, the node being spun by then).
pub trait HasParams {
    /// The parameter map.
    fn param_map(&self) -> &ParamMap;
}

impl HasParams for r2r::Node {
    fn param_map(&self) -> &ParamMap {
        &self.params
    }
}

impl HasParams for ParamMap {
    fn param_map(&self) -> &ParamMap {
        self
    }
}

/// Declares the parameters of `shared` with the shipped files' values as
/// defaults and their descriptions (a controller's with those of `tasks`),
/// and reads them into `T`, the adapter's own parameters (read
/// separately) left out.
pub fn node_params<T: serde::de::DeserializeOwned>(
    node: &impl HasParams,
    shared: RosNode,
    tasks: &TaskRegistry,
) -> Result<T, RosError> {
    let defaults = shared.defaults()?;
    let own = shared.own_names();
    let skip: Vec<&str> = own.iter().map(String::as_str).collect();
    let mut p = lock(node.param_map());
    params::declare(&mut p, &defaults, &shared.descriptions(tasks));
    Ok(params::read(&p, &skip, shared.name())?)
}

/// One of the adapter's own parameters, declared with its default and
/// description if absent.
fn own_param(
    node: &impl HasParams,
    name: &str,
    default: r2r::ParameterValue,
    description: &'static str,
) -> Result<r2r::ParameterValue, RosError> {
    let mut p = lock(node.param_map());
    let entry = p.entry(name.to_string()).or_insert(r2r::Parameter {
        value: default,
        description,
    });
    Ok(entry.value.clone())
}

/// Sets the node's own string parameter `name` to `value` (one the node
/// chose itself, such as the file it loaded), so that `ros2 param get`
/// says it.
pub fn set_own_string(node: &r2r::Node, name: &str, value: &str) {
    let mut params = lock(&node.params);
    if let Some(param) = params.get_mut(name) {
        param.value = r2r::ParameterValue::String(value.to_string());
    }
}

/// A string parameter of the adapter.
pub fn own_string(node: &impl HasParams, p: &OwnParam<&str>) -> Result<String, RosError> {
    let default = r2r::ParameterValue::String(p.default.into());
    match own_param(node, p.name, default, p.description)? {
        r2r::ParameterValue::String(s) => Ok(s),
        other => Err(wrong_type(p.name, "a string", &other)),
    }
}

/// The `models_dir` parameter (empty: the model cache folder): the folder
/// that the files a goal or a run-time parameter set names stay in
/// ([`ModelsDir`]); made if missing.
pub fn models_dir(node: &impl HasParams) -> Result<ModelsDir, RosError> {
    let given = own_string(node, &own_params::MODELS_DIR)?;
    let cache = crate::learn::default_model::cache_dir().unwrap_or_default();
    let dir = match given.is_empty() {
        true => cache.display().to_string(),
        false => given,
    };
    let refuse = |expected: String| ParamsError::Invalid {
        key: own_params::MODELS_DIR.name.into(),
        value: dir.clone(),
        expected,
    };
    if dir.is_empty() {
        return Err(refuse("a folder (no model cache folder: $HOME unset)".into()).into());
    }
    let models = ModelsDir::new(std::path::Path::new(&dir)).map_err(refuse)?;
    tracing::info!("models_dir {}", models.path().display());
    Ok(models)
}

/// A floating-point parameter of the adapter (integers accepted).
pub fn own_f64(node: &impl HasParams, p: &OwnParam<f64>) -> Result<f64, RosError> {
    let default = r2r::ParameterValue::Double(p.default);
    match own_param(node, p.name, default, p.description)? {
        r2r::ParameterValue::Double(d) if d.is_finite() => Ok(d),
        r2r::ParameterValue::Integer(i) => Ok(i as f64),
        other => Err(wrong_type(p.name, "a finite number", &other)),
    }
}

/// A non-negative integer parameter of the adapter.
pub fn own_u64(node: &impl HasParams, p: &OwnParam<u32>) -> Result<u64, RosError> {
    let default = r2r::ParameterValue::Integer(i64::from(p.default));
    match own_param(node, p.name, default, p.description)? {
        r2r::ParameterValue::Integer(i) if i >= 0 => Ok(i.unsigned_abs()),
        other => Err(wrong_type(p.name, "an integer >= 0", &other)),
    }
}

/// A boolean parameter of the adapter.
pub fn own_bool(node: &impl HasParams, p: &OwnParam<bool>) -> Result<bool, RosError> {
    let default = r2r::ParameterValue::Bool(p.default);
    match own_param(node, p.name, default, p.description)? {
        r2r::ParameterValue::Bool(b) => Ok(b),
        other => Err(wrong_type(p.name, "true or false", &other)),
    }
}

/// A string-array parameter of the adapter.
pub fn own_strings(node: &impl HasParams, p: &OwnParam<&[&str]>) -> Result<Vec<String>, RosError> {
    let d = p.default.iter().map(|s| s.to_string()).collect();
    match own_param(
        node,
        p.name,
        r2r::ParameterValue::StringArray(d),
        p.description,
    )? {
        r2r::ParameterValue::StringArray(a) => Ok(a),
        other => Err(wrong_type(p.name, "a list of strings", &other)),
    }
}

/// A parameter refused: `key` = `value` is not what it must be (`expected`).
pub fn invalid(key: &str, value: &str, expected: String) -> RosError {
    RosError::Params(ParamsError::Invalid {
        key: key.into(),
        value: value.into(),
        expected,
    })
}

fn wrong_type(name: &str, expected: &str, found: &r2r::ParameterValue) -> RosError {
    RosError::Params(ParamsError::Invalid {
        key: name.into(),
        value: format!("{found:?}"),
        expected: expected.into(),
    })
}

/// Hands each message of `stream` to `f` with the node state `shared`
/// locked, on a task of its own.
pub fn each<M: Send + 'static, S: Send + 'static>(
    mut stream: impl futures::Stream<Item = M> + Unpin + Send + 'static,
    shared: &Arc<Mutex<S>>,
    mut f: impl FnMut(&mut S, M) + Send + 'static,
) {
    let shared = shared.clone();
    tokio::spawn(async move {
        while let Some(m) = futures::StreamExt::next(&mut stream).await {
            f(&mut lock(&shared), m);
        }
    });
}

/// The lock of `m`, also after a panic while another held it (the state
/// behind it stays usable: each holder leaves it whole).
pub fn lock<T>(m: &std::sync::Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Spins the node on a blocking task until [`Spinning`] is dropped (the
/// node is then destroyed, and leaves the ROS graph at once). Between two
/// spins it answers the [`Graph`]'s questions: the node is its alone.
pub fn spin(mut node: r2r::Node) -> Spinning {
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let (ask, asked) = std::sync::mpsc::channel::<Question>();
    let stopped = stop.clone();
    tokio::task::spawn_blocking(move || {
        while !stopped.load(std::sync::atomic::Ordering::Relaxed) {
            node.spin_once(Duration::from_millis(5));
            while let Ok((topic, reply)) = asked.try_recv() {
                let _ = reply.send(publishers(&node, &topic));
            }
        }
    });
    Spinning {
        graph: Graph(ask),
        stop,
    }
}

/// A question to the spin thread: the publishers on a topic.
type Question = (String, tokio::sync::oneshot::Sender<Vec<Publisher>>);

/// A node being spun; dropped, it stops.
pub struct Spinning {
    graph: Graph,
    stop: Arc<std::sync::atomic::AtomicBool>,
}

impl Spinning {
    /// The ROS graph as the node sees it.
    pub fn graph(&self) -> Graph {
        self.graph.clone()
    }
}

impl Drop for Spinning {
    fn drop(&mut self) {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
    }
}

/// The ROS graph as a spun node sees it, asked of its spin thread.
#[derive(Clone)]
pub struct Graph(std::sync::mpsc::Sender<Question>);

impl Graph {
    /// The publishers on `topic` (none if the graph cannot be read, or the
    /// node no longer spins).
    pub async fn publishers(&self, topic: &str) -> Vec<Publisher> {
        let (reply, answer) = tokio::sync::oneshot::channel();
        if self.0.send((topic.to_string(), reply)).is_err() {
            return Vec::new();
        }
        answer.await.unwrap_or_default()
    }
}

/// The publishers on `topic` of the graph `node` sees.
fn publishers(node: &r2r::Node, topic: &str) -> Vec<Publisher> {
    let Ok(name) = node.namespace().map(|ns| resolve(&ns, topic)) else {
        return Vec::new();
    };
    let found = node.get_publishers_info_by_topic(&name, false);
    found
        .unwrap_or_default()
        .into_iter()
        .map(|p| Publisher {
            node: format!("{}/{}", p.node_namespace.trim_end_matches('/'), p.node_name),
            qos: convert::qos(&p.qos_profile),
        })
        .collect()
}

/// `topic` in the namespace `ns` (an absolute name stays).
fn resolve(ns: &str, topic: &str) -> String {
    match topic.starts_with('/') {
        true => topic.to_string(),
        false => format!("{}/{topic}", ns.trim_end_matches('/')),
    }
}

/// The QoS the nodes' sensor inputs subscribe with: best effort, volatile,
/// so that every publisher reaches them, reliable ones and those with
/// SensorDataQoS alike (docs/ros2.md, "QoS").
pub fn input_qos() -> r2r::QosProfile {
    r2r::QosProfile::default().best_effort()
}
