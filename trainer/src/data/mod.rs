//! Measured data, from files to labelled windows:
//!
//! | module | what |
//! |---|---|
//! | [`mat`] | MATLAB level-5 `.mat` reader (CWRU files) |
//! | [`csv`] | CSV recordings (header of channel names, one column per channel) |
//! | [`record`] | [`Recording`]/[`Channel`], the CWRU and CSV loaders, [`load_recording`] |
//! | [`manifest`] | `MANIFEST.tsv`: labels, loads, speeds, sampling rates; class names |
//! | [`preprocess`](mod@preprocess) | to the model rate (anti-alias + decimation) with one common band limit |
//! | [`windows`] | windows and the leakage-free `time-block`, `cross-load`, `fault-size` splits |
//! | [`summary`] | what `pumptwin data summary` prints |
//!
//! The order of work: load a [`Recording`] at its own rate, [`preprocess()`] it to the
//! model rate, cut [`windows::WindowRef`]s, and let a [`windows::Split`] say which
//! windows train and which test.
pub mod csv;
pub mod manifest;
pub mod mat;
pub mod preprocess;
pub mod record;
pub mod summary;
pub mod windows;

pub use manifest::{
    read_manifest, ClassScheme, FaultType, ManifestEntry, CLASSES_10, FAULT_TYPE_CLASSES,
};
pub use mat::{read_mat, read_mat_file, MatError, MatFile, MatVariable};
pub use preprocess::{preprocess, PreprocessConfig, PreprocessError};
pub use record::{load_recording, Channel, DataError, Recording};
pub use summary::{summarize, DataSummary, SummaryError};
pub use windows::{build_split, Protocol, Split, SplitError, WindowConfig, WindowRef};
