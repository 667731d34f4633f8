//! Dynamic sparse sensor graph (paper eqs. 1–3, §4.1).
//!
//! Node features `x[τ][i][k]` (step τ, node i, feature k; features z-scored by the
//! caller so that no one feature's unit dominates). For each step `t` and node pair
//! `(i, j)`, over the sliding window `τ ∈ [max(0, t−w+1), t]`:
//!
//! ```text
//! ρ_ij(t) = Σ_k Σ_τ (x_ik(τ) − x̄_i)(x_jk(τ) − x̄_j)
//!           / ( √(Σ_k Σ_τ (x_ik(τ) − x̄_i)²) · √(Σ_k Σ_τ (x_jk(τ) − x̄_j)²) )      (1)
//! D_ij(t) = ρ_ij(t) if ρ_ij(t) ≥ τ_corr, else 0                                  (2)
//! A_ij(t) = (1 − β)·D_ij(t) + β·P_ij          (static placement / physics prior P)
//! Ã(t)    = A(t) + I,   Â(t) = D̃^−1/2 Ã(t) D̃^−1/2,  D̃_ii = Σ_j Ã_ij             (3)
//! ```
//!
//! Choices, and why:
//! - `x̄_i` is node i's mean over all `D·w` entries of the window, as the paper's text
//!   says ("its mean within the window"). With per-feature means (`x̄_i,k`, as eq. 1's
//!   subscripts suggest) a window of one step would have zero variance everywhere and
//!   the first `w−1` steps would carry no dynamic edges at all; the whole-window mean
//!   makes ρ the similarity of the two nodes' feature profiles, defined for any `w ≥ 1`.
//! - Eq. 2 compares "ω_ij" with the threshold; ω is taken as ρ itself, so only strong
//!   *positive* coupling makes an edge. Negative weights would make degrees in eq. 3
//!   non-positive and the normalization undefined, so `D_ij = 0` for `ρ ≤ 0` even when
//!   `τ_corr < 0` (a configuration the model file allows).
//! - The prior `P` (symmetric, entries in [0, 1]) carries the sensor placement and,
//!   from the trainer, the simulated spectral correlation between nodes (eq. 9's
//!   physics embedding); `β` blends it with the measured correlation.
//! - Self-loops (`+ I`) keep every degree ≥ 1, so eq. 3 is always defined. A masked
//!   (missing) node keeps only its self-loop: it neither sends nor receives messages.

use crate::error::{expect_len, Error, Result};
use crate::math;

/// A normalized adjacency matrix `Â` of `N` nodes, row-major.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adjacency<const N: usize>(pub [[f32; N]; N]);

impl<const N: usize> Adjacency<N> {
    /// All zeros.
    pub const ZERO: Self = Self([[0.0; N]; N]);
}

impl<const N: usize> Default for Adjacency<N> {
    fn default() -> Self {
        Self::ZERO
    }
}

/// Which nodes carry data (`true`) in this window.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeMask<const N: usize>(pub [bool; N]);

impl<const N: usize> NodeMask<N> {
    /// Every node present.
    pub const ALL: Self = Self([true; N]);
    /// Number of present nodes.
    pub fn count(&self) -> usize {
        self.0.iter().filter(|&&m| m).count()
    }

    /// The nodes the DS-STGAT reads its diagnosis from (its attention pooling):
    /// the **source node** 0 — the sensor on the monitored bearing's housing — when it
    /// is present, every present node otherwise.
    ///
    /// Why not every node, as the paper's pooling over nodes: the other sensors
    /// reach the bearing through the structure, and their response moves with the
    /// operating point. On CWRU the fan-end response of the ball-fault records at
    /// 3 HP lies 5–7 σ outside what 0–2 HP showed (RMS, spectral bandwidth), toward
    /// the inner-race records, and a pooling that lets the fan-end node's state vote
    /// read those windows as inner-race faults. Read at the source node, the remote
    /// sensors still inform the diagnosis, through the graph attention (eqs. 4–6) of
    /// every step, which weighs what they send by content. Chosen on the development
    /// protocols (`docs/evaluation-cwru.md`, seventh round): score 89.9 → 91.8, the
    /// clean load shift 93.3 → 96.0 % and higher on every seed.
    pub fn readout(&self) -> Self {
        match self.0.first() {
            Some(true) => {
                let mut only = [false; N];
                only[0] = true;
                Self(only)
            }
            _ => *self,
        }
    }
}

/// Parameters of the graph construction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GraphConfig<const N: usize> {
    /// Static prior `P` (symmetric, entries in [0, 1]; the diagonal is ignored).
    pub prior: [[f32; N]; N],
    /// Blend weight `β` ∈ [0, 1] of the prior.
    pub prior_weight: f32,
    /// Sliding window `w` in steps (≥ 1).
    pub window_steps: usize,
    /// Correlation threshold `τ_corr` ∈ [−1, 1].
    pub tau_corr: f32,
}

impl<const N: usize> GraphConfig<N> {
    /// Fully connected uniform prior, β = 0.3, w = 3, τ_corr = 0.3.
    pub const fn uniform() -> Self {
        Self {
            prior: [[1.0; N]; N],
            prior_weight: 0.3,
            window_steps: 3,
            tau_corr: 0.3,
        }
    }

    /// A graph that ignores measured correlation: `β = 1`, the prior alone
    /// (the "static graph" ablation).
    pub const fn static_prior(prior: [[f32; N]; N]) -> Self {
        Self {
            prior,
            prior_weight: 1.0,
            window_steps: 1,
            tau_corr: 1.0,
        }
    }

    /// Check ranges and symmetry of the prior.
    pub fn validate(&self) -> Result<()> {
        if !(self.prior_weight.is_finite() && self.tau_corr.is_finite()) {
            return Err(Error::NonFinite);
        }
        if !(0.0..=1.0).contains(&self.prior_weight) || !(-1.0..=1.0).contains(&self.tau_corr) {
            return Err(Error::InvalidParameter(
                "prior weight in [0,1], tau_corr in [-1,1]",
            ));
        }
        if self.window_steps == 0 {
            return Err(Error::InvalidParameter("window_steps must be >= 1"));
        }
        for i in 0..N {
            for j in 0..N {
                let p = self.prior[i][j];
                if !p.is_finite() {
                    return Err(Error::NonFinite);
                }
                if !(0.0..=1.0).contains(&p) || (p - self.prior[j][i]).abs() > 1e-6 {
                    return Err(Error::InvalidParameter(
                        "prior must be symmetric with entries in [0,1]",
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Pearson correlation (eq. 1) of nodes `i` and `j` over steps `lo..=hi`.
/// Returns 0 when either node is constant over the window, and for arguments outside
/// `x` (`hi < lo`, `hi ≥ x.len()`, `i` or `j ≥ N`): never panics.
pub fn window_pearson<const N: usize, const D: usize>(
    x: &[[[f32; D]; N]],
    i: usize,
    j: usize,
    lo: usize,
    hi: usize,
) -> f32 {
    let Some(rows) = x.get(lo..=hi) else {
        return 0.0;
    };
    if i >= N || j >= N || rows.is_empty() {
        return 0.0;
    }
    let count = (rows.len() * D) as f64;
    let (mut si, mut sj) = (0.0f64, 0.0f64);
    for row in rows {
        for k in 0..D {
            si += f64::from(row[i][k]);
            sj += f64::from(row[j][k]);
        }
    }
    let (mi, mj) = (si / count, sj / count);
    let (mut cov, mut vi, mut vj) = (0.0f64, 0.0f64, 0.0f64);
    for row in rows {
        for k in 0..D {
            let a = f64::from(row[i][k]) - mi;
            let b = f64::from(row[j][k]) - mj;
            cov += a * b;
            vi += a * a;
            vj += b * b;
        }
    }
    if vi <= 1e-24 || vj <= 1e-24 {
        return 0.0;
    }
    (cov / (math::sqrt(vi) * math::sqrt(vj))) as f32
}

/// Build `Â(t)` for every step: `out.len() == x.len() == T`.
///
/// # Errors
/// Bad configuration, non-finite features of a present node, length mismatch.
pub fn build_dynamic_graphs<const N: usize, const D: usize>(
    cfg: &GraphConfig<N>,
    x: &[[[f32; D]; N]],
    mask: &NodeMask<N>,
    out: &mut [Adjacency<N>],
) -> Result<()> {
    cfg.validate()?;
    expect_len(out.len(), x.len())?;
    for row in x {
        for (i, node) in row.iter().enumerate() {
            if mask.0[i] && node.iter().any(|v| !v.is_finite()) {
                return Err(Error::NonFinite);
            }
        }
    }
    let beta = cfg.prior_weight;
    for (t, adj) in out.iter_mut().enumerate() {
        let lo = (t + 1).saturating_sub(cfg.window_steps);
        let mut a = [[0.0f32; N]; N];
        for i in 0..N {
            if !mask.0[i] {
                a[i][i] = 1.0;
                continue;
            }
            a[i][i] = 1.0;
            for j in (i + 1)..N {
                if !mask.0[j] {
                    continue;
                }
                let rho = if beta < 1.0 {
                    window_pearson(x, i, j, lo, t)
                } else {
                    0.0
                };
                // Only positive coupling is an edge, whatever τ_corr (a τ_corr < 0
                // would otherwise let a negative ρ in: degrees < 1 or ≤ 0, eq. 3
                // undefined; found by the property tests, RELIABILITY.md).
                let dynamic = if rho >= cfg.tau_corr && rho > 0.0 {
                    rho
                } else {
                    0.0
                };
                let w = (1.0 - beta) * dynamic + beta * cfg.prior[i][j];
                a[i][j] = w;
                a[j][i] = w;
            }
        }
        normalize_symmetric(&mut a);
        adj.0 = a;
    }
    Ok(())
}

/// `Â = D^−1/2 A D^−1/2` in place (eq. 3); `A` must already hold its self-loops.
pub fn normalize_symmetric<const N: usize>(a: &mut [[f32; N]; N]) {
    let mut inv_sqrt_deg = [0.0f32; N];
    for (i, d) in inv_sqrt_deg.iter_mut().enumerate() {
        let deg: f32 = a[i].iter().sum();
        *d = if deg > 0.0 {
            1.0 / math::sqrtf(deg)
        } else {
            0.0
        };
    }
    for i in 0..N {
        for j in 0..N {
            a[i][j] *= inv_sqrt_deg[i] * inv_sqrt_deg[j];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Xoshiro128pp;
    use std::vec::Vec;

    const N: usize = 4;
    const D: usize = 6;

    #[test]
    fn the_readout_is_the_source_node_when_present() {
        let all = NodeMask::<3>([true, true, true]);
        assert_eq!(all.readout(), NodeMask([true, false, false]));
        let no_ba = NodeMask::<3>([true, true, false]);
        assert_eq!(no_ba.readout(), NodeMask([true, false, false]));
        // Source sensor lost: every node that is left.
        let no_source = NodeMask::<3>([false, true, true]);
        assert_eq!(no_source.readout(), no_source);
        let none = NodeMask::<3>([false; 3]);
        assert_eq!(none.readout(), none);
        assert_eq!(NodeMask::<0>([]).readout(), NodeMask([]));
    }

    fn random_features(t: usize, seed: u64) -> Vec<[[f32; D]; N]> {
        let mut r = Xoshiro128pp::seed_from_u64(seed);
        (0..t)
            .map(|_| {
                let mut step = [[0.0f32; D]; N];
                let base: [f64; D] = core::array::from_fn(|_| r.normal());
                for (i, node) in step.iter_mut().enumerate() {
                    for (k, v) in node.iter_mut().enumerate() {
                        // Nodes 0 and 1 share structure; 2 and 3 are mostly noise.
                        let shared = if i < 2 { base[k] } else { 0.2 * base[k] };
                        *v = (shared + 0.4 * r.normal()) as f32;
                    }
                }
                step
            })
            .collect()
    }

    /// A plain f64 implementation of eqs. 1–3, written independently of the kernel.
    fn reference(
        cfg: &GraphConfig<N>,
        x: &[[[f32; D]; N]],
        mask: &[bool; N],
        t: usize,
    ) -> [[f64; N]; N] {
        let lo = (t + 1).saturating_sub(cfg.window_steps);
        let mut a = [[0.0f64; N]; N];
        for i in 0..N {
            for j in 0..N {
                if i == j {
                    a[i][j] = 1.0;
                    continue;
                }
                if !(mask[i] && mask[j]) {
                    continue;
                }
                let xi: Vec<f64> = x[lo..=t]
                    .iter()
                    .flat_map(|s| s[i].iter().map(|&v| f64::from(v)))
                    .collect();
                let xj: Vec<f64> = x[lo..=t]
                    .iter()
                    .flat_map(|s| s[j].iter().map(|&v| f64::from(v)))
                    .collect();
                let mi = xi.iter().sum::<f64>() / xi.len() as f64;
                let mj = xj.iter().sum::<f64>() / xj.len() as f64;
                let cov: f64 = xi.iter().zip(&xj).map(|(a, b)| (a - mi) * (b - mj)).sum();
                let vi: f64 = xi.iter().map(|a| (a - mi).powi(2)).sum();
                let vj: f64 = xj.iter().map(|b| (b - mj).powi(2)).sum();
                let rho = cov / (vi.sqrt() * vj.sqrt());
                let dynamic = if rho >= f64::from(cfg.tau_corr) {
                    rho
                } else {
                    0.0
                };
                let beta = f64::from(cfg.prior_weight);
                a[i][j] = (1.0 - beta) * dynamic + beta * f64::from(cfg.prior[i][j]);
            }
        }
        let deg: Vec<f64> = a.iter().map(|r| r.iter().sum()).collect();
        let mut out = [[0.0f64; N]; N];
        for i in 0..N {
            for j in 0..N {
                out[i][j] = a[i][j] / (deg[i] * deg[j]).sqrt();
            }
        }
        out
    }

    #[test]
    fn matches_plain_reference() {
        let x = random_features(8, 3);
        let mut prior = [[0.5f32; N]; N];
        prior[0][3] = 0.0;
        prior[3][0] = 0.0;
        let cfg = GraphConfig {
            prior,
            prior_weight: 0.25,
            window_steps: 3,
            tau_corr: 0.2,
        };
        for mask in [[true; N], [true, true, false, true]] {
            let mut out = [Adjacency::<N>::ZERO; 8];
            build_dynamic_graphs(&cfg, &x, &NodeMask(mask), &mut out).unwrap();
            for t in 0..8 {
                let want = reference(&cfg, &x, &mask, t);
                for i in 0..N {
                    for j in 0..N {
                        let got = f64::from(out[t].0[i][j]);
                        assert!(
                            (got - want[i][j]).abs() < 1e-6,
                            "t {t} ({i},{j}): {got} vs {}",
                            want[i][j]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn invariants_symmetric_normalized_self_loops() {
        let x = random_features(8, 5);
        let cfg = GraphConfig::<N>::uniform();
        let mut out = [Adjacency::<N>::ZERO; 8];
        build_dynamic_graphs(&cfg, &x, &NodeMask::ALL, &mut out).unwrap();
        for adj in &out {
            for i in 0..N {
                assert!(adj.0[i][i] > 0.0, "self-loop");
                for j in 0..N {
                    assert_eq!(adj.0[i][j], adj.0[j][i]);
                    assert!((0.0..=1.0).contains(&adj.0[i][j]));
                }
            }
        }
        // Correlated nodes 0 and 1 are linked more strongly than 0 and 3.
        assert!(out[7].0[0][1] > out[7].0[0][3]);
    }

    #[test]
    fn masked_node_is_isolated_and_its_garbage_ignored() {
        let mut x = random_features(4, 8);
        for step in x.iter_mut() {
            step[2] = [f32::NAN; D];
        }
        let cfg = GraphConfig::<N>::uniform();
        let mut out = [Adjacency::<N>::ZERO; 4];
        let mask = NodeMask([true, true, false, true]);
        build_dynamic_graphs(&cfg, &x, &mask, &mut out).unwrap();
        for adj in &out {
            assert_eq!(adj.0[2], [0.0, 0.0, 1.0, 0.0]);
        }
        // Unmasked NaN is an error.
        assert_eq!(
            build_dynamic_graphs(&cfg, &x, &NodeMask::ALL, &mut out),
            Err(Error::NonFinite)
        );
    }

    #[test]
    fn threshold_removes_weak_edges_and_static_ignores_data() {
        let x = random_features(6, 1);
        let strict = GraphConfig {
            prior: [[0.0; N]; N],
            prior_weight: 0.0,
            window_steps: 6,
            tau_corr: 0.99,
        };
        let mut out = [Adjacency::<N>::ZERO; 6];
        build_dynamic_graphs(&strict, &x, &NodeMask::ALL, &mut out).unwrap();
        for i in 0..N {
            for j in 0..N {
                let want = if i == j { 1.0 } else { 0.0 };
                assert_eq!(out[5].0[i][j], want);
            }
        }
        let stat = GraphConfig::static_prior([[1.0; N]; N]);
        build_dynamic_graphs(&stat, &x, &NodeMask::ALL, &mut out).unwrap();
        assert!(out.iter().all(|a| a.0 == out[0].0));
        assert!((out[0].0[0][1] - 0.25).abs() < 1e-6);
    }

    #[test]
    fn rejects_bad_config() {
        let x = random_features(2, 1);
        let mut out = [Adjacency::<N>::ZERO; 2];
        let mut cfg = GraphConfig::<N>::uniform();
        cfg.prior[0][1] = 0.2; // asymmetric
        assert!(build_dynamic_graphs(&cfg, &x, &NodeMask::ALL, &mut out).is_err());
        let cfg = GraphConfig::<N> {
            window_steps: 0,
            ..GraphConfig::uniform()
        };
        assert!(build_dynamic_graphs(&cfg, &x, &NodeMask::ALL, &mut out).is_err());
        let mut short = [Adjacency::<N>::ZERO; 1];
        assert!(
            build_dynamic_graphs(&GraphConfig::uniform(), &x, &NodeMask::ALL, &mut short).is_err()
        );
    }

    /// `window_pearson` is public: arguments outside `x` give 0, never a panic.
    #[test]
    fn window_pearson_outside_the_window_is_zero() {
        let x = random_features(4, 3);
        assert_eq!(window_pearson(&x, 0, 1, 3, 2), 0.0); // hi < lo
        assert_eq!(window_pearson(&x, 0, 1, 0, 4), 0.0); // hi past the end
        assert_eq!(window_pearson(&x, 0, N, 0, 3), 0.0); // node out of range
        assert_eq!(window_pearson(&x, 0, 1, usize::MAX, usize::MAX), 0.0);
        assert!(window_pearson(&x, 0, 1, 0, 3).abs() > 0.0);
    }

    /// Regression (property test, RELIABILITY.md): with `τ_corr < 0` an anti-correlated
    /// pair made a negative edge, a degree below 1 and `Â_ii > 1` (or a node with no
    /// self-loop at all). Only positive ρ is an edge, whatever τ.
    #[test]
    fn negative_correlation_is_no_edge_even_with_a_negative_threshold() {
        let mut x = [[[0.0f32; 2]; 2]; 3];
        for (t, step) in x.iter_mut().enumerate() {
            let v = t as f32 + 1.0;
            step[0] = [v, -v];
            step[1] = [-v, v];
        }
        let cfg = GraphConfig {
            prior: [[0.0; 2]; 2],
            prior_weight: 0.0,
            window_steps: 3,
            tau_corr: -1.0,
        };
        let mut out = [Adjacency::<2>::ZERO; 3];
        build_dynamic_graphs(&cfg, &x, &NodeMask::ALL, &mut out).unwrap();
        for a in &out {
            assert_eq!(a.0, [[1.0, 0.0], [0.0, 1.0]]);
        }
    }
}
