//! `pumptwin-trainer`: the DS-STGAT in burn and everything that learns or judges it —
//! the network and its baselines, the dataset of featurized windows, the physics
//! embedding (simulated priors and pre-training, the twin's Θ per record), training,
//! metrics, figures, the comparison table, and the int8 export to the postcard model
//! file.
//!
//! **Depends on** `pumptwin-core`, `pumptwin-data` and `pumptwin-twin` (never on the
//! edge app: no SocketCAN, no MQTT in a training build). Physics, features and graphs
//! come from `pumptwin_core` (one source of truth shared with the edge and firmware);
//! records and windows from `pumptwin_data`; the closed loop's fit from `pumptwin_twin`.
#![forbid(unsafe_code)]

pub mod baselines;
pub mod compare;
pub mod dataset;
pub mod export;
pub mod figures;
pub mod metrics;
pub mod model;
pub mod physics;
pub mod targets;
pub mod training;

/// Tests that seed burn's device random stream (and draw from it: initialization,
/// training) hold this lock: the stream is one per process, and two such tests running
/// at once would draw from each other's seed (a test once failed that way in CI).
#[cfg(test)]
pub(crate) fn device_rng_lock() -> std::sync::MutexGuard<'static, ()> {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    LOCK.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}
