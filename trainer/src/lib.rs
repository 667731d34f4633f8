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
