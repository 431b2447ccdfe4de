//! A ROS 1 bag (format 2.0, read with the `rosbag` crate) as one session
//! of training data: a hand's BioTac messages (`sr_robot_msgs/BiotacAll`,
//! `biotac_sensors/BioTacHand`, [`crate::biotac::hand`]), one sensor of which is
//! read, paired by header stamp with the F/T sensor's
//! `geometry_msgs/WrenchStamped`, as [`super::bag::read_bag`] pairs a
//! rosbag2 bag's.
//!
//! The chunks are read in file order (the index is not needed, but a bag
//! whose recording was not closed has none and is refused: `rosbag
//! reindex` mends it). A message whose header stamp is zero is stamped
//! with its record time.

use std::collections::hash_map::Entry;
use std::collections::HashMap;
use std::path::Path;

use rosbag::{ChunkRecord, MessageRecord, RosBag};

use super::bag::{paired, stamp_or_log_time, Bag, BagError, BagTopics, Holds, Series};
use crate::biotac::hand::{ros1_wrench, Encoding, HandKind, HandLayout, ROS1_WRENCH_TYPE};
use crate::biotac::BioTacReading;
use crate::wrench::Wrench;

/// The first bytes of a ROS 1 bag of format 2.0.
pub const ROS1_MAGIC: &[u8] = b"#ROSBAG V2.0\n";

/// The types this reader takes on the BioTac topic.
const READING_TYPES: &str = "sr_robot_msgs/BiotacAll or biotac_sensors/BioTacHand";

/// Whether the file at `path` starts as a ROS 1 bag does (any version).
pub fn is_ros1_bag(path: &Path) -> bool {
    let mut head = [0u8; 9];
    std::fs::File::open(path)
        .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
        .is_ok_and(|()| &head == b"#ROSBAG V")
}

/// What a connection's messages are to the reader.
#[derive(Clone, Copy)]
enum Role {
    Readings(HandLayout),
    Wrenches,
    Other,
}

/// Reads the readings of sensor `topics.finger` and the wrenches of
/// `topics` from the ROS 1 bag at `path` and pairs each reading with the
/// wrench of nearest stamp.
pub fn read_ros1_bag(path: &Path, topics: &BagTopics) -> Result<Bag, BagError> {
    let p = path.display().to_string();
    let bag = open(path, &p)?;
    let mut reader = Reader::new(&p, topics);
    for record in bag.chunk_records() {
        let chunk = match record {
            Ok(ChunkRecord::Chunk(chunk)) => chunk,
            Ok(ChunkRecord::IndexData(_)) => continue,
            Err(e) => return Err(reader.corrupt(e.to_string())),
        };
        for record in chunk.messages() {
            match record.map_err(|e| reader.corrupt(e.to_string()))? {
                MessageRecord::Connection(c) => {
                    reader.connection(c.id, c.topic, c.tp, c.message_definition)?
                }
                MessageRecord::MessageData(m) => reader.message(m.conn_id, m.data, m.time)?,
            }
        }
    }
    reader.finish()
}

/// The bag at `path` (named `p`), its header checked first.
fn open(path: &Path, p: &str) -> Result<RosBag, BagError> {
    let io = |source| BagError::Open {
        path: p.into(),
        source,
    };
    let corrupt = |reason: String| Reader::new(p, &BagTopics::default()).corrupt(reason);
    // The header is within the first 4 KiB as rosbag writes it.
    let mut head = Vec::new();
    let file = std::fs::File::open(path).map_err(io)?;
    let file_len = file.metadata().map_err(io)?.len();
    std::io::Read::read_to_end(&mut std::io::Read::take(file, 1 << 16), &mut head).map_err(io)?;
    check_header(&head, file_len).map_err(|e| match e {
        HeaderError::NotABag(reason) => BagError::NotRos1 {
            path: p.into(),
            reason,
        },
        HeaderError::Broken(reason) => corrupt(reason),
    })?;
    RosBag::new(path).map_err(|e| corrupt(e.to_string()))
}

/// A bag's records taken in file order: its connections' roles, the
/// readings and wrenches so far, what it holds.
struct Reader<'a> {
    p: &'a str,
    topics: &'a BagTopics,
    readings: Series<'a, BioTacReading>,
    wrenches: Series<'a, Wrench>,
    /// Role, topic and type by connection id.
    connections: HashMap<u32, (Role, String, String)>,
    messages: usize,
    holds: Holds,
    /// The first connection of an unknown type, told once the bag is counted.
    unknown: Option<BagError>,
}

impl<'a> Reader<'a> {
    fn new(p: &'a str, topics: &'a BagTopics) -> Self {
        Reader {
            p,
            topics,
            readings: Series::new(p, &topics.biotac),
            wrenches: Series::new(p, &topics.ft),
            connections: HashMap::new(),
            messages: 0,
            holds: Holds::new(),
            unknown: None,
        }
    }

    /// The bag is broken here, for `reason`.
    fn corrupt(&self, reason: String) -> BagError {
        BagError::Ros1Corrupt {
            path: self.p.into(),
            messages: self.messages,
            holds: self.holds.to_string(),
            reason,
        }
    }

    /// A connection record: its role, kept by id (the first record of an id).
    fn connection(
        &mut self,
        id: u32,
        topic: &str,
        tp: &str,
        definition: &str,
    ) -> Result<(), BagError> {
        let Entry::Vacant(slot) = self.connections.entry(id) else {
            return Ok(());
        };
        let role = match role(self.p, topic, tp, definition, self.topics) {
            Err(e @ BagError::UnknownType { .. }) => {
                self.unknown.get_or_insert(e);
                Role::Other
            }
            role => role?,
        };
        if let Role::Readings(_) = role {
            self.readings.msg_type = tp.into();
        }
        slot.insert((role, topic.into(), tp.into()));
        Ok(())
    }

    /// A message of connection `id`, logged at `time` (ns).
    fn message(&mut self, id: u32, data: &[u8], time: u64) -> Result<(), BagError> {
        let Some((role, topic, tp)) = self.connections.get(&id) else {
            let reason = format!("a message of connection {id} before it");
            return Err(self.corrupt(reason));
        };
        self.messages += 1;
        self.holds.count(topic, || tp.clone());
        let (tolerance_s, finger) = (self.topics.tolerance_s, self.topics.finger);
        match *role {
            Role::Readings(layout) => self.readings.push(data, time, tolerance_s, |b| {
                let (stamp_s, reading) = layout.decode(b, Encoding::Ros1, finger)?;
                Ok(stamp_or_log_time(stamp_s, reading, time))
            }),
            Role::Wrenches => self.wrenches.push(data, time, tolerance_s, |b| {
                let (stamp_s, wrench) = ros1_wrench(b)?;
                let zero = stamp_s == 0.0;
                Ok((if zero { time as f64 * 1e-9 } else { stamp_s }, wrench))
            }),
            Role::Other => Ok(()),
        }
    }

    /// The readings paired with the wrenches; the first unknown type
    /// refused, naming what the bag holds.
    fn finish(mut self) -> Result<Bag, BagError> {
        if let Some(BagError::UnknownType {
            path,
            topic,
            expected,
            found,
            ..
        }) = self.unknown
        {
            let holds = self.holds.to_string();
            return Err(BagError::UnknownType {
                path,
                topic,
                expected,
                found,
                holds,
            });
        }
        paired(
            self.p,
            self.topics,
            &mut self.readings,
            &mut self.wrenches,
            &self.holds,
        )
    }
}

/// The role of a connection on `topic` of type `tp`; an error when a topic
/// asked for carries another type or a definition that differs.
fn role(
    path: &str,
    topic: &str,
    tp: &str,
    definition: &str,
    topics: &BagTopics,
) -> Result<Role, BagError> {
    let unknown = |expected| BagError::UnknownType {
        path: path.into(),
        topic: topic.into(),
        expected,
        found: tp.into(),
        holds: String::new(),
    };
    if topic == topics.biotac {
        let kind = HandKind::of(tp)
            .filter(|_| !tp.contains("/msg/"))
            .ok_or_else(|| unknown(READING_TYPES))?;
        let layout = HandLayout::from_definition(kind, definition).map_err(|reason| {
            BagError::Definition {
                path: path.into(),
                topic: topic.into(),
                msg_type: tp.into(),
                reason,
            }
        })?;
        Ok(Role::Readings(layout))
    } else if topic == topics.ft {
        match tp {
            ROS1_WRENCH_TYPE => Ok(Role::Wrenches),
            _ => Err(unknown(ROS1_WRENCH_TYPE)),
        }
    } else {
        Ok(Role::Other)
    }
}

/// Why a file's start is not a readable bag.
enum HeaderError {
    /// Not a ROS 1 bag of format 2.0 at all.
    NotABag(String),
    /// A bag whose header or index position is broken.
    Broken(String),
}

/// Checks the bag header: the version line, then an index position within
/// the file and after the header (what the `rosbag` crate slices by).
fn check_header(data: &[u8], file: u64) -> Result<(), HeaderError> {
    if !data.starts_with(ROS1_MAGIC) {
        let line = data.split(|&b| b == b'\n').next().unwrap_or_default();
        let line = String::from_utf8_lossy(&line[..line.len().min(20)]).into_owned();
        return Err(HeaderError::NotABag(format!(
            "it starts with {line:?}, not \"#ROSBAG V2.0\""
        )));
    }
    let broken = |what: &str| HeaderError::Broken(what.to_string());
    let u32_at = |at: usize| -> Option<usize> {
        let b = data.get(at..at.checked_add(4)?)?;
        Some(u32::from_le_bytes(b.try_into().ok()?) as usize)
    };
    let at = ROS1_MAGIC.len();
    let len = u32_at(at).ok_or_else(|| broken("the file ends in its header"))?;
    let header = (at + 4)
        .checked_add(len)
        .and_then(|end| data.get(at + 4..end))
        .ok_or_else(|| broken("the file ends in its header"))?;
    let data_len = u32_at(at + 4 + len).ok_or_else(|| broken("the file ends in its header"))?;
    let start = at + 8 + len + data_len;
    let mut index = None;
    let mut rest = header;
    while rest.len() >= 4 {
        let n = u32::from_le_bytes(rest[..4].try_into().expect("4 bytes")) as usize;
        let field = rest
            .get(4..4 + n)
            .ok_or_else(|| broken("a header field runs past it"))?;
        if let Some(v) = field.strip_prefix(b"index_pos=") {
            let v: [u8; 8] = v
                .try_into()
                .map_err(|_| broken("index_pos is not 8 bytes"))?;
            index = Some(u64::from_le_bytes(v));
        }
        rest = &rest[4 + n..];
    }
    let index = index.ok_or_else(|| broken("the header has no index_pos"))?;
    if index == 0 {
        return Err(broken(
            "its index position is 0: the recording was not closed (rosbag reindex mends it)",
        ));
    }
    if index > file {
        return Err(HeaderError::Broken(format!(
            "its index starts at byte {index} but the file ends at byte {file}: cut short"
        )));
    }
    if index < start as u64 {
        return Err(HeaderError::Broken(format!(
            "its index position {index} is inside the header (which ends at byte {start})"
        )));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
