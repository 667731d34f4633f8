//! Workspace-level end-to-end tests live in `tests/`; this library holds what they share.

use std::path::PathBuf;

/// `../shared/data/cwru` next to the workspace, or `None` (with a printed notice) when
/// the measured data is not there: tests that need it then skip.
pub fn cwru_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/cwru");
    if dir.join("MANIFEST.tsv").is_file() {
        Some(dir)
    } else {
        eprintln!(
            "SKIP: CWRU data not found at {} (tests needing measured data skip)",
            dir.display()
        );
        None
    }
}
