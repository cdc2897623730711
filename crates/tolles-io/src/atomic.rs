//! Writing a file all at once or not at all: the bytes go to a temporary file next to the target
//! (`.tolles-*.tmp`, same directory so the rename stays on one file system), which is renamed
//! over the target only once complete. A write that fails part way (disk full, a file-size
//! limit, an error in the data) leaves the target as it was — even when the target is the input
//! being read — and removes the temporary file; a killed process may leave the temporary file,
//! never a partial target.
//!
//! A large file goes to the disk in aligned chunks of a few MiB past the page cache (`O_DIRECT`
//! on Linux, where the file system takes it; ordinary writes otherwise, and for the last
//! partial chunk): writing a 169 MB survey then costs no copy into the cache and leaves no dirty
//! pages for the kernel to write back at the flush before the rename — or at the rename itself,
//! which on ext4 writes back a file renamed over an existing one.
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
use std::io::Write;
use std::path::{Path, PathBuf};
use tempfile::NamedTempFile;

/// A file being written in place of `target`; dropped without [`AtomicFile::commit`], it is
/// removed and `target` is untouched.
///
/// A target that exists and is not a regular file (a device such as `/dev/null`, a named pipe,
/// a socket, `/dev/stdout`) is written straight into instead: a rename would replace it with a
/// regular file, and such a target is a stream with nothing to keep whole.
pub struct AtomicFile {
    destination: Destination,
    target: PathBuf,
}

enum Destination {
    Temporary(NamedTempFile),
    Stream(File),
}

impl AtomicFile {
    /// A new temporary file in `target`'s directory, with `target`'s permissions when it exists
    /// (a rename would otherwise leave the owner-only mode of a temporary file).
    pub fn create(target: &Path) -> Result<Self, IoError> {
        let fail = |source| write_error(target, source);
        if is_stream(target) {
            let file = std::fs::OpenOptions::new()
                .write(true)
                .open(target)
                .map_err(fail)?;
            return Ok(Self {
                destination: Destination::Stream(file),
                target: target.to_path_buf(),
            });
        }
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
            destination: Destination::Temporary(temp),
            target: target.to_path_buf(),
        })
    }

    /// The temporary file (or the stream), to write to.
    pub fn file(&self) -> &File {
        match &self.destination {
            Destination::Temporary(temp) => temp.as_file(),
            Destination::Stream(file) => file,
        }
    }

    /// A writer to the temporary file that sends large writes past the page cache (see
    /// [`DirectWriter`]); flush it before [`AtomicFile::commit`].
    pub fn direct_writer(&self) -> Result<DirectWriter, IoError> {
        let file = self
            .file()
            .try_clone()
            .map_err(|e| write_error(&self.target, e))?;
        Ok(match &self.destination {
            Destination::Temporary(_) => DirectWriter::new(file),
            Destination::Stream(_) => DirectWriter::buffered(file),
        })
    }

    /// The file the bytes are meant for.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Flushes the file to disk and renames it over the target.
    pub fn commit(self) -> Result<(), IoError> {
        let target = self.target;
        let temp = match self.destination {
            Destination::Temporary(temp) => temp,
            Destination::Stream(_) => return Ok(()),
        };
        temp.as_file()
            .sync_all()
            .map_err(|e| write_error(&target, e))?;
        temp.persist(&target)
            .map_err(|e| write_error(&target, e.error))?;
        Ok(())
    }
}

/// Whether `target` exists as something other than a regular file or a directory (through
/// symbolic links): a device, a named pipe or a socket.
fn is_stream(target: &Path) -> bool {
    std::fs::metadata(target).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// Writes `path` through `write`, atomically (see the module documentation).
pub fn write_with(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), IoError> {
    let file = AtomicFile::create(path)?;
    let mut out = file.direct_writer()?;
    write(&mut out)
        .and_then(|_| out.flush())
        .map_err(|e| write_error(path, e))?;
    file.commit()
}

/// Bytes in a direct write: a multiple of [`ALIGN`].
const DIRECT_CHUNK: usize = 4 << 20;

/// Alignment of a direct write's memory, file offset and length (bytes); enough for every
/// block device's logical block.
const ALIGN: usize = 4096;

/// Writes to a file in [`DIRECT_CHUNK`]s that go straight to the disk, past the page cache
/// (`O_DIRECT`, Linux), and the last partial chunk through the page cache. A survey's output
/// then costs no copy into the cache, no dirty pages for the kernel to write back later (which
/// a rename over an existing file on ext4 does at once), and little flush before the rename.
/// A file system that refuses direct writes gets ordinary ones, from where it refused.
///
/// [`Write::flush`] writes what is held through the page cache; writes after it go through the
/// page cache too (the file's end is then no longer aligned).
pub struct DirectWriter {
    file: File,
    /// Room for a chunk at an aligned offset.
    buffer: Vec<u8>,
    start: usize,
    held: usize,
    direct: Direct,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Direct {
    NotTried,
    On,
    Refused,
}

impl DirectWriter {
    fn new(file: File) -> Self {
        Self {
            file,
            buffer: Vec::new(),
            start: 0,
            held: 0,
            direct: Direct::NotTried,
        }
    }

    /// A writer that never tries direct writes (a device or a pipe has no page cache to pass).
    fn buffered(file: File) -> Self {
        Self {
            direct: Direct::Refused,
            ..Self::new(file)
        }
    }

    fn room(&mut self) -> &mut [u8] {
        if self.buffer.is_empty() {
            self.buffer = vec![0; DIRECT_CHUNK + ALIGN];
            self.start = self.buffer.as_ptr().align_offset(ALIGN);
        }
        &mut self.buffer[self.start + self.held..self.start + DIRECT_CHUNK]
    }

    /// Writes the full chunk held, directly when the file system allows.
    fn write_chunk(&mut self) -> std::io::Result<()> {
        if self.direct == Direct::NotTried {
            self.direct = match set_direct(&self.file, true) {
                Ok(()) => Direct::On,
                Err(_) => Direct::Refused,
            };
        }
        let mut done = 0;
        while done < self.held {
            let chunk = &self.buffer[self.start + done..self.start + self.held];
            match (&self.file).write(chunk) {
                Ok(0) => return Err(std::io::ErrorKind::WriteZero.into()),
                Ok(n) => done += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                // A direct write refused writes nothing: go on through the page cache.
                Err(e) if self.direct == Direct::On && e.raw_os_error() == Some(EINVAL) => {
                    set_direct(&self.file, false)?;
                    self.direct = Direct::Refused;
                }
                Err(e) => return Err(e),
            }
            // After a short direct write the offset is no longer aligned.
            if self.direct == Direct::On && done % ALIGN != 0 {
                set_direct(&self.file, false)?;
                self.direct = Direct::Refused;
            }
        }
        self.held = 0;
        Ok(())
    }
}

impl Write for DirectWriter {
    fn write(&mut self, data: &[u8]) -> std::io::Result<usize> {
        let room = self.room();
        let n = room.len().min(data.len());
        room[..n].copy_from_slice(&data[..n]);
        self.held += n;
        if self.held == DIRECT_CHUNK {
            self.write_chunk()?;
        }
        Ok(n)
    }

    /// Writes what is held through the page cache.
    fn flush(&mut self) -> std::io::Result<()> {
        if self.direct == Direct::On {
            set_direct(&self.file, false)?;
            self.direct = Direct::Refused;
        }
        let held = &self.buffer[self.start..self.start + self.held];
        (&self.file).write_all(held)?;
        self.held = 0;
        Ok(())
    }
}

/// The error of a direct write the file system refuses (no error code elsewhere).
#[cfg(target_os = "linux")]
const EINVAL: i32 = rustix::io::Errno::INVAL.raw_os_error();
#[cfg(not(target_os = "linux"))]
const EINVAL: i32 = -1;

/// Switches `O_DIRECT` on or off for `file`.
#[cfg(target_os = "linux")]
fn set_direct(file: &File, on: bool) -> std::io::Result<()> {
    use rustix::fs::{fcntl_getfl, fcntl_setfl, OFlags};
    let flags = fcntl_getfl(file)?;
    fcntl_setfl(
        file,
        flags.difference(OFlags::DIRECT) | if on { OFlags::DIRECT } else { OFlags::empty() },
    )?;
    Ok(())
}

#[cfg(not(target_os = "linux"))]
fn set_direct(_file: &File, on: bool) -> std::io::Result<()> {
    match on {
        true => Err(std::io::ErrorKind::Unsupported.into()),
        false => Ok(()),
    }
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

    #[cfg(unix)]
    #[test]
    fn a_named_pipe_is_written_into_and_stays_a_pipe() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            return; // no mkfifo here: nothing to test with
        }
        let reader = {
            let fifo = fifo.clone();
            std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
        };
        write_bytes(&fifo, b"through the pipe\n").unwrap();
        assert_eq!(reader.join().unwrap(), "through the pipe\n");
        use std::os::unix::fs::FileTypeExt;
        assert!(std::fs::metadata(&fifo).unwrap().file_type().is_fifo());
    }

    fn names(dir: &Path) -> Vec<String> {
        let entries = std::fs::read_dir(dir).unwrap();
        entries
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .collect()
    }

    /// Bytes of every value, in writes of many sizes: some within a chunk, some across two,
    /// one of several chunks at once.
    fn write_in_pieces(path: &Path) -> Vec<u8> {
        let bytes: Vec<u8> = (0..3 * DIRECT_CHUNK + 12_345)
            .map(|k| (k % 251) as u8)
            .collect();
        let sizes = [1, 4095, 4097, DIRECT_CHUNK - 3, 2 * DIRECT_CHUNK + 7, 10];
        write_with(path, |w| {
            let mut at = 0;
            for size in sizes.iter().cycle() {
                let end = (at + size).min(bytes.len());
                w.write_all(&bytes[at..end])?;
                at = end;
                if at == bytes.len() {
                    return Ok(());
                }
            }
            Ok(())
        })
        .unwrap();
        bytes
    }

    #[test]
    fn large_files_are_written_byte_for_byte_wherever_they_go() {
        // The temporary directory, the workspace's target directory (on a disk, which takes
        // direct writes) and shared memory (tmpfs may refuse them), where they exist.
        let target = concat!(env!("CARGO_MANIFEST_DIR"), "/../../target");
        let dirs = [
            std::env::temp_dir().as_path(),
            Path::new(target),
            Path::new("/dev/shm"),
        ]
        .map(|d| tempfile::tempdir_in(d).ok());
        for dir in dirs.iter().flatten() {
            let path = dir.path().join("survey_c.csv");
            std::fs::write(&path, "old").unwrap();
            let bytes = write_in_pieces(&path);
            assert!(
                std::fs::read(&path).unwrap() == bytes,
                "{}",
                dir.path().display()
            );
            assert_eq!(names(dir.path()), ["survey_c.csv"]);
        }
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
