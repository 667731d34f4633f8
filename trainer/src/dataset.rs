//! Training data for the DS-STGAT: every window of a protocol's split as the core's
//! normalized node features, dynamic graphs, node mask and physical-indicator targets.
//!
//! The order of work (nothing is cached on disk):
//!
//! ```text
//! MANIFEST.tsv → load every record → preprocess (model rate, common band limit)
//!   → build_split(protocol) (leak-free, verified)
//!   → raw node features per window          featurize::window_features (core)
//!   → FeatureNorm fitted on TRAIN windows    featurize::fit_norm
//!   → normalized x and graphs A_1..A_T       featurize::window_graphs (core, eqs. 1-3)
//!   → indicator targets (eq. 13), z-scored with TRAIN statistics
//! ```
//!
//! The test side is normalized with the train side's statistics, never its own.
//! [`featurize_windows`] takes an optional [`NoiseSpec`] so the noise-robustness
//! evaluation ([`crate::metrics`]) recomputes features and graphs from noisy signals
//! through exactly the same path.
//!
//! # Shapes (per side, `W` windows, row-major)
//! - `x`: `[W, T, N, F]` normalized node features (`T` = 8 steps, `N` = 3 nodes
//!   DE/FE/BA, `F` = 28 features); an absent node's rows are 0
//! - `adj`: `[W, T, N, N]` the core's normalized adjacency `Â_t` (row `i` = neighbours
//!   of node `i`; an absent node keeps only its self-loop)
//! - `mask`: `[W, N]` present nodes (the normal record 97 has no BA channel)
//! - `indicators`: `[W, 4]` z-scored targets of the indicator head, see
//!   [`indicator_targets`]
//! - `label`, `record`: `[W]`
//! - `raw`: `[W, N, 2048]` the window's band-limited samples at the model rate (0 for an
//!   absent node): the input of the raw-signal baselines (WDCNN, CoFusion-CNN, TST)
//! - `spectra`: `[W, N, 16]` each node's spectrum shape ([`crate::targets::spectrum_shape`],
//!   0 for an absent node): the target of the spectral consistency head (eq. 11)
//! - `theta`: `[W, 4]` the record's fitted Θ_phys, z-scored (`NaN` where unknown):
//!   F_map's target (eqs. 23–24), filled by [`Dataset::attach_theta`]

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::Instant;

use pumptwin_core::bearing::BearingGeometry;
use pumptwin_core::features::{
    band_share, feature_index, FeatureNorm, FEATURE_DIM, SPECTRAL_BANDS,
};
use pumptwin_core::graph::{Adjacency, GraphConfig};
use pumptwin_core::rng::Xoshiro128pp;

use crate::targets::{spectrum_shape, Theta, N_THETA, SPEC_BANDS};
use pumptwin_data::entry::{load_entry, EntryError};
use pumptwin_data::featurize::{
    feature_config, fit_norm, window_features, window_graphs, MaskCounts, WindowFeatures, SEGMENTS,
    WINDOW,
};
use pumptwin_data::manifest::{read_manifest, ManifestEntry, ManifestError};
use pumptwin_data::preprocess::MODEL_FS_HZ;
use pumptwin_data::preprocess::{preprocess, PreprocessConfig};
use pumptwin_data::recording::{Channel, Recording};
use pumptwin_data::windows::{build_split, Protocol, RecordMeta, Split, SplitError, WindowConfig};
use pumptwin_data::WindowRef;

/// Node channels, in node order, and their number: the measured sensors (the core's
/// layout, the one the int8 model file and the edge run).
pub use pumptwin_core::layout::{NODE_NAMES as NODES, N_NODES};
/// The measured nodes plus the paper's derived temperature and pressure nodes
/// (section 6.2, [`pumptwin_data::derived`]): the `--nodes derived` option.
pub const DERIVED_NODES: [&str; N_DERIVED_NODES] = [
    "DE",
    "FE",
    "BA",
    pumptwin_data::derived::TEMP,
    pumptwin_data::derived::PRES,
];
/// Number of graph nodes with the derived nodes.
pub const N_DERIVED_NODES: usize = 5;

/// Which nodes a model sees.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum NodeSet {
    /// The measured DE, FE, BA channels (`NODES`).
    Measured,
    /// The measured channels plus derived temperature and pressure
    /// (`DERIVED_NODES`); float models only, reported separately.
    Derived,
}

impl NodeSet {
    /// Number of nodes.
    pub fn count(self) -> usize {
        match self {
            Self::Measured => N_NODES,
            Self::Derived => N_DERIVED_NODES,
        }
    }
}
/// Graph steps per window (`T`).
pub const STEPS: usize = SEGMENTS;
/// Features per node and step (`F`).
pub const FEATURES: usize = FEATURE_DIM;
/// Physical indicators of the indicator head (eq. 13).
pub const N_INDICATORS: usize = 4;
/// Names of the indicators, in output order (the core's, which the edge reads back).
pub const INDICATOR_NAMES: [&str; N_INDICATORS] = pumptwin_core::model_file::INDICATOR_NAMES;

/// Index of `rms` in a feature row.
const RMS: usize = feature_index("rms");
/// Index of `env_kurtosis` (the impact intensity) in a feature row.
const ENV_KURTOSIS: usize = feature_index("env_kurtosis");
/// Index of `band_db_01` (the other band shares follow it).
const BAND_DB_01: usize = feature_index("band_db_01");

/// Errors building a data set.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// The manifest could not be read.
    #[error(transparent)]
    Manifest(#[from] ManifestError),
    /// A listed record cannot be used.
    #[error(transparent)]
    Entry(#[from] EntryError),
    /// Neither the file nor the manifest gives the shaft speed.
    #[error("record {label}: shaft speed unknown (no RPM in the file or the manifest)")]
    NoSpeed {
        /// CWRU label.
        label: String,
    },
    /// The split could not be built or failed its leak check.
    #[error(transparent)]
    Split(#[from] SplitError),
    /// The core refused a window's graph construction.
    #[error("record {record}, window at {start}: graph construction failed: {source:?}")]
    Graph {
        /// Record index.
        record: usize,
        /// Window start.
        start: usize,
        /// The core's error.
        source: pumptwin_core::Error,
    },
    /// The split has no training windows.
    #[error("protocol {0}: the split has no training windows")]
    EmptyTrain(Protocol),
}

/// One manifest record, preprocessed.
#[derive(Debug, Clone)]
pub struct CorpusRecord {
    /// Its manifest entry.
    pub entry: ManifestEntry,
    /// At the model rate with the common band limit.
    pub rec: Recording,
    /// Shaft rate in Hz (the file's RPM, else the manifest's, / 60).
    pub shaft_hz: f32,
}

/// Every record of a data directory, preprocessed, in manifest order.
#[derive(Debug, Clone)]
pub struct Corpus {
    /// The data directory.
    pub data_dir: PathBuf,
    /// Records in manifest order (indices are the split's record indices).
    pub records: Vec<CorpusRecord>,
    /// Seconds spent loading and preprocessing.
    pub load_seconds: f64,
}

impl Corpus {
    /// Load and preprocess every record listed in `data_dir/MANIFEST.tsv`.
    pub fn load(data_dir: &Path, preprocess_cfg: &PreprocessConfig) -> Result<Self, DatasetError> {
        let t0 = Instant::now();
        let entries = read_manifest(data_dir)?;
        let mut records = Vec::with_capacity(entries.len());
        for entry in entries {
            let raw = load_entry(&entry)?;
            let rec = preprocess(&raw, preprocess_cfg)
                .map_err(|source| EntryError::preprocess(&entry, source))?;
            let rpm = rec
                .rpm
                .or(entry.rpm_recorded)
                .ok_or_else(|| DatasetError::NoSpeed {
                    label: entry.label.clone(),
                })?;
            records.push(CorpusRecord {
                shaft_hz: rpm / 60.0,
                entry,
                rec,
            });
        }
        Ok(Self {
            data_dir: data_dir.to_path_buf(),
            records,
            load_seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// What the splits need to know about each record.
    pub fn metas(&self) -> Vec<RecordMeta> {
        self.records
            .iter()
            .map(|r| RecordMeta::from_entry(&r.entry, r.rec.len()))
            .collect()
    }

    /// The protocol's split, checked leak-free and in bounds.
    pub fn split(&self, protocol: Protocol, windows: &WindowConfig) -> Result<Split, DatasetError> {
        let split = build_split(protocol, &self.metas(), windows)?;
        split.verify_disjoint()?;
        let lens: Vec<usize> = self.records.iter().map(|r| r.rec.len()).collect();
        split.verify_bounds(&lens)?;
        Ok(split)
    }
}

/// White Gaussian noise added to each window of each channel before featurization:
/// `x + σ·n`, `n ~ N(0, 1)`, `σ² = mean(x²) · 10^(−snr_db/10)` with `mean(x²)` the
/// power of that channel within that window (so the SNR holds per window).
///
/// The noise is added at the model rate, after the common band limit: it is white up
/// to the model's Nyquist frequency, as sensor and ADC noise in the band would be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseSpec {
    /// Signal-to-noise ratio in dB.
    pub snr_db: f32,
    /// Seed of the noise (each window draws from `seed` mixed with its position).
    pub seed: u64,
}

/// Raw node features of `windows` (in their order), computed by the core on the
/// corpus' signals (noisy ones if `noise` is given). Masked nodes are counted in
/// `counts`.
pub fn featurize_windows<const N: usize>(
    corpus: &Corpus,
    windows: &[(WindowRef, usize)],
    nodes: &[&'static str; N],
    noise: Option<NoiseSpec>,
    counts: &mut MaskCounts,
) -> (Vec<WindowFeatures<N>>, Vec<f32>) {
    let orders = BearingGeometry::CWRU_6205_DE.orders();
    let records: BTreeSet<usize> = windows.iter().map(|(w, _)| w.record).collect();
    let mut out: Vec<Option<WindowFeatures<N>>> = vec![None; windows.len()];
    let rw = N * WINDOW;
    let mut raw = vec![0.0f32; windows.len() * rw];
    let derive = pumptwin_data::derived::any_derived(nodes);
    for record in records {
        let r = &corpus.records[record];
        let cfg = feature_config(r.rec.fs_hz, r.shaft_hz, orders);
        let positions: Vec<usize> = (0..windows.len())
            .filter(|&k| windows[k].0.record == record)
            .collect();
        let copy_raw = |rec: &Recording, starts: &[usize], raw: &mut [f32]| {
            for (&k, &start) in positions.iter().zip(starts) {
                copy_window_samples(rec, nodes, start, &mut raw[k * rw..(k + 1) * rw]);
            }
        };
        let features = if noise.is_none() && !derive {
            let starts: Vec<usize> = positions.iter().map(|&k| windows[k].0.start).collect();
            copy_raw(&r.rec, &starts, &mut raw);
            window_features(&r.rec, nodes, &cfg, &starts, counts)
        } else {
            // The windows (noisy, with derived nodes, as asked) laid end to end in a
            // scratch recording.
            let scratch = window_recording(&r.rec, windows, &positions, noise, derive);
            let starts: Vec<usize> = (0..positions.len()).map(|k| k * WINDOW).collect();
            copy_raw(&scratch, &starts, &mut raw);
            let mut f = window_features(&scratch, nodes, &cfg, &starts, counts);
            for (w, &k) in f.iter_mut().zip(&positions) {
                w.start = windows[k].0.start;
            }
            f
        };
        for (w, &k) in features.into_iter().zip(&positions) {
            out[k] = Some(w);
        }
    }
    let features = out
        .into_iter()
        .map(|w| w.expect("every window belongs to a record"))
        .collect();
    (features, raw)
}

/// The samples of each node's channel (`nodes`, in order) in the window starting at
/// `start`, node after node, into `out` (`[N, WINDOW]`); a missing channel's part is
/// left as it is.
pub fn copy_window_samples(rec: &Recording, nodes: &[&str], start: usize, out: &mut [f32]) {
    for (i, name) in nodes.iter().enumerate() {
        let src = rec
            .channel(name)
            .and_then(|c| c.samples.get(start..start + WINDOW));
        if let (Some(x), Some(dst)) = (src, out.get_mut(i * WINDOW..(i + 1) * WINDOW)) {
            dst.copy_from_slice(x);
        }
    }
}

/// A recording holding the windows at `positions` end to end, each with noise at
/// `noise.snr_db` relative to its own power per channel (if any), and with the derived
/// nodes computed from each window's own (noisy) samples if `derive`.
fn window_recording(
    rec: &Recording,
    windows: &[(WindowRef, usize)],
    positions: &[usize],
    noise: Option<NoiseSpec>,
    derive: bool,
) -> Recording {
    match noise {
        Some(spec) => {
            let mut out = noisy_windows(rec, windows, positions, spec);
            if derive {
                pumptwin_data::derived::append_channels(&mut out, WINDOW);
            }
            out
        }
        None => {
            let starts: Vec<usize> = positions.iter().map(|&k| windows[k].0.start).collect();
            windows_end_to_end(rec, &starts, derive)
        }
    }
}

/// A recording holding the windows of `rec` starting at `starts` end to end (window
/// `k` at `k·WINDOW`), with the derived nodes ([`pumptwin_data::derived`]) computed from each
/// window's own samples if `derive`.
pub fn windows_end_to_end(rec: &Recording, starts: &[usize], derive: bool) -> Recording {
    let mut out = Recording {
        name: rec.name.clone(),
        fs_hz: rec.fs_hz,
        rpm: rec.rpm,
        channels: rec
            .channels
            .iter()
            .map(|ch| Channel {
                name: ch.name.clone(),
                samples: starts
                    .iter()
                    .flat_map(|&s| ch.samples[s..s + WINDOW].iter().copied())
                    .collect(),
            })
            .collect(),
    };
    if derive {
        pumptwin_data::derived::append_channels(&mut out, WINDOW);
    }
    out
}

/// A recording holding the windows at `positions` end to end, each with noise at
/// `spec.snr_db` relative to its own power per channel.
fn noisy_windows(
    rec: &Recording,
    windows: &[(WindowRef, usize)],
    positions: &[usize],
    spec: NoiseSpec,
) -> Recording {
    let channels = rec
        .channels
        .iter()
        .enumerate()
        .map(|(c, ch)| {
            let mut samples = Vec::with_capacity(positions.len() * WINDOW);
            for &k in positions {
                let w = windows[k].0;
                let x = &ch.samples[w.start..w.start + WINDOW];
                let power = x.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>() / WINDOW as f64;
                let sigma = (power * 10f64.powf(-f64::from(spec.snr_db) / 10.0)).sqrt();
                // One stream per (record, window start, channel): reproducible and
                // independent of which other windows are evaluated.
                let mut rng = Xoshiro128pp::seed_from_u64(
                    spec.seed
                        ^ (w.record as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
                        ^ (w.start as u64).wrapping_mul(0xBF58_476D_1CE4_E5B9)
                        ^ (c as u64 + 1).wrapping_mul(0x94D0_49BB_1331_11EB),
                );
                samples.extend(
                    x.iter()
                        .map(|&v| (f64::from(v) + sigma * rng.normal()) as f32),
                );
            }
            Channel {
                name: ch.name.clone(),
                samples,
            }
        })
        .collect();
    Recording {
        name: format!("{} + noise {} dB", rec.name, spec.snr_db),
        fs_hz: rec.fs_hz,
        rpm: rec.rpm,
        channels,
    }
}

/// The four physical indicators (eq. 13's `F`) of one window, unscaled:
///
/// ```text
/// impact_intensity     = mean over present i of env_kurtosis_i (the kurtosis of the
///                        node's envelope in the resonance band: the impacts'
///                        impulsiveness, which broadband noise does not erase as it
///                        does the broadband kurtosis)
/// dominant_band_ratio  = mean over present (t, i) of max_b band share_b,ti
///                        (the share from its `band_db` feature)
/// node_energy_diff_db  = mean over t of 20·log10( rms_t,0 / mean_{j≠0 present} rms_t,j )
///                        (0 when node 0 or every other node is absent)
/// graph_inconsistency  = 1 − mean over t of mean_{i≠j, both present} Â_t,ij
///                        (0 with fewer than two present nodes)
/// ```
///
/// Computed from the raw (unnormalized) features and the core's adjacency.
pub fn indicator_targets<const N: usize>(
    w: &WindowFeatures<N>,
    adj: &[Adjacency<N>; STEPS],
) -> [f32; N_INDICATORS] {
    let present: Vec<usize> = (0..N).filter(|&i| w.mask.0[i]).collect();
    if present.is_empty() {
        return [0.0; N_INDICATORS];
    }
    let pairs = (STEPS * present.len()) as f64;
    let mut kurt = 0.0f64;
    let mut band = 0.0f64;
    for step in &w.features {
        for &i in &present {
            kurt += f64::from(step[i][ENV_KURTOSIS]);
            let bands = &step[i][BAND_DB_01..BAND_DB_01 + SPECTRAL_BANDS];
            band += f64::from(band_share(bands.iter().copied().fold(f32::MIN, f32::max)));
        }
    }
    let others: Vec<usize> = present.iter().copied().filter(|&i| i != 0).collect();
    let energy_db = if w.mask.0[0] && !others.is_empty() {
        let mut sum = 0.0f64;
        for step in &w.features {
            let rms0 = f64::from(step[0][RMS]).max(1e-12);
            let rest =
                others.iter().map(|&j| f64::from(step[j][RMS])).sum::<f64>() / others.len() as f64;
            sum += 20.0 * (rms0 / rest.max(1e-12)).log10();
        }
        sum / STEPS as f64
    } else {
        0.0
    };
    let inconsistency = if present.len() >= 2 {
        let mut sum = 0.0f64;
        let mut n = 0usize;
        for a in adj {
            for &i in &present {
                for &j in &present {
                    if i != j {
                        sum += f64::from(a.0[i][j]);
                        n += 1;
                    }
                }
            }
        }
        1.0 - sum / n as f64
    } else {
        0.0
    };
    [
        (kurt / pairs) as f32,
        (band / pairs) as f32,
        energy_db as f32,
        inconsistency as f32,
    ]
}

/// Mean and standard deviation of each indicator over the training windows; the head
/// regresses z-scores so that no indicator's unit dominates the MSE.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IndicatorNorm {
    /// Means.
    pub mean: [f32; N_INDICATORS],
    /// Standard deviations (1 where the spread is zero).
    pub std: [f32; N_INDICATORS],
}

impl IndicatorNorm {
    /// Fit on unscaled indicator rows.
    pub fn fit(rows: &[[f32; N_INDICATORS]]) -> Self {
        let n = rows.len().max(1) as f64;
        let mut mean = [0.0f32; N_INDICATORS];
        let mut std = [1.0f32; N_INDICATORS];
        for k in 0..N_INDICATORS {
            let m = rows.iter().map(|r| f64::from(r[k])).sum::<f64>() / n;
            let v = rows
                .iter()
                .map(|r| (f64::from(r[k]) - m).powi(2))
                .sum::<f64>()
                / n;
            mean[k] = m as f32;
            std[k] = if v > 1e-12 { v.sqrt() as f32 } else { 1.0 };
        }
        Self { mean, std }
    }

    /// z-score one row.
    pub fn apply(&self, row: &[f32; N_INDICATORS]) -> [f32; N_INDICATORS] {
        let mut out = [0.0; N_INDICATORS];
        for k in 0..N_INDICATORS {
            out[k] = (row[k] - self.mean[k]) / self.std[k];
        }
        out
    }
}

/// One side of a split, as flat row-major arrays (see the module's `# Shapes`).
#[derive(Debug, Clone, PartialEq)]
pub struct Dataset {
    /// Nodes per window (`N`).
    pub nodes: usize,
    /// `[W, T, N, F]` normalized node features.
    pub x: Vec<f32>,
    /// `[W, T, N, N]` normalized adjacency.
    pub adj: Vec<f32>,
    /// `[W, N]` present nodes.
    pub mask: Vec<bool>,
    /// `[W, 4]` z-scored indicator targets.
    pub indicators: Vec<f32>,
    /// `[W]` class labels.
    pub label: Vec<i64>,
    /// `[W]` record index of each window.
    pub record: Vec<usize>,
    /// `[W, N, WINDOW]` raw samples (empty when not built, e.g. by `predict` for a
    /// feature model).
    pub raw: Vec<f32>,
    /// `[W, N, SPEC_BANDS]` node spectrum shapes (empty when `raw` is).
    pub spectra: Vec<f32>,
    /// `[W, N_THETA]` z-scored Θ_phys targets, `NaN` where unknown (empty until
    /// [`Dataset::attach_theta`]).
    pub theta: Vec<f32>,
}

impl Default for Dataset {
    /// An empty side of the measured layout ([`N_NODES`] nodes).
    fn default() -> Self {
        Self::new(N_NODES)
    }
}

impl Dataset {
    /// An empty side with `nodes` nodes per window.
    pub fn new(nodes: usize) -> Self {
        Self {
            nodes,
            x: Vec::new(),
            adj: Vec::new(),
            mask: Vec::new(),
            indicators: Vec::new(),
            label: Vec::new(),
            record: Vec::new(),
            raw: Vec::new(),
            spectra: Vec::new(),
            theta: Vec::new(),
        }
    }

    /// Values of `x` per window.
    pub fn x_per_window(&self) -> usize {
        STEPS * self.nodes * FEATURES
    }

    /// Values of `adj` per window.
    pub fn adj_per_window(&self) -> usize {
        STEPS * self.nodes * self.nodes
    }

    /// Values of `raw` per window.
    pub fn raw_per_window(&self) -> usize {
        self.nodes * WINDOW
    }

    /// Values of `spectra` per window.
    pub fn spec_per_window(&self) -> usize {
        self.nodes * SPEC_BANDS
    }

    /// The node mask of window `k` (`N` entries).
    pub fn window_mask(&self, k: usize) -> &[bool] {
        &self.mask[k * self.nodes..(k + 1) * self.nodes]
    }

    /// Whether the raw samples (and spectra) are present for every window.
    pub fn has_signals(&self) -> bool {
        self.raw.len() == self.len() * self.raw_per_window()
            && self.spectra.len() == self.len() * self.spec_per_window()
    }

    /// Append raw samples `[N, WINDOW]` of the last pushed window and its spectra
    /// (computed here; zero for absent nodes).
    pub fn push_signals(&mut self, raw: &[f32], mask: &[bool], fs_hz: f32) {
        debug_assert_eq!(raw.len(), self.raw_per_window());
        self.raw.extend_from_slice(raw);
        for (i, present) in mask.iter().enumerate() {
            if *present {
                let s = spectrum_shape(&raw[i * WINDOW..(i + 1) * WINDOW], fs_hz);
                self.spectra.extend_from_slice(&s);
            } else {
                self.spectra.extend_from_slice(&[0.0; SPEC_BANDS]);
            }
        }
    }

    /// Set every window's Θ target from its record's (z-scored with `mean`, `std`;
    /// `NaN` for records without one).
    pub fn attach_theta(
        &mut self,
        thetas: &std::collections::BTreeMap<usize, Theta>,
        mean: &[f32; N_THETA],
        std: &[f32; N_THETA],
    ) {
        self.theta.clear();
        for r in &self.record {
            let t = thetas.get(r).copied().unwrap_or([f32::NAN; N_THETA]);
            for k in 0..N_THETA {
                self.theta.push((t[k] - mean[k]) / std[k]);
            }
        }
    }

    /// Number of windows.
    pub fn len(&self) -> usize {
        self.label.len()
    }

    /// Whether there are no windows.
    pub fn is_empty(&self) -> bool {
        self.label.is_empty()
    }

    /// Append a window.
    pub fn push<const N: usize>(
        &mut self,
        x: &[[[f32; FEATURES]; N]; STEPS],
        adj: &[Adjacency<N>; STEPS],
        mask: &[bool; N],
        indicators: &[f32; N_INDICATORS],
        label: usize,
        record: usize,
    ) {
        debug_assert_eq!(N, self.nodes);
        self.x.extend(x.iter().flatten().flatten());
        self.adj
            .extend(adj.iter().flat_map(|a| a.0.iter().flatten()));
        self.mask.extend_from_slice(mask);
        self.indicators.extend_from_slice(indicators);
        self.label.push(label as i64);
        self.record.push(record);
    }

    /// Windows per class (`classes` entries).
    pub fn windows_per_class(&self, classes: usize) -> Vec<usize> {
        let mut n = vec![0; classes];
        for &l in &self.label {
            n[l as usize] += 1;
        }
        n
    }

    /// Distinct records per class (`classes` entries).
    pub fn records_per_class(&self, classes: usize) -> Vec<usize> {
        let mut sets = vec![BTreeSet::new(); classes];
        for (&l, &r) in self.label.iter().zip(&self.record) {
            sets[l as usize].insert(r);
        }
        sets.iter().map(BTreeSet::len).collect()
    }

    /// The windows where `keep` is true, in order.
    pub fn select(&self, keep: &[bool]) -> Self {
        let mut out = Self::new(self.nodes);
        for (k, _) in keep.iter().enumerate().filter(|(_, &m)| m) {
            let (xw, aw) = (self.x_per_window(), self.adj_per_window());
            out.x.extend_from_slice(&self.x[k * xw..(k + 1) * xw]);
            out.adj.extend_from_slice(&self.adj[k * aw..(k + 1) * aw]);
            out.mask.extend_from_slice(self.window_mask(k));
            out.indicators
                .extend_from_slice(&self.indicators[k * N_INDICATORS..(k + 1) * N_INDICATORS]);
            out.label.push(self.label[k]);
            out.record.push(self.record[k]);
            if self.has_signals() {
                let (rw, sw) = (self.raw_per_window(), self.spec_per_window());
                out.raw.extend_from_slice(&self.raw[k * rw..(k + 1) * rw]);
                out.spectra
                    .extend_from_slice(&self.spectra[k * sw..(k + 1) * sw]);
            }
            if self.theta.len() == self.len() * N_THETA {
                out.theta
                    .extend_from_slice(&self.theta[k * N_THETA..(k + 1) * N_THETA]);
            }
        }
        out
    }

    /// Distinct records.
    pub fn n_records(&self) -> usize {
        self.record.iter().collect::<BTreeSet<_>>().len()
    }
}

/// Normalize raw window features with `norm`, build the core's graphs and the
/// indicator targets, in the order of `windows`.
pub fn assemble<const N: usize>(
    raw: &[WindowFeatures<N>],
    signals: &[f32],
    windows: &[(WindowRef, usize)],
    norm: &FeatureNorm,
    indicator_norm: Option<&IndicatorNorm>,
    graph: &GraphConfig<N>,
) -> Result<(Dataset, Vec<[f32; N_INDICATORS]>), DatasetError> {
    let mut ds = Dataset::new(N);
    let mut unscaled = Vec::with_capacity(raw.len());
    for (k, (w, (wref, label))) in raw.iter().zip(windows).enumerate() {
        let (x, a) = window_graphs(w, norm, graph).map_err(|source| DatasetError::Graph {
            record: wref.record,
            start: wref.start,
            source,
        })?;
        let ind = indicator_targets(w, &a);
        unscaled.push(ind);
        let scaled = indicator_norm.map_or(ind, |n| n.apply(&ind));
        ds.push(&x, &a, &w.mask.0, &scaled, *label, wref.record);
        let rw = ds.raw_per_window();
        if let Some(sig) = signals.get(k * rw..(k + 1) * rw) {
            ds.push_signals(sig, &w.mask.0, MODEL_FS_HZ);
        }
    }
    Ok((ds, unscaled))
}

/// Everything training and evaluation need of one protocol, for `N` nodes
/// ([`NODES`] by default, [`DERIVED_NODES`] with the derived-node option).
#[derive(Debug, Clone)]
pub struct ProtocolData<const N: usize = N_NODES> {
    /// The protocol.
    pub protocol: Protocol,
    /// Node channel names, in node order.
    pub nodes: [&'static str; N],
    /// The split (window references and labels).
    pub split: Split,
    /// Feature normalization fitted on the training windows.
    pub norm: FeatureNorm,
    /// Indicator normalization fitted on the training windows.
    pub indicator_norm: IndicatorNorm,
    /// The graph construction used.
    pub graph: GraphConfig<N>,
    /// Training side.
    pub train: Dataset,
    /// Test side.
    pub test: Dataset,
    /// Masked node-windows, by cause, both sides.
    pub mask_counts: MaskCounts,
    /// Seconds spent computing features and graphs (both sides).
    pub featurize_seconds: f64,
}

impl<const N: usize> ProtocolData<N> {
    /// Build both sides of `protocol` from a loaded corpus for the nodes `nodes`. The
    /// normalizations are fitted on the training side, unless `norms` gives them (e.g.
    /// the ones saved with a trained model).
    pub fn build(
        corpus: &Corpus,
        protocol: Protocol,
        windows: &WindowConfig,
        norms: Option<(FeatureNorm, IndicatorNorm)>,
        graph: GraphConfig<N>,
        nodes: [&'static str; N],
    ) -> Result<Self, DatasetError> {
        let split = corpus.split(protocol, windows)?;
        if split.train.is_empty() {
            return Err(DatasetError::EmptyTrain(protocol));
        }
        let t0 = Instant::now();
        let mut mask_counts = MaskCounts::default();
        let (raw_train, sig_train) =
            featurize_windows(corpus, &split.train, &nodes, None, &mut mask_counts);
        let (raw_test, sig_test) =
            featurize_windows(corpus, &split.test, &nodes, None, &mut mask_counts);
        // Fitted on the training side only; the test side reuses it.
        let norm = norms.map_or_else(|| fit_norm(&raw_train), |(n, _)| n);
        let (mut train, train_ind) =
            assemble(&raw_train, &sig_train, &split.train, &norm, None, &graph)?;
        let indicator_norm = norms.map_or_else(|| IndicatorNorm::fit(&train_ind), |(_, n)| n);
        train.indicators = train_ind
            .iter()
            .flat_map(|r| indicator_norm.apply(r))
            .collect();
        let (test, _) = assemble(
            &raw_test,
            &sig_test,
            &split.test,
            &norm,
            Some(&indicator_norm),
            &graph,
        )?;
        Ok(Self {
            protocol,
            nodes,
            split,
            norm,
            indicator_norm,
            graph,
            train,
            test,
            mask_counts,
            featurize_seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// The test side rebuilt from noisy signals (features, graphs and indicators via
    /// the core, with the *training* normalizations).
    pub fn noisy_test(&self, corpus: &Corpus, noise: NoiseSpec) -> Result<Dataset, DatasetError> {
        let mut counts = MaskCounts::default();
        let (raw, signals) = featurize_windows(
            corpus,
            &self.split.test,
            &self.nodes,
            Some(noise),
            &mut counts,
        );
        let (mut ds, _) = assemble(
            &raw,
            &signals,
            &self.split.test,
            &self.norm,
            Some(&self.indicator_norm),
            &self.graph,
        )?;
        ds.theta = self.test.theta.clone();
        Ok(ds)
    }

    /// Class names.
    pub fn classes(&self) -> &[String] {
        &self.split.classes
    }

    /// A table of windows and records per class and side.
    pub fn counts_table(&self) -> String {
        let c = self.classes().len();
        let (tw, tr) = (
            self.train.windows_per_class(c),
            self.train.records_per_class(c),
        );
        let (ew, er) = (
            self.test.windows_per_class(c),
            self.test.records_per_class(c),
        );
        let mut s = format!(
            "{:<8} {:>13} {:>13} {:>12} {:>12}\n",
            "class", "train records", "train windows", "test records", "test windows"
        );
        for (k, name) in self.classes().iter().enumerate() {
            s.push_str(&format!(
                "{name:<8} {:>13} {:>13} {:>12} {:>12}\n",
                tr[k], tw[k], er[k], ew[k]
            ));
        }
        s.push_str(&format!(
            "{:<8} {:>13} {:>13} {:>12} {:>12}\n",
            "total",
            self.train.n_records(),
            self.train.len(),
            self.test.n_records(),
            self.test.len()
        ));
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use pumptwin_core::features::{band_db, FEATURE_NAMES};
    use pumptwin_core::graph::NodeMask;

    #[test]
    fn feature_indices_match_the_core() {
        assert_eq!(FEATURE_NAMES[RMS], "rms");
        assert_eq!(FEATURE_NAMES[ENV_KURTOSIS], "env_kurtosis");
        assert_eq!(FEATURE_NAMES[BAND_DB_01], "band_db_01");
        assert_eq!(FEATURE_NAMES[BAND_DB_01 + SPECTRAL_BANDS - 1], "band_db_16");
    }

    #[test]
    fn indicators_of_a_synthetic_window() {
        let mut w = WindowFeatures::<N_NODES> {
            start: 0,
            features: [[[0.0; FEATURES]; N_NODES]; STEPS],
            mask: NodeMask([true, true, false]),
        };
        for step in w.features.iter_mut() {
            step[0][ENV_KURTOSIS] = 5.0;
            step[1][ENV_KURTOSIS] = 3.0;
            step[0][RMS] = 1.0;
            step[1][RMS] = 0.1;
            // Band features are dB shares: the largest bands hold 0.7 and 0.5.
            step[0][BAND_DB_01..BAND_DB_01 + SPECTRAL_BANDS].fill(-40.0);
            step[1][BAND_DB_01..BAND_DB_01 + SPECTRAL_BANDS].fill(-40.0);
            step[0][BAND_DB_01 + 2] = band_db(0.7);
            step[1][BAND_DB_01] = band_db(0.5);
            // The absent node's values must not count.
            step[2][ENV_KURTOSIS] = 1000.0;
        }
        let mut a = [Adjacency::<N_NODES>::ZERO; STEPS];
        for m in a.iter_mut() {
            m.0 = [[0.5, 0.5, 0.0], [0.5, 0.5, 0.0], [0.0, 0.0, 1.0]];
        }
        let ind = indicator_targets(&w, &a);
        assert!((ind[0] - 4.0).abs() < 1e-6, "{ind:?}");
        assert!((ind[1] - 0.6).abs() < 1e-5, "{ind:?}");
        assert!((ind[2] - 20.0).abs() < 1e-4, "{ind:?}");
        assert!((ind[3] - 0.5).abs() < 1e-6, "{ind:?}");
    }

    #[test]
    fn derived_nodes_see_only_their_own_window() {
        let n = 4 * WINDOW;
        let tone = |k: usize| (k as f32 * 0.31).sin() + 0.3 * (k as f32 * 0.017).cos();
        let rec = |outside: f32| Recording {
            name: "r".into(),
            fs_hz: 12_000.0,
            rpm: None,
            channels: vec![Channel {
                name: "DE".into(),
                samples: (0..n)
                    .map(|k| {
                        if (WINDOW..2 * WINDOW).contains(&k) {
                            tone(k)
                        } else {
                            outside * tone(k)
                        }
                    })
                    .collect(),
            }],
        };
        // Same window samples, different history and future: same derived nodes.
        let a = windows_end_to_end(&rec(1.0), &[WINDOW], true);
        let b = windows_end_to_end(&rec(5.0), &[WINDOW], true);
        for name in [pumptwin_data::derived::TEMP, pumptwin_data::derived::PRES] {
            let (x, y) = (a.channel(name).unwrap(), b.channel(name).unwrap());
            assert_eq!(x.samples.len(), WINDOW);
            assert_eq!(x.samples, y.samples, "{name}");
        }
        // Without `derive` only the measured channel is copied.
        let plain = windows_end_to_end(&rec(1.0), &[0, WINDOW], false);
        assert_eq!(plain.channels.len(), 1);
        assert_eq!(plain.len(), 2 * WINDOW);
        assert_eq!(plain.channels[0].samples[WINDOW], tone(WINDOW));
    }

    #[test]
    fn noise_has_the_asked_snr() {
        let n = 4 * WINDOW;
        let samples: Vec<f32> = (0..n).map(|i| (i as f32 * 0.05).sin()).collect();
        let rec = Recording {
            name: "tone".into(),
            fs_hz: 12_000.0,
            rpm: Some(1797.0),
            channels: vec![Channel {
                name: "DE".into(),
                samples: samples.clone(),
            }],
        };
        let windows: Vec<(WindowRef, usize)> = (0..3)
            .map(|k| {
                (
                    WindowRef {
                        record: 0,
                        start: k * 1024,
                        len: WINDOW,
                    },
                    0,
                )
            })
            .collect();
        let noisy = noisy_windows(
            &rec,
            &windows,
            &[0, 1, 2],
            NoiseSpec {
                snr_db: 0.0,
                seed: 7,
            },
        );
        assert_eq!(noisy.len(), 3 * WINDOW);
        let x = &samples[1024..1024 + WINDOW];
        let y = &noisy.channels[0].samples[WINDOW..2 * WINDOW];
        let ps: f64 = x.iter().map(|v| f64::from(*v).powi(2)).sum();
        let pn: f64 = x.iter().zip(y).map(|(a, b)| f64::from(b - a).powi(2)).sum();
        let snr = 10.0 * (ps / pn).log10();
        assert!(snr.abs() < 0.3, "snr {snr}");
    }
}
