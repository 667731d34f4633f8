//! Test helpers shared by the crate's unit tests (no module's tests reach into
//! another's).
use std::path::PathBuf;

use crate::manifest::MANIFEST_FILE;

pub(crate) fn cwru_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/cwru"
    ));
    if dir.join(MANIFEST_FILE).is_file() {
        Some(dir)
    } else {
        eprintln!("skipping: CWRU data not found at {}", dir.display());
        None
    }
}

/// A fresh scratch directory under the system temp dir.
pub(crate) fn scratch_dir(tag: &str) -> PathBuf {
    use std::sync::atomic::{AtomicUsize, Ordering};
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("pumptwin-{tag}-{}-{n}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create scratch dir");
    dir
}

/// `../shared/data/<name>` when it holds a `MANIFEST.tsv` (MFPT, HIT-SM); `None`, with a
/// printed notice, otherwise.
pub(crate) fn dataset_dir(name: &str) -> Option<PathBuf> {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data")).join(name);
    if dir.join(MANIFEST_FILE).is_file() {
        Some(dir)
    } else {
        eprintln!("skipping: {name} data not found at {}", dir.display());
        None
    }
}
