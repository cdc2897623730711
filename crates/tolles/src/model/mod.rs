//! Model files: what `fit` writes and every other workflow reads.

mod file;

pub use file::{
    compensated_name, HeldOut, LearnedCorrection, ModelFile, ScalarModel, FORMAT, FS_RANGE_HZ,
    KEEP_MARGIN, VERSION,
};

use crate::error::{Error, Result};
use std::path::Path;

/// Reads the model file at `path`; a file without fits is an error.
pub fn load_model(path: &Path) -> Result<ModelFile> {
    let model = ModelFile::read(path)?;
    check_model(&model, path)?;
    Ok(model)
}

/// Writes `model` to `path` as pretty JSON.
pub fn save_model(model: &ModelFile, path: &Path) -> Result<()> {
    Ok(model.write(path)?)
}

/// Checks that `model` holds fits; `path` names it in the error.
pub fn check_model(model: &ModelFile, path: &Path) -> Result<()> {
    if model.fits.is_empty() {
        return Err(Error::EmptyModel {
            path: path.to_path_buf(),
        });
    }
    Ok(())
}
