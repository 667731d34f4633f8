//! Frames → per-channel sample rings → windows → the core's features and the physics
//! explanation, with health counters for everything that did not go to plan.
//!
//! # Frames: every frame lands in exactly one bucket
//!
//! Checked in this order; the first that applies decides:
//!
//! | bucket | frame | its samples |
//! |---|---|---|
//! | `remote` | a remote request | none |
//! | `error_frames` | an error frame | none |
//! | `unknown_id` | an identifier the sensor map does not name | none |
//! | `other_interface` | a channel's identifier from another interface than its first frame's | dropped |
//! | `malformed` | a payload that does not fit its channel's layout | dropped |
//! | `late` | timestamp earlier than the previous frame's (any id) | dropped |
//! | `duplicate` | the channel's last stored frame again: same counter, same payload | dropped |
//! | `out_of_sequence` | sequence counter ≠ expected, or a gap by the clock | **used** |
//! | `used` | everything else | used |
//!
//! so `frames_total = used + duplicate + out_of_sequence + unknown_id + other_interface
//! + malformed + late + remote + error_frames` ([`Health::frames_classified`]). Not frames, and so outside the sum:
//! `lost_frames` (frames a counter jump says never arrived), `bad_lines` (log lines
//! that are not frames), `realignments`, `windows`, `degraded_windows`.
//!
//! Why another interface's frame is dropped: a log (or a bridge) that merges two buses
//! can carry the same identifier from two machines; the sensor map names an identifier,
//! not a bus, so a channel belongs to the interface its first frame came on, and frames
//! with its identifier from any other are counted and kept out of its samples rather
//! than interleaved into one stream. Frames without an interface name (`ID#DATA`
//! lines) match any.
//!
//! Why a duplicate is dropped: it holds the same sample instants as the frame before
//! it (a bus retransmission, a logger or bridge that forwards a frame twice), so
//! storing it would insert a repeat and shift every later sample by a frame; dropped,
//! the stream stays in sequence and no window is degraded by it. A repeated counter
//! with a different payload is not a copy: it is `out_of_sequence`, as below.
//!
//! A channel silent for more than [`TIME_GAP_FRAMES`] frame periods (by the frames'
//! timestamps) has a gap too, counter or not: its next frame is `out_of_sequence`,
//! the frames the clock says are missing are `lost_frames` (for a channel with a
//! counter, the counter's jump plus the whole wraps of 256 the clock adds; up to
//! [`CLOCK_COUNT_FRAMES`] periods, beyond which a pause cannot be told from a loss and
//! only the counter's jump is counted), and the window holding the junction is
//! `discontinuous`. Shorter silences are reception jitter, not gaps.
//!
//! A silence is not always a loss: a sender, bridge or host that stalls and then sends
//! its backlog leaves the same silence, with every frame delivered. What follows tells
//! them apart: lost frames leave the sender's pace unchanged, so the next frame comes
//! a period later; held-up frames come as a backlog, faster than the sender's pace.
//! So the first frame after a silence by the clock that the counter does not see (no
//! counter, or a counter that runs on) is **held**, its samples not yet stored and the
//! frame not yet counted, until its channel's next frame that is neither a duplicate
//! nor malformed nor from another interface: if that one comes within half a frame
//! period ([`BACKLOG_FRACTION`]) and is not late, the silence was a hold-up, and the
//! held frame is `used`, its samples joined without a junction; otherwise it is
//! `out_of_sequence` with the clock's count of lost frames, as above. At the end of
//! the input, [`Pipeline::finish`] decides a frame still held by the clock alone. A
//! jump of the counter is a junction whatever the clock says, and a silence beyond
//! [`CLOCK_COUNT_FRAMES`] is one however it ends: neither waits.
//!
//! Why out-of-sequence frames are used: their payload is intact and current; what is
//! wrong is what came before them. The counter re-synchronizes to the frame; a forward
//! jump of 1–127 adds the jump to `lost_frames`; a larger jump reads as a backward step
//! (a duplicate or reordered frame) and adds nothing. Either way the samples before and
//! after do not join up, so the window holding the junction lists the channel under
//! `discontinuous` and is `degraded`; its values are still computed, from the
//! stitched samples. A dropped late frame marks the same junction. Late frames are
//! dropped because their time is not trustworthy; the clock reference is the previous
//! frame, so a clock step back costs one frame, not every frame after it.
//!
//! # Windows
//!
//! Channels are aligned by sample index (every channel samples at `fs_hz`). Window `n`
//! is samples `[s, s + 2048)` with `s = n·1024` of every channel, cut as soon as every
//! channel has written past `s + 2048`. Each channel keeps a ring of 4096 samples, so a
//! channel can run up to 2048 samples ahead of the slowest; when a channel would
//! overwrite samples the next window still needs, that window is cut anyway, and every
//! channel that does not hold all of `[s, s + 2048)` is `missing` from it (a dropout:
//! no value is made up for it; the window is `degraded`). A channel that falls behind
//! the window grid this way re-joins, when its frames come back, at the position of the
//! channel furthest ahead (`realignments`). A partial window at the end of the input is
//! not reported.
//!
//! # Band limit
//!
//! Every sample goes through the core's streaming FIR low-pass (101-tap Blackman
//! sinc at `min(5 kHz, 0.45·fs)`) before its ring: the same filter, taps and cutoff
//! the trainer applies to every record (zero-phase there), so the model sees the
//! features it was trained on. The causal filter delays every channel by the same
//! 50 samples, which shifts the window grid in time but changes no value: in the
//! interior of a stream the filtered samples equal the trainer's exactly. A channel
//! that re-joins after a dropout restarts its filter (the first 100 samples after a
//! restart are its transient; that window is already marked degraded).
//!
//! # Per channel and window
//!
//! ```text
//! rows[t]        = node_features::<2048>(x, cfg)[t]   t = 0..8, FEATURE_NAMES order (model input)
//! rms, kurtosis, crest_factor = TimeStats over the whole window
//! env_*_db       = the envelope features of the rows (shared by all 8)
//! envelope peak  = peak of envelope_spectrum(x) in 40–400 Hz, and its prominence (see explain)
//! cfg            = fs, f_r = rpm/60, the bearing's orders, envelope band 500 Hz – min(5 kHz, 0.45·fs),
//!                  band limit min(5 kHz, fs/2), 8 segments   (= trainer::featurize::feature_config)
//! ```

use crate::candump::{Frame, FrameKind};
use crate::dbc::SlowSignals;
use crate::explain::{nearest_kinematic, Explanation, PEAK_BAND_HZ};
use crate::ring::SampleRing;
use crate::sensor_map::{Channel, Machine, SensorMap, MAX_SAMPLES_PER_FRAME};
use pumptwin_core::diagnosis::{
    decide, segment_len, window_evidence, Buffers, Diagnosis, Thresholds, DEFAULT_REVOLUTIONS,
};
use pumptwin_core::features::{
    feature_index, node_features, peak_frequency, FeatureConfig, FeatureScratch, TimeStats,
    FEATURE_DIM,
};
use pumptwin_core::fft::Complex32;
use pumptwin_core::fir::{FirLowpass, BAND_LIMIT_TAPS, MAX_CUTOFF_FRACTION};
use pumptwin_core::simulator::BearingParams;
use pumptwin_core::tracking::{Tracker, TrackerConfig};

/// Window, hop (50 % overlap) and graph steps: the core's layout, which training and
/// `predict` read too.
pub use pumptwin_core::layout::{HOP, SEGMENTS, WINDOW};
/// Ring size per channel.
pub const RING: usize = 2 * WINDOW;
/// Samples of the monitored bearing's channel (the first) kept for the physical
/// diagnosis: 16 shaft revolutions down to 352 rpm at 12 kHz (2.7 s); a slower shaft
/// is read over what this holds.
pub const HISTORY: usize = 16 * WINDOW;
const _: () = assert!(RING >= WINDOW + MAX_SAMPLES_PER_FRAME && HOP >= MAX_SAMPLES_PER_FRAME);

/// `env_shaft_db` in a feature row.
pub const ENV_SHAFT_DB: usize = feature_index("env_shaft_db");
/// `env_bpfo_db` in a feature row.
pub const ENV_BPFO_DB: usize = feature_index("env_bpfo_db");
/// `env_bpfi_db` in a feature row.
pub const ENV_BPFI_DB: usize = feature_index("env_bpfi_db");
/// `env_bsf_db` in a feature row.
pub const ENV_BSF_DB: usize = feature_index("env_bsf_db");
/// `env_kurtosis` in a feature row.
pub const ENV_KURTOSIS: usize = feature_index("env_kurtosis");

/// Frame periods of silence on a channel, beyond the one expected, that make a gap
/// by the clock: half the 8-bit counter's range (module docs).
pub const TIME_GAP_FRAMES: f64 = 128.0;

/// Longest silence, in frame periods, whose missing frames the clock counts. A longer
/// one is a junction all the same, but the clock cannot tell a logger that lost the
/// frames from a sensor that paused and resumed, so only the counter's jump is counted.
pub const CLOCK_COUNT_FRAMES: u64 = 4096;

/// A frame that follows a held frame (module docs) within this fraction of a frame
/// period shows a backlog being delivered: the silence before the held frame was a
/// hold-up, not a loss. Half a period is the midpoint between a sender's pace (one
/// period, give or take reception jitter) and a backlog's (back to back).
pub const BACKLOG_FRACTION: f64 = 0.5;

pub use crate::health::{Disposition, Health};

/// What one channel contributed to a window.
#[derive(Debug, Clone, PartialEq)]
pub enum ChannelOutcome {
    /// Features computed.
    Computed {
        /// The features.
        features: Box<ChannelFeatures>,
        /// A discontinuity (lost, duplicate or dropped frames) lies inside the window.
        discontinuous: bool,
    },
    /// The channel does not hold the whole window (dropout).
    Missing,
    /// The core rejected the samples (e.g. a constant, dead sensor).
    Failed(pumptwin_core::Error),
}

/// Impact force of the tracker's model (cancels in its ratio features), N.
pub const TRACK_IMPACT_N: f64 = 50.0;
/// Impact width σ of the tracker's model, s.
pub const TRACK_IMPACT_SIGMA_S: f64 = 2.0e-5;

/// What the on-edge tracker did with a window (core `tracking`, eq. 10): the first
/// channel of the sensor map, nominal parameters `BearingParams::default_housing`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Tracking {
    /// Θ updated.
    Updated {
        /// Radial stiffness `k_r`, N/m.
        stiffness_radial: f64,
        /// Radial damping `c_r`, N·s/m.
        damping_radial: f64,
        /// `k_r` over its nominal value.
        stiffness_rel: f64,
        /// `c_r` over its nominal value.
        damping_rel: f64,
        /// Feature-space consistency loss before the step.
        loss_before: f64,
        /// After the step.
        loss_after: f64,
    },
    /// Not updated (Θ kept): why.
    Skipped(&'static str),
    /// The tracker refused the window (Θ kept).
    Failed(pumptwin_core::Error),
}

/// Features of one channel over one window.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelFeatures {
    /// `node_features` rows, raw (not normalized), one per segment: the model input.
    pub rows: [[f32; FEATURE_DIM]; SEGMENTS],
    /// Time statistics of the whole window.
    pub time: TimeStats,
    /// Envelope-spectrum peak in [`PEAK_BAND_HZ`], Hz.
    pub envelope_peak_hz: f32,
    /// Its prominence over the median envelope-spectrum level, dB.
    pub envelope_prominence_db: f32,
}

impl ChannelFeatures {
    /// A window-level feature by index (the envelope features, shared by all rows).
    pub fn envelope_feature(&self, index: usize) -> f32 {
        self.rows[0][index]
    }
}

/// One channel's part of a window.
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelWindow {
    /// Channel name.
    pub name: String,
    /// What it contributed.
    pub outcome: ChannelOutcome,
}

/// One window, all channels.
#[derive(Debug, Clone, PartialEq)]
pub struct Window {
    /// Window number, from 0.
    pub index: u64,
    /// Timestamp of the frame that completed (or forced) the window, s.
    pub t_s: f64,
    /// Absolute sample index of the first sample.
    pub start_sample: u64,
    /// Shaft rate used, Hz.
    pub shaft_hz: f32,
    /// Channels in sensor-map order.
    pub channels: Vec<ChannelWindow>,
    /// The physics explanation (`None` when no channel has features).
    pub explanation: Option<Explanation>,
    /// Latest slow-sensor values from DBC signals: `(role, value, unit)`.
    pub slow: Vec<(&'static str, f64, String)>,
    /// The latest on-edge parameter tracking (first channel): the window it ran on
    /// and its result. It runs after a window's line is out ([`Pipeline::track_pending`]),
    /// so a window reports the update of an earlier one and the diagnosis never
    /// waits for the tracker.
    pub tracking: (Option<u64>, Tracking),
    /// Counters as of this window.
    pub health: Health,
    /// The latest physical diagnosis of the first channel (`pumptwin_core::diagnosis`)
    /// and the window it ran on (an earlier one: it runs after each line,
    /// [`Pipeline::diagnose_pending`]); `None` when the channel was missing or broken
    /// in that window, or before the first.
    pub physics: (Option<u64>, Option<PhysicsResult>),
    /// What a reader must not miss about this line (filled by the gateway, which
    /// knows the network's classes: [`crate::report::physics_warnings`]).
    pub warnings: Vec<String>,
}

impl Window {
    /// Names of the channels missing from the window.
    pub fn missing(&self) -> impl Iterator<Item = &str> {
        self.channels
            .iter()
            .filter(|c| c.outcome == ChannelOutcome::Missing)
            .map(|c| c.name.as_str())
    }

    /// Names of the channels with a discontinuity inside the window.
    pub fn discontinuous(&self) -> impl Iterator<Item = &str> {
        self.channels
            .iter()
            .filter(|c| {
                matches!(
                    c.outcome,
                    ChannelOutcome::Computed {
                        discontinuous: true,
                        ..
                    }
                )
            })
            .map(|c| c.name.as_str())
    }

    /// Channels whose samples the core rejected, with the reason.
    pub fn failed(&self) -> impl Iterator<Item = (&str, pumptwin_core::Error)> {
        self.channels.iter().filter_map(|c| match c.outcome {
            ChannelOutcome::Failed(e) => Some((c.name.as_str(), e)),
            _ => None,
        })
    }

    /// Features of the channel named `name`, if computed.
    pub fn features(&self, name: &str) -> Option<&ChannelFeatures> {
        self.channels
            .iter()
            .find(|c| c.name == name)
            .and_then(|c| match &c.outcome {
                ChannelOutcome::Computed { features, .. } => Some(features.as_ref()),
                _ => None,
            })
    }

    /// Any channel missing, failed or discontinuous.
    pub fn is_degraded(&self) -> bool {
        self.channels.iter().any(|c| {
            !matches!(
                c.outcome,
                ChannelOutcome::Computed {
                    discontinuous: false,
                    ..
                }
            )
        })
    }
}

/// What [`Pipeline::push`] did with a frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Pushed {
    /// The frame's bucket.
    pub disposition: Disposition,
    /// Windows completed by this frame: usually 0 or 1; up to 4 right after a
    /// channel re-joins (the windows it missed are cut at once, listing it as missing).
    pub windows: Vec<Window>,
}

#[derive(Debug)]
struct ChannelState {
    spec: Channel,
    fir: Box<FirLowpass<BAND_LIMIT_TAPS>>,
    ring: Box<SampleRing<RING>>,
    expected_seq: Option<u8>,
    /// Payload of the last frame whose samples were stored (duplicate check).
    last_payload: Vec<u8>,
    /// Reception time of the channel's last frame that was not late, µs.
    last_ts_us: Option<u64>,
    /// Interface of the channel's first frame that named one.
    iface: Option<heapless::String<16>>,
    pending_gap: bool,
    /// The first frame after a silence, waiting for the channel's next frame.
    held: Option<HeldFrame>,
    /// The seconds before the window (first channel only), for the physics.
    history: Option<Box<SampleRing<HISTORY>>>,
}

/// A frame held after a silence by the clock (module docs).
#[derive(Debug)]
struct HeldFrame {
    samples: heapless::Vec<f32, MAX_SAMPLES_PER_FRAME>,
    ts_us: u64,
    /// Frames lost if the silence was a loss: the clock's count.
    lost: u64,
    /// A junction was already pending before the frame (a late frame dropped).
    gap_before: bool,
}

/// How a held frame was decided, for [`Pipeline::push`] to count and store it.
#[derive(Debug)]
struct Decided {
    channel: usize,
    frame: HeldFrame,
    backlog: bool,
}

/// Buffers of the physical diagnosis (`pumptwin_core::diagnosis`) over the history:
/// the stretch read, and the slabs its transforms are carved from.
#[derive(Debug)]
struct PhysicsBuffers {
    samples: Vec<f32>,
    complex: Vec<Complex32>,
    real: Vec<f32>,
}

impl PhysicsBuffers {
    fn new() -> Self {
        Self {
            samples: vec![0.0; HISTORY],
            complex: vec![Complex32::ZERO; Buffers::complex_len(HISTORY)],
            real: vec![0.0; Buffers::real_len(HISTORY)],
        }
    }
}

/// Caller-owned buffers of the core's transforms, one set for all channels.
#[derive(Debug)]
struct Scratch {
    features: FeatureScratch<WINDOW>,
    median: [f32; WINDOW / 2 + 1],
}

/// The gateway's signal path from frames to windows.
#[derive(Debug)]
pub struct Pipeline {
    machine: Machine,
    cfg: FeatureConfig,
    slow: SlowSignals,
    tracker: Box<Tracker<WINDOW>>,
    /// First-channel samples of the last window cut, waiting for [`Pipeline::track_pending`].
    track_buf: Box<[f32; WINDOW]>,
    track_pending: Option<u64>,
    /// The latest tracking result and the window it came from.
    last_tracking: (Option<u64>, Tracking),
    channels: Vec<ChannelState>,
    decoded: heapless::Vec<f32, MAX_SAMPLES_PER_FRAME>,
    next_start: u64,
    next_index: u64,
    last_ts_us: Option<u64>,
    health: Health,
    window: Box<[f32; WINDOW]>,
    scratch: Box<Scratch>,
    physics: Box<PhysicsBuffers>,
    /// The physical diagnosis' thresholds and the shaft revolutions it reads.
    diagnosis: (Thresholds, f32),
    /// The last window cut, `(index, start)`, waiting for [`Pipeline::track_pending`].
    physics_pending: Option<(u64, u64)>,
    /// The latest physical diagnosis and the window it came from.
    last_physics: (Option<u64>, Option<PhysicsResult>),
    /// The first [`MAX_UNKNOWN_IDS`] distinct identifiers the sensor map does not
    /// name, for the message when no frame was usable.
    unknown_ids: Vec<u32>,
    /// A held frame decided by the frame being pushed.
    decided: Option<Decided>,
}

/// Distinct unknown identifiers remembered.
pub const MAX_UNKNOWN_IDS: usize = 16;

/// A window's physical diagnosis, or why the core refused its samples.
pub type PhysicsResult = Result<Diagnosis, pumptwin_core::Error>;

impl Pipeline {
    /// A pipeline for a validated sensor map.
    ///
    /// # Errors
    /// The map's speed puts the defect lines where the envelope cannot read them
    /// ([`FeatureConfig::check_speed`]: `rpm = 1` or `1e9` is a wrong map, not a
    /// machine); the band-limit filter cannot be designed for the map's rate (not for
    /// a validated map: its rate is above the envelope band).
    pub fn new(map: SensorMap) -> Result<Self, pumptwin_core::Error> {
        let cfg = map.machine.feature_config();
        cfg.check_speed(WINDOW)?;
        let fs = map.machine.fs_hz;
        let cutoff = cfg.band_limit_hz.min(MAX_CUTOFF_FRACTION * fs);
        let channels = map
            .channels
            .into_iter()
            .enumerate()
            .map(|(i, spec)| {
                Ok(ChannelState {
                    spec,
                    fir: Box::new(FirLowpass::new(cutoff, fs)?),
                    ring: Box::new(SampleRing::new()),
                    expected_seq: None,
                    last_payload: Vec::new(),
                    last_ts_us: None,
                    iface: None,
                    pending_gap: false,
                    held: None,
                    history: (i == 0).then(|| Box::new(SampleRing::new())),
                })
            })
            .collect::<Result<_, pumptwin_core::Error>>()?;
        let tracker = Box::new(Tracker::new(TrackerConfig::edge_default(
            f64::from(fs),
            BearingParams::default_housing(),
            TRACK_IMPACT_N,
            TRACK_IMPACT_SIGMA_S,
        ))?);
        Ok(Self {
            machine: map.machine,
            cfg,
            slow: map.slow,
            tracker,
            track_buf: Box::new([0.0; WINDOW]),
            track_pending: None,
            last_tracking: (None, Tracking::Skipped("no window tracked yet")),
            channels,
            decoded: heapless::Vec::new(),
            next_start: 0,
            next_index: 0,
            last_ts_us: None,
            health: Health::default(),
            window: Box::new([0.0; WINDOW]),
            scratch: Box::new(Scratch {
                features: FeatureScratch::new(),
                median: [0.0; WINDOW / 2 + 1],
            }),
            physics: Box::new(PhysicsBuffers::new()),
            diagnosis: (Thresholds::DEFAULT, DEFAULT_REVOLUTIONS),
            physics_pending: None,
            last_physics: (None, None),
            unknown_ids: Vec::new(),
            decided: None,
        })
    }

    /// Counters so far.
    pub fn health(&self) -> Health {
        self.health
    }

    /// The machine.
    pub fn machine(&self) -> &Machine {
        &self.machine
    }

    /// The feature configuration in use.
    pub fn feature_config(&self) -> &FeatureConfig {
        &self.cfg
    }

    /// Channel names in sensor-map order.
    pub fn channel_names(&self) -> impl Iterator<Item = &str> {
        self.channels.iter().map(|c| c.spec.name.as_str())
    }

    /// The sensor map's channel identifiers, in map order.
    pub fn channel_ids(&self) -> impl Iterator<Item = u32> + '_ {
        self.channels.iter().map(|c| c.spec.can_id)
    }

    /// The first distinct identifiers seen that the sensor map does not name.
    pub fn unknown_ids(&self) -> &[u32] {
        &self.unknown_ids
    }

    /// Why a run produced no window, in words (`None` when it produced one): what an
    /// operator needs to fix the input or the sensor map.
    pub fn why_no_window(&self) -> Option<String> {
        let h = &self.health;
        if h.windows > 0 {
            return None;
        }
        let hex = |ids: &mut dyn Iterator<Item = u32>| {
            ids.map(|i| format!("0x{i:X}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        Some(if h.frames_total == 0 {
            format!(
                "the input held no CAN frame ({} lines were not frames)",
                h.bad_lines
            )
        } else if h.used == 0 && h.unknown_id > 0 {
            format!(
                "none of its {} frames has an identifier the sensor map names: seen {}{}, \
                 the map's {}",
                h.frames_total,
                hex(&mut self.unknown_ids.iter().copied()),
                if self.unknown_ids.len() == MAX_UNKNOWN_IDS {
                    ", …"
                } else {
                    ""
                },
                hex(&mut self.channel_ids())
            )
        } else {
            format!(
                "{} of its {} frames were used, fewer samples than one window \
                 ({WINDOW} per channel, every channel)",
                h.used, h.frames_total
            )
        })
    }

    /// Count a log line that was not a frame.
    pub fn note_bad_line(&mut self) {
        self.health.bad_lines += 1;
    }

    /// A DBC message with slow signals: decoded (not when late), and a new shaft speed
    /// takes effect for the next windows.
    fn slow_frame(&mut self, frame: &Frame, late: bool) -> Disposition {
        if late {
            return Disposition::SlowLate;
        }
        if !self.slow.update(frame) {
            return Disposition::SlowMalformed;
        }
        if let Some(rpm) = self.slow.value("rpm") {
            // A speed the envelope cannot read the lines at (a stopping pump, a bad
            // value) is not taken: the window keeps the last good one, and the
            // reported `rpm` slow value shows what the bus said.
            let hz = (rpm / 60.0) as f32;
            let cfg =
                FeatureConfig::standard(self.machine.fs_hz, hz, self.machine.bearing.orders());
            if hz != self.cfg.shaft_hz && cfg.check_speed(WINDOW).is_ok() {
                self.cfg = cfg;
            }
        }
        Disposition::Slow
    }

    /// Run the tracker on the last window cut, if its first channel was whole
    /// (Θ update, eq. 10); the result goes into the next window's line.
    pub fn track_pending(&mut self) {
        let Some(index) = self.track_pending.take() else {
            return;
        };
        let nominal = self.tracker.config().nominal;
        let result = match self.tracker.update(&self.track_buf) {
            Ok(step) => Tracking::Updated {
                stiffness_radial: step.theta.stiffness_radial,
                damping_radial: step.theta.damping_radial,
                stiffness_rel: step.theta.stiffness_radial / nominal.stiffness_radial,
                damping_rel: step.theta.damping_radial / nominal.damping_radial,
                loss_before: step.loss_before,
                loss_after: step.loss_after,
            },
            Err(e) => Tracking::Failed(e),
        };
        self.last_tracking = (Some(index), result);
    }

    /// The physical diagnosis of the last window cut, after its line is out (as Θ
    /// tracking: a stretch of 16 revolutions costs a dozen transforms of up to 16 384
    /// points, more than a line's latency budget); the next window reports it.
    pub fn diagnose_pending(&mut self) {
        if let Some((index, start)) = self.physics_pending.take() {
            self.last_physics = (Some(index), self.physics(start));
        }
    }

    /// Latest slow-sensor values (`(role, value, unit)`), for the window output.
    pub fn slow_values(&self) -> Vec<(&'static str, f64, String)> {
        self.slow
            .signals
            .iter()
            .zip(&self.slow.latest)
            .filter_map(|(s, v)| v.map(|v| (s.role, v, s.unit.clone())))
            .collect()
    }

    /// Take one frame: classify and count it, store its samples, and return the windows
    /// it completed.
    pub fn push(&mut self, frame: &Frame) -> Pushed {
        let late = self.last_ts_us.is_some_and(|t| frame.ts_us < t);
        self.last_ts_us = Some(frame.ts_us);
        let disposition = match frame.kind {
            FrameKind::Remote { .. } => Disposition::Remote,
            FrameKind::Error => Disposition::ErrorFrame,
            FrameKind::Data => self.classify_data(frame, late),
        };
        let mut windows = Vec::new();
        if let Some(decided) = self.decided.take() {
            self.store_decided(decided, &mut windows);
        }
        if !matches!(disposition, Disposition::Held { .. }) {
            self.health.frames_total += 1;
        }
        let h = &mut self.health;
        let store = match disposition {
            Disposition::Used { channel } => {
                h.used += 1;
                Some(channel)
            }
            Disposition::Duplicate { .. } => {
                h.duplicate += 1;
                None
            }
            Disposition::OutOfSequence { channel, lost } => {
                h.out_of_sequence += 1;
                h.lost_frames += lost;
                Some(channel)
            }
            Disposition::UnknownId => {
                h.unknown_id += 1;
                if self.unknown_ids.len() < MAX_UNKNOWN_IDS && !self.unknown_ids.contains(&frame.id)
                {
                    self.unknown_ids.push(frame.id);
                }
                None
            }
            Disposition::OtherInterface { .. } => {
                h.other_interface += 1;
                None
            }
            Disposition::Slow => {
                h.used += 1;
                None
            }
            Disposition::SlowMalformed => {
                h.malformed += 1;
                None
            }
            Disposition::SlowLate => {
                h.late += 1;
                None
            }
            Disposition::Malformed { .. } => {
                h.malformed += 1;
                None
            }
            Disposition::Late { .. } => {
                h.late += 1;
                None
            }
            Disposition::Held { .. } => None,
            Disposition::Remote => {
                h.remote += 1;
                None
            }
            Disposition::ErrorFrame => {
                h.error_frames += 1;
                None
            }
        };
        if let Some(channel) = store {
            self.store(channel, frame.ts_us, &mut windows);
        }
        Pushed {
            disposition,
            windows,
        }
    }

    /// Decide the frames still held after a silence (by the clock alone: no frame
    /// came after them), count and store them, and return the windows they complete.
    /// Call once, at the end of the input.
    pub fn finish(&mut self) -> Vec<Window> {
        let mut windows = Vec::new();
        for channel in 0..self.channels.len() {
            if let Some(frame) = self.channels[channel].held.take() {
                let decided = Decided {
                    channel,
                    frame,
                    backlog: false,
                };
                self.store_decided(decided, &mut windows);
            }
        }
        windows
    }

    /// Count a decided held frame and store its samples, with a junction before them
    /// unless the silence was a hold-up; the flag the frame being pushed left for its
    /// own samples is kept for them.
    fn store_decided(&mut self, decided: Decided, windows: &mut Vec<Window>) {
        let Decided {
            channel,
            frame,
            backlog,
        } = decided;
        let h = &mut self.health;
        h.frames_total += 1;
        if backlog {
            h.used += 1;
        } else {
            h.out_of_sequence += 1;
            h.lost_frames += frame.lost;
        }
        let junction = frame.gap_before || !backlog;
        let pushed_gap = std::mem::replace(&mut self.channels[channel].pending_gap, junction);
        let mut samples = frame.samples;
        std::mem::swap(&mut self.decoded, &mut samples);
        self.store(channel, frame.ts_us, windows);
        std::mem::swap(&mut self.decoded, &mut samples);
        self.channels[channel].pending_gap = pushed_gap;
    }

    /// Decode a data frame into `self.decoded` and decide its bucket; updates the
    /// channel's sequence state.
    fn classify_data(&mut self, frame: &Frame, late: bool) -> Disposition {
        let Some(channel) = self.channels.iter().position(|c| c.spec.matches(frame)) else {
            if self.slow.matches(frame) {
                return self.slow_frame(frame, late);
            }
            return Disposition::UnknownId;
        };
        let ch = &mut self.channels[channel];
        if !frame.iface.is_empty() {
            match &ch.iface {
                Some(own) if *own != frame.iface => {
                    return Disposition::OtherInterface { channel };
                }
                Some(_) => {}
                None => ch.iface = Some(frame.iface.clone()),
            }
        }
        let seq = match ch.spec.decode(&frame.data, frame.fd, &mut self.decoded) {
            Ok(seq) => seq,
            Err(error) => return Disposition::Malformed { channel, error },
        };
        let period_us = 1e6 * ch.spec.samples_per_frame as f64 / f64::from(self.machine.fs_hz);
        let duplicate = seq.is_some_and(|s| {
            ch.expected_seq == Some(s.wrapping_add(1)) && ch.last_payload == frame.data[..]
        });
        if !duplicate {
            if let Some(held) = ch.held.take() {
                let since_us = frame.ts_us.saturating_sub(held.ts_us) as f64;
                self.decided = Some(Decided {
                    channel,
                    frame: held,
                    backlog: !late && since_us < BACKLOG_FRACTION * period_us,
                });
            }
        }
        if late {
            // Its samples are dropped: the stream has a junction here, and the counter
            // moves past the frame so the next one is not blamed for it.
            ch.pending_gap = true;
            if let Some(s) = seq {
                ch.expected_seq = Some(s.wrapping_add(1));
            }
            return Disposition::Late { channel };
        }
        if duplicate {
            return Disposition::Duplicate { channel };
        }
        // Frames missing by the clock: more than half the counter's range of frame
        // periods since this channel's last frame is a gap, whatever the counter says
        // (a run of 256 lost frames brings it back to where it was; a channel without
        // a counter has only the clock). Below that, reception jitter is not a gap.
        let missing_by_clock = ch
            .last_ts_us
            .replace(frame.ts_us)
            .map(|t| frame.ts_us.saturating_sub(t) as f64 / period_us - 1.0)
            .filter(|&m| m > TIME_GAP_FRAMES)
            .map(|m| m.round() as u64);
        // The counter counts losses modulo 256; the clock says how many wraps.
        let (jump, lost_by_clock) = match seq {
            None => (0, missing_by_clock),
            Some(s) => {
                ch.last_payload.clear();
                ch.last_payload.extend_from_slice(&frame.data);
                let j = ch.expected_seq.map_or(0, |e| s.wrapping_sub(e));
                ch.expected_seq = Some(s.wrapping_add(1));
                let wraps = |by_clock: u64| {
                    ((by_clock as f64 - f64::from(j)) / 256.0).round().max(0.0) as u64
                };
                (j, missing_by_clock.map(|m| u64::from(j) + 256 * wraps(m)))
            }
        };
        match (missing_by_clock, lost_by_clock) {
            (Some(m), Some(lost)) if jump == 0 && m <= CLOCK_COUNT_FRAMES => {
                // Only the clock sees this silence: a loss or a hold-up, as the next
                // frame will tell.
                ch.held = Some(HeldFrame {
                    samples: self.decoded.clone(),
                    ts_us: frame.ts_us,
                    lost,
                    gap_before: std::mem::take(&mut ch.pending_gap),
                });
                Disposition::Held { channel }
            }
            (Some(m), _) => {
                ch.pending_gap = true;
                let lost = if m <= CLOCK_COUNT_FRAMES {
                    lost_by_clock.unwrap_or(0)
                } else {
                    u64::from(jump)
                };
                Disposition::OutOfSequence { channel, lost }
            }
            (None, _) if jump == 0 => Disposition::Used { channel },
            (None, _) => {
                ch.pending_gap = true;
                Disposition::OutOfSequence {
                    channel,
                    lost: if jump < 128 { u64::from(jump) } else { 0 },
                }
            }
        }
    }

    /// Append `self.decoded` to `channel`, cutting the windows that become due.
    fn store(&mut self, channel: usize, ts_us: u64, windows: &mut Vec<Window>) {
        let k = self.decoded.len() as u64;
        if self.channels[channel].ring.written() < self.next_start {
            // Fell behind the window grid (dropout, or a late start): re-join where the
            // channel furthest ahead is, which is about "now".
            let now = self
                .channels
                .iter()
                .map(|c| c.ring.written())
                .fold(self.next_start, u64::max);
            let ch = &mut self.channels[channel];
            ch.ring.restart_at(now);
            if let Some(h) = ch.history.as_mut() {
                h.restart_at(now);
            }
            ch.fir.reset();
            ch.pending_gap = false;
            self.health.realignments += 1;
        }
        while self.channels[channel].ring.written() + k > self.next_start + RING as u64 {
            let w = self.cut_window(ts_us);
            windows.push(w);
        }
        let ch = &mut self.channels[channel];
        let mut gap = std::mem::take(&mut ch.pending_gap);
        for &x in &self.decoded {
            let y = ch.fir.push(x);
            ch.ring.push(y, gap);
            if let Some(h) = ch.history.as_mut() {
                h.push(y, gap);
            }
            gap = false;
        }
        while self
            .channels
            .iter()
            .all(|c| c.ring.written() >= self.next_start + WINDOW as u64)
        {
            let w = self.cut_window(ts_us);
            windows.push(w);
        }
    }

    /// Cut the window at `next_start` from every channel, compute, advance.
    fn cut_window(&mut self, ts_us: u64) -> Window {
        let start = self.next_start;
        let mut channels = Vec::with_capacity(self.channels.len());
        self.track_pending = None;
        for (ci, ch) in self.channels.iter().enumerate() {
            let outcome = if !ch.ring.copy_out(start, &mut self.window[..]) {
                ChannelOutcome::Missing
            } else {
                if ci == 0 && !ch.ring.has_gap(start, WINDOW) {
                    self.track_buf.copy_from_slice(&self.window[..]);
                    self.track_pending = Some(self.next_index);
                }
                match analyse(&self.window, &self.cfg, &mut self.scratch) {
                    Ok(features) => ChannelOutcome::Computed {
                        features: Box::new(features),
                        discontinuous: ch.ring.has_gap(start, WINDOW),
                    },
                    Err(e) => ChannelOutcome::Failed(e),
                }
            };
            channels.push(ChannelWindow {
                name: ch.spec.name.clone(),
                outcome,
            });
        }
        let explanation = self.explain(&channels);
        self.physics_pending = Some((self.next_index, start));
        let mut window = Window {
            index: self.next_index,
            t_s: ts_us as f64 / 1e6,
            start_sample: start,
            shaft_hz: self.cfg.shaft_hz,
            channels,
            explanation,
            slow: self.slow_values(),
            tracking: self.last_tracking,
            health: Health::default(),
            physics: self.last_physics,
            warnings: Vec::new(),
        };
        self.next_start += HOP as u64;
        self.next_index += 1;
        self.health.windows += 1;
        if window.is_degraded() {
            self.health.degraded_windows += 1;
        }
        window.health = self.health;
        window
    }

    /// Decide the physical diagnosis with `thresholds`, each window read over
    /// `revolutions` of the shaft (a model file's own settings; the core's by default).
    pub fn set_diagnosis(&mut self, thresholds: Thresholds, revolutions: f32) {
        self.diagnosis = (thresholds, revolutions);
    }

    /// The physical diagnosis of the first channel (the monitored bearing) over the
    /// 16 shaft revolutions ending where the window at `start` ends, or the longest
    /// stretch of them (a power of two ≥ the window) the history holds without a
    /// gap; `None` when not even the window itself is whole.
    fn physics(&mut self, start: u64) -> Option<PhysicsResult> {
        let history = self.channels.first()?.history.as_ref()?;
        let end = start + WINDOW as u64;
        let (thresholds, revolutions) = self.diagnosis;
        let mut len =
            segment_len(self.cfg.fs_hz, self.cfg.shaft_hz, revolutions, WINDOW).min(HISTORY);
        while len > WINDOW
            && (end < len as u64
                || !history.covers(end - len as u64, len)
                || history.has_gap(end - len as u64, len))
        {
            len /= 2;
        }
        let from = end.checked_sub(len as u64)?;
        let b = &mut *self.physics;
        if !history.covers(from, len) || history.has_gap(from, len) {
            return None;
        }
        history.copy_out(from, &mut b.samples[..len]);
        let orders = self.machine.bearing.orders();
        let (fs, shaft) = (self.cfg.fs_hz, self.cfg.shaft_hz);
        Some(
            Buffers::carve(&mut b.complex, &mut b.real, len)
                .and_then(|buf| window_evidence(&b.samples[..len], fs, shaft, &orders, buf))
                .map(|e| decide(&e, &thresholds)),
        )
    }

    /// The most prominent envelope peak among the computed channels, matched to the
    /// bearing's kinematic lines.
    fn explain(&self, channels: &[ChannelWindow]) -> Option<Explanation> {
        let (name, f) = channels
            .iter()
            .filter_map(|c| match &c.outcome {
                ChannelOutcome::Computed { features, .. }
                    if features.envelope_prominence_db.is_finite() =>
                {
                    Some((c.name.as_str(), features.as_ref()))
                }
                _ => None,
            })
            .max_by(|a, b| {
                a.1.envelope_prominence_db
                    .total_cmp(&b.1.envelope_prominence_db)
            })?;
        let freqs = self.machine.bearing.frequencies(self.cfg.shaft_hz);
        let df = self.cfg.fs_hz / WINDOW as f32;
        let kinematic = nearest_kinematic(f.envelope_peak_hz, &freqs, df)?;
        Some(Explanation {
            channel: name.to_owned(),
            peak_hz: f.envelope_peak_hz,
            peak_order: f.envelope_peak_hz / self.cfg.shaft_hz,
            prominence_db: f.envelope_prominence_db,
            kinematic,
        })
    }
}

/// The core's features of one channel's window, and its envelope peak.
fn analyse(
    x: &[f32; WINDOW],
    cfg: &FeatureConfig,
    s: &mut Scratch,
) -> Result<ChannelFeatures, pumptwin_core::Error> {
    let mut rows = [[0.0f32; FEATURE_DIM]; SEGMENTS];
    node_features(x, cfg, &mut s.features, &mut rows)?;
    let time = TimeStats::compute(x)?;
    // The envelope spectrum node_features just computed (no second transform).
    let spec = s.features.envelope_spectrum();
    let peak_hz = peak_frequency(spec, cfg.fs_hz, PEAK_BAND_HZ.0, PEAK_BAND_HZ.1)?;
    let df = cfg.fs_hz / WINDOW as f32;
    let k = (peak_hz / df).round() as usize;
    let level = spec
        .get(k.saturating_sub(1)..=(k + 1).min(spec.len() - 1))
        .map_or(0.0, |b| b.iter().copied().fold(0.0, f32::max));
    // Median over the same span as the core's envelope floor: 4 × the highest line.
    let o = cfg.orders;
    let max_f = o.bpfi.max(o.bpfo).max(o.bsf).max(1.0) * cfg.shaft_hz;
    let k_floor = ((4.0 * max_f / df) as usize).clamp(1, spec.len() - 1);
    let work = &mut s.median[..k_floor];
    work.copy_from_slice(&spec[1..=k_floor]);
    let (_, median, _) = work.select_nth_unstable_by(k_floor / 2, |a, b| a.total_cmp(b));
    let prominence_db = if *median > 0.0 && level > 0.0 {
        10.0 * (level / *median).log10()
    } else {
        f32::NAN
    };
    Ok(ChannelFeatures {
        rows,
        time,
        envelope_peak_hz: peak_hz,
        envelope_prominence_db: prominence_db,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumptwin_core::features::FEATURE_NAMES;

    #[test]
    fn feature_indices_name_the_right_features() {
        assert_eq!(FEATURE_NAMES[ENV_SHAFT_DB], "env_shaft_db");
        assert_eq!(FEATURE_NAMES[ENV_BPFO_DB], "env_bpfo_db");
        assert_eq!(FEATURE_NAMES[ENV_BPFI_DB], "env_bpfi_db");
        assert_eq!(FEATURE_NAMES[ENV_BSF_DB], "env_bsf_db");
        assert_eq!(FEATURE_NAMES[ENV_KURTOSIS], "env_kurtosis");
    }

    #[test]
    fn feature_config_at_12_khz_is_the_default_band() {
        let map = SensorMap::from_toml_str(
            "[machine]\nrpm = 1797\nbearing = \"cwru-6205-de\"\nfs_hz = 12000\n\
             [[channel]]\nname = \"DE\"\ncan_id = 0x101\nsamples_per_frame = 4\nscale = 0.001\n",
        )
        .unwrap();
        let cfg = map.machine.feature_config();
        assert_eq!(
            cfg.envelope_band,
            pumptwin_core::features::EnvelopeBand::DEFAULT
        );
        assert_eq!(cfg.band_limit_hz, 5000.0);
        assert_eq!(cfg.segments, 8);
        assert!((cfg.shaft_hz - 29.95).abs() < 1e-4);
    }
}
