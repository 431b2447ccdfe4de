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

use crate::biotac::msg::{from_cdr, join_stamp, CdrLengths, BIOTAC_MSG_TYPE};
use crate::biotac::BioTacReading;
use crate::exit::{Classify, ExitClass};
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
}

impl Default for BagTopics {
    /// `/biotac/readings`, `/ft_sensor/wrench`, 5 ms (half a 100 Hz period).
    fn default() -> Self {
        BagTopics {
            biotac: "/biotac/readings".into(),
            ft: "/ft_sensor/wrench".into(),
            tolerance_s: 0.005,
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

/// Why a bag could not be read into records.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BagError {
    /// The file could not be opened or read.
    #[error("bag {path}: cannot read: {source}")]
    Open {
        /// File path.
        path: String,
        /// Underlying error.
        source: std::io::Error,
    },
    /// The file does not start with the MCAP magic bytes.
    #[error("{path}: not an MCAP file")]
    NotMcap {
        /// File path.
        path: String,
    },
    /// The MCAP structure is broken: the file is damaged, or cut short
    /// before its first whole chunk (a cut after one reads, [`Bag::cut_after`]).
    #[error("bag {path}: truncated or corrupt MCAP file after {messages} messages: {source}")]
    Corrupt {
        /// File path.
        path: String,
        /// Messages read before the error.
        messages: usize,
        /// The `mcap` crate's error.
        source: McapError,
    },
    /// No message on a topic.
    #[error("{path}: no message on topic {topic} (topics with messages: {found})")]
    MissingTopic {
        /// File path.
        path: String,
        /// The topic asked for.
        topic: String,
        /// The topics found, each with its type.
        found: String,
    },
    /// A topic's channel carries another message type or encoding.
    #[error("{path}: topic {topic} carries {found}, expected {expected} in {MESSAGE_ENCODING}")]
    WrongType {
        /// File path.
        path: String,
        /// The topic.
        topic: String,
        /// The type expected.
        expected: &'static str,
        /// The schema name and message encoding found.
        found: String,
    },
    /// A message that does not decode as its type.
    #[error(
        "{path}: topic {topic}, message {index} (log time {}.{:09} s) does not decode: {reason}",
        log_time_ns / 1_000_000_000,
        log_time_ns % 1_000_000_000
    )]
    Decode {
        /// File path.
        path: String,
        /// The topic.
        topic: String,
        /// 1-based number of the message on its topic.
        index: usize,
        /// The message's log time (ns).
        log_time_ns: u64,
        /// The decode error.
        reason: String,
    },
    /// The header stamps of a topic step back by more than the tolerance,
    /// or forward by more than [`MAX_GAP_S`].
    #[error(
        "{path}: topic {topic}, message {index}: header stamp {stamp_s:.6} s follows \
         {previous_s:.6} s ({:+.6} s): a clock jump or a gap",
        stamp_s - previous_s
    )]
    ClockJump {
        /// File path.
        path: String,
        /// The topic.
        topic: String,
        /// 1-based number of the message on its topic.
        index: usize,
        /// The previous message's stamp (s).
        previous_s: f64,
        /// This message's stamp (s).
        stamp_s: f64,
    },
    /// No reading has a wrench within the tolerance.
    #[error(
        "{path}: no reading on {biotac} has a wrench on {ft} within {tolerance_s} s (readings \
         stamped {:.6}..{:.6} s, wrenches {:.6}..{:.6} s)",
        readings_s.0, readings_s.1, wrenches_s.0, wrenches_s.1
    )]
    NoPairs {
        /// File path.
        path: String,
        /// The readings topic.
        biotac: String,
        /// The wrench topic.
        ft: String,
        /// The tolerance (s).
        tolerance_s: f64,
        /// First and last reading stamp (s).
        readings_s: (f64, f64),
        /// First and last wrench stamp (s).
        wrenches_s: (f64, f64),
    },
    /// A session could not be written ([`SessionWriter`]).
    #[error("session {path}: cannot write: {reason}")]
    Write {
        /// File path.
        path: String,
        /// What failed.
        reason: String,
    },
}

/// A bag refused: refused input; a session not written: the work failed.
impl Classify for BagError {
    fn class(&self) -> ExitClass {
        match self {
            BagError::Write { .. } => ExitClass::Failure,
            _ => ExitClass::Refused,
        }
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
    let options = LinearReaderOptions::default()
        .with_validate_chunk_crcs(true)
        .with_record_length_limit(record_limit(file.metadata().map_err(io_err)?.len()));
    let stream = mcap::io::MessageReader::new_with_options(BufReader::new(file), options);

    let mut readings = Series::new(&p, &topics.biotac);
    let mut wrenches = Series::new(&p, &topics.ft);
    // The role of each channel id, checked once; the topics found.
    let mut roles: HashMap<u16, Role> = HashMap::new();
    let mut found: BTreeMap<String, String> = BTreeMap::new();
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
                    source,
                })
            }
        };
        let channel = &message.channel;
        let role = match roles.get(&channel.id) {
            Some(role) => *role,
            None => {
                let role = Role::of(channel, topics).map_err(|(expected, found_type)| {
                    BagError::WrongType {
                        path: p.clone(),
                        topic: channel.topic.clone(),
                        expected,
                        found: found_type,
                    }
                })?;
                found.insert(channel.topic.clone(), type_name(channel));
                roles.insert(channel.id, role);
                role
            }
        };
        let (log_time_ns, tolerance_s) = (message.log_time, topics.tolerance_s);
        match role {
            Role::Readings => readings.push(&message.data, log_time_ns, tolerance_s, |b| {
                let reading = from_cdr(b).map_err(|e| e.to_string())?.0;
                Ok((reading.stamp_s, reading))
            })?,
            Role::Wrenches => {
                wrenches.push(&message.data, log_time_ns, tolerance_s, wrench_from_cdr)?
            }
            Role::Other => {}
        }
    }

    let missing = if readings.items.is_empty() {
        Some(&topics.biotac)
    } else if wrenches.items.is_empty() {
        Some(&topics.ft)
    } else {
        None
    };
    if let Some(topic) = missing {
        let list: Vec<String> = found.iter().map(|(t, ty)| format!("{t} ({ty})")).collect();
        return Err(BagError::MissingTopic {
            path: p,
            topic: topic.clone(),
            found: if list.is_empty() {
                "none".into()
            } else {
                list.join(", ")
            },
        });
    }
    let bag = pair(readings.sorted(), wrenches.sorted(), topics.tolerance_s);
    bag.map(|b| Bag { cut_after, ..b })
        .ok_or_else(|| BagError::NoPairs {
            path: p.clone(),
            biotac: topics.biotac.clone(),
            ft: topics.ft.clone(),
            tolerance_s: topics.tolerance_s,
            readings_s: readings.span(),
            wrenches_s: wrenches.span(),
        })
}

/// What a channel's messages are to the reader.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Role {
    Readings,
    Wrenches,
    Other,
}

impl Role {
    /// The channel's role; (type expected, type and encoding found) when
    /// a topic asked for carries another type or encoding.
    fn of(channel: &Channel, topics: &BagTopics) -> Result<Role, (&'static str, String)> {
        let (role, expected) = if channel.topic == topics.biotac {
            (Role::Readings, BIOTAC_MSG_TYPE)
        } else if channel.topic == topics.ft {
            (Role::Wrenches, WRENCH_STAMPED_TYPE)
        } else {
            return Ok(Role::Other);
        };
        let name = channel.schema.as_ref().map(|s| s.name.as_str());
        if name == Some(expected) && channel.message_encoding == MESSAGE_ENCODING {
            return Ok(role);
        }
        let encoding = match channel.message_encoding.as_str() {
            "" => "no encoding",
            e => e,
        };
        Err((expected, format!("{} in {encoding}", type_name(channel))))
    }
}

/// The schema name of a channel, or "no schema".
fn type_name(channel: &Channel) -> String {
    match &channel.schema {
        Some(s) if !s.name.is_empty() => s.name.clone(),
        _ => "no schema".into(),
    }
}

/// The decoded messages of one topic, (header stamp in s, value), in the
/// order read.
struct Series<'a, T> {
    path: &'a str,
    topic: &'a str,
    items: Vec<(f64, T)>,
}

impl<'a, T> Series<'a, T> {
    fn new(path: &'a str, topic: &'a str) -> Self {
        Series {
            path,
            topic,
            items: Vec::new(),
        }
    }

    /// Decodes a message and checks its stamp against the previous one's.
    fn push(
        &mut self,
        bytes: &[u8],
        log_time_ns: u64,
        tolerance_s: f64,
        decode: impl FnOnce(&[u8]) -> Result<(f64, T), String>,
    ) -> Result<(), BagError> {
        let index = self.items.len() + 1;
        let (stamp_s, value) = decode(bytes).map_err(|reason| BagError::Decode {
            path: self.path.into(),
            topic: self.topic.into(),
            index,
            log_time_ns,
            reason,
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
    fn sorted(&mut self) -> &[(f64, T)] {
        self.items.sort_by(|a, b| a.0.total_cmp(&b.0));
        &self.items
    }

    /// First and last stamp (s), once sorted.
    fn span(&self) -> (f64, f64) {
        let stamp = |item: Option<&(f64, T)>| item.map_or(f64::NAN, |i| i.0);
        (stamp(self.items.first()), stamp(self.items.last()))
    }
}

/// Pairs each reading with the wrench of nearest stamp within
/// `tolerance_s`; both in stamp order. None when no reading pairs.
fn pair(
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

mod write;
pub use write::{write_bag, SessionWriter};

#[cfg(test)]
mod tests;
