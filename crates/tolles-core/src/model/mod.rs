//! What a Tolles-Lawson model is: conventions, terms, the design matrix, vector series and the
//! physical reading of fitted coefficients.

pub mod conventions;
pub mod coverage;
pub mod design;
pub mod extra;
pub mod interpret;
pub mod limits;
pub mod magnitude;
pub mod network;
pub mod terms;
pub mod uncertainty;
pub mod vector;
