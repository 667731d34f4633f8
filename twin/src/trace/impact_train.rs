//! A second impact train: envelope lines at the harmonics of a rate the model lacks
//! (a compound fault, a rub, impacts once or k times per turn, or a source nobody
//! declared).

use super::context::{load_zone_line, TraceContext, NAMED_RATE_TOLERANCE};
use crate::residual::{
    on_model_comb, refine_comb_rate, Candidate, Check, Component, Evidence, ResidualAnalysis,
};
use crate::residual::{Domain, Kind};
use crate::signature::SignatureConfig;
use crate::twin::{fault_name, Effect, TwinModel};
use pumptwin_core::bearing::DefectLocation;

/// A second impact train read off the residual's envelope lines.
#[derive(Debug, Clone, PartialEq)]
pub struct SecondTrain {
    /// Impact rate, Hz: least squares over the matched lines, refined on the PSD comb.
    pub rate_hz: f64,
    /// What the rate matches (`inner_race`, `outer_race`, `ball`, `shaft`,
    /// `shaft_synchronous` for an integer number of impacts per turn, `unexplained`).
    pub source: &'static str,
    /// Harmonic numbers of the matched envelope lines.
    pub harmonics: Vec<u32>,
    /// The matched envelope lines.
    pub lines: Vec<Component>,
}

/// Relative distance from the modelled defect rate (and its multiples and
/// submultiples) inside which a harmonic family is that train's, not a second one.
const OWN_RATE_EXCLUSION: f64 = 0.05;
/// Highest harmonic of a second train matched in the envelope spectrum.
const TRAIN_MAX_HARMONIC: f64 = 20.0;

/// Impacts the model lacks: residual envelope lines (not the modelled comb, not its
/// load-zone sidebands) that form a harmonic family `k·r`, at least two lines one of
/// which is the first or second harmonic (once-per-turn trains, named `shaft`, need
/// three: the shaft's own 1× and 2× envelope lines come from modulation as often).
/// The rate is named for the bearing's defect rates (the modelled one excluded) or
/// the shaft rate within [`NAMED_RATE_TOLERANCE`], else `unexplained`.
pub fn second_train(
    analysis: &ResidualAnalysis,
    model: &TwinModel,
    cfg: &SignatureConfig,
    meas_psd_db: &[f32],
    span_s: f64,
) -> Option<SecondTrain> {
    let dfe = f64::from(cfg.fs_hz) / cfg.env_n as f64;
    let freqs = &model.op.freqs;
    let shaft = f64::from(freqs.shaft);
    let own = model.fault.map(|loc| {
        (
            f64::from(freqs.impact_rate(loc)) * (1.0 + model.get("rate_factor").unwrap_or(0.0)),
            f64::from(freqs.modulation_rate(loc)),
        )
    });
    let tol = |f: f64| (1.5 * dfe).max(0.005 * f);
    // Lines the modelled defect's modulation puts there (k·f_d ± m·f_mod, m·f_mod, m ≤ 2)
    // are that effect's evidence, not a second train's — also once the model modulates:
    // its load zone is a cosine, and a real one's second harmonic stays in the residual.
    let modulation_line = |f: f64| match own {
        Some((fd, fm)) if fm > 0.0 => load_zone_line(f, fd, fm, tol(f)),
        _ => false,
    };
    let lines: Vec<&Component> = analysis
        .envelope
        .iter()
        .filter(|c| c.kind == Kind::Line && c.f_hz >= 5.0)
        .filter(|c| !on_model_comb(model, c, dfe, span_s) && !modulation_line(c.f_hz))
        .collect();
    if lines.len() < 2 {
        return None;
    }
    // Candidate rates: every line as the first, second or third harmonic.
    let mut best: Option<(Vec<usize>, Vec<u32>, f64, f64)> = None;
    for l in &lines {
        for m in 1..=3u32 {
            let r0 = l.f_hz / f64::from(m);
            if r0 < 3.0 * dfe {
                continue;
            }
            let matched: Vec<(usize, u32)> = lines
                .iter()
                .enumerate()
                .filter_map(|(i, c)| {
                    let k = (c.f_hz / r0).round();
                    ((1.0..=TRAIN_MAX_HARMONIC).contains(&k)
                        && (c.f_hz - k * r0).abs() < tol(c.f_hz))
                    .then_some((i, k as u32))
                })
                .collect();
            let mut ks: Vec<u32> = matched.iter().map(|&(_, k)| k).collect();
            ks.sort_unstable();
            ks.dedup();
            if ks.len() < 2 || ks[0] > 2 {
                continue;
            }
            // Least-squares rate through the matched lines.
            let (num, den) = matched.iter().fold((0.0, 0.0), |(n, d), &(i, k)| {
                (n + lines[i].f_hz * f64::from(k), d + f64::from(k * k))
            });
            let r = num / den;
            // An impact train's strongest envelope line is its fundamental: it must be
            // there, unless the model's own comb or its sidebands cover it (a
            // line-dense residual otherwise offers chance families at low rates).
            if ks[0] != 1 {
                let at_r = Component {
                    domain: Domain::Envelope,
                    kind: Kind::Line,
                    f_hz: r,
                    width_hz: dfe,
                    excess_db: 0.0,
                    order: r / shaft,
                    centre_hz: None,
                };
                if !(on_model_comb(model, &at_r, dfe, span_s) || modulation_line(r)) {
                    continue;
                }
            }
            // Not the modelled comb's own rate, a multiple or a submultiple of it: within
            // 5 % that is the modelled train misplaced (a drifting speed smears its lines
            // off the comb), and no two defect rates of a bearing lie that close.
            if let Some((fd, _)) = own {
                let near = |a: f64, b: f64| (a - b).abs() < OWN_RATE_EXCLUSION * b;
                if (1..=4).any(|j| near(r, fd * f64::from(j)) || near(r, fd / f64::from(j))) {
                    continue;
                }
            }
            let idx: Vec<usize> = matched.iter().map(|&(i, _)| i).collect();
            // A harmonic sum normalised by the harmonic slots the rate has below the
            // envelope's upper limit (a matched filter's SNR): a low rate collects many
            // weak lines by chance in a line-dense spectrum, a real train its strong ones.
            let slots = (f64::from(cfg.env_max_hz) / r)
                .floor()
                .clamp(1.0, TRAIN_MAX_HARMONIC);
            let score = idx
                .iter()
                .map(|&i| f64::from(lines[i].excess_db))
                .sum::<f64>()
                / slots.sqrt();
            if best.as_ref().is_none_or(|(_, _, _, s)| score > *s) {
                best = Some((idx, ks, r, score));
            }
        }
    }
    let (idx, harmonics, r, _) = best?;
    let source = source_of(r, harmonics.len(), model)?;
    let rate_hz = refine_comb_rate(meas_psd_db, cfg, r, 0.004);
    Some(SecondTrain {
        rate_hz,
        source,
        harmonics,
        lines: idx.iter().map(|&i| lines[i].clone()).collect(),
    })
}

/// What a second train's rate `r` (with `harmonics` matched lines) is named for: a
/// defect rate of the bearing other than the modelled one, the shaft (three lines at
/// least), an integer number of impacts per turn, or nothing the model knows; `None`
/// for a once-per-turn family too thin to tell from modulation.
fn source_of(r: f64, harmonics: usize, model: &TwinModel) -> Option<&'static str> {
    let freqs = &model.op.freqs;
    let shaft = f64::from(freqs.shaft);
    // Bearing sources carry `fault_name`'s names, which `Effect::second_train_location`
    // reads back.
    let mut named: Vec<(f64, &'static str)> = vec![
        (
            f64::from(freqs.bpfo),
            fault_name(Some(DefectLocation::OuterRace)),
        ),
        (
            f64::from(freqs.bpfi),
            fault_name(Some(DefectLocation::InnerRace)),
        ),
        (
            f64::from(freqs.impact_rate(DefectLocation::Ball)),
            fault_name(Some(DefectLocation::Ball)),
        ),
        (f64::from(freqs.bsf), fault_name(Some(DefectLocation::Ball))),
        (shaft, "shaft"),
    ];
    if let Some(loc) = model.fault {
        let own_rate = f64::from(freqs.impact_rate(loc));
        named.retain(|(f, _)| (f - own_rate).abs() > 1e-6);
        if loc == DefectLocation::Ball {
            named.retain(|(_, n)| *n != fault_name(Some(DefectLocation::Ball)));
        }
    }
    let source = named
        .iter()
        .filter(|(f, _)| (r / f - 1.0).abs() <= NAMED_RATE_TOLERANCE)
        .min_by(|a, b| (r / a.0 - 1.0).abs().total_cmp(&(r / b.0 - 1.0).abs()))
        .map_or("unexplained", |(_, n)| *n);
    if source == "shaft" && harmonics < 3 {
        return None;
    }
    // An integer number of impacts per turn is tied to the rotor: a coupling's jaws or
    // bolts, vanes or blades, a gear's teeth.
    let order = r / shaft;
    let source = if source == "unexplained"
        && order.round() >= 2.0
        && (order - order.round()).abs() <= 0.005 * order.round()
    {
        "shaft_synchronous"
    } else {
        source
    };
    Some(source)
}

/// The candidate of a second impact train `t`.
pub(super) fn candidate(t: SecondTrain, ctx: &TraceContext<'_>, out: &mut Vec<Candidate>) {
    let model = ctx.model;
    let shaft = f64::from(model.op.freqs.shaft);
    // --- Envelope: a second impact train.
    {
        let what = match t.source {
            "unexplained" => "no rate of the bearing or the shaft: impacts from a source the model does not name (a neighbouring machine or bearing, a loose or struck part)".to_string(),
            "shaft" => "once per turn: a rub or a loose part struck by the rotor".to_string(),
            "shaft_synchronous" => format!("{:.0} impacts per turn, tied to the rotor: a coupling's jaws or bolts, vanes or blades, a gear's teeth", t.rate_hz / shaft),
            named => format!("the {named} defect rate: a second defect (compound fault)"),
        };
        let strength =
            t.lines.iter().map(|c| c.excess_db).fold(0.0, f32::max) + t.harmonics.len() as f32;
        let mut figures = serde_json::Map::new();
        figures.insert("harmonics".into(), serde_json::json!(t.harmonics));
        out.push(Candidate {
            effect: Effect::SecondImpactTrain {
                rate_hz: t.rate_hz,
                source: t.source.to_string(),
            },
            evidence: Evidence {
                summary: format!(
                    "{} envelope line(s) the model lacks at harmonics {:?} of {:.2} Hz = {:.3} x shaft: {what}",
                    t.lines.len(),
                    t.harmonics,
                    t.rate_hz,
                    t.rate_hz / shaft
                ),
                components: t.lines,
                figures,
            },
            strength,
            check: Check::Lines,
        });
    }
}
