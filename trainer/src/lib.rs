//! pumptwin host side: data loading, windowing and splits, simulation, features,
//! plots. Physics, features and graphs come from `pumptwin_core` (one source of truth
//! shared with the edge and firmware); this crate orchestrates them on records.
#![forbid(unsafe_code)]

pub mod baselines;
pub mod can_encode;
pub mod cli;
pub mod compare;
pub mod data;
pub mod dataset;
pub mod derived;
pub mod export;
pub mod featurize;
pub mod figures;
pub mod metrics;
pub mod model;
pub mod physics;
pub mod plot;
pub mod predict;
pub mod sim;
pub mod training;
pub mod twin;

/// Tests that seed burn's device random stream (and draw from it: initialization,
/// training) hold this lock: the stream is one per process, and two such tests running
/// at once would draw from each other's seed (a test once failed that way in CI).
#[cfg(test)]
pub(crate) fn device_rng_lock() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LOCK.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}
