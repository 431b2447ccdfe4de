//! Sessions written as rosbag2 MCAP files, as they are recorded: a
//! [`SessionWriter`] takes one record at a time and, on
//! [`SessionWriter::flush`], ends the MCAP chunk and hands it to the disk
//! (fsync). A process killed part-way leaves a file whose chunks up to the
//! last flush read back ([`super::read_bag`] says it was cut); no chunk is
//! half on disk with a length still to be patched, because chunks are built
//! in memory and written whole.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::{BagError, BagTopics, CdrWrenchStamped, MESSAGE_ENCODING, WRENCH_STAMPED_TYPE};
use crate::biotac::msg::{split_stamp, to_cdr, BioTacMeta, BIOTAC_MSG_TYPE};
use crate::record::Record;

/// The BioTac message's definition, as rosbag2 stores a schema (`ros2msg`:
/// the message, then each type it uses after a line of `=`).
const BIOTAC_SCHEMA: &str = concat!(
    include_str!("../../../../msg/msg/BioTac.msg"),
    "\n================================================================================\n",
    "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n",
    "================================================================================\n",
    "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n",
);

/// geometry_msgs/msg/WrenchStamped's definition (ROS 2 common_interfaces),
/// as rosbag2 stores it.
const WRENCH_STAMPED_SCHEMA: &str = concat!(
    "std_msgs/Header header\nWrench wrench\n",
    "================================================================================\n",
    "MSG: std_msgs/Header\nbuiltin_interfaces/Time stamp\nstring frame_id\n",
    "================================================================================\n",
    "MSG: builtin_interfaces/Time\nint32 sec\nuint32 nanosec\n",
    "================================================================================\n",
    "MSG: geometry_msgs/Wrench\nVector3 force\nVector3 torque\n",
    "================================================================================\n",
    "MSG: geometry_msgs/Vector3\nfloat64 x\nfloat64 y\nfloat64 z\n",
);

/// A file whose flush reaches the disk (fsync), so that a flushed chunk
/// survives a power cut as well as a kill.
struct Synced(File);

impl Write for Synced {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.write(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.0.flush()?;
        self.0.sync_data()
    }
}

impl Seek for Synced {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.0.seek(pos)
    }
}

/// A session being written: records in, MCAP chunks out at each flush.
/// Dropped without [`SessionWriter::finish`], the `mcap` writer still ends
/// the file (its summary and footer); only a killed process leaves it cut.
pub struct SessionWriter {
    path: PathBuf,
    writer: mcap::Writer<BufWriter<Synced>>,
    readings: u16,
    wrenches: u16,
    meta: BioTacMeta,
    t0_s: f64,
    written: usize,
    flushed: usize,
}

impl std::fmt::Debug for SessionWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SessionWriter")
            .field("path", &self.path)
            .field("written", &self.written)
            .field("flushed", &self.flushed)
            .finish()
    }
}

impl SessionWriter {
    /// Creates the file at `path` with the schemas and channels of
    /// `topics`; each reading and wrench is stamped `t0_s + t` and its
    /// wrench framed `frame_id`. A file (or symlink) there is removed
    /// first: the session is a new file, never one written through.
    pub fn create(
        path: &Path,
        topics: &BagTopics,
        frame_id: &str,
        t0_s: f64,
    ) -> Result<Self, BagError> {
        let io = |e: std::io::Error| write_error(path, e.to_string());
        match std::fs::remove_file(path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(io(e)),
            _ => {}
        }
        let file = File::options()
            .write(true)
            .create_new(true)
            .open(path)
            .map_err(io)?;
        // Chunks built in memory (no seeking back): a chunk is on disk whole
        // or cut at the file's end, never with a length still to patch.
        let options = mcap::WriteOptions::new().disable_seeking(true);
        let mut w = options
            .create(BufWriter::new(Synced(file)))
            .map_err(|e| write_error(path, e.to_string()))?;
        let mcap_err = |e: mcap::McapError| write_error(path, e.to_string());
        let none = BTreeMap::new();
        let schema = w
            .add_schema(BIOTAC_MSG_TYPE, "ros2msg", BIOTAC_SCHEMA.as_bytes())
            .map_err(mcap_err)?;
        let readings = w
            .add_channel(schema, &topics.biotac, MESSAGE_ENCODING, &none)
            .map_err(mcap_err)?;
        let schema = w
            .add_schema(
                WRENCH_STAMPED_TYPE,
                "ros2msg",
                WRENCH_STAMPED_SCHEMA.as_bytes(),
            )
            .map_err(mcap_err)?;
        let wrenches = w
            .add_channel(schema, &topics.ft, MESSAGE_ENCODING, &none)
            .map_err(mcap_err)?;
        Ok(SessionWriter {
            path: path.to_path_buf(),
            writer: w,
            readings,
            wrenches,
            meta: BioTacMeta {
                frame_id: frame_id.into(),
                ..BioTacMeta::default()
            },
            t0_s,
            written: 0,
            flushed: 0,
        })
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Records written so far, and those of them flushed to disk.
    pub fn counts(&self) -> (usize, usize) {
        (self.written, self.flushed)
    }

    /// Writes a record: its reading and its wrench, both stamped
    /// `t0_s + r.t` (header stamp and log time).
    pub fn write(&mut self, r: &Record) -> Result<(), BagError> {
        let stamp_s = self.t0_s + r.t;
        let (sec, nanosec) = split_stamp(stamp_s);
        let log_time = u64::try_from(sec).unwrap_or(0) * 1_000_000_000 + u64::from(nanosec);
        let mut reading = r.reading;
        reading.stamp_s = stamp_s;
        let wrench = CdrWrenchStamped {
            sec,
            nanosec,
            _frame_id: self.meta.frame_id.clone(),
            force: r.wrench.force.into(),
            torque: r.wrench.torque.into(),
        };
        let wrench = cdr::serialize::<_, _, cdr::CdrLe>(&wrench, cdr::Infinite)
            .map_err(|e| write_error(&self.path, e.to_string()))?;
        let reading = to_cdr(&reading, &self.meta);
        for (channel, data) in [(self.readings, reading), (self.wrenches, wrench)] {
            let header = mcap::records::MessageHeader {
                channel_id: channel,
                sequence: self.written as u32,
                log_time,
                publish_time: log_time,
            };
            self.writer
                .write_to_known_channel(&header, &data)
                .map_err(|e| write_error(&self.path, e.to_string()))?;
        }
        self.written += 1;
        Ok(())
    }

    /// Ends the chunk being built and puts it on disk (fsync): what was
    /// written survives a kill from here on.
    pub fn flush(&mut self) -> Result<(), BagError> {
        if self.flushed == self.written {
            return Ok(());
        }
        self.writer
            .flush()
            .map_err(|e| write_error(&self.path, e.to_string()))?;
        self.flushed = self.written;
        Ok(())
    }

    /// Ends the file (its summary and footer) and puts it on disk; the
    /// records written.
    pub fn finish(self) -> Result<usize, BagError> {
        let SessionWriter {
            path,
            mut writer,
            written,
            ..
        } = self;
        let err = |reason: String| write_error(&path, reason);
        writer.finish().map_err(|e| err(e.to_string()))?;
        let mut buffered = writer.into_inner();
        buffered.flush().map_err(|e| err(e.to_string()))?;
        Ok(written)
    }
}

fn write_error(path: &Path, reason: String) -> BagError {
    BagError::Write {
        path: path.display().to_string(),
        reason,
    }
}

/// Writes `records` as a rosbag2 MCAP file that [`super::read_bag`] reads
/// back: each reading on `topics.biotac` and its wrench (BioTac frame,
/// `frame_id`) on `topics.ft`, both stamped `t0_s + t` (their header stamp
/// and log time). What a ROS deployment records with `ros2 bag record`.
pub fn write_bag(
    path: &Path,
    records: &[Record],
    topics: &BagTopics,
    frame_id: &str,
    t0_s: f64,
) -> Result<(), BagError> {
    let mut w = SessionWriter::create(path, topics, frame_id, t0_s)?;
    for r in records {
        w.write(r)?;
    }
    w.finish()?;
    Ok(())
}
