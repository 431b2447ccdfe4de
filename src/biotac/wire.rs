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
//!     electrodes: [2000; 19].into(),
//!     pdc: 1500,
//!     pac: [2048; 22].into(),
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

use super::{
    BioTacReading, ElectrodeLayout, Electrodes, Pac, ADC_MAX, MAX_ELECTRODES, N_ELECTRODES, N_PAC,
};

use crate::exit::{Classify, ExitClass};

mod decoder;
pub use decoder::{Decoder, DecoderStats};

/// Bytes per frame.
pub const FRAME_LEN: usize = 100;
/// Response words per frame: E1..E19, PDC, TAC, TDC and 22 PAC samples.
pub const N_WORDS: usize = 44;
/// Response words in a BioTac SP's default frame (E1..E24, PDC, TAC, TDC
/// and 27 PAC samples), the most a [`ChannelMask`] holds; the Cheetah
/// backend reads such frames, the bridge does not.
pub const MAX_WORDS: usize = 2 * (MAX_ELECTRODES + 3);
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
pub(super) fn with_odd_parity(byte: u8) -> u8 {
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

/// Response words in the default frame of `layout`'s sensor: 44 on a
/// BioTac, 54 on a BioTac SP.
pub fn frame_words(layout: ElectrodeLayout) -> usize {
    2 * (layout.count() + 3)
}

/// The name of the channel at a position of `layout`'s default frame ("e7",
/// "pac3", "pdc", "tac", "tdc"; PAC samples count from 1 like the
/// electrodes); `None` past the frame's words.
pub fn channel_name(position: usize, layout: ElectrodeLayout) -> Option<String> {
    let index = position / 2;
    if position >= frame_words(layout) {
        return None;
    }
    Some(match (position % 2, index.checked_sub(layout.count())) {
        (1, _) => format!("pac{}", index + 1),
        (_, None) => format!("e{}", index + 1),
        (_, Some(0)) => "pdc".into(),
        (_, Some(1)) => "tac".into(),
        _ => "tdc".into(),
    })
}

/// The reading's field at a position of its layout's default frame: even
/// positions hold the electrodes, PDC, TAC, TDC; odd positions the PAC
/// samples in order.
pub(super) fn slot(reading: &mut BioTacReading, position: usize) -> Option<&mut u16> {
    let index = position / 2;
    if position % 2 == 1 {
        return reading.pac.get_mut(index);
    }
    match index.checked_sub(reading.electrodes.len()) {
        None => reading.electrodes.get_mut(index),
        Some(0) => Some(&mut reading.pdc),
        Some(1) => Some(&mut reading.tac),
        Some(2) => Some(&mut reading.tdc),
        Some(_) => None,
    }
}

/// The reading's values in its default frame's order (0 past its words).
pub(super) fn to_frame_order(reading: &BioTacReading) -> [u16; MAX_WORDS] {
    // `slot` hands out `&mut`: read through a copy.
    let mut copy = *reading;
    std::array::from_fn(|position| slot(&mut copy, position).map_or(0, |v| *v))
}

/// A set of frame positions (0..54), such as the channels whose words were
/// invalid.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct ChannelMask(u64);

impl ChannelMask {
    /// Adds a frame position; positions past 53 are ignored.
    pub fn insert(&mut self, position: usize) {
        if position < MAX_WORDS {
            self.0 |= 1 << position;
        }
    }

    /// Whether the set holds a frame position.
    pub fn contains(self, position: usize) -> bool {
        position < MAX_WORDS && (self.0 >> position) & 1 == 1
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
        (0..MAX_WORDS).filter(move |&position| self.contains(position))
    }

    /// The channel names in the set for a frame of `layout`, in frame order
    /// (see [`channel_name`]).
    pub fn names(self, layout: ElectrodeLayout) -> impl Iterator<Item = String> {
        self.positions()
            .filter_map(move |position| channel_name(position, layout))
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

impl DecodedFrame {
    /// The names of its invalid channels (`e3`, `pac27`, `pdc`, ...), in
    /// frame order.
    pub fn invalid_names(&self) -> impl Iterator<Item = String> {
        self.invalid.names(self.reading.electrodes.layout())
    }
}

/// The frame for one reading. `reading.seq` is ignored in favour of `seq`;
/// a sensor index of 3 or more is written as given, and decoders reject it.
/// The frame holds a BioTac's 44 words: of a BioTac SP's reading, E20..E24
/// and PAC samples 23..27 are not carried (the bridge reads BioTacs;
/// docs/serial-protocol.md says so).
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
    let mut biotac = *reading;
    biotac.electrodes = Electrodes::filled(ElectrodeLayout::Biotac, 0);
    biotac
        .electrodes
        .copy_from_slice(&reading.electrodes[..N_ELECTRODES.min(reading.electrodes.len())]);
    biotac.pac =
        Pac::from_slice(&reading.pac[..N_PAC.min(reading.pac.len())]).unwrap_or(reading.pac);
    let order = to_frame_order(&biotac);
    let words: [u16; N_WORDS] = std::array::from_fn(|p| encode_word(order[p]));
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
        ..BioTacReading::zeroed(ElectrodeLayout::Biotac)
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

#[cfg(test)]
pub(super) mod tests;
