//! Serial wire format v1 of the BioTac bridge, and a streaming decoder.
//!
//! The bridge sends one 100-byte frame per sensor every 10 ms, little-endian
//! (docs/serial-protocol.md has the full description):
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 2 | sync 0xAA 0x55 |
//! | 2 | 1 | format version = 1 |
//! | 3 | 1 | sensor index (0..=2) |
//! | 4 | 2 | sequence number (u16, wraps) |
//! | 6 | 4 | bridge timestamp in microseconds (u32, wraps) |
//! | 10 | 88 | 44 raw SPI response words (u16) in the default frame order |
//! | 98 | 2 | CRC-16/CCITT-FALSE over bytes 2..98 (u16, little-endian) |
//!
//! Each word is the BioTac's SPI response word (docs/ARCHITECTURE.md,
//! "Reference facts / BioTac"): bits 15..9 = `D[11:5]`, bit 8 = odd parity of
//! the high byte, bits 7..3 = `D[4:0]`, bits 2..1 = 0, bit 0 = odd parity of the
//! low byte. A word with high byte 0xA5 is an error word. The frame order is
//! E1, PAC, E2, PAC, ..., E19, PAC, PDC, PAC, TAC, PAC, TDC, PAC.
//!
//! # Decoding
//!
//! [`Decoder`] takes byte chunks of any size and calls back with every frame
//! whose sync, version, sensor index and CRC are good. It searches for the
//! sync anywhere in the stream; when a candidate fails (bad version or sensor
//! byte, or a CRC mismatch) it resumes the search at the byte after that sync,
//! so a torn frame or a false sync inside data never hides the next frame.
//! It keeps fewer than 100 bytes between calls, owns no heap memory, and
//! counts what it sees in [`DecoderStats`].
//!
//! # Invalid samples
//!
//! A word that fails parity, an error word, or a word with bits 2..1 set is
//! an invalid sample: its channel is set to 0 in the reading and listed in
//! [`DecodedFrame::invalid`]. What the estimator then gets is the driver's
//! policy, [`HoldLastGood`](super::driver::HoldLastGood) (the driver's module
//! documentation, "Invalid samples").
//!
//! # Sequence gaps
//!
//! Per sensor, a sequence number `d` steps after the previous one (wrapping,
//! so 65535 -> 0 is one step) counts `d - 1` lost frames for `d` in
//! 2..=32768. A number that repeats or lies behind the previous one (`d` = 0
//! or above 32768) is taken as a restarted bridge: it counts in
//! [`DecoderStats::restarts`], not as lost frames, and counting continues from
//! the new number. The first frame of a sensor is not a gap. A gap longer
//! than 32768 frames (5.5 min) is indistinguishable from a restart.
//!
//! # Example
//!
//! ```
//! use tactile_force::biotac::driver::HoldLastGood;
//! use tactile_force::biotac::wire::{encode_frame, Decoder};
//! use tactile_force::biotac::BioTacReading;
//!
//! let reading = BioTacReading {
//!     seq: 7,
//!     stamp_s: 0.0,
//!     electrodes: [2000; 19],
//!     pdc: 1500,
//!     pac: [2048; 22],
//!     tdc: 2600,
//!     tac: 2040,
//! };
//! let mut stream = vec![0x13, 0xAA, 0x00]; // garbage before the frame
//! stream.extend_from_slice(&encode_frame(1, 7, 70_000, &reading));
//!
//! let mut decoder = Decoder::new();
//! let mut policy = HoldLastGood::new();
//! let mut out = Vec::new();
//! for chunk in stream.chunks(16) {
//!     decoder.push(chunk, |frame| out.extend(policy.apply(&frame)));
//! }
//! assert_eq!(out, vec![reading]);
//! assert_eq!(decoder.stats().bytes_skipped, 3);
//! ```
//!
//! Throughput: `cargo bench --bench wire`.

use super::{BioTacReading, ADC_MAX, N_ELECTRODES, N_PAC};

use crate::exit::{Classify, ExitClass};

/// Bytes per frame.
pub const FRAME_LEN: usize = 100;
/// Response words per frame: E1..E19, PDC, TAC, TDC and 22 PAC samples.
pub const N_WORDS: usize = 44;
/// The two bytes every frame starts with.
pub const SYNC: [u8; 2] = [0xAA, 0x55];
/// The format version this module writes and reads.
pub const VERSION: u8 = 1;
/// Sensors on one bridge (sensor indices 0..N_SENSORS).
pub const N_SENSORS: usize = 3;
/// Default baud rate: carries two sensors; three need 460800
/// (docs/serial-protocol.md, "Bandwidth and baud rate").
pub const DEFAULT_BAUD: u32 = 230_400;
/// High byte of a BioTac error word.
pub const ERROR_WORD_HIGH: u8 = 0xA5;

/// Sync, version and sensor: enough to reject a candidate early.
const PREFIX_LEN: usize = 4;
/// Sync, version, sensor, sequence number and timestamp.
const HEADER_LEN: usize = 10;
/// Bits 2..1 of the low byte, zero in every valid word.
const RESERVED_BITS: u8 = 0b110;
/// CRC-16/CCITT-FALSE generator polynomial (no reflection, xorout 0).
const CRC_POLY: u16 = 0x1021;
/// CRC-16/CCITT-FALSE initial value.
const CRC_INIT: u16 = 0xFFFF;
/// Largest sequence step counted as a gap; larger steps go backwards.
const MAX_SEQ_STEP: u16 = 32_768;
/// Decoder buffer: one frame must fit; the rest saves compactions.
const BUF_LEN: usize = 1024;

const _: () = assert!(HEADER_LEN + 2 * N_WORDS + 2 == FRAME_LEN);
const _: () = assert!(BUF_LEN >= 2 * FRAME_LEN);

/// Channel names in frame order; PAC samples count from 1 like the electrodes.
const CHANNEL_NAMES: [&str; N_WORDS] = [
    "e1", "pac1", "e2", "pac2", "e3", "pac3", "e4", "pac4", "e5", "pac5", "e6", "pac6", "e7",
    "pac7", "e8", "pac8", "e9", "pac9", "e10", "pac10", "e11", "pac11", "e12", "pac12", "e13",
    "pac13", "e14", "pac14", "e15", "pac15", "e16", "pac16", "e17", "pac17", "e18", "pac18", "e19",
    "pac19", "pdc", "pac20", "tac", "pac21", "tdc", "pac22",
];

/// Why a response word carries no sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum WordError {
    /// The BioTac reported an error (high byte 0xA5).
    #[error("error word {word:#06x} (high byte 0xA5)")]
    ErrorWord {
        /// The word as received.
        word: u16,
    },
    /// A byte of the word has even parity.
    #[error("parity error in word {word:#06x}")]
    Parity {
        /// The word as received.
        word: u16,
    },
    /// Parity holds but bits 2..1, always 0, are set.
    #[error("reserved bits 2..1 set in word {word:#06x}")]
    Reserved {
        /// The word as received.
        word: u16,
    },
}

/// A word the serial link garbled: the work failed.
impl Classify for WordError {
    fn class(&self) -> ExitClass {
        ExitClass::Failure
    }
}

/// Why 100 bytes are not a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum FrameError {
    /// The first two bytes are not 0xAA 0x55.
    #[error("no sync: frame starts {found:02x?}, expected [aa, 55]")]
    Sync {
        /// The first two bytes.
        found: [u8; 2],
    },
    /// The format version is not 1.
    #[error("format version {found}, this decoder reads version 1")]
    Version {
        /// The version byte.
        found: u8,
    },
    /// The sensor index is past the bridge's sensors.
    #[error("sensor index {found}, a bridge has sensors 0..=2")]
    Sensor {
        /// The sensor byte.
        found: u8,
    },
    /// The CRC over bytes 2..98 does not match bytes 98..100.
    #[error("CRC mismatch: frame carries {received:#06x}, bytes 2..98 give {computed:#06x}")]
    Crc {
        /// The CRC in the frame.
        received: u16,
        /// The CRC of the frame's bytes.
        computed: u16,
    },
}

/// A frame the serial link garbled: the work failed.
impl Classify for FrameError {
    fn class(&self) -> ExitClass {
        ExitClass::Failure
    }
}

/// The response word for a 12-bit value, with both parity bits.
///
/// Values above 4095 are a caller bug: a debug build panics, a release
/// build keeps the low 12 bits.
pub fn encode_word(value: u16) -> u16 {
    debug_assert!(value <= ADC_MAX, "{value} does not fit in 12 bits");
    let value = value & ADC_MAX;
    let high = ((value >> 5) as u8) << 1;
    let low = ((value & 0x1F) as u8) << 3;
    u16::from_be_bytes([with_odd_parity(high), with_odd_parity(low)])
}

/// The 12-bit value of a response word, or why it carries none.
///
/// An error word is reported as such although its high byte also fails
/// parity.
pub fn decode_word(word: u16) -> Result<u16, WordError> {
    let [high, low] = word.to_be_bytes();
    if high == ERROR_WORD_HIGH {
        Err(WordError::ErrorWord { word })
    } else if !has_odd_parity(high) || !has_odd_parity(low) {
        Err(WordError::Parity { word })
    } else if low & RESERVED_BITS != 0 {
        Err(WordError::Reserved { word })
    } else {
        Ok(u16::from(high >> 1) << 5 | u16::from(low >> 3))
    }
}

/// Whether `byte` has an odd number of ones.
fn has_odd_parity(byte: u8) -> bool {
    byte.count_ones() % 2 == 1
}

/// `byte` with bit 0 set if that gives it odd parity.
fn with_odd_parity(byte: u8) -> u8 {
    byte | u8::from(!has_odd_parity(byte))
}

/// CRC-16/CCITT-FALSE lookup table, one entry per leading byte.
const CRC_TABLE: [u16; 256] = crc_table();

const fn crc_table() -> [u16; 256] {
    let mut table = [0; 256];
    let mut i = 0;
    while i < 256 {
        let mut crc = (i as u16) << 8;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ CRC_POLY
            } else {
                crc << 1
            };
            bit += 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
}

/// CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF, no
/// reflection, no final xor (check value 0x29B1 for b"123456789").
pub fn crc16_ccitt_false(bytes: &[u8]) -> u16 {
    bytes.iter().fold(CRC_INIT, |crc, &byte| {
        (crc << 8) ^ CRC_TABLE[usize::from((crc >> 8) as u8 ^ byte)]
    })
}

/// The name of the channel at a frame position ("e7", "pac3", "pdc", "tac",
/// "tdc"); `None` past the 44 positions.
pub fn channel_name(position: usize) -> Option<&'static str> {
    CHANNEL_NAMES.get(position).copied()
}

/// The reading's field at a frame position: even positions hold E1..E19,
/// PDC, TAC, TDC; odd positions the PAC samples in order.
pub(super) fn slot(reading: &mut BioTacReading, position: usize) -> Option<&mut u16> {
    let index = position / 2;
    if position % 2 == 1 {
        return reading.pac.get_mut(index);
    }
    match index.checked_sub(N_ELECTRODES) {
        None => reading.electrodes.get_mut(index),
        Some(0) => Some(&mut reading.pdc),
        Some(1) => Some(&mut reading.tac),
        Some(2) => Some(&mut reading.tdc),
        Some(_) => None,
    }
}

/// The reading's 44 values in frame order.
pub(super) fn to_frame_order(reading: &BioTacReading) -> [u16; N_WORDS] {
    // `slot` hands out `&mut`: read through a copy.
    let mut copy = *reading;
    std::array::from_fn(|position| slot(&mut copy, position).map_or(0, |v| *v))
}

/// A set of frame positions (0..44), such as the channels whose words were
/// invalid.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct ChannelMask(u64);

impl ChannelMask {
    /// Adds a frame position; positions past 43 are ignored.
    pub fn insert(&mut self, position: usize) {
        if position < N_WORDS {
            self.0 |= 1 << position;
        }
    }

    /// Whether the set holds a frame position.
    pub fn contains(self, position: usize) -> bool {
        position < N_WORDS && (self.0 >> position) & 1 == 1
    }

    /// Number of positions in the set.
    pub fn len(self) -> usize {
        self.0.count_ones() as usize
    }

    /// Whether the set is empty.
    pub fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// The positions in both sets.
    pub fn intersection(self, other: ChannelMask) -> ChannelMask {
        ChannelMask(self.0 & other.0)
    }

    /// The frame positions in the set, ascending.
    pub fn positions(self) -> impl Iterator<Item = usize> {
        (0..N_WORDS).filter(move |&position| self.contains(position))
    }

    /// The channel names in the set, in frame order (see [`channel_name`]).
    pub fn names(self) -> impl Iterator<Item = &'static str> {
        self.positions().filter_map(channel_name)
    }
}

/// One frame off the wire.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DecodedFrame {
    /// Sensor index on the bridge (0..N_SENSORS).
    pub sensor: u8,
    /// Sequence number of the sensor's frames (wraps).
    pub seq: u16,
    /// Bridge timestamp (us, wraps every 71.6 min).
    pub bridge_us: u32,
    /// The samples; `seq` as above, `stamp_s` 0.0 (the driver stamps it),
    /// invalid channels 0.
    pub reading: BioTacReading,
    /// Channels whose words were invalid.
    pub invalid: ChannelMask,
}

/// The frame for one reading. `reading.seq` is ignored in favour of `seq`;
/// a sensor index of 3 or more is written as given, and decoders reject it.
///
/// Values above 4095 are a caller bug (see [`encode_word`]).
pub fn encode_frame(
    sensor: u8,
    seq: u16,
    bridge_us: u32,
    reading: &BioTacReading,
) -> [u8; FRAME_LEN] {
    let [s0, s1] = SYNC;
    let [q0, q1] = seq.to_le_bytes();
    let [t0, t1, t2, t3] = bridge_us.to_le_bytes();
    let header = [s0, s1, VERSION, sensor, q0, q1, t0, t1, t2, t3];
    let words = to_frame_order(reading).map(encode_word);
    let mut frame = [0; FRAME_LEN];
    let bytes = header
        .into_iter()
        .chain(words.into_iter().flat_map(u16::to_le_bytes));
    for (dst, src) in frame.iter_mut().zip(bytes) {
        *dst = src;
    }
    let [_, _, body @ .., _, _] = &frame;
    let crc = crc16_ccitt_false(body).to_le_bytes();
    let [.., c0, c1] = &mut frame;
    [*c0, *c1] = crc;
    frame
}

/// Checks sync, version and sensor index.
fn check_prefix(&[s0, s1, version, sensor]: &[u8; PREFIX_LEN]) -> Result<(), FrameError> {
    if [s0, s1] != SYNC {
        Err(FrameError::Sync { found: [s0, s1] })
    } else if version != VERSION {
        Err(FrameError::Version { found: version })
    } else if usize::from(sensor) >= N_SENSORS {
        Err(FrameError::Sensor { found: sensor })
    } else {
        Ok(())
    }
}

/// Decodes one frame: checks sync, version, sensor and CRC, then decodes the
/// words (invalid ones become 0 and are listed in [`DecodedFrame::invalid`]).
pub fn decode_frame(frame: &[u8; FRAME_LEN]) -> Result<DecodedFrame, FrameError> {
    let [s0, s1, version, sensor, q0, q1, t0, t1, t2, t3, words @ .., c0, c1] = frame;
    check_prefix(&[*s0, *s1, *version, *sensor])?;
    let [_, _, body @ .., _, _] = frame;
    let received = u16::from_le_bytes([*c0, *c1]);
    let computed = crc16_ccitt_false(body);
    if received != computed {
        return Err(FrameError::Crc { received, computed });
    }
    let seq = u16::from_le_bytes([*q0, *q1]);
    let mut reading = BioTacReading {
        seq,
        stamp_s: 0.0,
        electrodes: [0; N_ELECTRODES],
        pdc: 0,
        pac: [0; N_PAC],
        tdc: 0,
        tac: 0,
    };
    let mut invalid = ChannelMask::default();
    for (position, &bytes) in words.as_chunks::<2>().0.iter().enumerate() {
        match (
            decode_word(u16::from_le_bytes(bytes)),
            slot(&mut reading, position),
        ) {
            (Ok(value), Some(dst)) => *dst = value,
            _ => invalid.insert(position),
        }
    }
    Ok(DecodedFrame {
        sensor: *sensor,
        seq,
        bridge_us: u32::from_le_bytes([*t0, *t1, *t2, *t3]),
        reading,
        invalid,
    })
}

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
fn seq_lost(previous: u16, seq: u16) -> Option<u16> {
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

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    /// A reading whose 44 values all differ, shifted by `offset` (shared with
    /// the invalid-sample policy's tests).
    pub(in crate::biotac) fn reading(offset: u16) -> BioTacReading {
        let value = |i: usize| (i as u16 * 89 + offset) % (ADC_MAX + 1);
        BioTacReading {
            seq: 0,
            stamp_s: 0.0,
            electrodes: std::array::from_fn(value),
            pdc: value(19),
            pac: std::array::from_fn(|i| value(20 + i)),
            tdc: value(42),
            tac: value(43),
        }
    }

    /// Decodes `bytes` in one push; returns the frames and the decoder.
    fn decode_all(bytes: &[u8]) -> (Vec<DecodedFrame>, Decoder) {
        let mut decoder = Decoder::new();
        let mut frames = Vec::new();
        decoder.push(bytes, |f| frames.push(f));
        (frames, decoder)
    }

    /// Overwrites word `position` of an encoded frame and fixes the CRC.
    fn set_word(frame: &mut [u8; FRAME_LEN], position: usize, word: u16) {
        let at = HEADER_LEN + 2 * position;
        frame[at..at + 2].copy_from_slice(&word.to_le_bytes());
        let crc = crc16_ccitt_false(&frame[2..98]);
        frame[98..].copy_from_slice(&crc.to_le_bytes());
    }

    #[test]
    fn every_12_bit_value_round_trips() {
        for value in 0..=ADC_MAX {
            assert_eq!(decode_word(encode_word(value)), Ok(value), "{value}");
        }
    }

    #[test]
    fn word_layout_matches_the_architecture_page() {
        // D = 0b1010_1100_1011: D[11:5] = 0b1010110, D[4:0] = 0b01011.
        let word = encode_word(0b1010_1100_1011);
        assert_eq!(word >> 9, 0b1010110);
        assert_eq!((word >> 3) & 0x1F, 0b01011);
        assert_eq!(word & 0b110, 0);
        let [high, low] = word.to_be_bytes();
        assert_eq!(high.count_ones() % 2, 1);
        assert_eq!(low.count_ones() % 2, 1);
    }

    #[test]
    fn every_single_bit_flip_is_detected() {
        for value in 0..=ADC_MAX {
            for bit in 0..16 {
                let flipped = encode_word(value) ^ (1 << bit);
                let err = decode_word(flipped).expect_err("flip went undetected");
                // A flip can turn the high byte into 0xA5 (even parity too).
                let expected = if flipped >> 8 == u16::from(ERROR_WORD_HIGH) {
                    WordError::ErrorWord { word: flipped }
                } else {
                    WordError::Parity { word: flipped }
                };
                assert_eq!(err, expected, "value {value} bit {bit}");
            }
        }
    }

    #[test]
    fn words_starting_0xa5_are_error_words() {
        for low in 0..=u8::MAX {
            let word = u16::from_be_bytes([ERROR_WORD_HIGH, low]);
            assert_eq!(decode_word(word), Err(WordError::ErrorWord { word }));
        }
    }

    #[test]
    fn reserved_bits_are_rejected_when_parity_holds() {
        let word = encode_word(1234) | 0b110; // two flips: parity unchanged
        assert_eq!(decode_word(word), Err(WordError::Reserved { word }));
    }

    #[test]
    #[cfg(debug_assertions)]
    #[should_panic(expected = "does not fit in 12 bits")]
    fn encode_word_refuses_13_bits_in_debug() {
        encode_word(ADC_MAX + 1);
    }

    #[test]
    #[cfg(not(debug_assertions))]
    fn encode_word_masks_to_12_bits_in_release() {
        assert_eq!(decode_word(encode_word(0xF123)), Ok(0x123));
    }

    #[test]
    fn crc_matches_the_standard_check_value() {
        assert_eq!(crc16_ccitt_false(b"123456789"), 0x29B1);
        assert_eq!(crc16_ccitt_false(&[]), 0xFFFF);
    }

    #[test]
    fn crc_table_matches_bitwise_crc() {
        let bitwise = |bytes: &[u8]| {
            bytes.iter().fold(CRC_INIT, |mut crc, &b| {
                crc ^= u16::from(b) << 8;
                for _ in 0..8 {
                    crc = if crc & 0x8000 != 0 {
                        (crc << 1) ^ CRC_POLY
                    } else {
                        crc << 1
                    };
                }
                crc
            })
        };
        let bytes: Vec<u8> = (0..=u8::MAX).chain((0..=u8::MAX).rev()).collect();
        for end in 0..bytes.len() {
            assert_eq!(crc16_ccitt_false(&bytes[..end]), bitwise(&bytes[..end]));
        }
    }

    #[test]
    fn channel_names_follow_the_frame_order() {
        for k in 0..N_ELECTRODES {
            assert_eq!(channel_name(2 * k), Some(format!("e{}", k + 1).as_str()));
        }
        for k in 0..N_PAC {
            assert_eq!(
                channel_name(2 * k + 1),
                Some(format!("pac{}", k + 1).as_str())
            );
        }
        assert_eq!(channel_name(38), Some("pdc"));
        assert_eq!(channel_name(40), Some("tac"));
        assert_eq!(channel_name(42), Some("tdc"));
        assert_eq!(channel_name(N_WORDS), None);
    }

    #[test]
    fn slots_follow_the_frame_order() {
        let r = reading(1);
        let values = to_frame_order(&r);
        assert_eq!(values[12], r.electrodes[6]); // e7
        assert_eq!(values[5], r.pac[2]); // pac3
        assert_eq!(values[38], r.pdc);
        assert_eq!(values[40], r.tac);
        assert_eq!(values[42], r.tdc);
        assert_eq!(values[43], r.pac[21]);
        let mut sorted = values.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), N_WORDS, "every field appears once");
    }

    #[test]
    fn channel_mask_lists_names_in_frame_order() {
        let mut mask = ChannelMask::default();
        for position in [42, 12, 5, 38, 40, 44, 100] {
            mask.insert(position);
        }
        assert_eq!(mask.len(), 5);
        assert!(mask.contains(12) && !mask.contains(13) && !mask.contains(44));
        assert_eq!(
            mask.names().collect::<Vec<_>>(),
            ["pac3", "e7", "pdc", "tac", "tdc"]
        );
    }

    #[test]
    fn frame_layout_matches_the_spec() {
        let r = reading(3);
        let frame = encode_frame(2, 0x1234, 0xDEAD_BEEF, &r);
        assert_eq!(frame[..4], [0xAA, 0x55, 1, 2]);
        assert_eq!(frame[4..6], [0x34, 0x12]);
        assert_eq!(frame[6..10], [0xEF, 0xBE, 0xAD, 0xDE]);
        let word = |position: usize| {
            u16::from_le_bytes([frame[10 + 2 * position], frame[11 + 2 * position]])
        };
        assert_eq!(word(0), encode_word(r.electrodes[0]));
        assert_eq!(word(1), encode_word(r.pac[0]));
        assert_eq!(word(36), encode_word(r.electrodes[18]));
        assert_eq!(word(38), encode_word(r.pdc));
        assert_eq!(word(40), encode_word(r.tac));
        assert_eq!(word(42), encode_word(r.tdc));
        assert_eq!(word(43), encode_word(r.pac[21]));
        let crc = crc16_ccitt_false(&frame[2..98]);
        assert_eq!(frame[98..], crc.to_le_bytes());
    }

    #[test]
    fn frame_round_trips_and_takes_seq_from_the_header() {
        let r = BioTacReading {
            seq: 999,
            stamp_s: 4.5,
            ..reading(7)
        };
        let decoded = decode_frame(&encode_frame(1, 65535, 42, &r)).unwrap();
        assert_eq!(
            decoded,
            DecodedFrame {
                sensor: 1,
                seq: 65535,
                bridge_us: 42,
                reading: BioTacReading {
                    seq: 65535,
                    stamp_s: 0.0,
                    ..r
                },
                invalid: ChannelMask::default(),
            }
        );
    }

    #[test]
    fn decode_frame_reports_each_header_fault() {
        let good = encode_frame(0, 1, 2, &reading(0));
        let with = |at: usize, byte: u8| {
            let mut f = good;
            f[at] = byte;
            decode_frame(&f)
        };
        assert_eq!(
            with(1, 0x56),
            Err(FrameError::Sync {
                found: [0xAA, 0x56]
            })
        );
        assert_eq!(with(2, 2), Err(FrameError::Version { found: 2 }));
        assert_eq!(with(3, 3), Err(FrameError::Sensor { found: 3 }));
        let computed = crc16_ccitt_false(
            &{
                let mut f = good;
                f[50] ^= 0x10;
                f
            }[2..98],
        );
        let received = u16::from_le_bytes([good[98], good[99]]);
        assert_eq!(
            with(50, good[50] ^ 0x10),
            Err(FrameError::Crc { received, computed })
        );
    }

    #[test]
    fn invalid_words_are_zeroed_and_listed() {
        let mut frame = encode_frame(0, 5, 0, &reading(9));
        set_word(&mut frame, 12, encode_word(100) ^ 1); // e7: parity
        set_word(&mut frame, 38, 0xA5A5); // pdc: error word
        let decoded = decode_frame(&frame).unwrap();
        assert_eq!(decoded.invalid.names().collect::<Vec<_>>(), ["e7", "pdc"]);
        assert_eq!(decoded.reading.electrodes[6], 0);
        assert_eq!(decoded.reading.pdc, 0);
        assert_eq!(decoded.reading.electrodes[5], reading(9).electrodes[5]);
        let (_, decoder) = decode_all(&frame);
        assert_eq!(decoder.stats().parity_errors, 2);
    }

    #[test]
    fn decoder_finds_frames_fed_byte_by_byte() {
        let bytes: Vec<u8> = (0..5)
            .flat_map(|i| encode_frame(i % 3, i.into(), 0, &reading(i.into())))
            .collect();
        let mut decoder = Decoder::new();
        let mut seqs = Vec::new();
        for byte in &bytes {
            decoder.push(std::slice::from_ref(byte), |f| seqs.push(f.seq));
        }
        assert_eq!(seqs, [0, 1, 2, 3, 4]);
        assert_eq!(decoder.pending(), 0);
        assert_eq!(decoder.stats().bytes_skipped, 0);
    }

    #[test]
    fn decoder_resyncs_after_garbage() {
        let mut bytes = vec![0x00, 0xAA, 0xAA, 0x55, 0x01, 0x07, 0x55, 0xAA];
        bytes.extend_from_slice(&encode_frame(0, 1, 0, &reading(0)));
        let (frames, decoder) = decode_all(&bytes);
        assert_eq!(frames.len(), 1);
        assert_eq!(decoder.stats().bytes_skipped, 8);
        assert_eq!(
            decoder.stats().crc_errors,
            0,
            "bad sensor byte rejected early"
        );
    }

    #[test]
    fn torn_frame_does_not_hide_the_next_one() {
        let torn = encode_frame(0, 1, 0, &reading(1));
        let mut bytes = torn[..60].to_vec();
        bytes.extend_from_slice(&encode_frame(0, 2, 0, &reading(2)));
        let (frames, decoder) = decode_all(&bytes);
        assert_eq!(frames.iter().map(|f| f.seq).collect::<Vec<_>>(), [2]);
        assert_eq!(decoder.stats().crc_errors, 1);
        assert_eq!(decoder.stats().bytes_skipped, 60);
    }

    #[test]
    fn false_sync_resumes_at_the_next_byte() {
        // A sync with a good prefix 10 bytes before a real frame: its CRC
        // fails, and the real frame starts inside its 100 bytes.
        let mut bytes = vec![0xAA, 0x55, 0x01, 0x00, 0, 0, 0, 0, 0, 0];
        bytes.extend_from_slice(&encode_frame(1, 7, 0, &reading(5)));
        let (frames, decoder) = decode_all(&bytes);
        assert_eq!(frames.len(), 1);
        assert_eq!(frames[0].reading.electrodes, reading(5).electrodes);
        assert_eq!(decoder.stats().crc_errors, 1);
        assert_eq!(decoder.stats().bytes_skipped, 10);
    }

    #[test]
    fn garbage_never_grows_the_buffer() {
        let mut decoder = Decoder::new();
        let patterns: [&[u8]; 3] = [&[0xAA], &[0xAA, 0x55, 0x01, 0x00], &[0x00, 0x55, 0xAA]];
        for pattern in patterns {
            for _ in 0..10_000 {
                decoder.push(pattern, |_| panic!("no frame in garbage"));
                assert!(decoder.pending() < FRAME_LEN);
            }
        }
        let s = decoder.stats();
        assert_eq!(s.bytes_skipped + decoder.pending() as u64, 80_000);
    }

    #[test]
    fn sequence_gaps_are_counted_per_sensor() {
        let seqs: [(u8, u16); 8] = [
            (0, 10),    // first frame of sensor 0: not a gap
            (1, 65534), // first frame of sensor 1
            (0, 11),
            (1, 65535),
            (0, 14), // 2 lost
            (1, 0),  // wrap: not a gap
            (1, 3),  // 2 lost
            (0, 15),
        ];
        let bytes: Vec<u8> = seqs
            .iter()
            .flat_map(|&(sensor, seq)| encode_frame(sensor, seq, 0, &reading(0)))
            .collect();
        let (frames, decoder) = decode_all(&bytes);
        assert_eq!(frames.len(), 8);
        assert_eq!(decoder.stats().lost, [2, 2, 0]);
        assert_eq!(decoder.stats().restarts, 0);
    }

    #[test]
    fn backward_sequence_jump_is_a_restart_not_a_gap() {
        let bytes: Vec<u8> = [500u16, 501, 0, 1, 3, 3]
            .iter()
            .flat_map(|&seq| encode_frame(2, seq, 0, &reading(0)))
            .collect();
        let (_, decoder) = decode_all(&bytes);
        assert_eq!(decoder.stats().lost, [0, 0, 1]);
        assert_eq!(decoder.stats().restarts, 2, "501 -> 0 and 3 -> 3");
        assert_eq!(seq_lost(0, 32_768), Some(32_767));
        assert_eq!(seq_lost(0, 32_769), None);
    }
}
