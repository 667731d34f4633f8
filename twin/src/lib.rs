//! `pumptwin-twin`: the digital twin of the bearing. Multi-node simulation and the
//! closed loop between measurement and mechanism model (paper §4.3, eq. 10; §5.4):
//! fit the simulator to a record, find the residual, trace it to an effect the model
//! lacks, add the effect, refit, report the error before and after, repeat.
//!
//! | module | step |
//! |---|---|
//! | [`signature`] | phase-free comparison domains and error figures |
//! | [`twin`] | the parametric twin ([`twin::TwinModel`]) |
//! | [`effect`] | the effects the loop can add to it |
//! | [`fit`] | eq. 10 as Levenberg–Marquardt with common random numbers |
//! | [`residual`] | significant residual components and the measurements behind evidence |
//! | [`trace`] | one tracer per kind of evidence: residual components → candidate effects |
//! | [`closed_loop`] | the loop itself and its report |
//! | [`generate`] | records with undeclared effects, for tests |
//! | [`report`] | `report.json` and the PNG plots |
//! | [`sim`] | multi-node records from the core's 2-DOF model (DE, FE, BA) |
//! | [`bench`] | the loop's benchmark: randomized records with undeclared effects, claims scored |
//! | [`randomized`] | simulated records with the conditions randomized (the `sim-only` development set) |
//! | [`plot`] | line plots (PNG) shared with the trainer's figures |
//!
//! **Depends on** `pumptwin-core` and `pumptwin-data`. **Invariant:** no burn (the
//! twin builds and tests without the learning stack: `cargo tree -p pumptwin-twin`
//! names no burn crate), no network.

#![forbid(unsafe_code)]

pub mod bench;
pub mod closed_loop;
pub mod effect;
pub mod fit;
pub mod generate;
pub mod plot;
pub mod randomized;
pub mod report;
pub mod residual;
pub mod ringdown;
pub mod signature;
pub mod sim;
pub mod slip;
pub mod trace;
pub mod twin;
