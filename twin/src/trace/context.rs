//! What every tracer reads: the measurement and the current twin, and the limits
//! on how many effects of each kind the loop adds.

use super::null::NullDraws;
use crate::residual::{Component, Evidence};
use crate::signature::SignatureConfig;
use crate::twin::EffectKind;
use crate::twin::{Effect, TwinModel};
use pumptwin_core::bearing::DefectLocation;
use std::ops::Range;

/// What the tracer is told about the measurement.
#[derive(Debug, Clone)]
pub struct TraceContext<'a> {
    /// Measured signal.
    pub x: &'a [f32],
    /// Simulated signal of the current model (same length or shorter).
    pub sim: &'a [f32],
    /// Current model.
    pub model: &'a TwinModel,
    /// Signature settings used for the residual.
    pub cfg: &'a SignatureConfig,
    /// Measured PSD in dB at residual resolution.
    pub meas_psd_db: Vec<f32>,
    /// Model PSD in dB (same reference) at residual resolution.
    pub sim_psd_db: Vec<f32>,
    /// The current model simulated again with other seeds: the null a statistic's
    /// threshold is read from ([`super::null`]).
    pub nulls: &'a NullDraws<'a>,
    /// Sample ranges where the acquisition held one value (dropouts), in `x` and in
    /// the simulations alike.
    pub holds: &'a [Range<usize>],
    /// The keys of the candidates the loop has tried (`closed_loop`'s `tried_key`):
    /// a tracer that reads several sources offers the next one untried.
    pub tried: &'a [String],
}

/// What a tried second impact train of `source` is remembered by.
pub fn second_train_key(source: &str) -> String {
    format!("second_impact_train@{source}")
}

/// Evidence with no extra figures.
pub(crate) fn evidence(summary: String, components: Vec<Component>) -> Evidence {
    Evidence {
        summary,
        components,
        figures: serde_json::Map::new(),
    }
}

/// Structural modes the loop may add besides the base mode: CWRU's drive-end spectra
/// show three to four bands (≈ 0.6, 1.2, 2.7–3.6 kHz) that persist across records.
pub const MAX_EXTRA_MODES: usize = 3;
/// Most tones nobody declared the loop adds, one per step (a record can carry several
/// unrelated ones: a neighbouring machine, a drive's switching, a sensor cable's pickup).
pub const MAX_UNEXPLAINED_TONES: usize = 3;
/// How much weaker (dB) the defect rate may stand in a band's measured envelope than
/// in the model's before the band's excess counts as added at the sensor rather than a
/// mode the impacts excite (see the band tracer).
pub const BAND_DILUTION_DB: f32 = 6.0;
/// Least `ln(measured / model)` of the kurtosis over the compared band for random
/// impacts on the structure to be offered: the loop's tolerance on the time statistics
/// (a residual whose kurtosis agrees within it is noise-like on that count).
pub const MIN_LOG_KURTOSIS_EXCESS: f32 = 0.2;
/// Most unexplained bands the loop adds.
pub const MAX_UNEXPLAINED_BANDS: usize = 2;

/// Least dilution of the defect rate in a band's envelope (dB against the model's,
/// [`band_carries_defect`]) for the band to be offered as [`Effect::RandomBursts`]:
/// a mode the impacts excite strengthens the rhythm (generated modes −6 to −1 dB).
pub const BURST_DILUTION_DB: f32 = 1.0;

/// Most modulations of the impacts the loop adds (see the tracer).
pub const MAX_MODULATIONS: usize = 2;

/// The rates, Hz, the model modulates its impacts at.
pub(crate) fn modulation_rates(model: &TwinModel) -> Vec<f64> {
    model
        .effects
        .iter()
        .filter_map(|(e, _)| match e {
            Effect::LoadZoneModulation { mod_hz } | Effect::LoadZone { mod_hz } => Some(*mod_hz),
            _ => None,
        })
        .collect()
}

/// The rates, Hz, a defect at `loc` has its impacts modulated at in the model: its
/// kinematic load-zone rate (shaft for an inner race, cage for a ball; none for an
/// outer race) and every modulation the model carries. Envelope lines at
/// `k·f_d ± m·f_m` for any of them are the first defect's, not a second one's: on
/// CWRU 234 (an outer race, 0 HP) a shaft-rate modulation kept in the first round
/// left BPFO + 2·f_r (167.3 Hz) to be read as an inner race's rate in the next.
pub(crate) fn impact_modulations(model: &TwinModel, loc: DefectLocation) -> Vec<f64> {
    let kinematic = f64::from(model.op.freqs.modulation_rate(loc));
    std::iter::once(kinematic)
        .chain(modulation_rates(model))
        .filter(|&m| m > 0.0)
        .collect()
}

/// Does the model modulate its impacts at `f_hz` already (within 3 %)?
pub(crate) fn modulated_at(model: &TwinModel, f_hz: f64) -> bool {
    modulation_rates(model)
        .iter()
        .any(|m| (m - f_hz).abs() <= 0.03 * f_hz)
}

/// Does the model have an effect of this kind already?
pub(crate) fn has(model: &TwinModel, kind: EffectKind) -> bool {
    model.effects.iter().any(|(e, _)| e.kind() == kind)
}

/// Sideband orders of a load zone the residual's tracers read as its own: their lines
/// stand 10 dB out, which a zone's outer sidebands do not (the told reading, which
/// reads lines a few dB over their floor, reads further: `told_defect`).
pub(crate) const ZONE_SIDEBANDS_READ: u32 = 2;

/// Is `f` within `tol` of a line a load zone puts in the envelope spectrum of impacts
/// at `fd` modulated at `fm`: a sideband `k·fd ± m·fm` (k ≤ 5) or `m·fm` itself
/// (m ≤ `orders`)?
pub(crate) fn load_zone_line(f: f64, fd: f64, fm: f64, orders: u32, tol: f64) -> bool {
    (1..=orders).any(|m| {
        let side = f64::from(m) * fm;
        (f - side).abs() < tol
            || (1..=5).any(|k| {
                let tooth = f64::from(k) * fd;
                (f - (tooth + side)).abs() < tol || (f - (tooth - side)).abs() < tol
            })
    })
}

/// How far a train's rate may lie from a kinematic rate and still be named for it:
/// rolling elements slip by 1–2 %, and the nominal speed is itself a percent off on
/// many rigs.
pub(crate) const NAMED_RATE_TOLERANCE: f64 = 0.03;
