//! Progress of long work, reported through a trait so a library caller chooses how to show it
//! (a terminal bar in the CLI, nothing in Python or in tests).

/// A stage of a workflow whose progress is reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Reading a file; units are bytes.
    Reading,
    /// Fitting models; no units (a spinner).
    Fitting,
    /// A first pass over a file to check it; units are rows, total unknown.
    Checking,
    /// Computing and writing the output; units are rows.
    Compensating,
    /// Simulating a flight; units are samples.
    Simulating,
}

impl Stage {
    /// A short label for a progress display.
    pub fn label(self) -> &'static str {
        match self {
            Stage::Reading => "reading",
            Stage::Fitting => "fitting",
            Stage::Checking => "checking",
            Stage::Compensating => "compensating",
            Stage::Simulating => "simulating",
        }
    }
}

/// Receives progress. Every method has an empty default, so an implementation shows only what
/// it cares about. Methods take `&self` because fits report from several threads.
pub trait Progress: Sync {
    /// `stage` begins; `total` units of work when known.
    fn begin(&self, _stage: Stage, _total: Option<u64>) {}
    /// `units` more units of the current stage are done.
    fn advance(&self, _units: u64) {}
    /// The current stage is over.
    fn finish(&self) {}
}

/// Progress that goes nowhere.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Progress for Silent {}

/// A reader that reports the bytes read through it as progress.
pub(crate) struct CountingReader<'p, R> {
    pub inner: R,
    pub progress: &'p dyn Progress,
}

impl<R: std::io::Read> std::io::Read for CountingReader<'_, R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        self.progress.advance(n as u64);
        Ok(n)
    }
}
