//! BioTacs on SynTouch's multi-BioTac board, read over SPI by a Total Phase
//! Cheetah USB adapter, as a [`FrameSource`] for the [`Driver`].
//!
//! What to shift and how to read it back is [`super::spi`]'s (the sampling
//! sequence, commands, timing, parity); this module only hands its
//! operations to the adapter's library ([`ffi`], loaded at run time) and its
//! returned bytes back. The driver's policies (hold-last-good, stale,
//! reconnect with back-off, statistics, tare) apply unchanged.
//!
//! Opening (each reconnect too): find the adapter (by port or serial
//! number), open it, SPI mode 0 (clock idle low, sample on the leading
//! edge), MSB first, slave selects active low, target power on (SynTouch's
//! library then waits 100 ms), 4.4 MHz; ask each board position for its
//! serial number; sample the positions asked for (by default those that
//! answered). Streaming: one frame per batch, [`ASYNC_DEPTH`] batches
//! submitted ahead so the adapter never idles; each read collects one
//! batch (10 ms) and submits the next.
//!
//! Counters ([`DecoderStats`]): `frames` decoded, `parity_errors` invalid
//! words (parity, error words, reserved bits), `crc_errors` and `lost`
//! unused (SPI has no CRC; batches are never skipped while the link holds).

use std::ffi::c_int;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use super::driver::{Driver, DriverConfig, FrameSource, LinkError};
use super::spi::{self, BatchPlan, SensorModel, SpiOp, BITRATE_KHZ, BOARD_SLOTS};
use super::wire::{DecodedFrame, DecoderStats};
use crate::exit::{Classify, ExitClass};

pub mod ffi;
use ffi::CheetahLib;

/// Batches submitted ahead of the one being collected.
pub const ASYNC_DEPTH: usize = 3;
/// Frames per batch: one (10 ms), so a reading waits at most one frame.
pub const FRAMES_PER_BATCH: usize = 1;
/// Wait after powering the board (ms), as SynTouch's library does.
pub const POWER_ON_WAIT_MS: u64 = 100;

/// Which adapter: its port number or its serial number.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AdapterId {
    /// The port number `ch_find_devices` lists (0, 1, ...).
    Port(u16),
    /// The adapter's serial number, as printed on it ("1364-123456") or as
    /// one number (1364123456).
    Serial(u32),
}

impl std::str::FromStr for AdapterId {
    type Err = CheetahError;

    /// A port number (up to 4 digits) or a serial number (10 digits, with
    /// or without the dash after the fourth).
    fn from_str(s: &str) -> Result<Self, CheetahError> {
        let s = s.trim();
        let digits: String = s.chars().filter(|c| *c != '-').collect();
        let bad = || CheetahError::Adapter(s.to_string());
        if digits.is_empty() || !digits.chars().all(|c| c.is_ascii_digit()) {
            return Err(bad());
        }
        if s.contains('-') || digits.len() > 4 {
            digits.parse().map(AdapterId::Serial).map_err(|_| bad())
        } else {
            digits.parse().map(AdapterId::Port).map_err(|_| bad())
        }
    }
}

impl std::fmt::Display for AdapterId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            AdapterId::Port(p) => write!(f, "port {p}"),
            AdapterId::Serial(s) => write!(f, "serial {:04}-{:06}", s / 1_000_000, s % 1_000_000),
        }
    }
}

/// What the Cheetah backend reads.
#[derive(Debug, Clone, PartialEq)]
pub struct CheetahConfig {
    /// The adapter.
    pub adapter: AdapterId,
    /// The library file (or a directory holding it); `None`: searched
    /// ([`ffi::candidates`]).
    pub library: Option<PathBuf>,
    /// Board positions to sample (0..=2); `None`: those whose BioTac
    /// answers its serial number.
    pub sensors: Option<Vec<u8>>,
    /// The BioTac model on the board.
    pub model: SensorModel,
}

impl CheetahConfig {
    /// The adapter `adapter`, its library searched, every BioTac that answers.
    pub fn new(adapter: AdapterId) -> Self {
        CheetahConfig {
            adapter,
            library: None,
            sensors: None,
            model: SensorModel::BioTac,
        }
    }

    /// The configuration from its settings as the CLI and the ROS node take
    /// them: the adapter's id, the library (empty: searched), the board
    /// positions (empty: those that answer) and the electrodes (19 or 24).
    pub fn from_settings(
        adapter: &str,
        library: &str,
        sensors: &[u8],
        electrodes: usize,
    ) -> Result<Self, CheetahError> {
        let model =
            SensorModel::from_electrodes(electrodes).ok_or(CheetahError::Electrodes(electrodes))?;
        if let Some(&bad) = sensors.iter().find(|&&s| usize::from(s) >= BOARD_SLOTS) {
            return Err(CheetahError::Plan(spi::PlanError::Slots(vec![bad])));
        }
        Ok(CheetahConfig {
            adapter: adapter.parse()?,
            library: (!library.is_empty()).then(|| PathBuf::from(library)),
            sensors: (!sensors.is_empty()).then(|| sensors.to_vec()),
            model,
        })
    }
}

/// What went wrong with the adapter or its library.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum CheetahError {
    /// No library file where it was looked for.
    #[error(
        "Total Phase's Cheetah library not found (searched {}). Download the Cheetah \
         API for Linux from totalphase.com and put its `cheetah.so` next to the executable, in \
         the current directory or in a directory of LD_LIBRARY_PATH, or name the file with \
         --cheetah-lib (the ROS parameter cheetah_library)",
        .searched.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", ")
    )]
    LibraryNotFound {
        /// The files tried.
        searched: Vec<PathBuf>,
    },
    /// The file is not a loadable library.
    #[error("cannot load the Cheetah library {}: {error}", .path.display())]
    LibraryLoad {
        /// The file.
        path: PathBuf,
        /// The loader's error.
        error: String,
    },
    /// The library lacks a function the backend calls.
    #[error("{} is not Total Phase's Cheetah library: no function {name} (nor c_{name})", .path.display())]
    MissingFunction {
        /// The file.
        path: PathBuf,
        /// The function.
        name: String,
    },
    /// An adapter id that is neither a port nor a serial number.
    #[error("Cheetah adapter {0:?}: expected a port number (0, 1, ...) or a serial number (1364-123456)")]
    Adapter(String),
    /// A sensor model that does not exist.
    #[error("{0} electrodes: a BioTac has 19, a BioTac SP 24")]
    Electrodes(usize),
    /// A call returned a negative status.
    #[error("{call}: {status}")]
    Call {
        /// The function.
        call: &'static str,
        /// The library's name of the status.
        status: String,
    },
    /// The adapter is not attached (or not accessible).
    #[error(
        "no Cheetah adapter at {wanted} (attached: {found}); check the USB cable and the udev rule"
    )]
    NotFound {
        /// The adapter asked for.
        wanted: AdapterId,
        /// The adapters attached.
        found: String,
    },
    /// Another program has the adapter open.
    #[error("the Cheetah adapter at {0} is in use by another program")]
    Busy(AdapterId),
    /// No BioTac answered on the board.
    #[error("no BioTac answered its serial number on the board (positions 0, 1, 2)")]
    NoBioTac,
    /// A board position or batch that cannot be planned.
    #[error(transparent)]
    Plan(#[from] spi::PlanError),
}

impl CheetahError {
    /// Whether retrying cannot help.
    pub fn fatal(&self) -> bool {
        self.class() == ExitClass::Refused
    }
}

/// A missing or wrong library, a bad id or plan: refused input;
/// the adapter failing at run time: the work failed.
impl Classify for CheetahError {
    fn class(&self) -> ExitClass {
        match self {
            CheetahError::LibraryNotFound { .. }
            | CheetahError::LibraryLoad { .. }
            | CheetahError::MissingFunction { .. }
            | CheetahError::Adapter(_)
            | CheetahError::Electrodes(_)
            | CheetahError::Plan(_) => ExitClass::Refused,
            _ => ExitClass::Failure,
        }
    }
}

impl From<CheetahError> for LinkError {
    fn from(e: CheetahError) -> Self {
        if e.fatal() {
            LinkError::Fatal(e.to_string())
        } else {
            LinkError::Lost(e.to_string())
        }
    }
}

/// An open adapter: its handle and what streams.
struct Session {
    handle: c_int,
    plan: BatchPlan,
    buf: Vec<u8>,
}

/// The Cheetah backend (module documentation).
pub struct CheetahSource {
    config: CheetahConfig,
    lib: Option<Arc<CheetahLib>>,
    session: Option<Session>,
    seq: [u16; BOARD_SLOTS],
    serials: [Option<String>; BOARD_SLOTS],
    stats: DecoderStats,
}

impl CheetahSource {
    /// The backend for `config`; nothing is loaded or opened yet.
    pub fn new(config: CheetahConfig) -> Self {
        CheetahSource {
            config,
            lib: None,
            session: None,
            seq: [0; BOARD_SLOTS],
            serials: Default::default(),
            stats: DecoderStats::default(),
        }
    }

    /// The driver on this source, stale after three of its sensor's frames
    /// (30 ms; 37 ms for a BioTac SP's longer frame).
    pub fn into_driver(self) -> Driver {
        let config = DriverConfig {
            stale_after_s: 3.0 * self.config.model.frame_period_s(),
            ..DriverConfig::new("")
        };
        Driver::with_source(config, Box::new(self))
    }

    /// The serial numbers the BioTacs answered at the last open, by board
    /// position.
    pub fn serials(&self) -> &[Option<String>; BOARD_SLOTS] {
        &self.serials
    }

    /// The library, loaded on first use.
    fn library(&mut self) -> Result<Arc<CheetahLib>, CheetahError> {
        if let Some(lib) = &self.lib {
            return Ok(lib.clone());
        }
        let path = ffi::locate(self.config.library.as_deref())?;
        let lib = Arc::new(CheetahLib::load(&path)?);
        tracing::info!(library = %path.display(), "Cheetah library loaded");
        self.lib = Some(lib.clone());
        Ok(lib)
    }

    /// The adapter's port, checked free.
    fn find(&self, lib: &CheetahLib) -> Result<u16, CheetahError> {
        let wanted = self.config.adapter;
        let devices = lib.find_devices()?;
        let found = devices.iter().find(|&&(port, id)| match wanted {
            AdapterId::Port(p) => port & !ffi::PORT_NOT_FREE == p,
            AdapterId::Serial(s) => id == s,
        });
        match found {
            Some(&(port, _)) if port & ffi::PORT_NOT_FREE != 0 => Err(CheetahError::Busy(wanted)),
            Some(&(port, _)) => Ok(port),
            None => Err(CheetahError::NotFound {
                wanted,
                found: if devices.is_empty() {
                    "none".into()
                } else {
                    devices
                        .iter()
                        .map(|&(p, id)| {
                            let port = AdapterId::Port(p & !ffi::PORT_NOT_FREE);
                            format!("{port} = {}", AdapterId::Serial(id))
                        })
                        .collect::<Vec<_>>()
                        .join(", ")
                },
            }),
        }
    }

    /// Opens, configures, identifies the BioTacs and starts streaming.
    fn start(&mut self, lib: &CheetahLib, h: c_int) -> Result<String, CheetahError> {
        lib.spi_configure(h, 0, 0, 0, 0x00)?;
        lib.target_power(h, ffi::TARGET_POWER_ON)?;
        std::thread::sleep(Duration::from_millis(POWER_ON_WAIT_MS));
        let khz = lib.spi_bitrate(h, BITRATE_KHZ as c_int)?;
        if khz != BITRATE_KHZ as c_int {
            tracing::warn!(
                asked = BITRATE_KHZ,
                set = khz,
                "Cheetah SPI bitrate differs"
            );
        }
        lib.queue_clear(h)?;
        lib.queue_oe(h, 1)?;
        for slot in 0..BOARD_SLOTS as u8 {
            let ops = BatchPlan::serial_number_ops(slot);
            let mut answer = vec![0; shifted(&ops)];
            queue(lib, h, &ops)?;
            lib.batch_shift(h, &mut answer)?;
            self.serials[usize::from(slot)] = spi::serial_number(&answer);
        }
        let answered: Vec<u8> = (0..BOARD_SLOTS as u8)
            .filter(|&s| self.serials[usize::from(s)].is_some())
            .collect();
        let slots = match &self.config.sensors {
            Some(s) => s.clone(),
            None if answered.is_empty() => return Err(CheetahError::NoBioTac),
            None => answered,
        };
        let plan = BatchPlan::new(self.config.model, &slots, FRAMES_PER_BATCH)?;
        queue(lib, h, &plan.ops())?;
        for _ in 0..ASYNC_DEPTH {
            lib.async_submit(h)?;
        }
        let sensors: Vec<String> = plan
            .slots()
            .iter()
            .map(|&s| match &self.serials[usize::from(s)] {
                Some(serial) => format!("{s}: {serial}"),
                None => format!("{s}: no answer"),
            })
            .collect();
        let text = format!(
            "Cheetah {} ({}), BioTacs {}",
            self.config.adapter,
            lib.path().display(),
            sensors.join(", ")
        );
        self.session = Some(Session {
            handle: h,
            buf: vec![0; plan.batch_len()],
            plan,
        });
        Ok(text)
    }
}

/// Bytes the operations shift.
fn shifted(ops: &[SpiOp]) -> usize {
    ops.iter()
        .map(|op| match op {
            SpiOp::Bytes(b) => b.len(),
            _ => 0,
        })
        .sum()
}

/// Clears the adapter's queue and queues `ops`.
fn queue(lib: &CheetahLib, h: c_int, ops: &[SpiOp]) -> Result<(), CheetahError> {
    lib.queue_clear(h)?;
    for op in ops {
        match op {
            SpiOp::Select(mask) => lib.queue_ss(h, *mask)?,
            SpiOp::Bytes(bytes) => lib.queue_array(h, bytes)?,
            SpiOp::DelayNs(ns) => lib.queue_delay_ns(h, *ns)?,
        };
    }
    Ok(())
}

impl FrameSource for CheetahSource {
    fn name(&self) -> String {
        format!("Cheetah {}", self.config.adapter)
    }

    fn open(&mut self) -> Result<String, LinkError> {
        self.close();
        let lib = self.library()?;
        let port = self.find(&lib)?;
        let h = lib.open(port)?;
        self.start(&lib, h).map_err(|e| {
            lib.close(h);
            LinkError::from(e)
        })
    }

    fn read(&mut self, _timeout_s: f64, frames: &mut Vec<DecodedFrame>) -> Result<(), LinkError> {
        let (Some(lib), Some(s)) = (self.lib.clone(), self.session.as_mut()) else {
            return Err(LinkError::Lost("not open".into()));
        };
        let n = lib.async_collect(s.handle, &mut s.buf)?;
        lib.async_submit(s.handle)?;
        if n != s.buf.len() {
            let e = format!("a batch returned {n} bytes, expected {}", s.buf.len());
            return Err(LinkError::Lost(e));
        }
        for frame in s.plan.decode(&s.buf, &mut self.seq) {
            self.stats.frames += 1;
            self.stats.parity_errors += frame.invalid.len() as u64;
            frames.push(frame);
        }
        Ok(())
    }

    fn close(&mut self) {
        if let (Some(lib), Some(s)) = (&self.lib, self.session.take()) {
            lib.close(s.handle);
        }
    }

    fn stats(&self) -> DecoderStats {
        self.stats
    }
}

impl Drop for CheetahSource {
    fn drop(&mut self) {
        self.close();
    }
}

#[cfg(test)]
mod tests;
