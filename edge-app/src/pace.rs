//! Replay pacing: as fast as possible, or following the log's timestamps.

use std::time::{Duration, Instant};

/// How fast a replay runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Speed {
    /// No waiting.
    Max,
    /// Sleep so that frames come out at the log's pace.
    Realtime,
}

/// Sleeps before each frame so that `ts_us − first ts_us` of log time has passed
/// since the first frame. When the log's clock steps back, the pacer re-anchors at
/// that frame instead of running free until the clock catches up.
#[derive(Debug, Clone)]
pub struct Pacer {
    speed: Speed,
    anchor: Option<(u64, Instant)>,
    last_ts_us: u64,
}

impl Pacer {
    /// A pacer at `speed`.
    pub fn new(speed: Speed) -> Self {
        Self {
            speed,
            anchor: None,
            last_ts_us: 0,
        }
    }

    /// The speed.
    pub fn speed(&self) -> Speed {
        self.speed
    }

    /// Wait until the frame stamped `ts_us` is due.
    pub fn wait_for(&mut self, ts_us: u64) {
        if self.speed == Speed::Max {
            return;
        }
        let now = Instant::now();
        let (t0, start) = match self.anchor {
            Some(a) if ts_us >= self.last_ts_us => a,
            _ => {
                self.anchor = Some((ts_us, now));
                (ts_us, now)
            }
        };
        self.last_ts_us = ts_us;
        let due = start.checked_add(Duration::from_micros(ts_us - t0));
        if let Some(wait) = due.and_then(|d| d.checked_duration_since(now)) {
            std::thread::sleep(wait);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn realtime_follows_the_timestamps() {
        let mut p = Pacer::new(Speed::Realtime);
        let t = Instant::now();
        for ts in [1_000_000, 1_020_000, 1_040_000, 1_000_000, 1_010_000] {
            p.wait_for(ts);
        }
        // 40 ms to the third frame; the step back re-anchors, then 10 ms more.
        let e = t.elapsed();
        assert!(e >= Duration::from_millis(50), "{e:?}");
        assert!(e < Duration::from_millis(2000), "{e:?}");
    }

    #[test]
    fn max_does_not_wait() {
        let mut p = Pacer::new(Speed::Max);
        let t = Instant::now();
        p.wait_for(0);
        p.wait_for(10_000_000);
        assert!(t.elapsed() < Duration::from_millis(500));
    }
}
