//! What happened to every frame and window: the counters ([`Health`]) and the bucket
//! one frame lands in ([`Disposition`]); the pipeline's module docs say how each is
//! decided.

use crate::sensor_map::LayoutError;
use serde::Serialize;

/// Counters of what happened to frames and windows (see the module docs).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Health {
    /// Frames received and classified (a frame held after a silence is counted when
    /// its bucket is decided: module docs).
    pub frames_total: u64,
    /// Frames whose samples were used, in sequence.
    pub used: u64,
    /// Frames that repeat their channel's last stored frame, counter and payload
    /// (dropped).
    pub duplicate: u64,
    /// Frames with an unexpected sequence counter (samples used).
    pub out_of_sequence: u64,
    /// Frames with an identifier the sensor map does not name.
    pub unknown_id: u64,
    /// Frames with a channel's identifier from another interface than the channel's
    /// first frame (dropped).
    pub other_interface: u64,
    /// Frames whose payload does not fit the layout.
    pub malformed: u64,
    /// Frames with a timestamp before the previous frame's (dropped).
    pub late: u64,
    /// Remote frames.
    pub remote: u64,
    /// Error frames.
    pub error_frames: u64,
    /// Frames missing according to forward sequence-counter jumps (not in `frames_total`).
    pub lost_frames: u64,
    /// Log lines that are not frames (not in `frames_total`).
    pub bad_lines: u64,
    /// Channels re-joined after falling behind the window grid.
    pub realignments: u64,
    /// Windows reported.
    pub windows: u64,
    /// Windows reported as degraded.
    pub degraded_windows: u64,
}

impl Health {
    /// Sum of the frame buckets; equals `frames_total`.
    pub fn frames_classified(&self) -> u64 {
        self.used
            + self.duplicate
            + self.out_of_sequence
            + self.unknown_id
            + self.other_interface
            + self.malformed
            + self.late
            + self.remote
            + self.error_frames
    }
}

impl std::fmt::Display for Health {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} frames: {} used, {} duplicate, {} out of sequence ({} lost), {} unknown id, \
             {} from another interface, {} malformed, \
             {} late, {} remote, {} error frames; {} bad lines; {} windows ({} degraded); \
             {} channel re-alignments",
            self.frames_total,
            self.used,
            self.duplicate,
            self.out_of_sequence,
            self.lost_frames,
            self.unknown_id,
            self.other_interface,
            self.malformed,
            self.late,
            self.remote,
            self.error_frames,
            self.bad_lines,
            self.windows,
            self.degraded_windows,
            self.realignments
        )
    }
}

/// The bucket one frame landed in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Disposition {
    /// Samples used.
    Used {
        /// Channel index in the sensor map.
        channel: usize,
    },
    /// The channel's last stored frame again (same counter and payload); dropped.
    Duplicate {
        /// Channel index.
        channel: usize,
    },
    /// Samples used after a sequence-counter jump.
    OutOfSequence {
        /// Channel index.
        channel: usize,
        /// Frames the jump (or the time gap) says were lost (0 for a backward step).
        lost: u64,
    },
    /// No channel has this identifier.
    UnknownId,
    /// A channel's identifier from another interface than the channel's first frame;
    /// dropped.
    OtherInterface {
        /// Channel index.
        channel: usize,
    },
    /// The payload does not fit the channel's layout.
    Malformed {
        /// Channel index.
        channel: usize,
        /// How.
        error: LayoutError,
    },
    /// Timestamp before the previous frame's; dropped.
    Late {
        /// Channel index.
        channel: usize,
    },
    /// The first frame after a silence by the clock that the counter does not see:
    /// held, not yet counted, until the channel's next frame says whether the silence
    /// was a loss or a hold-up (module docs).
    Held {
        /// Channel index.
        channel: usize,
    },
    /// A DBC message with slow signals, decoded (counted as used).
    Slow,
    /// A DBC message too short for one of its signals (counted as malformed).
    SlowMalformed,
    /// A DBC message with a timestamp before the previous frame's (counted as late).
    SlowLate,
    /// A remote frame.
    Remote,
    /// An error frame.
    ErrorFrame,
}
