//! `biotac_driver`: the serial bridge ([`Driver`], docs/serial-protocol.md),
//! or with `interface: cheetah` a multi-BioTac board on a Total Phase
//! Cheetah adapter ([`CheetahSource`], docs/demos.md "Connect your BioTac
//! — Cheetah"), -> `biotac/readings` (tactile_force_msgs/BioTac, untyped, sensor-data
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
use crate::biotac::cheetah::{CheetahConfig, CheetahSource};
use crate::biotac::driver::{Driver, DriverConfig, DriverEvent};
use crate::biotac::msg::{self as biotac_msg, BioTacMeta, BIOTAC_MSG_TYPE};
use crate::params::ParamsError;

/// Runs the node until the process ends.
pub async fn run() -> Result<(), RosError> {
    let mut node = super::create_node("biotac_driver")?;
    let port = super::own_string(
        &node,
        "port",
        "/dev/ttyACM0",
        "Serial device of the BioTac bridge.",
    )?;
    let interface = super::own_string(
        &node,
        "interface",
        "serial",
        "serial (the bridge at `port`) or cheetah (a board on a Cheetah adapter).",
    )?;
    let cheetah = super::own_string(
        &node,
        "cheetah",
        "0",
        "Cheetah adapter: port number (0, 1, ...) or serial number (1364-123456).",
    )?;
    let library = super::own_string(
        &node,
        "cheetah_library",
        "",
        "Total Phase's cheetah.so (file or directory); empty: searched.",
    )?;
    let sensors = super::own_strings(
        &node,
        "sensors",
        &[],
        "Board positions (0, 1, 2) to sample; empty: every BioTac that answers.",
    )?;
    let electrodes = super::own_f64(
        &node,
        "electrodes",
        19.0,
        "Electrodes of the BioTacs: 19 (BioTac) or 24 (BioTac SP).",
    )?;
    let driver = match interface.as_str() {
        "serial" => Driver::new(DriverConfig::new(port.clone())),
        "cheetah" => {
            let invalid = |key: &str, value: String, e: &dyn std::fmt::Display| {
                let expected = e.to_string();
                ParamsError::Invalid {
                    key: key.into(),
                    value,
                    expected,
                }
            };
            let slots = sensors
                .iter()
                .map(|s| s.parse::<u8>())
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| invalid("sensors", sensors.join(","), &e))?;
            let config =
                CheetahConfig::from_settings(&cheetah, &library, &slots, electrodes as usize)
                    .map_err(|e| invalid("cheetah", cheetah.clone(), &e))?;
            CheetahSource::new(config).into_driver()
        }
        other => return Err(invalid_interface(other).into()),
    };
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
    let guard = std::sync::Arc::new(crate::nodes::bounds::InputGuard::new());
    let clock = super::serve_parameters(&mut node, RuntimeParams::none(&guard))?;
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
    let link = if interface == "cheetah" {
        format!("cheetah {cheetah}")
    } else {
        port
    };
    let blocking = tokio::task::spawn_blocking(move || {
        let mut driver = driver;
        let mut failed = None;
        while failed.is_none() {
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
                            invalid_channels: frame.invalid_names().collect(),
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
                    DriverEvent::Failed { reason } => {
                        failed = Some(reason.clone());
                        Some((ERROR, format!("stopped: {reason}"), vec![]))
                    }
                };
                if let Some((level, message, values)) = diag {
                    let name = "biotac_driver: link";
                    let msg = convert::diagnostics_msg(now, level, name, message, &link, values);
                    if let Err(e) = diagnostics.publish(&msg) {
                        tracing::warn!("diagnostics: {e}");
                    }
                }
            });
        }
        Err(RosError::Driver(failed.unwrap_or_default()))
    });
    blocking.await?
}

/// An `interface` the node does not know.
fn invalid_interface(value: &str) -> ParamsError {
    ParamsError::Invalid {
        key: "interface".into(),
        value: value.into(),
        expected: "serial or cheetah".into(),
    }
}
