//! Total Phase's Cheetah library, loaded at run time (`libloading`): the
//! functions the backend calls, found by name, and nothing else. Every
//! function only moves bytes or settings to the adapter.
//!
//! Names and signatures are those of Total Phase's `cheetah.h` (API v3.06,
//! "Cheetah Interface Library"): `Cheetah` is a C `int` handle (> 0 when
//! valid), every call returns an `int` that is a count or, when negative, a
//! status code (`ch_status_string` names it). The shared object Total
//! Phase ships (`cheetah.so`) exports each function under the name `c_ch_*`
//! (its `cheetah.c` binds `ch_*` to those); a library that exports the plain
//! `ch_*` names (a wrapper linked with `cheetah.c`) is accepted too.

use std::ffi::{c_char, c_int, CStr};
use std::path::{Path, PathBuf};

use super::CheetahError;

/// The file names the library is looked for under, in order.
pub const LIBRARY_NAMES: [&str; 2] = ["cheetah.so", "libcheetah.so"];

/// `ch_find_devices_ext`: devices in use have this bit set in their port.
pub const PORT_NOT_FREE: u16 = 0x8000;
/// `ch_target_power`: power on.
pub const TARGET_POWER_ON: u8 = 0x01;

type FindDevicesExt = unsafe extern "C" fn(c_int, *mut u16, c_int, *mut u32) -> c_int;
type Open = unsafe extern "C" fn(c_int) -> c_int;
type HandleOnly = unsafe extern "C" fn(c_int) -> c_int;
type HandleInt = unsafe extern "C" fn(c_int, c_int) -> c_int;
type HandleByte = unsafe extern "C" fn(c_int, u8) -> c_int;
type StatusString = unsafe extern "C" fn(c_int) -> *const c_char;
type SpiConfigure = unsafe extern "C" fn(c_int, c_int, c_int, c_int, u8) -> c_int;
type QueueArray = unsafe extern "C" fn(c_int, c_int, *const u8) -> c_int;
type Shift = unsafe extern "C" fn(c_int, c_int, *mut u8) -> c_int;

/// The loaded library and the functions the backend uses.
pub struct CheetahLib {
    path: PathBuf,
    find_devices_ext: FindDevicesExt,
    open: Open,
    close: HandleOnly,
    status_string: StatusString,
    target_power: HandleByte,
    spi_configure: SpiConfigure,
    spi_bitrate: HandleInt,
    queue_clear: HandleOnly,
    queue_oe: HandleByte,
    queue_ss: HandleByte,
    queue_array: QueueArray,
    queue_delay_ns: HandleInt,
    batch_shift: Shift,
    async_submit: HandleOnly,
    async_collect: Shift,
    // Last: the functions above point into it, so it must outlive them.
    _library: libloading::Library,
}

/// Where the library is looked for when no path is given: each directory of
/// `LD_LIBRARY_PATH`, the executable's directory, the current directory;
/// in each, [`LIBRARY_NAMES`] in order. A given path is taken as the file,
/// or, if it is a directory, searched like the others.
pub fn candidates(given: Option<&Path>) -> Vec<PathBuf> {
    let dirs: Vec<PathBuf> = match given {
        Some(p) if !p.is_dir() => return vec![p.to_path_buf()],
        Some(dir) => vec![dir.to_path_buf()],
        None => std::env::var_os("LD_LIBRARY_PATH")
            .map(|v| std::env::split_paths(&v).collect::<Vec<_>>())
            .unwrap_or_default()
            .into_iter()
            .filter(|d| !d.as_os_str().is_empty())
            .chain(
                std::env::current_exe()
                    .ok()
                    .and_then(|e| e.parent().map(Path::to_path_buf)),
            )
            .chain(std::env::current_dir().ok())
            .collect(),
    };
    dirs.iter()
        .flat_map(|d| LIBRARY_NAMES.iter().map(move |n| d.join(n)))
        .collect()
}

/// The first candidate that exists, or the error that lists them.
pub fn locate(given: Option<&Path>) -> Result<PathBuf, CheetahError> {
    let searched = candidates(given);
    searched
        .iter()
        .find(|p| p.is_file())
        .cloned()
        .ok_or(CheetahError::LibraryNotFound { searched })
}

/// Looks up `name` as Total Phase's shared object exports it (`c_` + name),
/// else under its own name.
fn symbol<T: Copy>(lib: &libloading::Library, path: &Path, name: &str) -> Result<T, CheetahError> {
    for exported in [format!("c_{name}"), name.to_string()] {
        // SAFETY: the type T is the C signature of `name` in cheetah.h; the
        // pointer is used only while `lib` is loaded (CheetahLib keeps it).
        if let Ok(f) = unsafe { lib.get::<T>(exported.as_bytes()) } {
            return Ok(*f);
        }
    }
    Err(CheetahError::MissingFunction {
        path: path.to_path_buf(),
        name: name.to_string(),
    })
}

impl CheetahLib {
    /// Loads the library at `path` and finds every function used.
    pub fn load(path: &Path) -> Result<Self, CheetahError> {
        // SAFETY: loading runs the library's initialisers; the library is
        // the user's Cheetah library (or the tests' double), named by them.
        let library =
            unsafe { libloading::Library::new(path) }.map_err(|e| CheetahError::LibraryLoad {
                path: path.to_path_buf(),
                error: e.to_string(),
            })?;
        let l = &library;
        Ok(CheetahLib {
            path: path.to_path_buf(),
            find_devices_ext: symbol(l, path, "ch_find_devices_ext")?,
            open: symbol(l, path, "ch_open")?,
            close: symbol(l, path, "ch_close")?,
            status_string: symbol(l, path, "ch_status_string")?,
            target_power: symbol(l, path, "ch_target_power")?,
            spi_configure: symbol(l, path, "ch_spi_configure")?,
            spi_bitrate: symbol(l, path, "ch_spi_bitrate")?,
            queue_clear: symbol(l, path, "ch_spi_queue_clear")?,
            queue_oe: symbol(l, path, "ch_spi_queue_oe")?,
            queue_ss: symbol(l, path, "ch_spi_queue_ss")?,
            queue_array: symbol(l, path, "ch_spi_queue_array")?,
            queue_delay_ns: symbol(l, path, "ch_spi_queue_delay_ns")?,
            batch_shift: symbol(l, path, "ch_spi_batch_shift")?,
            async_submit: symbol(l, path, "ch_spi_async_submit")?,
            async_collect: symbol(l, path, "ch_spi_async_collect")?,
            _library: library,
        })
    }

    /// The file loaded.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// `ch_status_string`: the library's name of a status code.
    pub fn status(&self, code: c_int) -> String {
        // SAFETY: cheetah.h: returns a static string or NULL.
        let p = unsafe { (self.status_string)(code) };
        if p.is_null() {
            return format!("status {code}");
        }
        // SAFETY: non-null: a NUL-terminated static string.
        let text = unsafe { CStr::from_ptr(p) }.to_string_lossy();
        format!("{text} ({code})")
    }

    /// A call's result: a negative status becomes the error.
    fn check(&self, call: &'static str, code: c_int) -> Result<c_int, CheetahError> {
        if code < 0 {
            Err(CheetahError::Call {
                call,
                status: self.status(code),
            })
        } else {
            Ok(code)
        }
    }

    /// `ch_find_devices_ext`: the attached adapters' ports (with
    /// [`PORT_NOT_FREE`] for those in use) and unique ids.
    pub fn find_devices(&self) -> Result<Vec<(u16, u32)>, CheetahError> {
        let mut ports = [0u16; 16];
        let mut ids = [0u32; 16];
        // SAFETY: both arrays hold the 16 elements passed.
        let n = unsafe { (self.find_devices_ext)(16, ports.as_mut_ptr(), 16, ids.as_mut_ptr()) };
        let n = self.check("ch_find_devices_ext", n)? as usize;
        Ok(ports.into_iter().zip(ids).take(n.min(16)).collect())
    }

    /// `ch_open`: a handle (> 0).
    pub fn open(&self, port: u16) -> Result<c_int, CheetahError> {
        // SAFETY: plain integers.
        let h = unsafe { (self.open)(c_int::from(port)) };
        match self.check("ch_open", h)? {
            0 => Err(CheetahError::Call {
                call: "ch_open",
                status: "handle 0".into(),
            }),
            h => Ok(h),
        }
    }

    /// `ch_close` (errors ignored: the handle is dropped either way).
    pub fn close(&self, h: c_int) {
        // SAFETY: plain integers.
        unsafe { (self.close)(h) };
    }

    /// `ch_target_power`.
    pub fn target_power(&self, h: c_int, flag: u8) -> Result<c_int, CheetahError> {
        // SAFETY: plain integers.
        self.check("ch_target_power", unsafe { (self.target_power)(h, flag) })
    }

    /// `ch_spi_configure`: polarity, phase, bit order (cheetah.h's enums as
    /// ints), slave-select polarity mask.
    pub fn spi_configure(
        &self,
        h: c_int,
        polarity: c_int,
        phase: c_int,
        bitorder: c_int,
        ss_polarity: u8,
    ) -> Result<c_int, CheetahError> {
        // SAFETY: plain integers.
        let r = unsafe { (self.spi_configure)(h, polarity, phase, bitorder, ss_polarity) };
        self.check("ch_spi_configure", r)
    }

    /// `ch_spi_bitrate`: the bitrate set (kHz).
    pub fn spi_bitrate(&self, h: c_int, khz: c_int) -> Result<c_int, CheetahError> {
        // SAFETY: plain integers.
        self.check("ch_spi_bitrate", unsafe { (self.spi_bitrate)(h, khz) })
    }

    /// `ch_spi_queue_clear`.
    pub fn queue_clear(&self, h: c_int) -> Result<c_int, CheetahError> {
        // SAFETY: plain integers.
        self.check("ch_spi_queue_clear", unsafe { (self.queue_clear)(h) })
    }

    /// `ch_spi_queue_oe`.
    pub fn queue_oe(&self, h: c_int, oe: u8) -> Result<c_int, CheetahError> {
        // SAFETY: plain integers.
        self.check("ch_spi_queue_oe", unsafe { (self.queue_oe)(h, oe) })
    }

    /// `ch_spi_queue_ss`.
    pub fn queue_ss(&self, h: c_int, mask: u8) -> Result<c_int, CheetahError> {
        // SAFETY: plain integers.
        self.check("ch_spi_queue_ss", unsafe { (self.queue_ss)(h, mask) })
    }

    /// `ch_spi_queue_array`.
    pub fn queue_array(&self, h: c_int, bytes: &[u8]) -> Result<c_int, CheetahError> {
        let n = c_int::try_from(bytes.len()).unwrap_or(c_int::MAX);
        // SAFETY: the library reads n bytes of `bytes`.
        let r = unsafe { (self.queue_array)(h, n, bytes.as_ptr()) };
        self.check("ch_spi_queue_array", r)
    }

    /// `ch_spi_queue_delay_ns`.
    pub fn queue_delay_ns(&self, h: c_int, ns: u32) -> Result<c_int, CheetahError> {
        let ns = c_int::try_from(ns).unwrap_or(c_int::MAX);
        // SAFETY: plain integers.
        self.check("ch_spi_queue_delay_ns", unsafe {
            (self.queue_delay_ns)(h, ns)
        })
    }

    /// `ch_spi_batch_shift`: shifts the queue, fills `into`; bytes returned.
    pub fn batch_shift(&self, h: c_int, into: &mut [u8]) -> Result<usize, CheetahError> {
        let n = c_int::try_from(into.len()).unwrap_or(c_int::MAX);
        // SAFETY: the library writes at most n bytes into `into`.
        let r = unsafe { (self.batch_shift)(h, n, into.as_mut_ptr()) };
        self.check("ch_spi_batch_shift", r).map(|r| r as usize)
    }

    /// `ch_spi_async_submit`: queues the batch for shifting.
    pub fn async_submit(&self, h: c_int) -> Result<c_int, CheetahError> {
        // SAFETY: plain integers.
        self.check("ch_spi_async_submit", unsafe { (self.async_submit)(h) })
    }

    /// `ch_spi_async_collect`: waits for the oldest submitted batch, fills
    /// `into`; bytes returned.
    pub fn async_collect(&self, h: c_int, into: &mut [u8]) -> Result<usize, CheetahError> {
        let n = c_int::try_from(into.len()).unwrap_or(c_int::MAX);
        // SAFETY: the library writes at most n bytes into `into`.
        let r = unsafe { (self.async_collect)(h, n, into.as_mut_ptr()) };
        self.check("ch_spi_async_collect", r).map(|r| r as usize)
    }
}
