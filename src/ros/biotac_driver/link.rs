//! `biotac_driver`'s link: the serial bridge or a Cheetah adapter, from the
//! node's parameters.

use crate::biotac::cheetah::{CheetahConfig, CheetahSource};
use crate::biotac::driver::{Driver, DriverConfig};
use crate::nodes::own_params;
use crate::params::ParamsError;
use crate::ros::{self, RosError};

/// Declares the link's parameters and opens nothing yet: the driver for
/// them, and the link's name for /diagnostics.
pub fn declare(node: &impl ros::HasParams) -> Result<(Driver, String), RosError> {
    let port = ros::own_string(node, &own_params::PORT)?;
    let interface = ros::own_string(node, &own_params::LINK)?;
    let cheetah = ros::own_string(node, &own_params::CHEETAH)?;
    let library = ros::own_string(node, &own_params::CHEETAH_LIBRARY)?;
    let sensors = ros::own_strings(node, &own_params::SENSORS)?;
    let electrodes = ros::own_f64(node, &own_params::ELECTRODES)?;
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
