//! `tactile_force_msgs/msg/BioTac` <-> [`BioTacReading`], as the JSON value
//! r2r's untyped publishers carry, and from the CDR bytes a raw
//! subscription delivers (`msg/msg/BioTac.msg`).
//!
//! Under r2r's `doc-only` build there are no Rust types for our own
//! interface package, so the BioTac topic is untyped: this module is the one
//! place that knows its field names. The tests read `msg/msg/BioTac.msg`
//! and check every field name, type and array length against it.

use serde_json::{json, Value};

use crate::biotac::reading::{N_ELECTRODES, N_PAC};
use crate::biotac::BioTacReading;

/// The ROS type name of the readings topic.
pub const BIOTAC_MSG_TYPE: &str = "tactile_force_msgs/msg/BioTac";

/// Why a BioTac message was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BioTacMsgError {
    /// A field is missing or of the wrong type.
    #[error("BioTac message: field `{field}` missing or not {expected}")]
    Field {
        /// Field name.
        field: &'static str,
        /// What was expected.
        expected: &'static str,
    },
    /// An array has the wrong length.
    #[error("BioTac message: `{field}` has {found} values, expected {expected}")]
    Length {
        /// Field name.
        field: &'static str,
        /// Values found.
        found: usize,
        /// Values expected.
        expected: usize,
    },
    /// The bytes are not a BioTac message in CDR (too short, a wrong
    /// array or string length).
    #[error("BioTac message: not decodable as CDR ({0})")]
    Cdr(String),
    /// A count above the 12-bit range.
    #[error("BioTac message: `{field}` = {value} is above 4095")]
    Range {
        /// Field name.
        field: &'static str,
        /// The value.
        value: u64,
    },
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

fn field<'a>(v: &'a Value, name: &'static str) -> Result<&'a Value, BioTacMsgError> {
    v.get(name).ok_or(BioTacMsgError::Field {
        field: name,
        expected: "present",
    })
}

fn count(v: &Value, name: &'static str) -> Result<u16, BioTacMsgError> {
    let n = v.as_u64().ok_or(BioTacMsgError::Field {
        field: name,
        expected: "an unsigned integer",
    })?;
    if n > 4095 {
        return Err(BioTacMsgError::Range {
            field: name,
            value: n,
        });
    }
    Ok(n as u16)
}

fn counts<const N: usize>(v: &Value, name: &'static str) -> Result<[u16; N], BioTacMsgError> {
    let a = v.as_array().ok_or(BioTacMsgError::Field {
        field: name,
        expected: "an array",
    })?;
    if a.len() != N {
        return Err(BioTacMsgError::Length {
            field: name,
            found: a.len(),
            expected: N,
        });
    }
    let mut out = [0u16; N];
    for (o, x) in out.iter_mut().zip(a) {
        *o = count(x, name)?;
    }
    Ok(out)
}

/// The reading in a message; refuses missing fields, wrong lengths and
/// counts above 4095.
pub fn from_json(v: &Value) -> Result<(BioTacReading, BioTacMeta), BioTacMsgError> {
    let header = field(v, "header")?;
    let stamp = field(header, "stamp")?;
    let int = |v: &Value, name: &'static str| {
        v.get(name)
            .and_then(Value::as_u64)
            .ok_or(BioTacMsgError::Field {
                field: name,
                expected: "an unsigned integer",
            })
    };
    let sec = i32::try_from(int(stamp, "sec")?).map_err(|_| BioTacMsgError::Field {
        field: "sec",
        expected: "a 32-bit integer",
    })?;
    let nanosec = u32::try_from(int(stamp, "nanosec")?).map_err(|_| BioTacMsgError::Field {
        field: "nanosec",
        expected: "a 32-bit integer",
    })?;
    let string = |v: &Value, name: &'static str| {
        v.get(name)
            .and_then(Value::as_str)
            .map(str::to_string)
            .ok_or(BioTacMsgError::Field {
                field: name,
                expected: "a string",
            })
    };
    let seq = u16::try_from(int(v, "seq")?).map_err(|_| BioTacMsgError::Field {
        field: "seq",
        expected: "a 16-bit integer",
    })?;
    let sensor_index =
        u8::try_from(int(v, "sensor_index")?).map_err(|_| BioTacMsgError::Field {
            field: "sensor_index",
            expected: "an 8-bit integer",
        })?;
    let invalid = field(v, "invalid_channels")?
        .as_array()
        .and_then(|a| {
            a.iter()
                .map(|s| s.as_str().map(str::to_string))
                .collect::<Option<Vec<_>>>()
        })
        .ok_or(BioTacMsgError::Field {
            field: "invalid_channels",
            expected: "an array of strings",
        })?;
    let reading = BioTacReading {
        seq,
        stamp_s: join_stamp(sec, nanosec),
        electrodes: counts::<N_ELECTRODES>(field(v, "electrodes")?, "electrodes")?,
        pdc: count(field(v, "pdc")?, "pdc")?,
        pac: counts::<N_PAC>(field(v, "pac")?, "pac")?,
        tdc: count(field(v, "tdc")?, "tdc")?,
        tac: count(field(v, "tac")?, "tac")?,
    };
    let meta = BioTacMeta {
        frame_id: string(header, "frame_id")?,
        serial: string(v, "serial")?,
        sensor_index,
        invalid_channels: invalid,
    };
    Ok((reading, meta))
}

/// The message's fields in CDR order (`msg/msg/BioTac.msg`).
#[derive(serde::Serialize, serde::Deserialize)]
struct CdrBioTac {
    sec: i32,
    nanosec: u32,
    frame_id: String,
    serial: String,
    sensor_index: u8,
    seq: u16,
    electrodes: [u16; N_ELECTRODES],
    pdc: u16,
    pac: [u16; N_PAC],
    tdc: u16,
    tac: u16,
    invalid_channels: Vec<String>,
}

/// The reading in a serialized message (CDR, with its encapsulation
/// header, as DDS delivers it); refuses bytes that do not decode and counts
/// above 4095.
pub fn from_cdr(bytes: &[u8]) -> Result<(BioTacReading, BioTacMeta), BioTacMsgError> {
    let m: CdrBioTac = cdr::deserialize(bytes).map_err(|e| BioTacMsgError::Cdr(e.to_string()))?;
    let range = |field: &'static str, values: &[u16]| match values.iter().find(|v| **v > 4095) {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// (name, type, array length) of every field in msg/msg/BioTac.msg.
    fn msg_fields() -> Vec<(String, String, Option<usize>)> {
        let text = include_str!("../../msg/msg/BioTac.msg");
        text.lines()
            .map(|l| l.split('#').next().unwrap_or("").trim())
            .filter(|l| !l.is_empty())
            .map(|l| {
                let mut it = l.split_whitespace();
                let ty = it.next().unwrap().to_string();
                let name = it.next().unwrap().to_string();
                match ty.split_once('[') {
                    Some((base, rest)) => {
                        let n = rest.trim_end_matches(']');
                        (name, format!("{base}[]"), n.parse().ok())
                    }
                    None => (name, ty, None),
                }
            })
            .collect()
    }

    fn reading() -> BioTacReading {
        BioTacReading {
            seq: 65535,
            stamp_s: 12.25,
            electrodes: std::array::from_fn(|i| 100 * i as u16 + 7),
            pdc: 2000,
            pac: std::array::from_fn(|i| 2048 + i as u16),
            tdc: 1800,
            tac: 4095,
        }
    }

    #[test]
    fn every_field_of_the_msg_file_is_written_with_its_type_and_length() {
        let meta = BioTacMeta {
            frame_id: "biotac".into(),
            serial: "BT-1".into(),
            sensor_index: 2,
            invalid_channels: vec!["e3".into(), "pac7".into()],
        };
        let v = to_json(&reading(), &meta);
        let obj = v.as_object().unwrap();
        let fields = msg_fields();
        assert_eq!(obj.len(), fields.len(), "{obj:?} vs {fields:?}");
        for (name, ty, len) in &fields {
            let x = obj
                .get(name)
                .unwrap_or_else(|| panic!("{name} not written"));
            match ty.as_str() {
                "std_msgs/Header" => {
                    assert!(x["stamp"]["sec"].is_u64() && x["stamp"]["nanosec"].is_u64());
                    assert!(x["frame_id"].is_string());
                }
                "string" => assert!(x.is_string(), "{name}"),
                "uint8" => assert!(x.as_u64().unwrap() <= u8::MAX as u64, "{name}"),
                "uint16" => assert!(x.as_u64().unwrap() <= u16::MAX as u64, "{name}"),
                "uint16[]" => {
                    let a = x.as_array().unwrap();
                    assert_eq!(Some(a.len()), *len, "{name}");
                    assert!(a.iter().all(|e| e.as_u64().unwrap() <= 4095), "{name}");
                }
                "string[]" => assert!(x.as_array().unwrap().iter().all(Value::is_string)),
                other => panic!("field {name}: type {other} not handled"),
            }
        }
        assert_eq!(
            fields.iter().find(|f| f.0 == "electrodes").unwrap().2,
            Some(N_ELECTRODES)
        );
        assert_eq!(fields.iter().find(|f| f.0 == "pac").unwrap().2, Some(N_PAC));
        let (r, m) = from_json(&v).unwrap();
        assert_eq!(r, reading());
        assert_eq!(m, meta);
    }

    #[test]
    fn bad_messages_are_refused_not_panicked_on() {
        let good = to_json(&reading(), &BioTacMeta::default());
        let mut short = good.clone();
        short["electrodes"] = json!([1, 2, 3]);
        assert!(matches!(
            from_json(&short),
            Err(BioTacMsgError::Length { found: 3, .. })
        ));
        let mut high = good.clone();
        high["pdc"] = json!(5000);
        assert!(matches!(
            from_json(&high),
            Err(BioTacMsgError::Range { .. })
        ));
        let mut nan = good.clone();
        nan["tdc"] = json!(f64::NAN); // serde_json writes null
        assert!(from_json(&nan).is_err());
        let mut neg = good;
        neg["header"]["stamp"]["sec"] = json!(-1);
        assert!(from_json(&neg).is_err());
        assert!(from_json(&json!("no")).is_err());
    }

    #[test]
    fn stamps_split_and_join() {
        assert_eq!(split_stamp(12.25), (12, 250_000_000));
        assert_eq!(split_stamp(f64::NAN), (0, 0));
        assert_eq!(split_stamp(-1.0), (0, 0));
        assert!((join_stamp(12, 250_000_000) - 12.25).abs() < 1e-12);
    }

    #[test]
    fn cdr_bytes_decode_and_short_or_out_of_range_ones_are_refused() {
        let r = reading();
        let (sec, nanosec) = split_stamp(r.stamp_s);
        let mut m = CdrBioTac {
            sec,
            nanosec,
            frame_id: "biotac".into(),
            serial: "BT-1".into(),
            sensor_index: 1,
            seq: r.seq,
            electrodes: r.electrodes,
            pdc: r.pdc,
            pac: r.pac,
            tdc: r.tdc,
            tac: r.tac,
            invalid_channels: vec!["e3".into()],
        };
        let bytes = cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).unwrap();
        let (back, meta) = from_cdr(&bytes).unwrap();
        assert_eq!(back, r);
        assert_eq!(
            (meta.serial.as_str(), meta.invalid_channels.len()),
            ("BT-1", 1)
        );
        // A message cut short (an electrode array of 10 values, say).
        let err = from_cdr(&bytes[..40]).unwrap_err();
        assert!(matches!(err, BioTacMsgError::Cdr(_)), "{err}");
        m.pac[3] = 5000;
        let bytes = cdr::serialize::<_, _, cdr::CdrLe>(&m, cdr::Infinite).unwrap();
        let err = from_cdr(&bytes).unwrap_err().to_string();
        assert!(err.contains("pac") && err.contains("5000"), "{err}");
    }
}
