//! Output files checked before the work that makes them: a run that would
//! end unable to write its model, its recording or its plot is refused
//! before it starts (a calibration: before the arm moves), naming the file
//! by its role ("model file", "session", "plot").

use std::fs::OpenOptions;
use std::path::{Path, PathBuf};

use crate::exit::{Classify, ExitClass};

pub mod models_dir;

/// An output that cannot be written, refused before any work.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{role} {}: {reason}", path.display())]
pub struct OutputError {
    /// What the file is to the run ("model file", "session", "plot").
    pub role: &'static str,
    /// The file.
    pub path: PathBuf,
    /// Why it cannot be written, said once.
    pub reason: String,
}

/// An output refused: refused input.
impl Classify for OutputError {
    fn class(&self) -> ExitClass {
        ExitClass::Refused
    }
}

/// Checks that `path` can be written as `role`: it is not a folder, its
/// folder exists and takes a new file (a probe file is made and removed),
/// and an existing file opens for writing (it is not changed).
pub fn check_writable(path: &Path, role: &'static str) -> Result<(), OutputError> {
    let refuse = |reason: String| OutputError {
        role,
        path: path.to_path_buf(),
        reason,
    };
    let Some(name) = path.file_name() else {
        return Err(refuse("not a file name".into()));
    };
    if path.is_dir() {
        return Err(refuse("is a folder".into()));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        let what = if dir.exists() {
            "is not a folder"
        } else {
            "does not exist"
        };
        return Err(refuse(format!("its folder {} {what}", dir.display())));
    }
    let mut probe_name = std::ffi::OsString::from(".");
    probe_name.push(name);
    probe_name.push(format!(".probe-{}", std::process::id()));
    let probe = dir.join(probe_name);
    match OpenOptions::new().write(true).create_new(true).open(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
        }
        Err(e) => {
            return Err(refuse(format!(
                "its folder {} takes no new file ({e})",
                dir.display()
            )))
        }
    }
    if path.exists() {
        OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| refuse(format!("cannot be overwritten ({e})")))?;
    }
    Ok(())
}

/// Checks that `path`'s extension is one of `formats` (lower case, any
/// case accepted), then that it can be written ([`check_writable`]).
pub fn check_format(path: &Path, role: &'static str, formats: &[&str]) -> Result<(), OutputError> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if !formats.iter().any(|f| f.eq_ignore_ascii_case(ext)) {
        let found = match ext {
            "" => "no extension".to_string(),
            e => format!("the format .{e}"),
        };
        let list: Vec<String> = formats.iter().map(|f| format!(".{f}")).collect();
        return Err(OutputError {
            role,
            path: path.to_path_buf(),
            reason: format!("{found} is not written (supported: {})", list.join(", ")),
        });
    }
    check_writable(path, role)
}

/// Writes `bytes` to `path` whole or not at all: into a new temporary
/// file in the same folder (flushed to disk), then renamed over `path`. An
/// existing `path` is replaced, never written through (a symlink there is
/// replaced, not followed); a reader sees the old file or the new one.
pub fn write_whole(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let name = path
        .file_name()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name"))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".tmp-{}", std::process::id()));
    let tmp = path.with_file_name(tmp_name);
    let written = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .and_then(|mut f| f.write_all(bytes).and_then(|()| f.sync_all()))
        .and_then(|()| std::fs::rename(&tmp, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

#[cfg(test)]
mod tests;
