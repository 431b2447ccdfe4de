//! The BioTac's own SPI protocol on SynTouch's multi-BioTac board, as a
//! Total Phase Cheetah adapter drives it: which bytes to shift, in which
//! order, with which slave selects and delays, and how the bytes that come
//! back become readings. Nothing here touches a device: [`BatchPlan::ops`]
//! lists the operations the adapter queues, and [`BatchPlan::decode`] reads
//! the bytes a batch returned; `biotac::cheetah` only moves them.
//!
//! # Sources
//!
//! The facts below come from SynTouch's BioTac Product Manual (V21, August
//! 2018; its chapter 5 "Sensor Electronics" covers the SPI interface and
//! the default sampling sequence: only its table of contents could be read
//! here, so no table number is cited) and, for every byte and delay, from
//! SynTouch's own C library for the Cheetah (`biotac.h` / `biotac.c`,
//! (c) 2011-2012 SynTouch LLC, "SPI version 2 commands", as redistributed in
//! Penn's `biotac_sensors` ROS driver, kth-ros-pkg/biotac_driver; its
//! BioTac SP edition in CNCR-NTU/biotac_sp_ros). Only numbers are taken
//! from them, no code.
//!
//! - **Sampling command** (one byte, then one padding byte): bit 7 set,
//!   the channel index in bits 6..1, bit 0 the odd parity of the byte.
//!   Channel indices: PAC 0, PDC 1, TAC 2, TDC 3, electrode Ek 16 + k
//!   (E1 = 17 ... E19 = 35; the BioTac SP's E20..E24 = 36..40). So PAC is
//!   0x80, PDC 0x83, TAC 0x85, TDC 0x86, E1 0xA2, E19 0xC7, E24 0xD0.
//! - **Response word** (two bytes, high byte first): the 12-bit sample with
//!   an odd-parity bit on each byte, the same word the serial bridge
//!   forwards; [`super::wire::decode_word`] checks it (parity, error words
//!   0xA5xx, reserved bits).
//! - **Default sampling sequence**: every electrode followed by a PAC
//!   sample, then PDC, PAC, TAC, PAC, TDC, PAC: 44 words (22 PAC samples)
//!   on the BioTac, 54 (27 PAC samples) on the BioTac SP
//!   ([`ElectrodeLayout::pac_per_frame`] cites the SP's): a frame every
//!   10 ms, or 12.3 ms on the SP.
//! - **Timing** (the library's defaults): 4400 samples per second (44 words:
//!   100 frames/s), SPI clock 4.4 MHz, 50 us between a sampling command and
//!   reading its result, 10 us after the words; the rest of the sample
//!   period is a wait computed from the bits shifted, one byte time per
//!   slave-select change and 3 us for the adapter.
//! - **The board**: slave select k (bit k of the Cheetah's SS mask) reaches
//!   the BioTac at board position k (0..=2); a sampling command is sent to
//!   every selected BioTac at once (all SS lines asserted), then each
//!   BioTac's result is clocked out under its own SS line.
//! - **Identification**: the read command 0x61 followed by 0x15 makes the
//!   BioTac answer its 16-character serial number, which starts with "BT".

use super::reading::{BioTacReading, ElectrodeLayout};
use super::wire::{decode_word, slot, with_odd_parity, ChannelMask, DecodedFrame};

/// BioTacs on one multi-BioTac board (board positions 0..BOARD_SLOTS).
pub const BOARD_SLOTS: usize = 3;
/// SPI clock (kHz): 4.4 MHz.
pub const BITRATE_KHZ: u32 = 4400;
/// Samples (words) per second of the default sequence.
pub const SAMPLE_RATE_HZ: u32 = 4400;
/// Wait between a sampling command and reading its result (ns).
pub const AFTER_SAMPLE_NS: u32 = 50_000;
/// Wait after the words of one sample (ns).
pub const INTERWORD_NS: u32 = 10_000;
/// What each sample leaves to the adapter itself (ns), as SynTouch's
/// library budgets it.
pub const ADAPTER_OVERHEAD_NS: u32 = 3_000;
/// Bit times the adapter spends on one slave-select change (SynTouch's
/// library budgets one byte).
pub const SS_CHANGE_BITS: u32 = 8;
/// The read command: the next byte names the property.
pub const READ_COMMAND: u8 = 0x61;
/// The property "serial number" (16 characters).
pub const SERIAL_NUMBER_PROPERTY: u8 = 0x15;
/// Characters of a serial number.
pub const SERIAL_NUMBER_LEN: usize = 16;

/// Which BioTac sits on the board: how many electrodes its frame samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SensorModel {
    /// The BioTac: 19 electrodes, 44 words per frame.
    BioTac,
    /// The BioTac SP: 24 electrodes, 54 words per frame.
    BioTacSp,
}

impl SensorModel {
    /// The model with `n` electrodes (19 or 24).
    pub fn from_electrodes(n: usize) -> Option<SensorModel> {
        match n {
            19 => Some(SensorModel::BioTac),
            24 => Some(SensorModel::BioTacSp),
            _ => None,
        }
    }

    /// Its electrodes.
    pub fn electrodes(self) -> usize {
        match self {
            SensorModel::BioTac => 19,
            SensorModel::BioTacSp => 24,
        }
    }

    /// Its electrode layout.
    pub fn layout(self) -> ElectrodeLayout {
        match self {
            SensorModel::BioTac => ElectrodeLayout::Biotac,
            SensorModel::BioTacSp => ElectrodeLayout::BiotacSp,
        }
    }

    /// Words in its default frame: each electrode and PDC, TAC, TDC, each
    /// followed by a PAC sample.
    pub fn frame_words(self) -> usize {
        super::wire::frame_words(self.layout())
    }

    /// Time its default frame takes at [`SAMPLE_RATE_HZ`] (s): 10 ms on the
    /// BioTac, 12.3 ms on the BioTac SP.
    pub fn frame_period_s(self) -> f64 {
        self.frame_words() as f64 / f64::from(SAMPLE_RATE_HZ)
    }
}

/// A channel the BioTac samples on command.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Channel {
    /// Dynamic pressure.
    Pac,
    /// Static pressure.
    Pdc,
    /// Heat flow.
    Tac,
    /// Temperature.
    Tdc,
    /// Electrode E1..E24 (the number, from 1).
    Electrode(u8),
}

impl Channel {
    /// The channel index of the sampling command (module documentation).
    pub fn index(self) -> u8 {
        match self {
            Channel::Pac => 0,
            Channel::Pdc => 1,
            Channel::Tac => 2,
            Channel::Tdc => 3,
            Channel::Electrode(k) => 16 + k,
        }
    }

    /// The sampling command byte: bit 7, the index in bits 6..1, odd parity
    /// in bit 0.
    pub fn command(self) -> u8 {
        with_odd_parity(0x80 | (self.index() & 0x3F) << 1)
    }

    /// The channel a sampling command byte asks for, if it is one (bit 7
    /// set, odd parity, a known index).
    pub fn from_command(byte: u8) -> Option<Channel> {
        if byte & 0x80 == 0 || byte.count_ones().is_multiple_of(2) {
            return None;
        }
        match (byte >> 1) & 0x3F {
            0 => Some(Channel::Pac),
            1 => Some(Channel::Pdc),
            2 => Some(Channel::Tac),
            3 => Some(Channel::Tdc),
            i @ 17..=40 => Some(Channel::Electrode(i - 16)),
            _ => None,
        }
    }
}

/// The default sampling sequence of `model`: E1, PAC, E2, PAC, ..., En, PAC,
/// PDC, PAC, TAC, PAC, TDC, PAC.
pub fn default_sequence(model: SensorModel) -> Vec<Channel> {
    let n = model.electrodes() as u8;
    (1..=n)
        .map(Channel::Electrode)
        .chain([Channel::Pdc, Channel::Tac, Channel::Tdc])
        .flat_map(|c| [c, Channel::Pac])
        .collect()
}

/// The slave-select mask of board position `slot` (0..=2).
pub fn ss_mask(slot: u8) -> u8 {
    1 << (slot & 0x07)
}

/// One operation queued on the adapter.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SpiOp {
    /// Assert the slave selects of this mask (bit k: board position k), the
    /// others released.
    Select(u8),
    /// Shift these bytes out; as many come back.
    Bytes(Vec<u8>),
    /// Wait (ns).
    DelayNs(u32),
}

/// What the adapter shifts for one batch of frames and how to read what
/// comes back. One batch samples `frames` frames of every board position
/// in `slots`, at [`SAMPLE_RATE_HZ`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BatchPlan {
    model: SensorModel,
    slots: Vec<u8>,
    frames: usize,
    sequence: Vec<Channel>,
}

/// A plan that cannot be made.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PlanError {
    /// No board position, a repeated one, or one past the board's three.
    #[error("board positions {0:?}: expected 1 to 3 distinct positions of 0, 1, 2")]
    Slots(Vec<u8>),
    /// Zero frames per batch.
    #[error("a batch holds at least one frame")]
    Frames,
}

/// Board positions or a batch size refused: refused input.
impl crate::exit::Classify for PlanError {
    fn class(&self) -> crate::exit::ExitClass {
        crate::exit::ExitClass::Refused
    }
}

impl BatchPlan {
    /// The plan for the BioTacs of `model` at board positions `slots`,
    /// `frames` frames per batch.
    pub fn new(model: SensorModel, slots: &[u8], frames: usize) -> Result<Self, PlanError> {
        let mut sorted = slots.to_vec();
        sorted.sort_unstable();
        sorted.dedup();
        let board = BOARD_SLOTS as u8;
        if sorted.is_empty() || sorted.len() != slots.len() || sorted.iter().any(|&s| s >= board) {
            return Err(PlanError::Slots(slots.to_vec()));
        }
        if frames == 0 {
            return Err(PlanError::Frames);
        }
        Ok(BatchPlan {
            model,
            slots: sorted,
            frames,
            sequence: default_sequence(model),
        })
    }

    /// The board positions sampled, ascending.
    pub fn slots(&self) -> &[u8] {
        &self.slots
    }

    /// The sensor model.
    pub fn model(&self) -> SensorModel {
        self.model
    }

    /// Frames per batch.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Bytes shifted (and returned) per sample: the command, its padding
    /// byte, and two per BioTac.
    pub fn bytes_per_sample(&self) -> usize {
        2 + 2 * self.slots.len()
    }

    /// Bytes a batch returns.
    pub fn batch_len(&self) -> usize {
        self.frames * self.sequence.len() * self.bytes_per_sample()
    }

    /// The wait that completes one sample period (ns): the period minus the
    /// bits shifted, the slave-select changes (all on, off, one per BioTac,
    /// off), the two fixed delays and the adapter's overhead.
    pub fn fill_delay_ns(&self) -> u32 {
        let period_ns = 1e9 / f64::from(SAMPLE_RATE_HZ);
        let bit_ns = 1e6 / f64::from(BITRATE_KHZ);
        let bits = 8 * self.bytes_per_sample() as u32 + SS_CHANGE_BITS * self.ss_changes();
        let busy = f64::from(bits) * bit_ns
            + f64::from(AFTER_SAMPLE_NS + INTERWORD_NS + ADAPTER_OVERHEAD_NS);
        (period_ns - busy).max(0.0).round() as u32
    }

    /// Slave-select changes per sample.
    pub fn ss_changes(&self) -> u32 {
        self.slots.len() as u32 + 3
    }

    /// The operations of one batch, in order.
    pub fn ops(&self) -> Vec<SpiOp> {
        let all = self.slots.iter().fold(0, |m, &s| m | ss_mask(s));
        let fill = self.fill_delay_ns();
        let mut ops = Vec::new();
        for _ in 0..self.frames {
            for channel in &self.sequence {
                ops.push(SpiOp::Select(all));
                ops.push(SpiOp::Bytes(vec![channel.command(), 0x00]));
                ops.push(SpiOp::Select(0));
                ops.push(SpiOp::DelayNs(AFTER_SAMPLE_NS));
                for &slot in &self.slots {
                    ops.push(SpiOp::Select(ss_mask(slot)));
                    ops.push(SpiOp::Bytes(vec![0x00, 0x00]));
                }
                ops.push(SpiOp::Select(0));
                ops.push(SpiOp::DelayNs(INTERWORD_NS + fill));
            }
        }
        ops
    }

    /// Decodes a batch's returned bytes into one frame per board position
    /// and frame, in time order (frame by frame, positions ascending).
    /// `seq` holds the next sequence number per board position and steps
    /// on. A short batch gives the frames it completes.
    pub fn decode(&self, bytes: &[u8], seq: &mut [u16; BOARD_SLOTS]) -> Vec<DecodedFrame> {
        let per_sample = self.bytes_per_sample();
        let per_frame = per_sample * self.sequence.len();
        let mut out = Vec::with_capacity(self.frames * self.slots.len());
        for frame in bytes.chunks_exact(per_frame).take(self.frames) {
            for (j, &slot) in self.slots.iter().enumerate() {
                let words = frame
                    .chunks_exact(per_sample)
                    .map(|s| u16::from_be_bytes([s[2 + 2 * j], s[3 + 2 * j]]));
                let next = &mut seq[usize::from(slot)];
                out.push(self.frame_of(slot, *next, words));
                *next = next.wrapping_add(1);
            }
        }
        out
    }

    /// One board position's frame from its words in sequence order (the
    /// default sequence: each word goes to its frame position's channel).
    fn frame_of(&self, slot_index: u8, seq: u16, words: impl Iterator<Item = u16>) -> DecodedFrame {
        let mut reading = BioTacReading {
            seq,
            ..BioTacReading::zeroed(self.model.layout())
        };
        let mut invalid = ChannelMask::default();
        for (position, word) in words.take(self.sequence.len()).enumerate() {
            match (decode_word(word), slot(&mut reading, position)) {
                (Ok(value), Some(dst)) => *dst = value,
                _ => invalid.insert(position),
            }
        }
        DecodedFrame {
            sensor: slot_index,
            seq,
            bridge_us: 0,
            reading,
            invalid,
        }
    }

    /// The operations that ask the BioTac at `slot` for its serial number:
    /// the read command, the wait, then the characters clocked out.
    pub fn serial_number_ops(slot: u8) -> Vec<SpiOp> {
        let mut ops = vec![
            SpiOp::Select(ss_mask(slot)),
            SpiOp::Bytes(vec![READ_COMMAND, SERIAL_NUMBER_PROPERTY]),
            SpiOp::Select(0),
            SpiOp::DelayNs(AFTER_SAMPLE_NS),
            SpiOp::Select(ss_mask(slot)),
        ];
        for _ in 0..SERIAL_NUMBER_LEN {
            ops.push(SpiOp::Bytes(vec![0x00]));
            ops.push(SpiOp::DelayNs(INTERWORD_NS));
        }
        ops.push(SpiOp::Select(0));
        ops
    }
}

/// The serial number in the bytes [`BatchPlan::serial_number_ops`] returned,
/// if a BioTac answered (printable characters starting "BT", up to the first
/// NUL or 0xFF).
pub fn serial_number(returned: &[u8]) -> Option<String> {
    let chars = returned.get(2..)?;
    let end = chars
        .iter()
        .position(|&b| b == 0 || b == 0xFF)
        .unwrap_or(chars.len());
    let text = chars.get(..end)?;
    (text.starts_with(b"BT") && text.iter().all(|b| b.is_ascii_graphic()))
        .then(|| String::from_utf8_lossy(text).into_owned())
}

#[cfg(test)]
mod tests;
