//! compensate
