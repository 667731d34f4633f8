//! The run loop: a [`FrameSource`] through the [`Pipeline`] to JSON lines.

use crate::candump::{FrameSource, SourceError};
use crate::diagnosis::{DiagnoseError, Diagnoser};
use crate::pace::Pacer;
use crate::pipeline::{Health, Pipeline, Window};
use crate::report::window_json;
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Called after each window's line is written, with the window and its diagnosis
/// (e.g. the `--publish-id` bus frame).
pub type Publisher<'d> =
    Box<dyn FnMut(&Window, Option<&serde_json::Value>) -> std::io::Result<()> + 'd>;

/// Latency from the frame that completes a window to its JSON line written (features,
/// graph, int8 inference, serialization), in a fixed histogram: 10 µs bins up to 20 ms
/// and one overflow bin, so memory stays constant over months of running.
#[derive(Debug, Clone)]
pub struct LatencyHistogram {
    bins: Box<[u64; LatencyHistogram::BINS + 1]>,
    count: u64,
    max_us: u64,
}

impl Default for LatencyHistogram {
    fn default() -> Self {
        Self {
            bins: Box::new([0; LatencyHistogram::BINS + 1]),
            count: 0,
            max_us: 0,
        }
    }
}

impl LatencyHistogram {
    /// Bin width, µs.
    pub const BIN_US: u64 = 10;
    /// Bins below the overflow bin (20 ms).
    pub const BINS: usize = 2000;

    /// Record one latency.
    pub fn record(&mut self, d: std::time::Duration) {
        let us = d.as_micros().min(u128::from(u64::MAX)) as u64;
        let bin = ((us / Self::BIN_US) as usize).min(Self::BINS);
        self.bins[bin] += 1;
        self.count += 1;
        self.max_us = self.max_us.max(us);
    }

    /// Latencies recorded.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The `q` quantile (0..=1), µs, as the upper edge of its bin (`None` if empty;
    /// the overflow bin reports the maximum seen).
    pub fn quantile_us(&self, q: f64) -> Option<u64> {
        if self.count == 0 {
            return None;
        }
        let rank = ((q.clamp(0.0, 1.0) * self.count as f64).ceil() as u64).max(1);
        let mut seen = 0;
        for (i, &n) in self.bins.iter().enumerate() {
            seen += n;
            if seen >= rank {
                return Some(if i == Self::BINS {
                    self.max_us
                } else {
                    (i as u64 + 1) * Self::BIN_US
                });
            }
        }
        Some(self.max_us)
    }
}

/// Bad log lines reported individually before the rest are only counted.
pub const BAD_LINES_SHOWN: u64 = 10;

/// Why a run stopped early.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum GatewayError {
    /// The frame source failed for good (I/O).
    #[error(transparent)]
    Source(SourceError),
    /// The output could not be written.
    #[error("writing window output: {0}")]
    Output(#[from] std::io::Error),
    /// A window could not be serialized.
    #[error("serializing a window: {0}")]
    Json(#[from] serde_json::Error),
    /// The diagnoser failed.
    #[error(transparent)]
    Diagnose(#[from] DiagnoseError),
}

/// Pipeline, pacing and the optional diagnoser, run over a frame source.
pub struct Gateway<'d> {
    pipeline: Pipeline,
    pacer: Pacer,
    diagnoser: Option<Box<dyn Diagnoser + 'd>>,
    publisher: Option<Publisher<'d>>,
    stop: Option<Arc<AtomicBool>>,
    /// Publisher calls that failed (logged on stderr, the run goes on).
    pub publish_failures: u64,
    /// Frame → JSON line latency of every window.
    pub latency: LatencyHistogram,
    metrics: Option<Arc<std::sync::Mutex<crate::ops::Metrics>>>,
    /// Write lines for people ([`crate::report::window_text`]) instead of JSON.
    human: bool,
    /// Windows per diagnosed class and per physical type, for the closing summary.
    pub tally: crate::report::Tally,
    /// The network's class of the last window written: the physics that runs on it
    /// after the line is judged against it on the next line.
    last_class: Option<(u64, String)>,
}

impl std::fmt::Debug for Gateway<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Gateway")
            .field("pipeline", &self.pipeline)
            .field("pacer", &self.pacer)
            .field(
                "diagnoser",
                &self.diagnoser.as_ref().map(|_| "dyn Diagnoser"),
            )
            .finish()
    }
}

impl<'d> Gateway<'d> {
    /// A gateway without a diagnoser (physics explanation and health only).
    pub fn new(pipeline: Pipeline, pacer: Pacer) -> Self {
        Self {
            pipeline,
            pacer,
            diagnoser: None,
            publisher: None,
            stop: None,
            publish_failures: 0,
            latency: LatencyHistogram::default(),
            metrics: None,
            human: false,
            tally: crate::report::Tally::default(),
            last_class: None,
        }
    }

    /// Write one line for people per window instead of JSON (a terminal's default).
    pub fn with_human_output(mut self, human: bool) -> Self {
        self.human = human;
        self
    }

    /// Add a diagnoser: its output goes into each window's `"diagnosis"`.
    pub fn with_diagnoser(mut self, diagnoser: Box<dyn Diagnoser + 'd>) -> Self {
        self.diagnoser = Some(diagnoser);
        self
    }

    /// Add a publisher, called after each window's line.
    pub fn with_publisher(mut self, publisher: Publisher<'d>) -> Self {
        self.publisher = Some(publisher);
        self
    }

    /// Stop between frames once `stop` is set (SIGINT/SIGTERM): what was written is
    /// flushed, the run returns normally.
    pub fn with_stop(mut self, stop: Arc<AtomicBool>) -> Self {
        self.stop = Some(stop);
        self
    }

    /// Keep `metrics` up to date after every window (for `--metrics-addr`).
    pub fn with_metrics(mut self, metrics: Arc<std::sync::Mutex<crate::ops::Metrics>>) -> Self {
        self.metrics = Some(metrics);
        self
    }

    /// The pipeline (for its counters).
    pub fn pipeline(&self) -> &Pipeline {
        &self.pipeline
    }

    /// Run until `source` is exhausted: one JSON line per window to `out`, flushed per
    /// line; bad log lines are counted, the first [`BAD_LINES_SHOWN`] described on
    /// `log`. Returns the final counters.
    pub fn run<S, W, L>(
        &mut self,
        source: &mut S,
        out: &mut W,
        log: &mut L,
    ) -> Result<Health, GatewayError>
    where
        S: FrameSource + ?Sized,
        W: Write + ?Sized,
        L: Write + ?Sized,
    {
        while let Some(item) = source.next_frame() {
            if self
                .stop
                .as_ref()
                .is_some_and(|s| s.load(Ordering::Relaxed))
            {
                break;
            }
            let frame = match item {
                Ok(frame) => frame,
                Err(e) if e.is_recoverable() => {
                    self.pipeline.note_bad_line();
                    let n = self.pipeline.health().bad_lines;
                    if n <= BAD_LINES_SHOWN {
                        writeln!(log, "pumptwin-edge: skipped: {e}")?;
                    }
                    if n == BAD_LINES_SHOWN {
                        writeln!(log, "pumptwin-edge: further bad lines are only counted")?;
                    }
                    continue;
                }
                Err(e) => return Err(GatewayError::Source(e)),
            };
            self.pacer.wait_for(frame.ts_us);
            let t_frame = std::time::Instant::now();
            for window in self.pipeline.push(&frame).windows {
                self.emit(window, t_frame, out, log)?;
            }
        }
        // A frame held after a silence (pipeline docs) is decided and its windows
        // reported: nothing is left behind at the end of the input.
        let t_end = std::time::Instant::now();
        for window in self.pipeline.finish() {
            self.emit(window, t_end, out, log)?;
        }
        Ok(self.pipeline.health())
    }

    /// Diagnose, write and publish one window; `t_frame` is when the frame that
    /// completed it arrived (for the latency figures).
    fn emit<W, L>(
        &mut self,
        mut window: Window,
        t_frame: std::time::Instant,
        out: &mut W,
        log: &mut L,
    ) -> Result<(), GatewayError>
    where
        W: Write + ?Sized,
        L: Write + ?Sized,
    {
        let diagnosis = match self.diagnoser.as_mut() {
            Some(d) => Some(d.diagnose(&window)?),
            None => None,
        };
        if let (Some(n), Some(p), Some((m, class))) =
            (window.physics.0, &window.physics.1, &self.last_class)
        {
            if n == *m {
                window.warnings = crate::report::physics_warnings(n, class, p);
            }
        }
        self.last_class = diagnosis
            .as_ref()
            .and_then(|d| d.get("class")?.as_str())
            .map(|c| (window.index, c.to_string()));
        self.tally.add(&window, diagnosis.as_ref());
        let line = if self.human {
            crate::report::window_text(&window, diagnosis.as_ref())
        } else {
            window_json(&window, diagnosis.as_ref())?
        };
        out.write_all(line.as_bytes())?;
        out.write_all(b"\n")?;
        out.flush()?;
        self.latency.record(t_frame.elapsed());
        // Θ tracking and the physics run after the line is out: they never
        // delay a diagnosis.
        self.pipeline.track_pending();
        self.pipeline.diagnose_pending();
        if let Some(m) = &self.metrics {
            if let Ok(mut m) = m.lock() {
                m.health = window.health;
                m.publish_failures = self.publish_failures;
                m.latency_us = (
                    self.latency.quantile_us(0.5).unwrap_or(0),
                    self.latency.quantile_us(0.99).unwrap_or(0),
                );
            }
        }
        if let Some(p) = self.publisher.as_mut() {
            if let Err(e) = p(&window, diagnosis.as_ref()) {
                self.publish_failures += 1;
                if self.publish_failures <= BAD_LINES_SHOWN {
                    writeln!(
                        log,
                        "pumptwin-edge: publishing window {}: {e}",
                        window.index
                    )?;
                }
            }
        }
        Ok(())
    }
}
