//! The Cheetah test double (cheetah_double.c), built by the test that uses
//! it with `cc -shared -fPIC`, and its controls: fault injection and
//! counters, through the same loaded library the driver uses (one file is
//! loaded once per process, so both see one state). Shared by
//! tests/cheetah.rs and examples/cheetah_soak.rs (`#[path]`).

#![allow(dead_code)]

use std::ffi::{c_char, c_int, c_long, CString};
use std::path::{Path, PathBuf};
use std::process::Command;

const SOURCE: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/cheetah_double/cheetah_double.c"
);

/// The double, built as `<dir>/cheetah.so` (the name Total Phase ships).
pub struct Double {
    path: PathBuf,
    lib: libloading::Library,
}

impl Double {
    /// Compiles the double into `dir` (its own copy: a test that injects
    /// faults does not disturb another's) and loads it.
    pub fn build(dir: &Path) -> Result<Double, String> {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let path = dir.join("cheetah.so");
        let out = Command::new("cc")
            .args(["-shared", "-fPIC", "-O2", "-o"])
            .arg(&path)
            .arg(SOURCE)
            .output()
            .map_err(|e| format!("cc: {e}"))?;
        if !out.status.success() {
            return Err(format!("cc: {}", String::from_utf8_lossy(&out.stderr)));
        }
        // SAFETY: our own double; its initialisers do nothing.
        let lib = unsafe { libloading::Library::new(&path) }.map_err(|e| e.to_string())?;
        Ok(Double { path, lib })
    }

    /// The library file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Sets a fault ("plugged", "parity_every", "missing") or the sensors'
    /// electrodes ("electrodes": 19 or 24).
    pub fn control(&self, key: &str, value: i64) {
        let key = CString::new(key).unwrap_or_default();
        // SAFETY: the double's exported `int cheetah_double_control(const char*, long)`.
        let f = unsafe {
            self.lib
                .get::<unsafe extern "C" fn(*const c_char, c_long) -> c_int>(
                    b"cheetah_double_control",
                )
        };
        if let Ok(f) = f {
            // SAFETY: a NUL-terminated key that outlives the call.
            unsafe { f(key.as_ptr(), value as c_long) };
        }
    }

    /// A counter ("words", "parity_injected", "frames", "opens", "submits",
    /// "out_of_order").
    pub fn stat(&self, key: &str) -> c_long {
        let key = CString::new(key).unwrap_or_default();
        // SAFETY: the double's exported `long cheetah_double_stat(const char*)`.
        let f = unsafe {
            self.lib
                .get::<unsafe extern "C" fn(*const c_char) -> c_long>(b"cheetah_double_stat")
        };
        match f {
            // SAFETY: a NUL-terminated key that outlives the call.
            Ok(f) => unsafe { f(key.as_ptr()) },
            Err(_) => -1,
        }
    }
}

/// Words in the default frame of a sensor with `electrodes` electrodes
/// (44; 54 on a BioTac SP).
pub fn frame_words(electrodes: usize) -> usize {
    2 * (electrodes + 3)
}

/// The value the double's BioTac at board position `s` answers at frame
/// position `p` of frame `k` (mod 4096); TDC (position `tdc`) answers `k`.
pub fn value(s: u32, k: u32, p: u32, tdc: u32) -> u16 {
    if p == tdc {
        return (k & 0xFFF) as u16;
    }
    let mut h = (s + 1).wrapping_mul(0x9E37_79B1)
        ^ k.wrapping_mul(0x85EB_CA77)
        ^ p.wrapping_mul(0xC2B2_AE3D);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h & 0xFFF) as u16
}

/// The values of frame `k` of board position `s` holding a sensor of
/// `electrodes`, in frame order.
pub fn frame_values(s: u8, k: u32, electrodes: usize) -> Vec<u16> {
    let words = frame_words(electrodes) as u32;
    (0..words)
        .map(|p| value(u32::from(s), k & 0xFFF, p, words - 2))
        .collect()
}

/// The reading's values in its default frame's order: E1, PAC1, ..., En,
/// PACn, PDC, PAC, TAC, PAC, TDC, PAC (written here from the sequence, not
/// taken from the crate).
pub fn reading_values(r: &tactile_force::biotac::BioTacReading) -> Vec<u16> {
    let n = r.electrodes.len();
    (0..frame_words(n))
        .map(|p| match (p % 2, p / 2) {
            (1, i) => r.pac.get(i).copied().unwrap_or(u16::MAX),
            (_, i) if i < n => r.electrodes[i],
            (_, i) if i == n => r.pdc,
            (_, i) if i == n + 1 => r.tac,
            _ => r.tdc,
        })
        .collect()
}

/// Per board position: what the driver delivered, checked against what the
/// double sent.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SensorTally {
    /// Frames decoded.
    pub frames: u64,
    /// Readings delivered (the rest dropped).
    pub readings: u64,
    /// Readings dropped by the invalid-sample policy.
    pub dropped: u64,
    /// Invalid words in the frames.
    pub invalid: u64,
    /// Channels held from the previous frame in delivered readings.
    pub held: u64,
    /// Values that differ from what the double sent (must stay 0).
    pub mismatches: u64,
    /// Frames whose number could not be told (TDC invalid, no previous).
    pub unverified: u64,
    /// Steps of the frame number other than +1 (frames lost on a reconnect).
    pub gaps: u64,
}

/// Checks every frame and reading against the double's contents.
#[derive(Debug, Default)]
pub struct Checker {
    /// The tallies by board position.
    pub sensors: [SensorTally; 3],
    last_k: [Option<u32>; 3],
}

impl Checker {
    /// Forgets the frame numbers (after a reconnect nothing is held).
    pub fn reconnected(&mut self) {
        self.last_k = [None; 3];
    }

    /// Checks one frame and the reading the driver made of it.
    pub fn check(
        &mut self,
        frame: &tactile_force::biotac::DecodedFrame,
        reading: Option<&tactile_force::biotac::BioTacReading>,
    ) {
        let s = usize::from(frame.sensor).min(2);
        let t = &mut self.sensors[s];
        t.frames += 1;
        t.invalid += frame.invalid.len() as u64;
        let electrodes = frame.reading.electrodes.len();
        let words = frame_words(electrodes);
        let k = if frame.invalid.contains(words - 2) {
            self.last_k[s].map(|k| (k + 1) & 0xFFF)
        } else {
            let k = u32::from(frame.reading.tdc);
            if self.last_k[s].is_some_and(|last| (last + 1) & 0xFFF != k) {
                t.gaps += 1;
            }
            Some(k)
        };
        self.last_k[s] = k;
        let Some(k) = k else {
            t.unverified += 1;
            t.dropped += u64::from(reading.is_none());
            t.readings += u64::from(reading.is_some());
            return;
        };
        let expected = frame_values(frame.sensor, k, electrodes);
        let previous = frame_values(frame.sensor, k.wrapping_sub(1) & 0xFFF, electrodes);
        let got = reading_values(&frame.reading);
        for p in 0..words {
            if !frame.invalid.contains(p) && got[p] != expected[p] {
                t.mismatches += 1;
            }
        }
        match reading {
            None => t.dropped += 1,
            Some(r) => {
                t.readings += 1;
                let delivered = reading_values(r);
                if delivered.len() != words {
                    t.mismatches += 1;
                }
                for p in 0..words.min(delivered.len()) {
                    let want = if frame.invalid.contains(p) {
                        t.held += 1;
                        previous[p]
                    } else {
                        expected[p]
                    };
                    if delivered[p] != want {
                        t.mismatches += 1;
                    }
                }
            }
        }
    }
}
