//! Records → windows → the core's node features and dynamic graphs.
//!
//! The windows are cut by [`crate::windows`]; every number here comes from
//! `pumptwin_core` (features, normalization, graph), the same code the edge runs.

use crate::recording::Recording;
use pumptwin_core::bearing::DefectOrders;
use pumptwin_core::features::{
    node_features, FeatureConfig, FeatureNorm, FeatureScratch, FEATURE_DIM,
};
use pumptwin_core::graph::{build_dynamic_graphs, Adjacency, GraphConfig, NodeMask};

/// Samples per window and graph steps per window: the core's layout, which the edge
/// and the firmware read too.
pub use pumptwin_core::layout::{SEGMENTS, WINDOW};

/// Node features of one window: `[T][N][F]`, plus which nodes are present.
#[derive(Debug, Clone, PartialEq)]
pub struct WindowFeatures<const N: usize> {
    /// First sample of the window in its record.
    pub start: usize,
    /// `features[t][i]`: feature row of node `i` in segment `t` (raw, not normalized).
    pub features: [[[f32; FEATURE_DIM]; N]; SEGMENTS],
    /// Present nodes (missing channel, dead or non-finite window → absent).
    pub mask: NodeMask<N>,
}

/// Why a node was masked in a window (counted, never silently dropped).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct MaskCounts {
    /// The record has no such channel.
    pub missing_channel: usize,
    /// A segment was constant (dead sensor) or the signal non-finite.
    pub rejected_signal: usize,
}

/// The feature configuration for a record at shaft rate `shaft_hz`: the core's
/// [`FeatureConfig::standard`], the one the edge uses too.
pub fn feature_config(fs_hz: f32, shaft_hz: f32, orders: DefectOrders) -> FeatureConfig {
    FeatureConfig::standard(fs_hz, shaft_hz, orders)
}

/// Features of the windows starting at `starts` for nodes named `nodes`.
pub fn window_features<const N: usize>(
    rec: &Recording,
    nodes: &[&str; N],
    cfg: &FeatureConfig,
    starts: &[usize],
    counts: &mut MaskCounts,
) -> Vec<WindowFeatures<N>> {
    let mut scratch = Box::new(FeatureScratch::<WINDOW>::new());
    let channels: Vec<Option<&[f32]>> = nodes
        .iter()
        .map(|name| rec.channel(name).map(|c| c.samples.as_slice()))
        .collect();
    let mut rows = [[0.0f32; FEATURE_DIM]; SEGMENTS];
    let mut out = Vec::with_capacity(starts.len());
    for &start in starts {
        let mut w = WindowFeatures {
            start,
            features: [[[0.0; FEATURE_DIM]; N]; SEGMENTS],
            mask: NodeMask([true; N]),
        };
        for (i, ch) in channels.iter().enumerate() {
            let Some(x) = ch.and_then(|c| c.get(start..start + WINDOW)) else {
                w.mask.0[i] = false;
                counts.missing_channel += 1;
                continue;
            };
            let x: &[f32; WINDOW] = x.try_into().expect("slice has WINDOW samples");
            match node_features(x, cfg, &mut scratch, &mut rows) {
                Ok(()) => {
                    for t in 0..SEGMENTS {
                        w.features[t][i] = rows[t];
                    }
                }
                Err(_) => {
                    w.mask.0[i] = false;
                    counts.rejected_signal += 1;
                }
            }
        }
        out.push(w);
    }
    out
}

/// Fit a [`FeatureNorm`] on the present nodes of `windows` (mean and std per feature;
/// a feature with zero spread gets std 1).
pub fn fit_norm<const N: usize>(windows: &[WindowFeatures<N>]) -> FeatureNorm {
    let mut n = 0.0f64;
    let mut sum = [0.0f64; FEATURE_DIM];
    let mut sq = [0.0f64; FEATURE_DIM];
    for w in windows {
        for step in &w.features {
            for (i, row) in step.iter().enumerate() {
                if !w.mask.0[i] {
                    continue;
                }
                n += 1.0;
                for k in 0..FEATURE_DIM {
                    let v = f64::from(row[k]);
                    sum[k] += v;
                    sq[k] += v * v;
                }
            }
        }
    }
    let mut mean = [0.0f32; FEATURE_DIM];
    let mut std = [1.0f32; FEATURE_DIM];
    if n > 0.0 {
        for k in 0..FEATURE_DIM {
            let m = sum[k] / n;
            let var = (sq[k] / n - m * m).max(0.0);
            mean[k] = m as f32;
            std[k] = if var > 1e-12 { var.sqrt() as f32 } else { 1.0 };
        }
    }
    FeatureNorm::new(mean, std).unwrap_or(FeatureNorm::IDENTITY)
}

/// Normalized node features of one window, `[T][N][F]`.
pub type NodeSequence<const N: usize> = [[[f32; FEATURE_DIM]; N]; SEGMENTS];

/// Normalized features and the dynamic graph sequence of one window.
pub fn window_graphs<const N: usize>(
    w: &WindowFeatures<N>,
    norm: &FeatureNorm,
    graph: &GraphConfig<N>,
) -> Result<(NodeSequence<N>, [Adjacency<N>; SEGMENTS]), pumptwin_core::Error> {
    let mut x = w.features;
    for step in x.iter_mut() {
        for (i, row) in step.iter_mut().enumerate() {
            if w.mask.0[i] {
                norm.apply(row);
            } else {
                *row = [0.0; FEATURE_DIM];
            }
        }
    }
    let mut a = [Adjacency::<N>::ZERO; SEGMENTS];
    build_dynamic_graphs(graph, &x, &w.mask, &mut a)?;
    Ok((x, a))
}
