//! The numerics against independent references: golden data of MagNav.jl and scipy, IGRF,
//! simulated flights with known truth, and properties; each area in its own module (one test
//! binary: one link instead of one per file).

mod common;

mod exact_floor;
mod extra_channels;
mod filter_props;
mod filter_scipy;
mod fom_truth;
mod harmonic_tables_simulated;
mod identifiability_box;
mod igrf_reference;
mod lag;
mod magnav_golden;
mod multi_fluxgate;
mod reference;
mod self_tuning;
mod sim_truth;
mod spectrum_scipy;
mod stream_adapt;
mod strobe;
mod trust;
