//! What the library returns, said on the command line: warnings on standard error, and errors
//! with the flag that fixes them where there is one.

use tolles::{Error, Warning};

/// What a command does with the rows a selection kept, for the message that says so.
#[derive(Clone, Copy)]
pub enum Use {
    Fit,
    Compensate,
    Fom,
    Other,
}

/// Prints `warnings` on standard error, one line each, and empties the vector.
pub fn warnings(warnings: &mut Vec<Warning>, purpose: Use) {
    for warning in warnings.drain(..) {
        eprintln!("{}", warning_text(&warning, purpose));
    }
}

/// One warning as the command line says it.
pub fn warning_text(warning: &Warning, purpose: Use) -> String {
    match warning {
        Warning::SampleRateDiffers {
            given_hz,
            from_time_hz,
        } => format!(
            "warning: --fs {given_hz} Hz differs from the {from_time_hz:.6} Hz of column \"tt\"; using --fs"
        ),
        Warning::RowsSelected { path, selection } => {
            let consequence = match purpose {
                Use::Fit => "the fit uses only these".to_string(),
                Use::Fom => "the FOM uses only these".to_string(),
                Use::Other => "only these are used".to_string(),
                Use::Compensate => format!(
                    "only these are compensated and written (the other {} rows are left out), and the correction's mean is taken over them",
                    selection.left_out
                ),
            };
            format!("{}: {}; {consequence}", path.display(), selection.summary)
        }
        other => format!("warning: {other}"),
    }
}

/// A library error, with the flag that fixes it where one does.
pub fn error(e: Error) -> anyhow::Error {
    match e {
        Error::NoSampleRate { path } => anyhow::anyhow!(
            "{}: no time column \"tt\" to take the sample rate from; give it with --fs HZ",
            path.display()
        ),
        Error::BadSampleRate { fs_hz } => {
            anyhow::anyhow!("--fs must be a positive number of hertz, got {fs_hz}")
        }
        Error::NoSuchManeuver { name, found, .. } => anyhow::anyhow!(
            "--ignore {name:?}: no such maneuver in the flight; found: {}",
            found.join(", ")
        ),
        Error::ManeuverList(e) => anyhow::anyhow!("--maneuvers: {e}"),
        other => anyhow::Error::new(other),
    }
}

/// `result` with a library error rendered by [`error`].
pub trait OrRender<T> {
    fn or_render(self) -> anyhow::Result<T>;
}

impl<T> OrRender<T> for Result<T, Error> {
    fn or_render(self) -> anyhow::Result<T> {
        self.map_err(error)
    }
}
