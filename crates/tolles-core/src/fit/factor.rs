//! A fold's rows reduced to triangular factors: what choosing a design and λ on held-out folds
//! works from, whichever rows (band, level, above the band) the fold held.

use nalgebra::DMatrix;

/// One fold's rows reduced to triangular factors of all the columns and the target.
#[derive(Clone)]
pub(super) struct FoldFactor {
    /// Factor of every row of the fold.
    pub(super) r: DMatrix<f64>,
    pub(super) rows: usize,
    /// Factor of its (weighted) level rows alone.
    pub(super) level_r: DMatrix<f64>,
    pub(super) level_rows: usize,
}
