//! `biotac_driver`: the serial bridge ([`Driver`], docs/serial-protocol.md)
//! -> `biotac/readings` (tactile_force_msgs/BioTac, untyped, sensor-data
//! QoS) and `/diagnostics` (diagnostic_msgs/DiagnosticArray, once per
//! statistics period and on every link change). `~/tare`
//! (std_srvs/Trigger) asks the driver for a tare; it is compiled only in a
//! real ROS build, as r2r's `doc-only` bindings lack std_srvs. With
//! `use_sim:=true` the launch files do not start this node: `sim_robot`
//! publishes the simulated BioTac.

use r2r::diagnostic_msgs::msg::DiagnosticArray;
use r2r::QosProfile;

use super::convert::level::{ERROR, OK, WARN};
use super::params::RuntimeParams;
use super::{convert, RosError};
use crate::biotac::driver::{Driver, DriverConfig, DriverEvent};
use crate::biotac::msg::{self as biotac_msg, BioTacMeta, BIOTAC_MSG_TYPE};

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
    let clock = super::serve_parameters(&mut node, RuntimeParams::none())?;
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
                let now = clock.now_s();
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
                    // (level, message, values)
                    DriverEvent::Connected { port } => {
                        Some((OK, format!("connected to {port}"), vec![]))
                    }
                    DriverEvent::Disconnected { reason, retry_in_s } => Some((
                        ERROR,
                        format!("disconnected: {reason}"),
                        vec![("retry_in_s", format!("{retry_in_s:.2}"))],
                    )),
                    DriverEvent::Stale { silent_s } => Some((
                        WARN,
                        "stale: no frames".into(),
                        vec![("silent_s", format!("{silent_s:.3}"))],
                    )),
                    DriverEvent::Stats(s) => Some((
                        OK,
                        "streaming".into(),
                        vec![
                            ("frames_per_s", format!("{:.1}", s.frames_per_s)),
                            ("dropped", s.dropped.to_string()),
                            ("disconnects", s.disconnects.to_string()),
                            ("decoder", format!("{:?}", s.decoder)),
                        ],
                    )),
                    DriverEvent::Tared(t) => {
                        Some((OK, format!("tared: PDC baseline {:.1}", t.pdc()), vec![]))
                    }
                    DriverEvent::TareRefused(e) => {
                        // The error says "tare refused: ..." itself.
                        Some((WARN, e.to_string(), vec![]))
                    }
                };
                if let Some((level, message, values)) = diag {
                    let name = "biotac_driver: link";
                    let msg = convert::diagnostics_msg(now, level, name, message, &port, values);
                    if let Err(e) = diagnostics.publish(&msg) {
                        tracing::warn!("diagnostics: {e}");
                    }
                }
            });
        }
    });
    Ok(blocking.await?)
}
