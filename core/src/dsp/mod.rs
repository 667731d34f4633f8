//! General-purpose signal processing on caller-owned buffers: the Hilbert envelope and
//! its spectrum, spectral peaks and harmonic levels, order statistics (quickselect, the
//! median of spectrum bins) and the time statistics of a segment.
//!
//! Nothing here knows the node-feature layout. [`crate::features`] builds the node
//! features on these helpers and re-exports the public ones under their old paths
//! (`features::envelope_spectrum`, …); this module imports nothing from it.
//!
//! | file | what |
//! |---|---|
//! | `envelope.rs` | [`EnvelopeBand`], [`envelope()`], [`envelope_spectrum`] |
//! | `peaks.rs` | [`interpolated_peak`], [`peak_frequency`], [`harmonic_level_db`] |
//! | `select.rs` | panic-free quickselect and the median of spectrum bins (crate-internal) |
//! | `stats.rs` | [`TimeStats`] and the central moments they share with the features |

mod envelope;
mod peaks;
mod select;
mod stats;

pub use envelope::{envelope, envelope_spectrum, EnvelopeBand};
pub use peaks::{harmonic_level_db, interpolated_peak, peak_frequency};
pub(crate) use select::{median_level, select_nth};
pub(crate) use stats::central_moments;
pub use stats::TimeStats;
