//! A written report printed to PDF by headless Chromium, for readers who want a document
//! rather than a page: the browser lays out the same HTML, with the page's print style.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The environment variable naming the browser to print with.
pub const BROWSER_VARIABLE: &str = "TOLLES_CHROMIUM";

/// Browsers looked for on `PATH` when [`BROWSER_VARIABLE`] is not set, in order.
const BROWSERS: [&str; 3] = ["chromium", "chromium-browser", "google-chrome"];

/// How long a print may take (s) before it is abandoned.
const TIMEOUT_S: u64 = 120;

/// Why a PDF could not be printed.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// No browser found; `tried` says where it was looked for.
    #[error("no Chromium to print the PDF: install chromium or set {BROWSER_VARIABLE} ({tried})")]
    NoBrowser {
        /// Where it was looked for.
        tried: String,
    },
    /// The browser could not be started, failed, or wrote no PDF.
    #[error("{} could not print {} to PDF: {reason}", browser.display(), page.display())]
    Failed {
        /// The browser.
        browser: PathBuf,
        /// The page printed.
        page: PathBuf,
        /// What went wrong (the browser's last line of output, if any).
        reason: String,
    },
    /// A file or directory could not be written.
    #[error("cannot write {}: {source}", path.display())]
    Io {
        /// The path that failed.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },
}

/// Prints the page `index` (an `index.html` written by [`crate::Report::write`]) to the PDF
/// `pdf` with the browser [`find_browser`] finds; `pdf` is replaced whole or left as it was.
pub fn print_pdf(index: &Path, pdf: &Path) -> Result<(), ExportError> {
    let browser = find_browser(std::env::var_os(BROWSER_VARIABLE), std::env::var_os("PATH"))?;
    print_with(&browser, index, pdf)
}

/// The browser named by `variable` (the value of [`BROWSER_VARIABLE`]), else the first of
/// chromium, chromium-browser, google-chrome found on `path` (the value of `PATH`).
pub fn find_browser(
    variable: Option<OsString>,
    path: Option<OsString>,
) -> Result<PathBuf, ExportError> {
    if let Some(named) = variable.filter(|v| !v.is_empty()) {
        let named = PathBuf::from(named);
        return match named.is_file() {
            true => Ok(named),
            false => Err(ExportError::NoBrowser {
                tried: format!("{BROWSER_VARIABLE}={} does not exist", named.display()),
            }),
        };
    }
    let dirs: Vec<PathBuf> = path.map_or(Vec::new(), |p| std::env::split_paths(&p).collect());
    BROWSERS
        .iter()
        .flat_map(|name| dirs.iter().map(move |dir| dir.join(name)))
        .find(|candidate| candidate.is_file())
        .ok_or_else(|| ExportError::NoBrowser {
            tried: format!("none of {} on PATH", BROWSERS.join(", ")),
        })
}

/// Prints `index` to `pdf` with `browser`, through a temporary file beside `pdf`.
pub fn print_with(browser: &Path, index: &Path, pdf: &Path) -> Result<(), ExportError> {
    let failed = |reason: String| ExportError::Failed {
        browser: browser.to_path_buf(),
        page: index.to_path_buf(),
        reason,
    };
    let page = index
        .canonicalize()
        .map_err(|e| failed(format!("cannot open the page: {e}")))?;
    let scratch = Scratch::new()?;
    let partial = partial_path(pdf);
    let result = run_browser(browser, &page, &partial, &scratch.0)
        .map_err(failed)
        .and_then(|()| check_pdf(&partial).map_err(failed))
        .and_then(|()| {
            std::fs::rename(&partial, pdf).map_err(|source| ExportError::Io {
                path: pdf.to_path_buf(),
                source,
            })
        });
    if result.is_err() {
        let _ = std::fs::remove_file(&partial);
    }
    result
}

/// `dir/.name.partial-PID.pdf` for `dir/name`.
fn partial_path(pdf: &Path) -> PathBuf {
    let name = pdf.file_name().unwrap_or_default().to_string_lossy();
    pdf.with_file_name(format!(".{name}.partial-{}.pdf", std::process::id()))
}

/// Runs the browser headless on `page`, printing to `out`, within [`TIMEOUT_S`].
fn run_browser(browser: &Path, page: &Path, out: &Path, profile: &Path) -> Result<(), String> {
    let log = profile.join("browser.log");
    let log_file = std::fs::File::create(&log).map_err(|e| e.to_string())?;
    let mut print_to = OsString::from("--print-to-pdf=");
    print_to.push(out);
    let mut profile_arg = OsString::from("--user-data-dir=");
    profile_arg.push(profile.join("profile"));
    let child = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-pdf-header-footer",
        ])
        .arg(profile_arg)
        .arg(print_to)
        .arg(page)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(log_file)
        .spawn()
        .map_err(|e| format!("cannot start it: {e}"))?;
    let last_line = || {
        let text = std::fs::read_to_string(&log).unwrap_or_default();
        text.lines()
            .rev()
            .find(|l| !l.trim().is_empty())
            .unwrap_or("")
            .to_string()
    };
    match wait(child, Duration::from_secs(TIMEOUT_S))? {
        Some(status) if status.success() => Ok(()),
        Some(status) => Err(format!("it exited with {status}: {}", last_line())),
        None => Err(format!("it did not finish within {TIMEOUT_S} s")),
    }
}

/// The child's exit status, or `None` (the child killed) when it outlasts `limit`.
fn wait(mut child: Child, limit: Duration) -> Result<Option<std::process::ExitStatus>, String> {
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().map_err(|e| e.to_string())? {
            return Ok(Some(status));
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            return Ok(None);
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Whether the printed file is there and reads as a PDF.
fn check_pdf(path: &Path) -> Result<(), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("it wrote no PDF ({e})"))?;
    match bytes.starts_with(b"%PDF") {
        true => Ok(()),
        false => Err("what it wrote is not a PDF".into()),
    }
}

/// A directory of its own for the browser's profile and log, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new() -> Result<Self, ExportError> {
        let nanos = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.subsec_nanos());
        let dir = std::env::temp_dir().join(format!("tolles-pdf-{}-{nanos}", std::process::id()));
        std::fs::create_dir_all(&dir).map_err(|source| ExportError::Io {
            path: dir.clone(),
            source,
        })?;
        Ok(Scratch(dir))
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_named_browser_is_a_one_line_error() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("no-chromium");
        let e = find_browser(Some(missing.clone().into()), None).unwrap_err();
        let message = e.to_string();
        assert!(
            message.starts_with(
                "no Chromium to print the PDF: install chromium or set TOLLES_CHROMIUM"
            ),
            "{message}"
        );
        assert!(
            message.contains(&missing.display().to_string()),
            "{message}"
        );
        assert!(!message.contains('\n'));
    }

    #[test]
    fn no_browser_on_the_path_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let e = find_browser(None, Some(dir.path().into())).unwrap_err();
        assert!(matches!(e, ExportError::NoBrowser { .. }), "{e}");
    }

    #[test]
    fn the_first_browser_on_the_path_is_taken() {
        let dir = tempfile::tempdir().unwrap();
        let chrome = dir.path().join("google-chrome");
        std::fs::write(&chrome, "").unwrap();
        assert_eq!(find_browser(None, Some(dir.path().into())).unwrap(), chrome);
    }

    #[cfg(unix)]
    #[test]
    fn a_browser_that_writes_no_pdf_fails_and_leaves_the_target_alone() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let fake = dir.path().join("fake-chromium");
        std::fs::write(&fake, "#!/bin/sh\necho 'cannot print' >&2\nexit 3\n").unwrap();
        std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
        let index = dir.path().join("index.html");
        std::fs::write(&index, "<html></html>").unwrap();
        let pdf = dir.path().join("out.pdf");
        std::fs::write(&pdf, "old").unwrap();
        let e = print_with(&fake, &index, &pdf).unwrap_err();
        assert!(e.to_string().contains("cannot print"), "{e}");
        assert_eq!(std::fs::read_to_string(&pdf).unwrap(), "old");
        let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(left.len(), 3, "no partial file left");
    }
}
