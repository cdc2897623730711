//! One module per subcommand.

pub mod compensate;
pub mod convert;
pub mod demo;
pub mod fit;
pub mod fom;
pub mod info;
pub mod plan;
pub mod procedure;
pub mod report;
pub mod simulate;
pub mod stream;
pub mod tables;
