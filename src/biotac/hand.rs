//! The hand drivers' BioTac messages, one sensor of which is a reading:
//! Shadow's `sr_robot_msgs/BiotacAll` (`Header header`, `Biotac[] tactiles`,
//! each `int16 pac0, pac1, pdc, tac, tdc`, `int16[] electrodes`) and the
//! Penn driver's `biotac_sensors/BioTacHand` (`Header header`, `string
//! hand_id`, `BioTacData[] bt_data`, each `string bt_serial`, `uint16
//! bt_position, tdc_data, tac_data, pdc_data`, `uint16[22] pac_data`,
//! `uint16[19] electrode_data`), in ROS 1 serialization or in CDR (ROS 2);
//! and ROS 1's `geometry_msgs/WrenchStamped`.
//!
//! Which arrays are fixed and which are sequences is read from the
//! message definition the bag stores (recorded `BiotacAll`s hold
//! `Biotac[5]`); a definition whose fields differ is refused.

use nalgebra::Vector3;

use crate::biotac::reading::PacError;
use crate::biotac::{BioTacReading, ElectrodeLayout, Electrodes, Pac, MAX_PAC};
use crate::wrench::Wrench;

/// The two hand message types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HandKind {
    /// Shadow hand: `sr_robot_msgs/BiotacAll`.
    BiotacAll,
    /// Penn's driver: `biotac_sensors/BioTacHand`.
    BioTacHand,
}

/// The ROS 1 type names of the hand messages.
pub const ROS1_TYPES: [&str; 2] = ["sr_robot_msgs/BiotacAll", "biotac_sensors/BioTacHand"];
/// Their ROS 2 type names.
pub const ROS2_TYPES: [&str; 2] = [
    "sr_robot_msgs/msg/BiotacAll",
    "biotac_sensors/msg/BioTacHand",
];
/// ROS 1's F/T message type.
pub const ROS1_WRENCH_TYPE: &str = "geometry_msgs/WrenchStamped";

impl HandKind {
    /// The kind of a ROS 1 or ROS 2 type name.
    pub fn of(type_name: &str) -> Option<HandKind> {
        let kinds = [HandKind::BiotacAll, HandKind::BioTacHand];
        (0..2)
            .find(|&i| type_name == ROS1_TYPES[i] || type_name == ROS2_TYPES[i])
            .map(|i| kinds[i])
    }

    /// The fields of the message (name, type) up to the sensors, then
    /// the sensor type's name and its fields: what the definition must say.
    fn fields(self) -> (Fields, &'static str, Fields) {
        match self {
            HandKind::BiotacAll => (
                &[("header", "Header"), ("tactiles", "Biotac[]")],
                "Biotac",
                &[
                    ("pac0", "int16"),
                    ("pac1", "int16"),
                    ("pdc", "int16"),
                    ("tac", "int16"),
                    ("tdc", "int16"),
                    ("electrodes", "int16[]"),
                ],
            ),
            HandKind::BioTacHand => (
                &[
                    ("header", "Header"),
                    ("hand_id", "string"),
                    ("bt_data", "BioTacData[]"),
                ],
                "BioTacData",
                &[
                    ("bt_serial", "string"),
                    ("bt_position", "uint16"),
                    ("tdc_data", "uint16"),
                    ("tac_data", "uint16"),
                    ("pdc_data", "uint16"),
                    ("pac_data", "uint16[]"),
                    ("electrode_data", "uint16[]"),
                ],
            ),
        }
    }
}

/// A message's fields as (name, type); `[]` stands for any array.
type Fields = &'static [(&'static str, &'static str)];

/// How a message is serialized.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// ROS 1: little-endian, packed, a header with `seq`.
    Ros1,
    /// ROS 2 CDR: an encapsulation header, aligned fields, no `seq`.
    Cdr,
}

/// An array's length: fixed by the definition, or stated in the message.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Len {
    Fixed(usize),
    Stated,
}

/// A hand message type as a bag's definition lays it out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HandLayout {
    /// The message type.
    pub kind: HandKind,
    sensors: Len,
    pac: Len,
    electrodes: Len,
}

/// Why a message does not give a reading.
#[derive(Debug, Clone, PartialEq)]
pub enum DecodeError {
    /// The finger asked for is not in the message.
    Finger {
        /// The index asked for.
        finger: usize,
        /// Sensors in the message.
        sensors: usize,
    },
    /// Anything else, said in words.
    Bad(String),
}

impl From<String> for DecodeError {
    fn from(s: String) -> Self {
        DecodeError::Bad(s)
    }
}

/// One field of a definition: (name, type without package, array suffix
/// kept as `[]` or `[N]`).
fn parse_fields(section: &str) -> Vec<(String, String)> {
    let mut fields = Vec::new();
    for line in section.lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        let (Some(ty), Some(name)) = (words.next(), words.next()) else {
            continue;
        };
        if ty == "MSG:" || name.contains('=') || words.next().is_some_and(|w| w.starts_with('=')) {
            continue; // a section's name or a constant
        }
        let ty = ty.rsplit('/').next().unwrap_or(ty);
        fields.push((name.to_string(), ty.to_string()));
    }
    fields
}

/// (section name without package, its text) of a definition; the main
/// message first, named "".
fn sections(definition: &str) -> Vec<(String, String)> {
    let mut out = vec![(String::new(), String::new())];
    for line in definition.lines() {
        if line.starts_with("====") {
            out.push((String::new(), String::new()));
        } else if let Some(name) = line.trim().strip_prefix("MSG:") {
            let name = name.trim();
            out.last_mut().unwrap().0 = name.rsplit('/').next().unwrap_or(name).into();
        } else {
            let text = &mut out.last_mut().unwrap().1;
            text.push_str(line);
            text.push('\n');
        }
    }
    out
}

/// Whether a definition's type matches the expected one (`[]` stands for
/// any array), and the array's length.
fn matches(found: &str, expected: &str) -> Option<Option<Len>> {
    let Some(base) = expected.strip_suffix("[]") else {
        return (found == expected).then_some(None);
    };
    let suffix = found
        .strip_prefix(base)?
        .strip_prefix('[')?
        .strip_suffix(']')?;
    if suffix.is_empty() || suffix.starts_with("<=") {
        return Some(Some(Len::Stated));
    }
    suffix.parse().ok().map(|n| Some(Len::Fixed(n)))
}

/// A Shadow hand's `sr_robot_msgs/BiotacAll` as its driver publishes it
/// (shadow-robot/sr_common: `Biotac[5] tactiles`, each `int16[]
/// electrodes`): the layout of live messages, which carry no definition.
pub const SHADOW_HAND: HandLayout = HandLayout {
    kind: HandKind::BiotacAll,
    sensors: Len::Fixed(5),
    pac: Len::Fixed(2),
    electrodes: Len::Stated,
};

impl HandLayout {
    /// The sensors every message holds, when the definition fixes them.
    pub fn fixed_sensors(&self) -> Option<usize> {
        match self.sensors {
            Len::Fixed(n) => Some(n),
            Len::Stated => None,
        }
    }

    /// The layout of `kind` from the bag's message definition (ROS 1's
    /// `message_definition`, rosbag2's `ros2msg` schema).
    pub fn from_definition(kind: HandKind, definition: &str) -> Result<HandLayout, String> {
        let (main, sensor_name, sensor) = kind.fields();
        let sections = sections(definition);
        let mut lens = Vec::new();
        let mut check = |text: &str, want: &[(&str, &str)], exact: bool, what: &str| {
            let found = parse_fields(text);
            let ok = (found.len() == want.len() || !exact && found.len() > want.len())
                && want.iter().zip(&found).all(|(&(name, ty), (n, t))| {
                    n == name
                        && matches(t, ty).is_some_and(|len| {
                            lens.extend(len);
                            true
                        })
                });
            if ok {
                return Ok(());
            }
            let said: Vec<String> = found.iter().map(|(n, t)| format!("{t} {n}")).collect();
            let wanted: Vec<String> = want.iter().map(|(n, t)| format!("{t} {n}")).collect();
            Err(format!(
                "the bag's definition of {what} has fields ({}), expected ({})",
                said.join(", "),
                wanted.join(", ")
            ))
        };
        check(&sections[0].1, main, false, "the message")?;
        let text = sections
            .iter()
            .find(|s| s.0 == sensor_name)
            .map(|s| s.1.as_str())
            .ok_or_else(|| format!("the bag's definition holds no MSG: {sensor_name} section"))?;
        check(text, sensor, true, sensor_name)?;
        let layout = match (kind, lens.as_slice()) {
            (HandKind::BiotacAll, &[sensors, electrodes]) => HandLayout {
                kind,
                sensors,
                pac: Len::Fixed(2),
                electrodes,
            },
            (HandKind::BioTacHand, &[sensors, pac, electrodes]) => HandLayout {
                kind,
                sensors,
                pac,
                electrodes,
            },
            _ => unreachable!("every array field gives its length"),
        };
        Ok(layout)
    }

    /// (header stamp in s, the reading of sensor `finger`) of one message.
    /// A zero stamp is returned as 0 (the caller takes the record time).
    pub fn decode(
        &self,
        bytes: &[u8],
        encoding: Encoding,
        finger: usize,
    ) -> Result<(f64, BioTacReading), DecodeError> {
        let mut w = Wire::new(bytes, encoding)?;
        let (seq, stamp_s) = w.header()?;
        if self.kind == HandKind::BioTacHand {
            w.string()?; // hand_id
        }
        let sensors = w.len(self.sensors, 1)?;
        if finger >= sensors {
            return Err(DecodeError::Finger { finger, sensors });
        }
        for i in 0..=finger {
            let (mut electrodes, mut pac) = (Vec::new(), Vec::new());
            let (pdc, tdc, tac) = match self.kind {
                HandKind::BiotacAll => {
                    pac = vec![w.i16()?, w.i16()?];
                    let pdc = w.i16()?;
                    let tac = w.i16()?;
                    (pdc, w.i16()?, tac)
                }
                HandKind::BioTacHand => {
                    w.string()?; // bt_serial
                    w.u16()?; // bt_position
                    let (tdc, tac, pdc) = (w.u16()?, w.u16()?, w.u16()?);
                    for _ in 0..w.len(self.pac, 2)? {
                        pac.push(w.u16()?);
                    }
                    (pdc, tdc, tac)
                }
            };
            let n = w.len(self.electrodes, 2)?;
            for _ in 0..n {
                electrodes.push(match self.kind {
                    HandKind::BiotacAll => w.i16()?,
                    HandKind::BioTacHand => w.u16()?,
                });
            }
            if i == finger {
                let channels = Channels {
                    electrodes: &electrodes,
                    pac: &pac,
                    pdc,
                    tdc,
                    tac,
                };
                let reading = reading_from(&channels, seq as u16, stamp_s)?;
                return Ok((stamp_s, reading));
            }
        }
        unreachable!("the loop returns at the finger")
    }
}

/// One sensor's channels as a message holds them (counts).
#[derive(Debug, Clone, Copy)]
pub struct Channels<'a> {
    /// The electrodes, in order.
    pub electrodes: &'a [i32],
    /// The PAC samples of the frame: 22 (27 from a BioTac SP), or as many
    /// as the message carries (the Shadow hand sends two, pac0 and pac1).
    pub pac: &'a [i32],
    /// Static pressure.
    pub pdc: i32,
    /// Temperature.
    pub tdc: i32,
    /// Heat flow.
    pub tac: i32,
}

/// The one place a reading is made from a hand message's channels.
/// Refuses an electrode count no BioTac has (19, or 24 on a BioTac SP), no
/// PAC sample or more than 27, and values that are not counts. The PAC
/// samples are kept as the message has them, so `pac_mean` is their mean.
pub fn reading_from(c: &Channels, seq: u16, stamp_s: f64) -> Result<BioTacReading, String> {
    let layout = ElectrodeLayout::with_count(c.electrodes.len())
        .map_err(|e| format!("the message has {e}"))?;
    let mut electrodes = Electrodes::filled(layout, 0);
    if c.pac.is_empty() || c.pac.len() > MAX_PAC {
        let e = PacError { found: c.pac.len() };
        return Err(format!("the message has {e}"));
    }
    let mut pac = Pac::filled(c.pac.len(), 0);
    let count =
        |name: &str, v: i32| u16::try_from(v).map_err(|_| format!("{name} is {v}, not a count"));
    for (k, (e, &v)) in electrodes.iter_mut().zip(c.electrodes).enumerate() {
        *e = count(&format!("electrode {}", k + 1), v)?;
    }
    for (p, &v) in pac.iter_mut().zip(c.pac) {
        *p = count("a PAC sample", v)?;
    }
    Ok(BioTacReading {
        seq,
        stamp_s,
        electrodes,
        pdc: count("pdc", c.pdc)?,
        pac,
        tdc: count("tdc", c.tdc)?,
        tac: count("tac", c.tac)?,
    })
}

/// (header stamp in s, wrench) of a ROS 1 `geometry_msgs/WrenchStamped`;
/// refuses values that are not finite.
pub fn ros1_wrench(bytes: &[u8]) -> Result<(f64, Wrench), String> {
    let mut w = Wire::new(bytes, Encoding::Ros1)?;
    let (_, stamp_s) = w.header()?;
    let mut v = [0.0; 6];
    for x in &mut v {
        *x = w.f64()?;
    }
    if !v.iter().all(|x| x.is_finite()) {
        return Err("a force or torque component is not finite".into());
    }
    let wrench = Wrench::new(
        Vector3::new(v[0], v[1], v[2]),
        Vector3::new(v[3], v[4], v[5]),
    );
    Ok((stamp_s, wrench))
}

/// A cursor over a serialized message; every read checks the length.
struct Wire<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Where CDR's alignment counts from (after the encapsulation).
    origin: usize,
    encoding: Encoding,
    little: bool,
}

impl<'a> Wire<'a> {
    fn new(bytes: &'a [u8], encoding: Encoding) -> Result<Self, String> {
        let (origin, little) = match encoding {
            Encoding::Ros1 => (0, true),
            Encoding::Cdr => match bytes.get(..4) {
                Some([0, 0, _, _]) => (4, false),
                Some([0, 1, _, _]) => (4, true),
                Some(head) => return Err(format!("CDR encapsulation {head:02x?} is not CDR")),
                None => return Err(format!("{} bytes: no CDR encapsulation", bytes.len())),
            },
        };
        Ok(Wire {
            bytes,
            pos: origin,
            origin,
            encoding,
            little,
        })
    }

    fn take<const N: usize>(&mut self) -> Result<[u8; N], String> {
        if self.encoding == Encoding::Cdr {
            let off = (self.pos - self.origin) % N;
            if off != 0 {
                self.pos += N - off;
            }
        }
        let end = self.pos.saturating_add(N);
        let got = self.bytes.get(self.pos..end).ok_or_else(|| {
            format!(
                "the message ends at byte {}, before byte {end}",
                self.bytes.len()
            )
        })?;
        self.pos = end;
        let mut b: [u8; N] = got.try_into().expect("N bytes");
        if !self.little {
            b.reverse();
        }
        Ok(b)
    }

    fn u16(&mut self) -> Result<i32, String> {
        Ok(u16::from_le_bytes(self.take()?).into())
    }

    fn i16(&mut self) -> Result<i32, String> {
        Ok(i16::from_le_bytes(self.take()?).into())
    }

    fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.take()?))
    }

    fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.take()?))
    }

    /// An array's length: fixed, or stated (checked against the bytes
    /// left at `min_size` bytes per element).
    fn len(&mut self, len: Len, min_size: usize) -> Result<usize, String> {
        if let Len::Fixed(n) = len {
            return Ok(n);
        }
        let n = self.u32()? as usize;
        let left = self.bytes.len().saturating_sub(self.pos);
        if n.saturating_mul(min_size) > left {
            return Err(format!("a stated length of {n} with {left} bytes left"));
        }
        Ok(n)
    }

    fn string(&mut self) -> Result<(), String> {
        let n = self.len(Len::Stated, 1)?;
        self.pos += n;
        Ok(())
    }

    /// (seq, stamp in s) of a std_msgs/Header.
    fn header(&mut self) -> Result<(u32, f64), String> {
        let seq = match self.encoding {
            Encoding::Ros1 => self.u32()?,
            Encoding::Cdr => 0,
        };
        let sec = self.u32()?;
        let nanosec = self.u32()?;
        if self.encoding == Encoding::Cdr && sec > i32::MAX as u32 || nanosec >= 1_000_000_000 {
            return Err(format!("stamp {sec} s {nanosec} ns is not a time"));
        }
        self.string()?; // frame_id
        Ok((seq, f64::from(sec) + f64::from(nanosec) * 1e-9))
    }
}

#[cfg(test)]
mod tests;
