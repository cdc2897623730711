//! One module per subcommand.

pub mod compensate;
pub mod demo;
pub mod fit;
pub mod fom;
