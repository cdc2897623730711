//! Helpers shared by the integration tests (and, by path, the CLI's).
pub mod gdf_independent;
