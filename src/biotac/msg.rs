//! `tactile_force_msgs/msg/BioTac` <-> [`BioTacReading`]: to the JSON value
//! r2r's untyped publishers carry, from the CDR bytes a raw subscription
//! delivers or a rosbag2 MCAP file holds (`msg/msg/BioTac.msg`).
//!
//! Under r2r's `doc-only` build there are no Rust types for our own
//! interface package, so the BioTac topic is untyped: this module is the one
//! place that knows its field names. It needs no ROS installation: the ROS
//! adapters and the bag reader ([`crate::learn::data::bag`]) both use it. The
//! tests read `msg/msg/BioTac.msg` and check every field name, type and
//! array length against it.

use serde_json::{json, Value};

use serde::de::DeserializeOwned;

use crate::biotac::reading::{Electrodes, Pac, MAX_ELECTRODES, MAX_PAC, N_ELECTRODES, N_PAC};
use crate::biotac::{BioTacReading, ADC_MAX};
use crate::exit::{Classify, ExitClass};

/// The ROS type name of the readings topic.
pub const BIOTAC_MSG_TYPE: &str = "tactile_force_msgs/msg/BioTac";

/// Why a BioTac message was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BioTacMsgError {
    /// The bytes are not a BioTac message in CDR (too short, a wrong
    /// array or string length).
    #[error("BioTac message: not decodable as CDR ({0})")]
    Cdr(String),
    /// A stamp that is not a time: negative, or nanoseconds past a second.
    #[error("BioTac message: stamp {sec} s {nanosec} ns is not a time")]
    Stamp {
        /// Seconds.
        sec: i32,
        /// Nanoseconds.
        nanosec: u32,
    },
    /// An electrode count no BioTac has.
    #[error("BioTac message: {0}")]
    Layout(#[from] crate::biotac::reading::LayoutError),
    /// No PAC sample, or more than a BioTac SP's frame holds.
    #[error("BioTac message: {0}")]
    Pac(#[from] crate::biotac::reading::PacError),
    /// A count above the 12-bit range.
    #[error("BioTac message: `{field}` = {value} is above 4095")]
    Range {
        /// Field name.
        field: &'static str,
        /// The value.
        value: u64,
    },
}

/// A message that does not decode: refused input.
impl Classify for BioTacMsgError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// What travels with a reading on the topic besides the samples.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BioTacMeta {
    /// `header.frame_id`: the BioTac frame.
    pub frame_id: String,
    /// Sensor serial number (empty when unknown).
    pub serial: String,
    /// Sensor index on the bridge.
    pub sensor_index: u8,
    /// Invalid channel names (`e1`, `pac3`, `pdc`, ...).
    pub invalid_channels: Vec<String>,
}

/// Seconds -> `builtin_interfaces/Time` fields (sec, nanosec); negative or
/// non-finite times become 0.
pub fn split_stamp(stamp_s: f64) -> (i32, u32) {
    if !(stamp_s.is_finite() && stamp_s >= 0.0) {
        return (0, 0);
    }
    let sec = stamp_s.floor().min(i32::MAX as f64);
    let nanosec = ((stamp_s - sec) * 1e9).round().min(999_999_999.0);
    (sec as i32, nanosec as u32)
}

/// `builtin_interfaces/Time` fields -> seconds.
pub fn join_stamp(sec: i32, nanosec: u32) -> f64 {
    f64::from(sec) + f64::from(nanosec) * 1e-9
}

/// The message for a reading.
pub fn to_json(r: &BioTacReading, meta: &BioTacMeta) -> Value {
    let (sec, nanosec) = split_stamp(r.stamp_s);
    json!({
        "header": {"stamp": {"sec": sec, "nanosec": nanosec}, "frame_id": meta.frame_id},
        "serial": meta.serial,
        "sensor_index": meta.sensor_index,
        "seq": r.seq,
        "electrodes": r.electrodes.to_vec(),
        "pdc": r.pdc,
        "pac": r.pac.to_vec(),
        "tdc": r.tdc,
        "tac": r.tac,
        "invalid_channels": meta.invalid_channels,
    })
}

/// How a message's arrays are laid out: today's `msg/msg/BioTac.msg`
/// (`uint16[] electrodes`, `uint16[] pac`), or a fixed array of messages
/// recorded before it (their bags' schema says so): `uint16[19]
/// electrodes` before the BioTac SP, `uint16[22] pac` before its 27 PAC
/// samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MsgLayout {
    /// `electrodes`: a sequence, or fixed (`uint16[19]`).
    pub electrodes: ArrayField,
    /// `pac`: a sequence, or fixed (`uint16[22]`).
    pub pac: ArrayField,
}

/// One array field of the message: a sequence (a length, then the values)
/// or the older fixed array (the values only).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ArrayField {
    /// `uint16[]`.
    Sequence,
    /// `uint16[N]`: 19 electrodes, 22 PAC samples.
    Fixed,
}

impl MsgLayout {
    /// Today's message: both arrays sequences.
    pub const CURRENT: MsgLayout = MsgLayout {
        electrodes: ArrayField::Sequence,
        pac: ArrayField::Sequence,
    };

    /// The layout a message definition (a bag's schema text) declares.
    pub fn of_definition(definition: &str) -> Self {
        let declares = |field: [&str; 2]| {
            definition.lines().any(|l| {
                let code = l.split('#').next().unwrap_or("");
                code.split_whitespace().eq(field)
            })
        };
        let field = |fixed| match declares(fixed) {
            true => ArrayField::Fixed,
            false => ArrayField::Sequence,
        };
        MsgLayout {
            electrodes: field(["uint16[19]", "electrodes"]),
            pac: field(["uint16[22]", "pac"]),
        }
    }
}

/// The message's fields in CDR order (`msg/msg/BioTac.msg`), electrodes
/// as `E` and PAC as `P` (a sequence, or an older fixed array).
#[derive(serde::Serialize, serde::Deserialize)]
pub(crate) struct CdrBioTac<E, P> {
    sec: i32,
    nanosec: u32,
    frame_id: String,
    serial: String,
    sensor_index: u8,
    seq: u16,
    electrodes: E,
    pdc: u16,
    pac: P,
    tdc: u16,
    tac: u16,
    invalid_channels: Vec<String>,
}

/// A walk over the strings and sequences of a CDR message (after its
/// encapsulation header) that checks each stated length against the bytes
/// that follow it. The `cdr` crate reserves memory for a stated length
/// before it reads the bytes, so a few bytes claiming a 4 GB string would
/// cost 4 GB; a decoder walks its message's layout with this first.
pub(crate) struct CdrLengths<'a> {
    body: &'a [u8],
    little: bool,
    /// Offset in `body`; alignment counts from the end of the header.
    at: usize,
}

impl<'a> CdrLengths<'a> {
    /// Starts after the encapsulation header: `[0, 0]` big-endian CDR,
    /// `[0, 1]` little-endian.
    pub(crate) fn new(bytes: &'a [u8]) -> Result<Self, &'static str> {
        let little = match bytes.get(..2) {
            Some([0, 0]) => false,
            Some([0, 1]) => true,
            _ => return Err("not a CDR encapsulation header"),
        };
        Ok(CdrLengths {
            body: &bytes[4.min(bytes.len())..],
            little,
            at: 0,
        })
    }

    /// Steps over `n` bytes of fixed-size fields, aligned to `align`.
    pub(crate) fn skip(&mut self, align: usize, n: usize) {
        self.at = self.at.next_multiple_of(align).saturating_add(n);
    }

    /// Reads a sequence or string length.
    pub(crate) fn length(&mut self) -> Result<usize, &'static str> {
        self.at = self.at.next_multiple_of(4);
        let word = self
            .body
            .get(self.at..self.at.saturating_add(4))
            .and_then(|w| <[u8; 4]>::try_from(w).ok())
            .ok_or("cut short")?;
        self.at += 4;
        let n = if self.little {
            u32::from_le_bytes(word)
        } else {
            u32::from_be_bytes(word)
        };
        Ok(n as usize)
    }

    /// Bytes after the current offset.
    pub(crate) fn left(&self) -> usize {
        self.body.len().saturating_sub(self.at)
    }

    /// Steps over a string, refusing one longer than the bytes left.
    pub(crate) fn string(&mut self) -> Result<(), &'static str> {
        let n = self.length()?;
        if n > self.left() {
            return Err("a string longer than the message");
        }
        self.at += n;
        Ok(())
    }
}

/// Checks every string and sequence length of a BioTac message in `bytes`
/// ([`CdrLengths`]).
fn check_lengths(bytes: &[u8], layout: MsgLayout) -> Result<(), BioTacMsgError> {
    let walk = || -> Result<(), &'static str> {
        let mut cdr = CdrLengths::new(bytes)?;
        cdr.skip(4, 8); // stamp: sec, nanosec
        cdr.string()?; // frame_id
        cdr.string()?; // serial
        cdr.skip(1, 1); // sensor_index
        cdr.skip(2, 2); // seq
        let electrodes = match layout.electrodes {
            ArrayField::Fixed => N_ELECTRODES,
            ArrayField::Sequence => cdr.length()?,
        };
        if electrodes > MAX_ELECTRODES {
            return Err("more electrodes than a BioTac SP has");
        }
        cdr.skip(2, 2 * (electrodes + 1)); // electrodes, pdc
        let pac = match layout.pac {
            ArrayField::Fixed => N_PAC,
            ArrayField::Sequence => cdr.length()?,
        };
        if pac > MAX_PAC {
            return Err("more PAC samples than a BioTac SP's frame has");
        }
        cdr.skip(2, 2 * (pac + 2)); // pac, tdc, tac
        let channels = cdr.length()?;
        // Each name takes at least its 4-byte length.
        if channels > cdr.left() / 4 {
            return Err("more invalid channels than the message holds");
        }
        (0..channels).try_for_each(|_| cdr.string())
    };
    walk().map_err(|what| BioTacMsgError::Cdr(what.to_string()))
}

/// The reading in a serialized message (CDR, with its encapsulation
/// header, as DDS delivers it); refuses bytes that do not decode, stamps
/// that are not times, an electrode or PAC count no BioTac has and counts
/// above 4095.
pub fn from_cdr(bytes: &[u8]) -> Result<(BioTacReading, BioTacMeta), BioTacMsgError> {
    from_cdr_as(bytes, MsgLayout::CURRENT)
}

/// [`from_cdr`] for a message whose arrays are laid out as `layout`.
pub fn from_cdr_as(
    bytes: &[u8],
    layout: MsgLayout,
) -> Result<(BioTacReading, BioTacMeta), BioTacMsgError> {
    use ArrayField::{Fixed, Sequence};
    check_lengths(bytes, layout)?;
    type Vec16 = Vec<u16>;
    let m = match (layout.electrodes, layout.pac) {
        (Sequence, Sequence) => decode::<Vec16, Vec16>(bytes),
        (Sequence, Fixed) => decode::<Vec16, [u16; N_PAC]>(bytes),
        (Fixed, Sequence) => decode::<[u16; N_ELECTRODES], Vec16>(bytes),
        (Fixed, Fixed) => decode::<[u16; N_ELECTRODES], [u16; N_PAC]>(bytes),
    }?;
    if m.sec < 0 || m.nanosec >= 1_000_000_000 {
        return Err(BioTacMsgError::Stamp {
            sec: m.sec,
            nanosec: m.nanosec,
        });
    }
    let range = |field: &'static str, values: &[u16]| match values.iter().find(|v| **v > ADC_MAX) {
        Some(v) => Err(BioTacMsgError::Range {
            field,
            value: u64::from(*v),
        }),
        None => Ok(()),
    };
    range("electrodes", &m.electrodes)?;
    range("pdc", &[m.pdc])?;
    range("pac", &m.pac)?;
    range("tdc", &[m.tdc])?;
    range("tac", &[m.tac])?;
    let reading = BioTacReading {
        seq: m.seq,
        stamp_s: join_stamp(m.sec, m.nanosec),
        electrodes: m.electrodes,
        pdc: m.pdc,
        pac: m.pac,
        tdc: m.tdc,
        tac: m.tac,
    };
    let meta = BioTacMeta {
        frame_id: m.frame_id,
        serial: m.serial,
        sensor_index: m.sensor_index,
        invalid_channels: m.invalid_channels,
    };
    Ok((reading, meta))
}

/// The message's fields with its arrays read as `E` and `P` (a sequence or
/// a fixed array), then checked as a reading's.
fn decode<E, P>(bytes: &[u8]) -> Result<CdrBioTac<Electrodes, Pac>, BioTacMsgError>
where
    E: DeserializeOwned + AsRef<[u16]>,
    P: DeserializeOwned + AsRef<[u16]>,
{
    let m: CdrBioTac<E, P> =
        cdr::deserialize(bytes).map_err(|e| BioTacMsgError::Cdr(e.to_string()))?;
    let electrodes = Electrodes::from_slice(m.electrodes.as_ref())?;
    let pac = Pac::from_slice(m.pac.as_ref())?;
    Ok(m.with_arrays(electrodes, pac))
}

/// A reading as a serialized message (little-endian CDR with its
/// encapsulation header), as DDS sends it and rosbag2 records it.
pub(crate) fn to_cdr(r: &BioTacReading, meta: &BioTacMeta) -> Vec<u8> {
    cdr::serialize::<_, _, cdr::CdrLe>(&CdrBioTac::new(r, meta), cdr::Infinite)
        .expect("CDR of a BioTac message")
}

impl<E, P> CdrBioTac<E, P> {
    /// The same fields with `electrodes` and `pac`.
    pub(crate) fn with_arrays<F, Q>(self, electrodes: F, pac: Q) -> CdrBioTac<F, Q> {
        CdrBioTac {
            sec: self.sec,
            nanosec: self.nanosec,
            frame_id: self.frame_id,
            serial: self.serial,
            sensor_index: self.sensor_index,
            seq: self.seq,
            electrodes,
            pdc: self.pdc,
            pac,
            tdc: self.tdc,
            tac: self.tac,
            invalid_channels: self.invalid_channels,
        }
    }
}

impl CdrBioTac<Vec<u16>, Vec<u16>> {
    /// The message's fields for `r` and `meta`.
    pub(crate) fn new(r: &BioTacReading, meta: &BioTacMeta) -> Self {
        let (sec, nanosec) = split_stamp(r.stamp_s);
        CdrBioTac {
            sec,
            nanosec,
            frame_id: meta.frame_id.clone(),
            serial: meta.serial.clone(),
            sensor_index: meta.sensor_index,
            seq: r.seq,
            electrodes: r.electrodes.to_vec(),
            pdc: r.pdc,
            pac: r.pac.to_vec(),
            tdc: r.tdc,
            tac: r.tac,
            invalid_channels: meta.invalid_channels.clone(),
        }
    }
}

#[cfg(test)]
mod tests;
