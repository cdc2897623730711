//! `tolles convert`: a flight file in another format, nothing lost.

use crate::progress::Terminal;
use crate::render::{self, OrRender, Use};
use anyhow::Result;
use std::path::PathBuf;
use tolles::convert::{ConvertRequest, ConvertResult};

const EXAMPLES: &str = "\
Examples:
  tolles convert Flt1002.h5 Flt1002.csv
  tolles convert survey.dfn survey.parquet --line 1002.02
  tolles convert test_data_TL.mat tl.h5";

/// Convert a flight file: any format tolles reads (CSV, Geosoft XYZ, ASEG-GDF2 .dfn/.dat, HDF5,
/// MATLAB .mat v5 and v7.3, Parquet) to CSV, HDF5 or Parquet, by OUTPUT's extension.
///
/// Nothing tolles can read is lost: text cells stay as written (in HDF5 and Parquet a column
/// that is not all numbers is written as text), MATLAB and HDF5 arrays of another length than
/// the columns are written too (HDF5: at their own length; CSV and Parquet: padded with empty
/// cells, as stderr says), and scalars (MATLAB `fs`, HDF5 `dt`) become scalar datasets in HDF5
/// and one-value columns in CSV and Parquet. What cannot be a column (matrices, text, cells) is
/// named on stderr. The output is written whole or not at all.
#[derive(clap::Args)]
#[command(after_help = EXAMPLES)]
pub struct Args {
    /// Flight file to read (format by extension; .mat v5 or v7.3 by content)
    pub input: PathBuf,
    /// File to write: .csv, .h5/.hdf5 or .parquet/.pq (any other extension is an error)
    pub output: PathBuf,
    #[command(flatten)]
    pub select: crate::select::Selection,
}

pub fn run(args: Args) -> Result<()> {
    let request = ConvertRequest {
        input: args.input,
        output: args.output,
        selection: args.select.rows(),
        renames: args.select.renames.clone(),
    };
    let mut warnings = Vec::new();
    let done = tolles::convert::convert(&request, &Terminal::default(), &mut warnings);
    render::warnings(&mut warnings, Use::Other);
    let done = done.or_render()?;
    note!("{}", summary(&done));
    Ok(())
}

/// One line: what was written, and how much was left out.
fn summary(done: &ConvertResult) -> String {
    let mut s = format!(
        "{}: wrote {} rows, {} columns ({})",
        done.output.display(),
        done.rows,
        done.columns,
        done.format
    );
    if done.rows_left_out > 0 {
        s += &format!("; {} rows not selected", done.rows_left_out);
    }
    if !done.left_out.is_empty() {
        s += &format!("; {} arrays left out (see above)", done.left_out.len());
    }
    s
}
