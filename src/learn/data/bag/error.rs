//! Why a bag (rosbag2 MCAP or ROS 1) could not be read: every error names
//! the file and what it holds.

use mcap::McapError;

use super::MESSAGE_ENCODING;
use crate::exit::{Classify, ExitClass};

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
    /// The MCAP structure is broken: the file is cut short or damaged.
    #[error(
        "bag {path}: truncated or corrupt MCAP file after {messages} messages (topics read: \
         {holds}): {source}"
    )]
    Corrupt {
        /// File path.
        path: String,
        /// Messages read before the error.
        messages: usize,
        /// The topics read so far, with types and counts.
        holds: String,
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
    /// or forward by more than [`super::MAX_GAP_S`].
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
    /// A hand message's definition in the bag is not the one read.
    #[error("{path}: topic {topic} ({msg_type}): {reason}")]
    Definition {
        /// File path.
        path: String,
        /// The topic.
        topic: String,
        /// Its message type.
        msg_type: String,
        /// What differs.
        reason: String,
    },
    /// `--finger` names a sensor the hand message does not hold.
    #[error(
        "{path}: topic {topic} ({msg_type}) holds {sensors} sensors (fingers 0..{}), \
         finger {finger} asked for",
        sensors.saturating_sub(1)
    )]
    FingerOutOfRange {
        /// File path.
        path: String,
        /// The topic.
        topic: String,
        /// Its message type.
        msg_type: String,
        /// The finger asked for.
        finger: usize,
        /// Sensors in the message.
        sensors: usize,
    },
    /// The file is not a ROS 1 bag of format 2.0.
    #[error("{path}: not a ROS 1 bag (format 2.0): {reason}")]
    NotRos1 {
        /// File path.
        path: String,
        /// What the file starts with, or what is missing.
        reason: String,
    },
    /// A ROS 1 bag cut short or damaged.
    #[error(
        "{path}: truncated or corrupt ROS 1 bag after {messages} messages (topics read: \
         {holds}): {reason}"
    )]
    Ros1Corrupt {
        /// File path.
        path: String,
        /// Messages read before the error.
        messages: usize,
        /// The topics read so far, with types and counts.
        holds: String,
        /// What is wrong.
        reason: String,
    },
    /// A ROS 1 topic asked for carries a type this reader does not take.
    #[error("{path}: topic {topic} carries {found}, expected {expected} (the bag holds: {holds})")]
    UnknownType {
        /// File path.
        path: String,
        /// The topic.
        topic: String,
        /// The types taken.
        expected: &'static str,
        /// The type found.
        found: String,
        /// The bag's topics, types and message counts.
        holds: String,
    },
    /// A session could not be written ([`super::SessionWriter`]).
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
