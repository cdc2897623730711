//! Signal processing that knows nothing of aircraft: filters, spectra, demodulation, runs of
//! usable samples, medians and noise metrics.

pub mod demodulate;
pub mod filter;
pub mod median;
pub mod metrics;
pub mod segment;
pub mod shift;
pub mod spectrum;
