//! The streaming decoder: frames out of byte chunks of any size.

use super::*;

/// What a [`Decoder`] has seen since it was made.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DecoderStats {
    /// Frames decoded (sync, version, sensor and CRC good).
    pub frames: u64,
    /// Candidates (sync, version and sensor good) dropped for a CRC mismatch.
    pub crc_errors: u64,
    /// Invalid words in decoded frames: parity failures, error words, words
    /// with reserved bits set.
    pub parity_errors: u64,
    /// Frames lost per sensor, from sequence gaps.
    pub lost: [u64; N_SENSORS],
    /// Sequence numbers that repeated or went backwards (a restarted bridge).
    pub restarts: u64,
    /// Bytes discarded while searching for frames.
    pub bytes_skipped: u64,
}

/// What one look at the buffered bytes found.
enum Step {
    /// Discard this many bytes: they cannot start a frame.
    Skip(usize),
    /// A candidate failed its CRC: discard its first byte.
    Crc,
    /// A frame: discard its bytes.
    Frame(DecodedFrame),
    /// The buffered bytes may start a frame that has not fully arrived.
    NeedMore,
}

/// Looks at the start of `bytes` (see [`Step`]).
fn step(bytes: &[u8]) -> Step {
    match bytes.windows(2).position(|w| w == SYNC) {
        Some(0) => {}
        Some(at) => return Step::Skip(at),
        None => {
            // A trailing 0xAA may be the first half of a sync.
            let keep = usize::from(bytes.last() == Some(&SYNC[0]));
            return match bytes.len().saturating_sub(keep) {
                0 => Step::NeedMore,
                n => Step::Skip(n),
            };
        }
    }
    match bytes.first_chunk::<PREFIX_LEN>().map(check_prefix) {
        None => return Step::NeedMore,
        Some(Err(_)) => return Step::Skip(1),
        Some(Ok(())) => {}
    }
    match bytes.first_chunk::<FRAME_LEN>().map(decode_frame) {
        None => Step::NeedMore,
        Some(Ok(frame)) => Step::Frame(frame),
        Some(Err(_)) => Step::Crc,
    }
}

/// Frames lost between a sensor's previous sequence number and `seq`, or
/// `None` if `seq` repeats or lies behind it (a restart).
pub(super) fn seq_lost(previous: u16, seq: u16) -> Option<u16> {
    match seq.wrapping_sub(previous) {
        step @ 1..=MAX_SEQ_STEP => Some(step - 1),
        _ => None,
    }
}

/// Streaming decoder: finds frames in byte chunks of any size (see the
/// module documentation for the resynchronisation rules).
pub struct Decoder {
    /// Bytes received but not yet consumed: `buf[..len]`.
    buf: [u8; BUF_LEN],
    len: usize,
    stats: DecoderStats,
    /// Last sequence number per sensor.
    last_seq: [Option<u16>; N_SENSORS],
}

impl Default for Decoder {
    fn default() -> Self {
        Decoder::new()
    }
}

impl std::fmt::Debug for Decoder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Decoder")
            .field("pending", &self.len)
            .field("stats", &self.stats)
            .field("last_seq", &self.last_seq)
            .finish()
    }
}

impl Decoder {
    /// A decoder that has seen nothing.
    pub fn new() -> Self {
        Decoder {
            buf: [0; BUF_LEN],
            len: 0,
            stats: DecoderStats::default(),
            last_seq: [None; N_SENSORS],
        }
    }

    /// Feeds bytes and calls `on_frame` with each frame they complete, in
    /// stream order. Allocates nothing.
    pub fn push(&mut self, mut bytes: &[u8], mut on_frame: impl FnMut(DecodedFrame)) {
        while !bytes.is_empty() {
            let taken = self.fill(bytes);
            bytes = bytes.get(taken..).unwrap_or_default();
            self.scan(&mut on_frame);
        }
    }

    /// Counters since the decoder was made.
    pub fn stats(&self) -> DecoderStats {
        self.stats
    }

    /// Bytes held back because they may start a frame (fewer than 100).
    pub fn pending(&self) -> usize {
        self.len
    }

    /// Appends as much of `bytes` as fits; returns how many.
    fn fill(&mut self, bytes: &[u8]) -> usize {
        let room = self.buf.get_mut(self.len..).unwrap_or_default();
        let n = room.len().min(bytes.len());
        if let (Some(dst), Some(src)) = (room.get_mut(..n), bytes.get(..n)) {
            dst.copy_from_slice(src);
        }
        self.len += n;
        n
    }

    /// Decodes all buffered frames and keeps only bytes that may start one.
    fn scan(&mut self, on_frame: &mut impl FnMut(DecodedFrame)) {
        let mut at = 0;
        while let Some(bytes) = self.buf.get(at..self.len) {
            match step(bytes) {
                Step::Skip(n) => {
                    self.stats.bytes_skipped += n as u64;
                    at += n;
                }
                Step::Crc => {
                    self.stats.crc_errors += 1;
                    self.stats.bytes_skipped += 1;
                    at += 1;
                }
                Step::Frame(frame) => {
                    at += FRAME_LEN;
                    self.count(&frame);
                    on_frame(frame);
                }
                Step::NeedMore => break,
            }
        }
        // Every step consumes at most the bytes it looked at: at <= len.
        self.buf.copy_within(at..self.len, 0);
        self.len -= at;
    }

    /// Updates the counters for a decoded frame.
    fn count(&mut self, frame: &DecodedFrame) {
        self.stats.frames += 1;
        self.stats.parity_errors += frame.invalid.len() as u64;
        let sensor = usize::from(frame.sensor);
        let (Some(last), Some(lost)) = (
            self.last_seq.get_mut(sensor),
            self.stats.lost.get_mut(sensor),
        ) else {
            return;
        };
        if let Some(previous) = last.replace(frame.seq) {
            match seq_lost(previous, frame.seq) {
                Some(n) => *lost += u64::from(n),
                None => self.stats.restarts += 1,
            }
        }
    }
}
