//! `pumptwin-data`: measured data, from files to labelled windows and the core's
//! features.
//!
//! **Depends on** `pumptwin-core` only (and small parsing crates). **Invariant:** no
//! burn, no plotting, no network: every reader here is pure and fuzzed (`fuzz/`), and
//! the twin, the trainer, the command line and the fuzz targets read data through
//! this crate alone.
//!
//! | module | what |
//! |---|---|
//! | [`mat`] | MATLAB level-5 `.mat` reader (numeric arrays, structs flattened to `s.field`, char arrays as text) |
//! | [`csv`] | CSV recordings (header of channel names, one column per channel) |
//! | [`wav`] | WAV recordings (channels DE, FE, BA, … in order; rate from the header) |
//! | [`tdms`] | NI TDMS files (our parser: channels, units, `wf_increment` rate) |
//! | [`uff`] | universal file format data set 58 / 58b time records |
//! | [`channels`] | a self-describing file's channels → a [`Recording`] (selection, sensor names, units to g, one rate) |
//! | [`recording`] | [`Recording`]/[`Channel`] and the checks every consumer relies on |
//! | [`record`] | the CWRU and CSV loaders, [`load_recording`] |
//! | [`entry`] | a manifest entry → its recording (checksum, file number, rate) |
//! | [`manifest`] | `MANIFEST.tsv`: labels, loads, speeds, sampling rates; class names |
//! | [`datasets`] | the MFPT / HIT-SM manifest layout, their fault classes, checksum-checked reads |
//! | [`mfpt`] | MFPT records (`bearing` struct) → one-channel [`Recording`] + load, fault orders |
//! | [`hit_sm`] | HIT-SM self-built-rig records (one variable per file) → one-channel [`Recording`] + fault size |
//! | [`preprocess`](mod@preprocess) | to the model rate (anti-alias + decimation) with one common band limit |
//! | [`windows`] | windows and the leakage-free `time-block`, `cross-load`, `fault-size` splits |
//! | [`summary`] | what `pumptwin data summary` prints for CWRU (records, windows, splits) |
//! | [`rig_summary`] | what it prints for MFPT and HIT-SM (every record read or refused) |
//! | [`featurize`] | records → windows → the core's node features and dynamic graphs |
//! | [`diagnose`] | the core's physical diagnosis over a recording's windows, and per record (majority type, confidence, severity) |
//! | [`derived`] | the paper's derived temperature and pressure nodes (§6.2) |
//!
//! The order of work: load a [`Recording`] at its own rate, [`preprocess()`] it to the
//! model rate, cut [`windows::WindowRef`]s, and let a [`windows::Split`] say which
//! windows train and which test.
#![forbid(unsafe_code)]

pub mod channels;
pub mod csv;
pub mod datasets;
pub mod derived;
pub mod diagnose;
pub mod entry;
pub mod featurize;
pub mod hit_sm;
pub mod manifest;
pub mod mat;
pub mod mfpt;
pub mod preprocess;
pub mod record;
pub mod recording;
pub mod rig_summary;
pub mod summary;
pub mod tdms;
#[cfg(test)]
mod test_support;
pub mod uff;
pub mod wav;
pub mod windows;

pub use datasets::{read_dataset_manifest, DatasetEntry, DatasetError, DatasetFault};
pub use hit_sm::{load_hit_sm, HitSmRecord};
pub use manifest::{
    read_manifest, ClassScheme, FaultType, ManifestEntry, CLASSES_10, FAULT_TYPE_CLASSES,
};
pub use mat::{read_mat, read_mat_file, MatError, MatFile, MatText, MatVariable};
pub use mfpt::{load_mfpt, MfptRecord};
pub use preprocess::{preprocess, PreprocessConfig, PreprocessError};
pub use record::{load_recording, DataError};
pub use recording::{Channel, Recording};
pub use summary::{summarize, DataSummary, SummaryError};
pub use windows::{build_split, Protocol, Split, SplitError, WindowConfig, WindowRef};
