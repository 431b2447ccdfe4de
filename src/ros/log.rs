//! ROS logging for our `tracing` events: each goes to rcutils under the
//! node's logger name (the console in the ROS format, on stderr, which
//! `ros2 launch` shows; the log files under `~/.ros/log`), and from info up
//! to `/rosout`. rcl leaves the `/rosout` publisher to the client library
//! (rclcpp and rclpy make it; r2r does not), so [`attach`] makes it, with
//! rclcpp's QoS. The ROS log level applies to the console
//! (`--ros-args --log-level debug`); `RUST_LOG`, if set, filters first.

use std::fmt::Write;
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use r2r::rcl_interfaces::msg::Log;

use tracing::field::{Field, Visit};
use tracing::{Event, Level, Subscriber};
use tracing_subscriber::layer::{Context, SubscriberExt};
use tracing_subscriber::util::SubscriberInitExt;
use tracing_subscriber::Layer;

/// The logger events go to: the executable's name until the node exists,
/// then the node's logger (its name after remapping).
static LOGGER: OnceLock<String> = OnceLock::new();

/// Routes `tracing` to ROS logging under `name` (until [`attach`]).
pub fn init(name: &str) {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info,tactile_force=debug"));
    let fallback = name.to_string();
    tracing_subscriber::registry()
        .with(filter)
        .with(RosLog { fallback })
        .init();
}

/// The node's `/rosout` publisher, once attached.
static ROSOUT: OnceLock<Mutex<r2r::Publisher<Log>>> = OnceLock::new();

/// Logs under the node's logger name from now on, and to `/rosout`.
pub fn attach(node: &mut r2r::Node) -> Result<(), r2r::Error> {
    let _ = LOGGER.set(node.logger().to_string());
    // rcl's rosout QoS: reliable, transient local, the last 1000 for 10 s.
    let qos = r2r::QosProfile::default()
        .keep_last(1000)
        .reliable()
        .transient_local()
        .lifespan(Duration::from_secs(10));
    let publisher = node.create_publisher::<Log>("/rosout", qos)?;
    let _ = ROSOUT.set(Mutex::new(publisher));
    Ok(())
}

thread_local! {
    /// Set while this thread publishes on `/rosout`: r2r logs a failed
    /// publish itself, and that record must not come back here.
    static PUBLISHING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Publishes a record on `/rosout` (info and above).
fn rosout(level: u8, logger: &str, msg: &str, file: &str, line: u32) {
    let Some(publisher) = ROSOUT.get() else {
        return;
    };
    if PUBLISHING.with(|p| p.replace(true)) {
        return;
    }
    let now = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(f64::NAN, |d| d.as_secs_f64());
    let record = Log {
        stamp: super::convert::time_msg(now),
        level,
        name: logger.into(),
        msg: msg.into(),
        file: file.into(),
        function: String::new(),
        line,
    };
    let publisher = super::lock(publisher);
    let _ = publisher.publish(&record);
    PUBLISHING.with(|p| p.set(false));
}

struct RosLog {
    fallback: String,
}

impl<S: Subscriber> Layer<S> for RosLog {
    fn on_event(&self, event: &Event<'_>, _ctx: Context<'_, S>) {
        let mut text = Text(String::new());
        event.record(&mut text);
        let meta = event.metadata();
        // The levels of rcl_interfaces/msg/Log (DEBUG 10 ... ERROR 40).
        let (severity, level) = match *meta.level() {
            Level::ERROR => (r2r::LogSeverity::Error, 40),
            Level::WARN => (r2r::LogSeverity::Warn, 30),
            Level::INFO => (r2r::LogSeverity::Info, 20),
            _ => (r2r::LogSeverity::Debug, 10),
        };
        // rcutils takes C strings: a NUL in a message would end it.
        let message = text.0.replace('\0', "\\0");
        let logger = LOGGER.get().unwrap_or(&self.fallback);
        let file = meta.file().unwrap_or("");
        let line = meta.line().unwrap_or(0);
        r2r::log(&message, logger, file, line, severity);
        if level >= 20 {
            rosout(level, logger, &message, file, line);
        }
    }
}

/// An event's message, then its other fields as ` key=value`.
struct Text(String);

impl Visit for Text {
    fn record_debug(&mut self, field: &Field, value: &dyn std::fmt::Debug) {
        if field.name() == "message" {
            let _ = write!(self.0, "{value:?}");
        } else {
            let _ = write!(self.0, " {}={value:?}", field.name());
        }
    }
}
