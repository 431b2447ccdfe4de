//! `biotac_driver`: the serial bridge ([`Driver`], docs/serial-protocol.md)
//! -> `biotac/readings` (tactile_force_msgs/BioTac, untyped, sensor-data
//! QoS) and `/diagnostics` (diagnostic_msgs/DiagnosticArray, once per
//! statistics period and on every link change). `~/tare`
//! (std_srvs/Trigger) asks the driver for a tare; it is compiled only in a
//! real ROS build, as r2r's `doc-only` bindings lack std_srvs. With
//! `use_sim:=true` the launch files do not start this node: `sim_robot`
//! publishes the simulated BioTac.

use r2r::diagnostic_msgs::msg::{DiagnosticArray, DiagnosticStatus, KeyValue};
use r2r::QosProfile;

use super::biotac_msg::{self, BioTacMeta, BIOTAC_MSG_TYPE};
use super::{convert, RosError};
use crate::biotac::driver::{Driver, DriverConfig, DriverEvent};

/// Diagnostic levels (diagnostic_msgs/DiagnosticStatus).
const OK: u8 = 0;
const WARN: u8 = 1;
const ERROR: u8 = 2;

fn status(level: u8, message: String, port: &str, values: Vec<(&str, String)>) -> DiagnosticStatus {
    DiagnosticStatus {
        level,
        name: "biotac_driver: link".into(),
        message,
        hardware_id: port.into(),
        values: values
            .into_iter()
            .map(|(k, v)| KeyValue {
                key: k.into(),
                value: v,
            })
            .collect(),
    }
}

/// Runs the node until the process ends.
pub async fn run() -> Result<(), RosError> {
    let mut node = super::create_node("biotac_driver")?;
    let port = super::own_string(
        &node,
        "port",
        "/dev/ttyACM0",
        "Serial device of the BioTac bridge.",
    )?;
    let frame_id = super::own_string(
        &node,
        "frame_id",
        "biotac",
        "Frame of the readings (the BioTac frame).",
    )?;
    let serial = super::own_string(
        &node,
        "serial",
        "",
        "Sensor serial number, copied into every message.",
    )?;
    let tare_samples = super::own_f64(
        &node,
        "tare_samples",
        50.0,
        "Readings averaged by a ~/tare request.",
    )?;
    let readings = node.create_publisher_untyped(
        "biotac/readings",
        BIOTAC_MSG_TYPE,
        QosProfile::sensor_data(),
    )?;
    let diagnostics =
        node.create_publisher::<DiagnosticArray>("/diagnostics", QosProfile::default())?;
    #[cfg(not(feature = "ros2-doc-only"))]
    let mut tare_srv = node.create_service::<r2r::std_srvs::srv::Trigger::Service>(
        "~/tare",
        QosProfile::services_default(),
    )?;
    let (handler, _events) = node.make_parameter_handler()?;
    tokio::spawn(handler);
    let mut clock = r2r::Clock::create(r2r::ClockType::RosTime)?;
    super::spin(node);

    let (tare_tx, tare_rx) = std::sync::mpsc::channel::<()>();
    #[cfg(not(feature = "ros2-doc-only"))]
    tokio::spawn(async move {
        use futures::StreamExt;
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
    #[cfg(feature = "ros2-doc-only")]
    drop(tare_tx);

    let samples = tare_samples.max(1.0) as usize;
    let blocking = tokio::task::spawn_blocking(move || {
        let mut driver = Driver::new(DriverConfig::new(port.clone()));
        loop {
            if tare_rx.try_recv().is_ok() {
                driver.request_tare(samples);
            }
            driver.poll(&mut |event| {
                let now = super::now_s(&mut clock);
                let diag = match event {
                    DriverEvent::Frame {
                        frame,
                        reading: Some(mut r),
                    } => {
                        r.stamp_s = now;
                        let meta = BioTacMeta {
                            frame_id: frame_id.clone(),
                            serial: serial.clone(),
                            sensor_index: frame.sensor,
                            invalid_channels: frame.invalid.names().map(str::to_string).collect(),
                        };
                        if let Err(e) = readings.publish(biotac_msg::to_json(&r, &meta)) {
                            tracing::warn!("biotac/readings: {e}");
                        }
                        None
                    }
                    DriverEvent::Frame { reading: None, .. } => None,
                    DriverEvent::Connected { port } => {
                        Some(status(OK, format!("connected to {port}"), &port, vec![]))
                    }
                    DriverEvent::Disconnected { reason, retry_in_s } => Some(status(
                        ERROR,
                        format!("disconnected: {reason}"),
                        &port,
                        vec![("retry_in_s", format!("{retry_in_s:.2}"))],
                    )),
                    DriverEvent::Stale { silent_s } => Some(status(
                        WARN,
                        "stale: no frames".into(),
                        &port,
                        vec![("silent_s", format!("{silent_s:.3}"))],
                    )),
                    DriverEvent::Stats(s) => Some(status(
                        OK,
                        "streaming".into(),
                        &port,
                        vec![
                            ("frames_per_s", format!("{:.1}", s.frames_per_s)),
                            ("dropped", s.dropped.to_string()),
                            ("disconnects", s.disconnects.to_string()),
                            ("decoder", format!("{:?}", s.decoder)),
                        ],
                    )),
                    DriverEvent::Tared(t) => Some(status(
                        OK,
                        format!("tared: PDC baseline {:.1}", t.pdc()),
                        &port,
                        vec![],
                    )),
                    DriverEvent::TareRefused(e) => {
                        // The error says "tare refused: ..." itself.
                        Some(status(WARN, e.to_string(), &port, vec![]))
                    }
                };
                if let Some(s) = diag {
                    let msg = DiagnosticArray {
                        header: r2r::std_msgs::msg::Header {
                            stamp: convert::time_msg(now),
                            frame_id: String::new(),
                        },
                        status: vec![s],
                    };
                    if let Err(e) = diagnostics.publish(&msg) {
                        tracing::warn!("diagnostics: {e}");
                    }
                }
            });
        }
    });
    blocking.await.map_err(|e| RosError::Setup(e.to_string()))
}
