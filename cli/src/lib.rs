//! `pumptwin`: the host-side command line. Each subcommand's flags (clap) and its
//! command function, calling the library crates: `pumptwin-data` (records, windows,
//! summaries), `pumptwin-twin` (simulation and the closed loop), `pumptwin-trainer`
//! (training, evaluation, export, prediction) and `pumptwin-edge` (the CAN packing of
//! `can-encode`).
//!
//! **Depends on** every crate of the workspace; nothing depends on it but the binary
//! and the end-to-end tests. **Invariant:** no computation lives here that a library
//! user would need: a command reads flags, calls the libraries, writes files.
#![forbid(unsafe_code)]

pub mod can_encode;
pub mod commands;
pub mod compare;
pub mod eval;
pub mod export;
pub mod generalization;
pub mod predict;
pub mod predict_report;
pub mod predict_text;
pub mod report;
pub mod report_plot;
mod rigs;
pub mod train;
