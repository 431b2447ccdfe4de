//! `biotac_driver`: the serial bridge ([`Driver`], docs/serial-protocol.md),
//! or with `interface: cheetah` a multi-BioTac board on a Total Phase
//! Cheetah adapter ([`CheetahSource`](crate::biotac::cheetah::CheetahSource), docs/demos.md "Connect your BioTac
//! — Cheetah"), -> `biotac/readings` (tactile_force_msgs/BioTac, untyped, sensor-data
//! QoS) and `/diagnostics` (diagnostic_msgs/DiagnosticArray, once per
//! statistics period and on every link change). `~/tare`
//! (std_srvs/Trigger) asks the driver for a tare; it is compiled only in a
//! real ROS build, as r2r's `doc-only` bindings lack std_srvs. With
//! `use_sim:=true` the launch files do not start this node: `sim_robot`
//! publishes the simulated BioTac.

mod link;
mod managed;

use r2r::diagnostic_msgs::msg::DiagnosticArray;
use r2r::QosProfile;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Receiver;
use std::sync::{Arc, Mutex};

use super::convert::level::{ERROR, OK, WARN};
use super::ending::Endings;
use super::params::RuntimeParams;
use super::{convert, RosClock, RosError};
use crate::biotac::driver::{Driver, DriverEvent};
use crate::biotac::msg::{self as biotac_msg, BioTacMeta, BIOTAC_MSG_TYPE};
use crate::nodes::bounds::InputGuard;
use crate::nodes::lifecycle::State;
use crate::nodes::own_params;

/// Runs the node until a signal ends it or the driver fails: the link's
/// and the readings' settings declared (and checked: a refused one ends
/// it at once), the topics and `~/tare` wired, its lifecycle brought to
/// `start_state` (`configure` opens the link on a thread of its own,
/// `activate` publishes its readings); at the end the link is closed.
pub async fn run(mut endings: Endings) -> Result<(), RosError> {
    let mut node = super::create_node("biotac_driver")?;
    link::declare(&node)?;
    let start = super::own_string(&node, &own_params::START_STATE)?;
    let start =
        State::start(&start).map_err(|expected| super::invalid("start_state", &start, expected))?;
    let publishers = Publishers {
        readings: node.create_publisher_untyped(
            "biotac/readings",
            BIOTAC_MSG_TYPE,
            QosProfile::sensor_data(),
        )?,
        diagnostics: node.create_publisher("/diagnostics", QosProfile::default())?,
    };
    let tare_requests = Arc::new(Mutex::new(serve_tare(&mut node)?));
    let guard = Arc::new(InputGuard::new());
    let unconfigured = Arc::new(AtomicBool::new(true));
    let now = unconfigured.clone();
    let live = RuntimeParams::none(&guard).unless_unconfigured(
        Box::new(move || now.load(Ordering::Relaxed)),
        &[own_params::START_STATE.name],
        node.params.clone(),
    );
    let clock = super::serve_parameters(&mut node, live)?;
    let (failed, mut failures) = tokio::sync::mpsc::unbounded_channel();
    let params = node.params.clone();
    let link = managed::Link::new(
        params,
        publishers,
        tare_requests,
        clock,
        failed,
        unconfigured,
    );
    let lifecycle = super::lifecycle::serve(&mut node, link, start)?;
    let _spinning = super::spin(node);
    let ended = tokio::select! {
        ending = endings.next() => ending.into_result(),
        Some(failure) = failures.recv() => Err(failure),
    };
    let mut l = super::lock(&lifecycle);
    if l.state() != State::Finalized {
        let _ = l.change(0, "shutdown");
    }
    ended
}

/// The `~/tare` service (std_srvs/Trigger): each request, answered at once,
/// comes out of the receiver for the driver's thread.
fn serve_tare(node: &mut r2r::Node) -> Result<Receiver<()>, RosError> {
    let (tare_tx, tare_rx) = std::sync::mpsc::channel::<()>();
    #[cfg(not(feature = "ros2-doc-only"))]
    {
        use futures::StreamExt;
        let mut tare_srv = node.create_service::<r2r::std_srvs::srv::Trigger::Service>(
            "~/tare",
            QosProfile::services_default(),
        )?;
        tokio::spawn(async move {
            while let Some(req) = tare_srv.next().await {
                let ok = tare_tx.send(()).is_ok();
                let _ = req.respond(r2r::std_srvs::srv::Trigger::Response {
                    success: ok,
                    message: if ok {
                        "tare requested; see /diagnostics".into()
                    } else {
                        "driver stopped".into()
                    },
                });
            }
        });
    }
    #[cfg(feature = "ros2-doc-only")]
    let _ = (node, tare_tx);
    Ok(tare_rx)
}

/// The node's publishers.
#[derive(Clone)]
struct Publishers {
    readings: r2r::PublisherUntyped,
    diagnostics: r2r::Publisher<DiagnosticArray>,
}

/// Where and how the driver's events are published.
struct Outputs {
    to: Publishers,
    frame_id: String,
    serial: String,
    tare_samples: usize,
    /// The link's name on /diagnostics (`port`, or `cheetah <adapter>`).
    link: String,
    /// True while active: readings are published.
    publishing: Arc<AtomicBool>,
}

impl Outputs {
    /// Reads the readings' settings.
    fn read(
        node: &impl super::HasParams,
        to: Publishers,
        link: String,
        publishing: Arc<AtomicBool>,
    ) -> Result<Self, RosError> {
        let frame_id = super::own_string(node, &own_params::READINGS_FRAME)?;
        let serial = super::own_string(node, &own_params::SERIAL)?;
        let tare_samples = super::own_f64(node, &own_params::TARE_SAMPLES)?;
        Ok(Outputs {
            to,
            frame_id,
            serial,
            tare_samples: tare_samples.max(1.0) as usize,
            link,
            publishing,
        })
    }

    /// Polls `driver`, tares it on request, publishes what it sends, until
    /// `stop` is set (Ok) or it fails (the error says why).
    fn drive(
        &self,
        mut driver: Driver,
        tare_requests: &Mutex<Receiver<()>>,
        clock: &RosClock,
        stop: &AtomicBool,
    ) -> Result<(), RosError> {
        let mut failed = None;
        while failed.is_none() {
            if stop.load(Ordering::Relaxed) {
                return Ok(());
            }
            if super::lock(tare_requests).try_recv().is_ok() {
                driver.request_tare(self.tare_samples);
            }
            driver.poll(&mut |event| {
                let now = clock.now_s();
                if let DriverEvent::Failed { reason } = &event {
                    failed = Some(reason.clone());
                }
                self.publish(event, now);
            });
        }
        Err(RosError::Driver(failed.unwrap_or_default()))
    }

    /// A reading on biotac/readings stamped `now`; a link event on /diagnostics.
    fn publish(&self, event: DriverEvent, now: f64) {
        let diag = match event {
            DriverEvent::Frame {
                frame,
                reading: Some(mut r),
            } => {
                if !self.publishing.load(Ordering::Relaxed) {
                    return;
                }
                r.stamp_s = now;
                let meta = BioTacMeta {
                    frame_id: self.frame_id.clone(),
                    serial: self.serial.clone(),
                    sensor_index: frame.sensor,
                    invalid_channels: frame.invalid_names().collect(),
                };
                if let Err(e) = self.to.readings.publish(biotac_msg::to_json(&r, &meta)) {
                    tracing::warn!("biotac/readings: {e}");
                }
                return;
            }
            DriverEvent::Frame { reading: None, .. } => return,
            // (level, message, values)
            DriverEvent::Connected { port } => (OK, format!("connected to {port}"), vec![]),
            DriverEvent::Disconnected { reason, retry_in_s } => (
                ERROR,
                format!("disconnected: {reason}"),
                vec![("retry_in_s", format!("{retry_in_s:.2}"))],
            ),
            DriverEvent::Stale { silent_s } => (
                WARN,
                "stale: no frames".into(),
                vec![("silent_s", format!("{silent_s:.3}"))],
            ),
            DriverEvent::Stats(s) => (
                OK,
                "streaming".into(),
                vec![
                    ("frames_per_s", format!("{:.1}", s.frames_per_s)),
                    ("dropped", s.dropped.to_string()),
                    ("disconnects", s.disconnects.to_string()),
                    ("decoder", format!("{:?}", s.decoder)),
                ],
            ),
            DriverEvent::Tared(t) => (OK, format!("tared: PDC baseline {:.1}", t.pdc()), vec![]),
            // The error says "tare refused: ..." itself.
            DriverEvent::TareRefused(e) => (WARN, e.to_string(), vec![]),
            DriverEvent::Failed { reason } => (ERROR, format!("stopped: {reason}"), vec![]),
        };
        let (level, message, values) = diag;
        let name = "biotac_driver: link";
        let msg = convert::diagnostics_msg(now, level, name, message, &self.link, values);
        if let Err(e) = self.to.diagnostics.publish(&msg) {
            tracing::warn!("diagnostics: {e}");
        }
    }
}
