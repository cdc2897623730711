//! A boundary around the third-party readers (`hdf5-pure`, `parquet`): a malformed file can make
//! them panic, and a panic there must become an [`IoError`] naming the file, not a crash with a
//! backtrace. The default panic hook would still print the panic message to stderr, so a hook
//! installed once stays silent on threads that are inside [`contain`] and defers to the previous
//! hook everywhere else (the CLI then prints its one-line error, and other panics are unchanged).
//!
//! An allocation failure aborts the process and cannot be caught here: the readers validate
//! declared sizes against the file's length before asking for memory.

use crate::error::IoError;
use std::any::Any;
use std::cell::Cell;
use std::panic::{self, AssertUnwindSafe};
use std::sync::Once;

thread_local! {
    /// True while this thread runs inside [`contain`].
    static CONTAINING: Cell<bool> = const { Cell::new(false) };
}

/// Runs `read`; a panic inside it becomes `fail(the panic message)`.
pub(crate) fn contain<T>(
    read: impl FnOnce() -> Result<T, IoError>,
    fail: impl FnOnce(String) -> IoError,
) -> Result<T, IoError> {
    install_hook();
    let outer = CONTAINING.with(|c| c.replace(true));
    // The reader's state is dropped with the panic, so nothing broken is observed afterwards.
    let result = panic::catch_unwind(AssertUnwindSafe(read));
    CONTAINING.with(|c| c.set(outer));
    result.unwrap_or_else(|payload| Err(fail(panic_message(payload.as_ref()))))
}

fn install_hook() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let previous = panic::take_hook();
        panic::set_hook(Box::new(move |info| {
            if !CONTAINING.with(Cell::get) {
                previous(info);
            }
        }));
    });
}

fn panic_message(payload: &(dyn Any + Send)) -> String {
    let text = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "the reader failed".to_string());
    // One line, whatever the third-party message looks like.
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn fail(message: String) -> IoError {
        IoError::Invalid {
            path: PathBuf::from("f.h5"),
            message: format!("not a readable HDF5 file ({message})"),
        }
    }

    #[test]
    fn a_panic_becomes_an_error_naming_the_file() {
        let err = contain(
            || -> Result<(), IoError> { panic!("index out\nof bounds") },
            fail,
        )
        .unwrap_err();
        assert_eq!(
            err.to_string(),
            "f.h5: not a readable HDF5 file (index out of bounds)"
        );
    }

    #[test]
    fn results_pass_through() {
        assert_eq!(contain(|| Ok(3), fail).unwrap(), 3);
        assert!(contain(|| Err::<(), _>(fail("x".into())), fail).is_err());
    }
}
