//! Model files: what `fit` writes and every other workflow reads.

mod file;

pub use file::{
    compensated_name, HeldOut, LearnedCorrection, ModelFile, ScalarModel, FORMAT, FS_RANGE_HZ,
    VERSION,
};

use crate::error::Result;
use std::path::Path;

/// Reads the model file at `path`; a file without fits is an error.
pub fn load_model(path: &Path) -> Result<ModelFile> {
    let model = ModelFile::read(path)?;
    crate::compensate::check_model(&model, path)?;
    Ok(model)
}

/// Writes `model` to `path` as pretty JSON.
pub fn save_model(model: &ModelFile, path: &Path) -> Result<()> {
    Ok(model.write(path)?)
}
