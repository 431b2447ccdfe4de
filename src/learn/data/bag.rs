//! A rosbag2 MCAP file as one session of training data: BioTac readings
//! (`tactile_force_msgs/msg/BioTac`) paired by header stamp with the F/T
//! sensor's wrenches (`geometry_msgs/msg/WrenchStamped`).
//!
//! The file is streamed once with the `mcap` crate; messages of other topics
//! are skipped. A bag is one session and one trial: its first rows are out
//! of contact and tare it, as in a collected CSV.

use std::collections::{BTreeMap, HashMap};
use std::fs::File;
use std::io::{BufReader, Read, Seek};
use std::path::Path;

use mcap::sans_io::LinearReaderOptions;
use mcap::{Channel, McapError};
use nalgebra::Vector3;

use crate::biotac::hand::{DecodeError, Encoding, HandKind, HandLayout};
use crate::biotac::msg::{from_cdr_as, join_stamp, CdrLengths, MsgLayout, BIOTAC_MSG_TYPE};
use crate::biotac::BioTacReading;
use crate::record::Record;
use crate::wrench::Wrench;

/// The ROS type name of the F/T sensor's topic.
pub const WRENCH_STAMPED_TYPE: &str = "geometry_msgs/msg/WrenchStamped";

/// The message encoding rosbag2 records ROS 2 messages in.
pub const MESSAGE_ENCODING: &str = "cdr";

/// Longest step forward between the header stamps of two consecutive
/// messages of a topic (s); a longer one is a clock jump or a lost stretch.
pub const MAX_GAP_S: f64 = 1.0;

/// Which topics to read and how close two stamps must be to pair.
#[derive(Debug, Clone, PartialEq)]
pub struct BagTopics {
    /// The BioTac readings topic.
    pub biotac: String,
    /// The F/T sensor's wrench topic.
    pub ft: String,
    /// Largest stamp difference between a reading and its wrench (s).
    pub tolerance_s: f64,
    /// Which sensor of a hand message (`tactiles[]`, `bt_data[]`) is read.
    pub finger: usize,
}

impl Default for BagTopics {
    /// `/biotac/readings`, `/ft_sensor/wrench`, 5 ms (half a 100 Hz period).
    fn default() -> Self {
        BagTopics {
            biotac: "/biotac/readings".into(),
            ft: "/ft_sensor/wrench".into(),
            tolerance_s: 0.005,
            finger: 0,
        }
    }
}

/// The records of a bag and what was left out.
#[derive(Debug, Clone, PartialEq)]
pub struct Bag {
    /// One record per paired reading, in stamp order; set 1, trial 1, `t`
    /// from the first paired reading, the wrench as recorded (F/T frame).
    pub records: Vec<Record>,
    /// Readings with no wrench within the tolerance (left out).
    pub unpaired_readings: usize,
    /// Wrenches that are no reading's nearest within the tolerance.
    pub unpaired_wrenches: usize,
    /// The readings' message type (as the bag names it).
    pub reading_type: String,
    /// The file ends without its summary and footer (a recording killed
    /// part-way): the messages read, those of its whole chunks.
    pub cut_after: Option<usize>,
}

impl Bag {
    /// The warning for a cut file, or None.
    pub fn cut_warning(&self, path: &Path) -> Option<String> {
        self.cut_after.map(|n| {
            format!(
                "{}: the file was cut (no summary or footer: its recording was interrupted); \
                 read up to its last whole chunk, {n} messages",
                path.display()
            )
        })
    }
}

/// Largest record the reader takes, decompressed (bytes): 32 times the
/// file, at least 16 MiB and at most 1 GiB, so that a damaged length field
/// is refused instead of allocated.
fn record_limit(file_len: u64) -> usize {
    let len = usize::try_from(file_len).unwrap_or(usize::MAX);
    len.saturating_mul(32).clamp(16 << 20, 1 << 30)
}

/// Reads the readings and wrenches of `topics` from the MCAP file at
/// `path` and pairs each reading with the wrench of nearest stamp.
pub fn read_bag(path: &Path, topics: &BagTopics) -> Result<Bag, BagError> {
    let p = path.display().to_string();
    let io_err = |source| BagError::Open {
        path: p.clone(),
        source,
    };
    let mut file = File::open(path).map_err(io_err)?;
    let mut magic = [0u8; 8];
    match file.read_exact(&mut magic) {
        Ok(()) if magic == mcap::MAGIC => {}
        Err(e) if e.kind() != std::io::ErrorKind::UnexpectedEof => return Err(io_err(e)),
        _ => return Err(BagError::NotMcap { path: p }),
    }
    file.rewind().map_err(io_err)?;
    // Each chunk's CRC checked before any of its messages is read: a chunk
    // cut short, or one whose length was damaged so that the file seems to
    // end inside it, gives nothing (a proptest found a damaged length that
    // let a damaged message through while the CRC was checked at the end).
    let options = LinearReaderOptions::default()
        .with_prevalidate_chunk_crcs(true)
        .with_record_length_limit(record_limit(file.metadata().map_err(io_err)?.len()));
    let stream = mcap::io::MessageReader::new_with_options(BufReader::new(file), options);

    let mut readings = Series::new(&p, &topics.biotac);
    let mut wrenches = Series::new(&p, &topics.ft);
    // The role of each channel id, checked once; the topics found.
    let mut roles: HashMap<u16, Role> = HashMap::new();
    let mut found = Holds::new();
    let mut cut_after = None;
    for (messages, message) in stream.enumerate() {
        let message = match message {
            Ok(m) => m,
            // Cut at the end after whole chunks: what was flushed reads.
            Err(McapError::UnexpectedEof) if messages > 0 => {
                cut_after = Some(messages);
                break;
            }
            Err(source) => {
                return Err(BagError::Corrupt {
                    path: p.clone(),
                    messages,
                    holds: found.to_string(),
                    source,
                })
            }
        };
        let channel = &message.channel;
        let role = match roles.get(&channel.id) {
            Some(role) => *role,
            None => {
                let role = Role::of(channel, topics, &p)?;
                if let Role::Readings(_) | Role::BioTac(_) = role {
                    readings.msg_type = type_name(channel);
                }
                roles.insert(channel.id, role);
                role
            }
        };
        found.count(&channel.topic, || type_name(channel));
        let (log_time_ns, tolerance_s) = (message.log_time, topics.tolerance_s);
        match role {
            Role::BioTac(field) => readings.push(&message.data, log_time_ns, tolerance_s, |b| {
                let reading = from_cdr_as(b, field).map_err(|e| e.to_string())?.0;
                Ok((reading.stamp_s, reading))
            })?,
            Role::Readings(layout) => {
                readings.push(&message.data, log_time_ns, tolerance_s, |b| {
                    let (stamp_s, reading) = layout.decode(b, Encoding::Cdr, topics.finger)?;
                    Ok(stamp_or_log_time(stamp_s, reading, log_time_ns))
                })?
            }
            Role::Wrenches => wrenches.push(&message.data, log_time_ns, tolerance_s, |b| {
                Ok(wrench_from_cdr(b)?)
            })?,
            Role::Other => {}
        }
    }
    let bag = paired(&p, topics, &mut readings, &mut wrenches, &found)?;
    Ok(Bag { cut_after, ..bag })
}

/// The readings paired with the wrenches ([`pair`]); an error naming what
/// the bag holds when a topic has no message, or when no reading pairs.
pub(super) fn paired(
    path: &str,
    topics: &BagTopics,
    readings: &mut Series<BioTacReading>,
    wrenches: &mut Series<Wrench>,
    holds: &Holds,
) -> Result<Bag, BagError> {
    let missing = if readings.items.is_empty() {
        Some(&topics.biotac)
    } else if wrenches.items.is_empty() {
        Some(&topics.ft)
    } else {
        None
    };
    if let Some(topic) = missing {
        return Err(BagError::MissingTopic {
            path: path.into(),
            topic: topic.clone(),
            found: holds.to_string(),
        });
    }
    let reading_type = readings.msg_type.clone();
    let bag = pair(readings.sorted(), wrenches.sorted(), topics.tolerance_s);
    bag.map(|bag| Bag {
        reading_type,
        ..bag
    })
    .ok_or_else(|| BagError::NoPairs {
        path: path.into(),
        biotac: topics.biotac.clone(),
        ft: topics.ft.clone(),
        tolerance_s: topics.tolerance_s,
        readings_s: readings.span(),
        wrenches_s: wrenches.span(),
    })
}

/// The reading's stamp: its header's, or the record time when the header
/// stamp is zero (a driver that does not stamp).
pub(super) fn stamp_or_log_time(
    stamp_s: f64,
    mut reading: BioTacReading,
    log_time_ns: u64,
) -> (f64, BioTacReading) {
    if stamp_s == 0.0 {
        reading.stamp_s = log_time_ns as f64 * 1e-9;
    }
    (reading.stamp_s, reading)
}

/// The readings' types a bag may hold on the BioTac topic.
const READING_TYPES: &str =
    "tactile_force_msgs/msg/BioTac, sr_robot_msgs/msg/BiotacAll or biotac_sensors/msg/BioTacHand";

/// What a channel's messages are to the reader: a hand message's readings
/// (its layout), our own BioTac message's, wrenches or another topic.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    /// A hand message, laid out as its schema says.
    Readings(HandLayout),
    /// Our own BioTac message, its arrays as its schema lays them out.
    BioTac(MsgLayout),
    Wrenches,
    Other,
}

impl Role {
    /// The channel's role; an error when a topic asked for carries
    /// another type or encoding, or a hand message's schema differs.
    fn of(channel: &Channel, topics: &BagTopics, path: &str) -> Result<Role, BagError> {
        let name = type_name(channel);
        let cdr = channel.message_encoding == MESSAGE_ENCODING;
        let (role, expected) = if channel.topic == topics.biotac {
            let role = match HandKind::of(&name) {
                Some(kind) => {
                    let schema = channel.schema.as_ref().map_or(&[][..], |s| &s.data[..]);
                    let definition = String::from_utf8_lossy(schema);
                    let layout =
                        HandLayout::from_definition(kind, &definition).map_err(|reason| {
                            BagError::Definition {
                                path: path.into(),
                                topic: channel.topic.clone(),
                                msg_type: name.clone(),
                                reason,
                            }
                        })?;
                    Role::Readings(layout)
                }
                None => {
                    let schema = channel.schema.as_ref().map_or(&[][..], |s| &s.data[..]);
                    Role::BioTac(MsgLayout::of_definition(&String::from_utf8_lossy(schema)))
                }
            };
            let ok = matches!(role, Role::Readings(_)) || name == BIOTAC_MSG_TYPE;
            (ok.then_some(role), READING_TYPES)
        } else if channel.topic == topics.ft {
            let ok = name == WRENCH_STAMPED_TYPE;
            (ok.then_some(Role::Wrenches), WRENCH_STAMPED_TYPE)
        } else {
            return Ok(Role::Other);
        };
        match role {
            Some(role) if cdr => Ok(role),
            _ => {
                let encoding = match channel.message_encoding.as_str() {
                    "" => "no encoding",
                    e => e,
                };
                Err(BagError::WrongType {
                    path: path.into(),
                    topic: channel.topic.clone(),
                    expected,
                    found: format!("{name} in {encoding}"),
                })
            }
        }
    }
}

/// The topics of a bag with their types and message counts, as errors
/// say what a bag holds.
pub(super) struct Holds(BTreeMap<String, (String, usize)>);

impl Holds {
    pub(super) fn new() -> Self {
        Holds(BTreeMap::new())
    }

    /// One more message on `topic`.
    pub(super) fn count(&mut self, topic: &str, type_name: impl FnOnce() -> String) {
        match self.0.get_mut(topic) {
            Some(entry) => entry.1 += 1,
            None => {
                self.0.insert(topic.into(), (type_name(), 1));
            }
        }
    }
}

impl std::fmt::Display for Holds {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.0.is_empty() {
            return write!(f, "none");
        }
        let list: Vec<String> = (self.0.iter())
            .map(|(t, (ty, n))| format!("{t} ({ty}, {n} messages)"))
            .collect();
        write!(f, "{}", list.join(", "))
    }
}

/// The schema name of a channel, or "no schema".
pub(super) fn type_name(channel: &Channel) -> String {
    match &channel.schema {
        Some(s) if !s.name.is_empty() => s.name.clone(),
        _ => "no schema".into(),
    }
}

/// The decoded messages of one topic, (header stamp in s, value), in the
/// order read.
pub(super) struct Series<'a, T> {
    path: &'a str,
    topic: &'a str,
    /// The topic's message type, as errors name it.
    pub(super) msg_type: String,
    pub(super) items: Vec<(f64, T)>,
}

impl<'a, T> Series<'a, T> {
    pub(super) fn new(path: &'a str, topic: &'a str) -> Self {
        Series {
            path,
            topic,
            msg_type: String::new(),
            items: Vec::new(),
        }
    }

    /// Decodes a message and checks its stamp against the previous one's.
    pub(super) fn push(
        &mut self,
        bytes: &[u8],
        log_time_ns: u64,
        tolerance_s: f64,
        decode: impl FnOnce(&[u8]) -> Result<(f64, T), DecodeError>,
    ) -> Result<(), BagError> {
        let index = self.items.len() + 1;
        let (stamp_s, value) = decode(bytes).map_err(|e| match e {
            DecodeError::Bad(reason) => BagError::Decode {
                path: self.path.into(),
                topic: self.topic.into(),
                index,
                log_time_ns,
                reason,
            },
            DecodeError::Finger { finger, sensors } => BagError::FingerOutOfRange {
                path: self.path.into(),
                topic: self.topic.into(),
                msg_type: self.msg_type.clone(),
                finger,
                sensors,
            },
        })?;
        if let Some(&(previous_s, _)) = self.items.last() {
            if previous_s - stamp_s > tolerance_s || stamp_s - previous_s > MAX_GAP_S {
                return Err(BagError::ClockJump {
                    path: self.path.into(),
                    topic: self.topic.into(),
                    index,
                    previous_s,
                    stamp_s,
                });
            }
        }
        self.items.push((stamp_s, value));
        Ok(())
    }

    /// The items in stamp order (steps back within the tolerance undone).
    pub(super) fn sorted(&mut self) -> &[(f64, T)] {
        self.items.sort_by(|a, b| a.0.total_cmp(&b.0));
        &self.items
    }

    /// First and last stamp (s), once sorted.
    pub(super) fn span(&self) -> (f64, f64) {
        let stamp = |item: Option<&(f64, T)>| item.map_or(f64::NAN, |i| i.0);
        (stamp(self.items.first()), stamp(self.items.last()))
    }
}

/// Pairs each reading with the wrench of nearest stamp within
/// `tolerance_s`; both in stamp order. None when no reading pairs.
pub(super) fn pair(
    readings: &[(f64, BioTacReading)],
    wrenches: &[(f64, Wrench)],
    tolerance_s: f64,
) -> Option<Bag> {
    let mut used = vec![false; wrenches.len()];
    let mut records = Vec::new();
    let mut t0 = None;
    for &(stamp_s, reading) in readings {
        let gap = |j: usize| (wrenches[j].0 - stamp_s).abs();
        let after = wrenches.partition_point(|w| w.0 < stamp_s);
        let nearest = (after.saturating_sub(1)..wrenches.len().min(after + 1))
            .min_by(|&a, &b| gap(a).total_cmp(&gap(b)))
            .filter(|&j| gap(j) <= tolerance_s);
        if let Some(j) = nearest {
            used[j] = true;
            let t0 = *t0.get_or_insert(stamp_s);
            records.push(Record {
                t: stamp_s - t0,
                set: 1,
                trial: 1,
                reading,
                wrench: wrenches[j].1,
            });
        }
    }
    (!records.is_empty()).then(|| Bag {
        cut_after: None,
        unpaired_readings: readings.len() - records.len(),
        unpaired_wrenches: used.iter().filter(|u| !**u).count(),
        records,
        reading_type: String::new(),
    })
}

/// `geometry_msgs/msg/WrenchStamped` in CDR order.
#[derive(serde::Deserialize, serde::Serialize)]
struct CdrWrenchStamped {
    sec: i32,
    nanosec: u32,
    // Read to reach the wrench; the caller applies the frame transform.
    _frame_id: String,
    force: [f64; 3],
    torque: [f64; 3],
}

/// (header stamp in s, wrench) of a serialized WrenchStamped (CDR with its
/// encapsulation header); refuses stamps that are not times and values
/// that are not finite.
fn wrench_from_cdr(bytes: &[u8]) -> Result<(f64, Wrench), String> {
    let mut lengths = CdrLengths::new(bytes)?;
    lengths.skip(4, 8); // stamp: sec, nanosec
    lengths.string()?; // frame_id
    let m: CdrWrenchStamped = cdr::deserialize(bytes).map_err(|e| e.to_string())?;
    if m.sec < 0 || m.nanosec >= 1_000_000_000 {
        return Err(format!("stamp {} s {} ns is not a time", m.sec, m.nanosec));
    }
    if !m.force.iter().chain(&m.torque).all(|v| v.is_finite()) {
        return Err("a force or torque component is not finite".into());
    }
    let wrench = Wrench::new(Vector3::from(m.force), Vector3::from(m.torque));
    Ok((join_stamp(m.sec, m.nanosec), wrench))
}

mod error;
mod write;
pub use write::{write_bag, SessionWriter};

#[cfg(test)]
mod tests;

pub use error::BagError;
