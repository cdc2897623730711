//! Writing a file all at once or not at all: the bytes go to a temporary file next to the target
//! (`.tolles-*.tmp`, same directory so the rename stays on one file system), which is renamed
//! over the target only once complete. A write that fails part way (disk full, a file-size
//! limit, an error in the data) leaves the target as it was — even when the target is the input
//! being read — and removes the temporary file; a killed process may leave the temporary file,
//! never a partial target.
//!
//! ```
//! use std::io::Write;
//! let dir = tempfile::tempdir().unwrap();
//! let path = dir.path().join("out.txt");
//! tolles_io::atomic::write_with(&path, |w| w.write_all(b"done\n")).unwrap();
//! assert_eq!(std::fs::read_to_string(&path).unwrap(), "done\n");
//! ```

use crate::error::IoError;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use tempfile::NamedTempFile;

/// A file being written in place of `target`; dropped without [`AtomicFile::commit`], it is
/// removed and `target` is untouched.
pub struct AtomicFile {
    temp: NamedTempFile,
    target: PathBuf,
}

impl AtomicFile {
    /// A new temporary file in `target`'s directory, with `target`'s permissions when it exists
    /// (a rename would otherwise leave the owner-only mode of a temporary file).
    pub fn create(target: &Path) -> Result<Self, IoError> {
        let fail = |source| write_error(target, source);
        let dir = match target.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir,
            _ => Path::new("."),
        };
        let temp = tempfile::Builder::new()
            .prefix(".tolles-")
            .suffix(".tmp")
            .tempfile_in(dir)
            .map_err(fail)?;
        let permissions = match std::fs::metadata(target) {
            Ok(meta) => Some(meta.permissions()),
            Err(_) => default_permissions(),
        };
        if let Some(permissions) = permissions {
            temp.as_file().set_permissions(permissions).map_err(fail)?;
        }
        Ok(Self {
            temp,
            target: target.to_path_buf(),
        })
    }

    /// The temporary file, to write to.
    pub fn file(&self) -> &File {
        self.temp.as_file()
    }

    /// The file the bytes are meant for.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Flushes the file to disk and renames it over the target.
    pub fn commit(self) -> Result<(), IoError> {
        let target = self.target;
        self.temp
            .as_file()
            .sync_all()
            .map_err(|e| write_error(&target, e))?;
        self.temp
            .persist(&target)
            .map_err(|e| write_error(&target, e.error))?;
        Ok(())
    }
}

/// Writes `path` through `write`, atomically (see the module documentation).
pub fn write_with(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<&File>) -> std::io::Result<()>,
) -> Result<(), IoError> {
    let file = AtomicFile::create(path)?;
    let mut out = BufWriter::new(file.file());
    write(&mut out)
        .and_then(|_| out.flush())
        .map_err(|e| write_error(path, e))?;
    drop(out);
    file.commit()
}

/// Writes `bytes` to `path`, atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    write_with(path, |w| w.write_all(bytes))
}

fn write_error(path: &Path, source: std::io::Error) -> IoError {
    IoError::Write {
        path: path.to_path_buf(),
        source,
    }
}

/// Read-write for everyone less the process's umask, as `File::create` gives a new file. The
/// umask is read from `/proc/self/status` (setting it to read it would race other threads);
/// without it, the common 022.
#[cfg(unix)]
fn default_permissions() -> Option<std::fs::Permissions> {
    use std::os::unix::fs::PermissionsExt;
    let mask = std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|status| {
            let line = status.lines().find(|l| l.starts_with("Umask:"))?;
            u32::from_str_radix(line.split_whitespace().nth(1)?, 8).ok()
        })
        .unwrap_or(0o022);
    Some(std::fs::Permissions::from_mode(0o666 & !mask))
}

#[cfg(not(unix))]
fn default_permissions() -> Option<std::fs::Permissions> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let entries = std::fs::read_dir(dir).unwrap();
        entries
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect()
    }

    #[test]
    fn a_failed_write_leaves_the_target_and_no_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("flight.csv");
        std::fs::write(&path, "tt,mag\n0,1\n").unwrap();
        let e = write_with(&path, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("disk full"))
        });
        assert!(e.unwrap_err().to_string().contains("disk full"));
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "tt,mag\n0,1\n");
        assert_eq!(names(dir.path()), ["flight.csv"]);
    }

    #[cfg(unix)]
    #[test]
    fn the_target_keeps_its_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.json");
        std::fs::write(&path, "{}").unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o640)).unwrap();
        write_bytes(&path, b"[]").unwrap();
        let mode = std::fs::metadata(&path).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o640);
        assert_eq!(names(dir.path()), ["m.json"]);
    }
}
