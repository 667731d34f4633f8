//! # pumptwin-edge
//!
//! The edge gateway's library: CAN frames → sensor map → per-channel rings → windows →
//! the core's features and the envelope-spectrum physics explanation → one JSON
//! object per window, with health counters. The binary `pumptwin-edge` is a thin
//! command line over [`gateway::Gateway`].
//!
//! | module | what |
//! |---|---|
//! | [`candump`] | `candump -l` log lines → [`candump::Frame`]; the [`candump::FrameSource`] trait and [`candump::CandumpReplay`] |
//! | [`dbc`] | slow sensors (shaft speed, temperature, pressure) from DBC signals (`can-dbc`) |
//! | [`sensor_map`] | TOML sensor map: machine (speed, bearing, fs) and channel layouts, validated |
//! | [`ring`] | fixed-size sample ring addressed by absolute sample index |
//! | [`pipeline`] | frame classification, windows, core features per channel |
//! | [`health`] | the frame and window counters and a frame's bucket |
//! | [`explain`] | envelope peak → nearest kinematic line (shaft, BPFO, BPFI, BSF, FTF) |
//! | [`report`] | the JSON line of a window |
//! | [`diagnosis`] | the extension point for diagnosers |
//! | [`network`] | the int8 DS-STGAT network, read from a model file (`--model`), as a diagnoser |
//! | [`live`] | live SocketCAN source (`--can IFACE`, reconnecting) and the `--publish-id` bus writer |
//! | `mqtt` | telemetry to an MQTT broker, QoS 1, with an on-disk store-and-forward queue (feature `mqtt`, on by default) |
//! | [`ops`] | `--config FILE.toml` for every flag, Prometheus `/metrics` endpoint |
//! | [`pace`] | replay at full speed or following the log's timestamps |
//! | [`gateway`] | the run loop |
//!
//! Hardware sits behind [`candump::FrameSource`]: the SocketCAN source ([`live`],
//! `--can IFACE`) is a second implementation, and tests script the bus with a third.
//!
//! **Depends on** `pumptwin-core` only among the workspace's crates (no burn, no data
//! or twin crate: the gateway runs the core's features and int8 network as the
//! firmware does). **Invariant:** a bad frame, a wrong model file or a missing channel
//! is counted or reported, never a panic; the window layout is the core's
//! (`pumptwin_core::layout`), so the gateway sees what training saw.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

pub mod candump;
pub mod dbc;
pub mod diagnosis;
pub mod explain;
pub mod gateway;
pub mod health;
pub mod live;
#[cfg(feature = "mqtt")]
pub mod mqtt;
pub mod network;
pub mod ops;
pub mod pace;
pub mod pipeline;
pub mod report;
pub mod ring;
pub mod sensor_map;
