//! Progress bars on standard error, drawn only when it is a terminal (indicatif hides them
//! otherwise, so pipes, files and CI logs stay clean): the library's [`Progress`] shown.

use indicatif::{ProgressBar, ProgressStyle};
use std::sync::Mutex;
use std::time::Duration;
use tolles::{Progress, Stage};

/// Shows each stage the library reports as a bar, a counter or a spinner.
#[derive(Default)]
pub struct Terminal {
    current: Mutex<Option<ProgressBar>>,
}

impl Progress for Terminal {
    fn begin(&self, stage: Stage, total: Option<u64>) {
        let shown = match (stage, total) {
            (Stage::Reading, Some(bytes)) => bytes_bar(bytes, stage.label()),
            (Stage::Checking, _) => rows(stage.label()),
            (_, Some(total)) => bar(total, stage.label()),
            (_, None) => spinner(stage.label()),
        };
        if let Some(old) = self.current.lock().unwrap().replace(shown) {
            old.finish_and_clear();
        }
    }

    fn advance(&self, units: u64) {
        if let Some(bar) = &*self.current.lock().unwrap() {
            bar.inc(units);
        }
    }

    fn finish(&self) {
        if let Some(bar) = self.current.lock().unwrap().take() {
            bar.finish_and_clear();
        }
    }
}

impl Drop for Terminal {
    fn drop(&mut self) {
        self.finish();
    }
}

/// A bar for `total` units of work described by `message`.
pub fn bar(total: u64, message: &str) -> ProgressBar {
    let bar = ProgressBar::new(total).with_message(message.to_string());
    bar.set_style(
        ProgressStyle::with_template("{msg:>12} [{bar:30}] {percent:>3}% {elapsed}/{duration}")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    bar
}

/// A bar over the bytes of a file being read.
pub fn bytes_bar(total: u64, message: &str) -> ProgressBar {
    let bar = ProgressBar::new(total).with_message(message.to_string());
    bar.set_style(
        ProgressStyle::with_template("{msg:>12} [{bar:30}] {bytes}/{total_bytes} {elapsed}")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    bar
}

/// A counter of rows read, for a first pass whose length is not known yet.
pub fn rows(message: &str) -> ProgressBar {
    let counter = ProgressBar::new_spinner().with_message(message.to_string());
    counter.set_style(
        ProgressStyle::with_template("{msg:>12} {spinner} {human_pos} rows {elapsed}")
            .expect("a valid template"),
    );
    counter.enable_steady_tick(Duration::from_millis(120));
    counter
}

/// A spinner for work of unknown length.
pub fn spinner(message: &str) -> ProgressBar {
    let spinner = ProgressBar::new_spinner().with_message(message.to_string());
    spinner.enable_steady_tick(Duration::from_millis(120));
    spinner
}
