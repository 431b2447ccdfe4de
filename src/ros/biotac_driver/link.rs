//! `biotac_driver`'s link: the serial bridge or a Cheetah adapter, from the
//! node's parameters.

use crate::biotac::cheetah::{CheetahConfig, CheetahSource};
use crate::biotac::driver::{Driver, DriverConfig};
use crate::params::ParamsError;
use crate::ros::{self, RosError};

/// Declares the link's parameters and opens nothing yet: the driver for
/// them, and the link's name for /diagnostics.
pub fn declare(node: &r2r::Node) -> Result<(Driver, String), RosError> {
    let port = ros::own_string(
        node,
        "port",
        "/dev/ttyACM0",
        "Serial device of the BioTac bridge.",
    )?;
    let interface = ros::own_string(
        node,
        "interface",
        "serial",
        "serial (the bridge at `port`) or cheetah (a board on a Cheetah adapter).",
    )?;
    let cheetah = ros::own_string(
        node,
        "cheetah",
        "0",
        "Cheetah adapter: port number (0, 1, ...) or serial number (1364-123456).",
    )?;
    let library = ros::own_string(
        node,
        "cheetah_library",
        "",
        "Total Phase's cheetah.so (file or directory); empty: searched.",
    )?;
    let sensors = ros::own_strings(
        node,
        "sensors",
        &[],
        "Board positions (0, 1, 2) to sample; empty: every BioTac that answers.",
    )?;
    let electrodes = ros::own_f64(
        node,
        "electrodes",
        19.0,
        "Electrodes of the BioTacs: 19 (BioTac) or 24 (BioTac SP).",
    )?;
    match interface.as_str() {
        "serial" => Ok((Driver::new(DriverConfig::new(port.clone())), port)),
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
            let driver = CheetahSource::new(config).into_driver();
            Ok((driver, format!("cheetah {cheetah}")))
        }
        other => Err(invalid_interface(other).into()),
    }
}

/// An `interface` the node does not know.
fn invalid_interface(value: &str) -> ParamsError {
    ParamsError::Invalid {
        key: "interface".into(),
        value: value.into(),
        expected: "serial or cheetah".into(),
    }
}
