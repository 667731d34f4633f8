//! Order statistics without a panic path: quickselect of the `k`-th smallest value and
//! the median of a spectrum's bins, in place on caller-owned buffers.

/// Median of the bins `1..=k_hi` of a spectrum (DC skipped; the features pass the
/// envelope spectrum), computed in `work` (no allocation).
pub(crate) fn median_level(spectrum: &[f32], k_hi: usize, work: &mut [f32]) -> f32 {
    let k_hi = k_hi.min(spectrum.len().saturating_sub(1)).min(work.len());
    let (Some(w), Some(bins)) = (work.get_mut(..k_hi), spectrum.get(1..=k_hi)) else {
        return 0.0;
    };
    if k_hi == 0 {
        return 0.0;
    }
    for (d, &s) in w.iter_mut().zip(bins) {
        *d = s;
    }
    select_nth(w, k_hi / 2).unwrap_or(0.0)
}

/// The `k`-th smallest value of `w` by `f32::total_cmp` (the value
/// `select_nth_unstable_by(k, total_cmp)` returns), reordering `w`; `None` for
/// `k ≥ w.len()`.
///
/// Quickselect with a median-of-three pivot and a three-way partition (runs of equal
/// values, e.g. the all-zero spectrum of a silent sensor, cost one pass), written
/// with checked accesses so that no panic path remains: core's `select_nth_unstable`
/// keeps bounds checks the optimiser cannot remove (RELIABILITY.md, "no panic path").
pub(crate) fn select_nth(w: &mut [f32], k: usize) -> Option<f32> {
    use core::cmp::Ordering::{Equal, Greater, Less};
    let (mut lo, mut hi) = (0usize, w.len());
    if k >= hi {
        return None;
    }
    loop {
        // Invariant: lo ≤ k < hi ≤ w.len(), and w[lo..hi] holds the k-th smallest.
        let seg = w.get_mut(lo..hi)?;
        let n = seg.len();
        let (a, b, c) = (*seg.first()?, *seg.get(n / 2)?, *seg.last()?);
        let pivot = if a.total_cmp(&b).is_lt() {
            if b.total_cmp(&c).is_lt() {
                b
            } else if a.total_cmp(&c).is_lt() {
                c
            } else {
                a
            }
        } else if a.total_cmp(&c).is_lt() {
            a
        } else if b.total_cmp(&c).is_lt() {
            c
        } else {
            b
        };
        // seg[..lt] < pivot, seg[lt..i] == pivot, seg[gt..] > pivot.
        let (mut lt, mut i, mut gt) = (0usize, 0usize, n);
        while i < gt {
            match seg.get(i)?.total_cmp(&pivot) {
                Less => {
                    swap_checked(seg, lt, i);
                    lt += 1;
                    i += 1;
                }
                Greater => {
                    gt -= 1;
                    swap_checked(seg, i, gt);
                }
                Equal => i += 1,
            }
        }
        let r = k - lo;
        if r < lt {
            hi = lo + lt;
        } else if r < gt {
            return Some(pivot);
        } else {
            lo += gt;
        }
    }
}

/// `s.swap(i, j)` when both are in bounds (always, at the call sites above).
fn swap_checked(s: &mut [f32], i: usize, j: usize) {
    if i < s.len() && j < s.len() {
        s.swap(i, j);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro128pp;
    use std::vec::Vec;

    /// `select_nth` (the panic-free median of `median_level`) returns exactly what
    /// core's `select_nth_unstable_by(k, total_cmp)` does, ties, NaN and ±0 included.
    #[test]
    fn select_nth_agrees_with_core_select() {
        let mut r = Xoshiro128pp::seed_from_u64(5);
        let mut cases: Vec<Vec<f32>> = std::vec![
            std::vec![0.0; 1024],
            (0..513).map(|i| i as f32).collect(),
            (0..513).rev().map(|i| i as f32).collect(),
            std::vec![3.0, f32::NAN, -0.0, 0.0, f32::INFINITY, -1.0, 3.0],
            std::vec![1.0],
            std::vec![2.0, 1.0],
        ];
        for n in [3usize, 10, 101, 1000] {
            cases.push((0..n).map(|_| (r.normal() * 4.0).round() as f32).collect());
            cases.push((0..n).map(|_| r.normal() as f32).collect());
        }
        for case in &cases {
            for k in [0, case.len() / 2, case.len() - 1] {
                let mut a = case.clone();
                let mut b = case.clone();
                let got = select_nth(&mut a, k).unwrap();
                let (_, want, _) = b.select_nth_unstable_by(k, |x, y| x.total_cmp(y));
                assert_eq!(got.to_bits(), want.to_bits(), "k = {k} of {case:?}");
            }
            assert_eq!(select_nth(&mut case.clone(), case.len()), None);
        }
        assert_eq!(median_level(&[], 10, &mut [0.0; 4]), 0.0);
        assert_eq!(median_level(&[1.0, 2.0, 3.0], 10, &mut []), 0.0);
    }
}
