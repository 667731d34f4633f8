//! A fixed-size ring of one channel's samples, addressed by absolute sample index.
//!
//! ```text
//! absolute index:  … valid_from … [written − N, written) …
//! slot of index i: i mod N
//! ```
//!
//! The ring remembers the last `N` samples pushed, which of them follow a
//! discontinuity (lost or dropped frames), and from which index on it holds real data
//! at all (`valid_from`: a channel that starts late or is re-aligned after a dropout
//! has nothing before it).

/// Ring of the last `N` samples of one channel.
#[derive(Debug, Clone)]
pub struct SampleRing<const N: usize> {
    samples: [f32; N],
    gap_before: [bool; N],
    written: u64,
    valid_from: u64,
}

impl<const N: usize> Default for SampleRing<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> SampleRing<N> {
    /// An empty ring at index 0.
    pub const fn new() -> Self {
        Self {
            samples: [0.0; N],
            gap_before: [false; N],
            written: 0,
            valid_from: 0,
        }
    }

    /// Absolute index of the next sample.
    pub fn written(&self) -> u64 {
        self.written
    }

    /// First absolute index holding real data.
    pub fn valid_from(&self) -> u64 {
        self.valid_from
    }

    /// Append one sample; `gap_before` marks a discontinuity just before it.
    pub fn push(&mut self, x: f32, gap_before: bool) {
        let slot = (self.written % N as u64) as usize;
        self.samples[slot] = x;
        self.gap_before[slot] = gap_before;
        self.written += 1;
    }

    /// Forget everything and continue at absolute index `index` (re-alignment after a
    /// dropout): nothing before `index` is valid.
    pub fn restart_at(&mut self, index: u64) {
        self.written = index;
        self.valid_from = index;
    }

    /// Whether `[start, start + len)` is all real data still held by the ring.
    pub fn covers(&self, start: u64, len: usize) -> bool {
        let end = start.saturating_add(len as u64);
        len <= N
            && start >= self.valid_from
            && end <= self.written
            && self.written - start <= N as u64
    }

    /// Copy `[start, start + out.len())` into `out`; `false` (and `out` untouched) when
    /// the ring does not [`cover`](Self::covers) it.
    pub fn copy_out(&self, start: u64, out: &mut [f32]) -> bool {
        if !self.covers(start, out.len()) {
            return false;
        }
        for (k, o) in out.iter_mut().enumerate() {
            *o = self.samples[((start + k as u64) % N as u64) as usize];
        }
        true
    }

    /// Whether a discontinuity lies inside `[start, start + len)` (one just before
    /// `start` does not count). Only meaningful where the ring covers the span.
    pub fn has_gap(&self, start: u64, len: usize) -> bool {
        (1..len as u64).any(|k| self.gap_before[((start + k) % N as u64) as usize])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_and_addresses_by_absolute_index() {
        let mut r = SampleRing::<8>::new();
        for i in 0..13 {
            r.push(i as f32, i == 10);
        }
        assert_eq!(r.written(), 13);
        assert!(r.covers(5, 8));
        assert!(!r.covers(4, 8), "index 4 was overwritten");
        assert!(!r.covers(6, 8), "index 13 not written yet");
        let mut out = [0.0; 4];
        assert!(r.copy_out(7, &mut out));
        assert_eq!(out, [7.0, 8.0, 9.0, 10.0]);
        assert!(r.has_gap(7, 4));
        assert!(
            !r.has_gap(10, 3),
            "a gap before the first sample is not inside"
        );
        assert!(!r.has_gap(5, 5));
    }

    #[test]
    fn restart_invalidates_the_past() {
        let mut r = SampleRing::<8>::new();
        for i in 0..6 {
            r.push(i as f32, false);
        }
        r.restart_at(100);
        assert!(!r.covers(100, 1));
        r.push(1.0, false);
        r.push(2.0, false);
        assert!(r.covers(100, 2));
        assert!(!r.covers(99, 2));
        assert_eq!(r.valid_from(), 100);
        let mut big = [0.0; 9];
        assert!(!r.copy_out(100, &mut big));
    }
}
