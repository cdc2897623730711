//! What a row selection (`--line`, `--time`) kept: a line to show and the rows left out. Its own
//! module because reading, compensating and the warnings all name it.

/// What a row selection kept.
#[derive(Debug, Clone, PartialEq)]
pub struct Selection {
    /// One line: `selected 360 of 4661 rows (lines 2, 4; tt ..200 s)`.
    pub summary: String,
    /// Rows of the file left out.
    pub left_out: usize,
}
