//! Which message the BioTac estimator reads (its `input` and `finger`
//! parameters), and each message made a reading: our
//! `tactile_force_msgs/BioTac` on `biotac/readings` ([`crate::biotac::msg`]),
//! or one sensor of a Shadow hand's `sr_robot_msgs/BiotacAll` on
//! `/rh/tactile` ([`crate::biotac::hand`], the decoding the bags use).
//! Both arrive as CDR bytes.

use crate::biotac::hand::{DecodeError, Encoding, SHADOW_HAND};
use crate::biotac::msg::{self as biotac_msg, BIOTAC_MSG_TYPE};
use crate::biotac::BioTacReading;
use crate::exit::{Classify, ExitClass};

/// The values of the `input` parameter.
pub const INPUTS: [&str; 2] = ["biotac", "biotac_all"];

/// Where the estimator's readings come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadingSource {
    /// `tactile_force_msgs/BioTac` (our driver, the simulator).
    BioTac,
    /// Sensor `finger` of a Shadow hand's `sr_robot_msgs/BiotacAll`
    /// (0 first finger, 1 middle, 2 ring, 3 little, 4 thumb).
    ShadowHand {
        /// Index into `tactiles`.
        finger: usize,
    },
}

/// Parameters that name no source: refused at start-up.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SourceError {
    /// An `input` that is none of [`INPUTS`].
    #[error("input = \"{0}\": expected biotac (tactile_force_msgs/BioTac) or biotac_all (a Shadow hand's sr_robot_msgs/BiotacAll)")]
    Input(String),
    /// A `finger` that is not a sensor of the message.
    #[error("finger = {finger}: a Shadow hand's BiotacAll holds {sensors} BioTacs, 0 (first finger) to {} (thumb)", sensors - 1)]
    Finger {
        /// The value given.
        finger: f64,
        /// Sensors in the message.
        sensors: usize,
    },
    /// The message type is not among those the ROS build generated.
    #[error("{0} is not among this build's ROS message types: build the package (for a Shadow hand, its sr_robot_msgs), source it, then build tactile_force with --features ros2 again")]
    NotBuilt(&'static str),
}

/// A parameter naming no source: refused input.
impl Classify for SourceError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// Why a message gave no reading.
#[derive(Debug, Clone, PartialEq)]
pub enum Unusable {
    /// Not a message of the source's type (lengths, stamp, counts).
    Undecodable(String),
    /// Channels the driver flagged invalid.
    InvalidChannels,
}

impl ReadingSource {
    /// The source of `input` ([`INPUTS`]); `finger` counts only for a hand.
    pub fn from_params(input: &str, finger: f64) -> Result<Self, SourceError> {
        match input {
            "biotac" => Ok(ReadingSource::BioTac),
            "biotac_all" => {
                let sensors = SHADOW_HAND.fixed_sensors().unwrap_or(0);
                let whole = finger.fract() == 0.0 && (0.0..sensors as f64).contains(&finger);
                if !whole {
                    return Err(SourceError::Finger { finger, sensors });
                }
                Ok(ReadingSource::ShadowHand {
                    finger: finger as usize,
                })
            }
            other => Err(SourceError::Input(other.into())),
        }
    }

    /// The topic read (a Shadow right hand's; remap it for a left one).
    pub fn topic(&self) -> &'static str {
        match self {
            ReadingSource::BioTac => "biotac/readings",
            ReadingSource::ShadowHand { .. } => "/rh/tactile",
        }
    }

    /// The ROS 2 message type of the topic.
    pub fn type_name(&self) -> &'static str {
        match self {
            ReadingSource::BioTac => BIOTAC_MSG_TYPE,
            ReadingSource::ShadowHand { .. } => "sr_robot_msgs/msg/BiotacAll",
        }
    }

    /// The reading of one message and the sensor's identity (the serial a
    /// saved tare is kept for; a hand's sensor is its finger).
    pub fn decode(&self, cdr: &[u8]) -> Result<(BioTacReading, String), Unusable> {
        match *self {
            ReadingSource::BioTac => match biotac_msg::from_cdr(cdr) {
                Ok((r, meta)) if meta.invalid_channels.is_empty() => Ok((r, meta.serial)),
                Ok(_) => Err(Unusable::InvalidChannels),
                Err(e) => Err(Unusable::Undecodable(e.to_string())),
            },
            ReadingSource::ShadowHand { finger } => {
                match SHADOW_HAND.decode(cdr, Encoding::Cdr, finger) {
                    Ok((_, r)) => Ok((r, format!("sr_robot_msgs/BiotacAll finger {finger}"))),
                    Err(DecodeError::Bad(why)) => Err(Unusable::Undecodable(why)),
                    Err(DecodeError::Finger { finger, sensors }) => Err(Unusable::Undecodable(
                        format!("finger {finger} of a message of {sensors} sensors"),
                    )),
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;
