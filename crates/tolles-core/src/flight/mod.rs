//! Flights and the world they happen in: attitude, flight plans, the earth's field, sensors and
//! simulated flights with known truth.

pub mod attitude;
pub mod effects;
pub mod environment;
pub mod field_estimate;
pub mod igrf;
pub mod maneuver_list;
pub mod plan;
pub mod sensor;
pub mod sim;
mod vec3;
