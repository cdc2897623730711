//! The `tolles` binary end to end: every command run as a user runs it, each area in its
//! own module (one test binary: one link instead of one per file).

mod common;

mod behaviour;
mod channel_names;
mod cli;
mod compensate_chunks;
mod convert;
mod effects;
mod extra;
mod fom;
mod formats;
mod front_door;
mod hostile;
mod hostile_input;
mod multi_fluxgate;
mod network;
mod outputs;
mod plan;
mod procedure;
mod reference;
mod report_scalars;
mod report_survey_files;
mod select;
mod simulate;
mod stream;
mod stumbles;
mod survey_conventions;
mod tables;
mod trust;
