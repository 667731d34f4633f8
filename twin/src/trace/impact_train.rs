//! A second impact train: envelope lines at the harmonics of a rate the model lacks
//! (a compound fault, a rub, impacts once or k times per turn, or a source nobody
//! declared).

use super::context::{
    impact_modulations, load_zone_line, TraceContext, NAMED_RATE_TOLERANCE, ZONE_SIDEBANDS_READ,
};
use super::null::NullTest;
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
    /// Where the train was read at a told rate rather than off the residual's lines
    /// (`super::told_defect`): its family's level against the model's realizations.
    pub null: Option<NullTest>,
}

/// Relative distance from the modelled defect rate (and its multiples and
/// submultiples) inside which a harmonic family is that train's, not a second one.
const OWN_RATE_EXCLUSION: f64 = 0.05;
/// Highest harmonic of a second train matched in the envelope spectrum.
const TRAIN_MAX_HARMONIC: f64 = 20.0;

/// Impacts the model lacks: residual envelope lines (not the modelled comb, not its
/// load-zone sidebands) that form another defect's kinematic family
/// (`defect_family`, looked for first), else a harmonic family `k·r`, at least two
/// lines one of which is the first or second harmonic (once-per-turn trains, named
/// `shaft`, need three: the shaft's own 1× and 2× envelope lines come from modulation
/// as often).
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
    let own = model
        .fault
        .map(|loc| (model.comb_rate_hz(loc), impact_modulations(model, loc)));
    let tol = |f: f64| (1.5 * dfe).max(0.005 * f);
    // Lines the modelled defect's modulations put there (k·f_d ± m·f_mod, m·f_mod, m ≤ 2)
    // are those effects' evidence, not a second train's — also once the model
    // modulates: a real zone's second harmonic stays in the residual.
    let modulation_line = |f: f64| match &own {
        Some((fd, fms)) => fms
            .iter()
            .any(|&fm| load_zone_line(f, *fd, fm, ZONE_SIDEBANDS_READ, tol(f))),
        None => false,
    };
    let lines: Vec<&Component> = analysis
        .envelope
        .iter()
        .filter(|c| c.kind == Kind::Line && c.f_hz >= 5.0)
        .filter(|c| !on_model_comb(model, c, dfe, span_s) && !modulation_line(c.f_hz))
        .collect();
    let own_rate = own.as_ref().map(|(fd, _)| *fd);
    if let Some(t) = defect_family(&lines, model, own_rate, &tol, f64::from(cfg.env_max_hz)) {
        return Some(SecondTrain {
            rate_hz: refine_comb_rate(meas_psd_db, cfg, t.rate_hz, 0.004),
            ..t
        });
    }
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
            if own_rate.is_some_and(|fd| near_own_rate(r, fd, OWN_RATE_EXCLUSION)) {
                continue;
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
        null: None,
    })
}

/// Harmonics of a defect's rate a kinematic family is read over.
const FAMILY_HARMONICS: u32 = 3;
/// Step of the slip factor scanned for a kinematic family.
const FAMILY_SLIP_STEP: f64 = 0.001;

/// A second defect's kinematic pattern among the residual's envelope `lines`: for
/// each defect the model does not carry, the lines at `k·f_d + m·f_m` (`k` =
/// 1..=[`FAMILY_HARMONICS`], `|m|` ≤ 2), `f_d` its impact rate and `f_m` its load
/// zone's rate (the shaft for an inner race, the cage for a ball, none for an outer
/// race), and for a ball the cage rate's own lines `m·f_m` too, both rates scaled by
/// one slip factor scanned over ±[`NAMED_RATE_TOLERANCE`]. A family needs a line at
/// `f_d` itself: an impact train's strongest envelope line is its fundamental, and
/// without it lines at `2·f_d` and `3·f_d` were other sources' (`--seed 3` cases 0,
/// 144 and 259: false ball claims on outer- and inner-race records).
///
/// Why before the plain harmonic search: the rates are told (geometry and speed), not
/// searched for, so a line there is a second defect far more often than chance; and
/// a modulated train is not a harmonic family. A ball's strikes pass the load zone
/// once per cage turn, so its envelope is `k·2·BSF ± m·FTF` with the cage rate's
/// lines below, which the harmonic search read as impacts at about the cage rate
/// from "no source the model names" (`--seed 3` case 235: lines at harmonics 1, 2,
/// 7–10 of 13.55 Hz, the ball's 2·BSF = 121.8 Hz and its FTF sidebands); and a weaker
/// compound's harmonics stay under the floor where its fundamental stands (case 253).
fn defect_family(
    lines: &[&Component],
    model: &TwinModel,
    own_rate: Option<f64>,
    tol: &dyn Fn(f64) -> f64,
    env_max_hz: f64,
) -> Option<SecondTrain> {
    let freqs = &model.op.freqs;
    let steps = (NAMED_RATE_TOLERANCE / FAMILY_SLIP_STEP).round() as i32;
    let mut best: Option<(f64, SecondTrain)> = None;
    for loc in [
        DefectLocation::OuterRace,
        DefectLocation::InnerRace,
        DefectLocation::Ball,
    ] {
        let nominal = f64::from(freqs.impact_rate(loc));
        if model.fault == Some(loc)
            || own_rate.is_some_and(|fd| near_own_rate(nominal, fd, OWN_RATE_EXCLUSION))
        {
            continue;
        }
        for step in -steps..=steps {
            let scale = 1.0 + f64::from(step) * FAMILY_SLIP_STEP;
            let fd = nominal * scale;
            let fm = f64::from(freqs.modulation_rate(loc)) * scale;
            let members = family_members(loc, fd, fm, env_max_hz);
            let matched = match_members(lines, &members, fd, tol);
            // The fundamental itself, `k = 1, m = 0` (its multiple of `f_d` is 1).
            if !matched.iter().any(|&(_, w)| (w - 1.0).abs() < 1e-9) {
                continue;
            }
            let score = matched
                .iter()
                .map(|&(i, _)| f64::from(lines[i].excess_db))
                .sum::<f64>()
                / (members.len() as f64).sqrt();
            if best.as_ref().is_none_or(|(s, _)| score > *s) {
                // The rate through the matched lines (least squares, each line a
                // fixed multiple of it): not the scan's step, which ties over a range.
                let (num, den) = matched.iter().fold((0.0, 0.0), |(n, d), &(i, w)| {
                    (n + lines[i].f_hz * w, d + w * w)
                });
                let mut harmonics: Vec<u32> =
                    matched.iter().map(|&(_, w)| w.round() as u32).collect();
                harmonics.sort_unstable();
                harmonics.dedup();
                let train = SecondTrain {
                    rate_hz: num / den,
                    source: fault_name(Some(loc)),
                    harmonics,
                    lines: matched.iter().map(|&(i, _)| lines[i].clone()).collect(),
                    null: None,
                };
                best = Some((score, train));
            }
        }
    }
    best.map(|(_, t)| t)
}

/// Whether `r` is within `within` (relative; the residual's line search uses
/// [`OWN_RATE_EXCLUSION`]) of the modelled comb's rate `fd`, a multiple or a
/// submultiple of it (1–4): there a family is the modelled train
/// misplaced (a drifting speed smears its lines off the comb), or another defect rate
/// that coincides with it, which no envelope can tell apart (`--seed 5` case 243:
/// BPFO 0.6 % from 2·BSF, the outer race's own teeth read as a ball; case 69: BPFI
/// 1.5 % from 2·BSF).
pub(super) fn near_own_rate(r: f64, fd: f64, within: f64) -> bool {
    let near = |a: f64, b: f64| (a - b).abs() < within * b;
    (1..=4).any(|j| near(r, fd * f64::from(j)) || near(r, fd / f64::from(j)))
}

/// The frequencies of defect `loc`'s kinematic family at rate `fd` and load-zone
/// rate `fm` (see [`defect_family`]), up to `env_max_hz`.
fn family_members(loc: DefectLocation, fd: f64, fm: f64, env_max_hz: f64) -> Vec<f64> {
    let ms: &[i32] = if fm > 0.0 { &[-2, -1, 0, 1, 2] } else { &[0] };
    let mut members: Vec<f64> = Vec::new();
    if loc == DefectLocation::Ball {
        members.extend([fm, 2.0 * fm]);
    }
    for k in 1..=FAMILY_HARMONICS {
        members.extend(ms.iter().map(|&m| f64::from(k) * fd + f64::from(m) * fm));
    }
    members.retain(|&f| f > 0.0 && f <= env_max_hz);
    members
}

/// Each member's nearest line within `tol` that no earlier member took, in
/// `members`' order: `(line index, the member's multiple of the rate fd)` (1 is the
/// fundamental itself).
fn match_members(
    lines: &[&Component],
    members: &[f64],
    fd: f64,
    tol: &dyn Fn(f64) -> f64,
) -> Vec<(usize, f64)> {
    let mut used = vec![false; lines.len()];
    let mut matched = Vec::new();
    for &f in members {
        let hit = lines
            .iter()
            .enumerate()
            .filter(|(i, c)| !used[*i] && (c.f_hz - f).abs() < tol(f))
            .min_by(|a, b| (a.1.f_hz - f).abs().total_cmp(&(b.1.f_hz - f).abs()));
        if let Some((i, _)) = hit {
            used[i] = true;
            matched.push((i, f / fd));
        }
    }
    matched
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
        let told = t.null.map_or(String::new(), |n| {
            figures.insert("null_test".into(), n.figures("told_family_level_db"));
            format!(
                " (read at the rate the geometry tells: {:.1} dB over the floor, {:.1} standard deviations beyond the model's own realizations)",
                n.observed,
                n.z()
            )
        });
        out.push(Candidate {
            effect: Effect::SecondImpactTrain {
                rate_hz: t.rate_hz,
                source: t.source.to_string(),
            },
            evidence: Evidence {
                summary: format!(
                    "{} envelope line(s) the model lacks at harmonics {:?} of {:.2} Hz = {:.3} x shaft{told}: {what}",
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residual::Domain;
    use crate::twin::OperatingPoint;
    use pumptwin_core::bearing::BearingGeometry;

    fn line(f_hz: f64, excess_db: f32) -> Component {
        Component {
            domain: Domain::Envelope,
            kind: Kind::Line,
            f_hz,
            width_hz: 1.46,
            excess_db,
            order: f_hz / 29.95,
            centre_hz: None,
        }
    }

    fn model(fault: DefectLocation) -> TwinModel {
        let op = OperatingPoint {
            fs_hz: 12_000.0,
            freqs: BearingGeometry::CWRU_6205_DE.frequencies(29.95),
        };
        TwinModel::base(op, Some(fault), 3000.0, 0.05, 40.0, 0.01)
    }

    fn family(lines: &[Component], m: &TwinModel) -> Option<SecondTrain> {
        let refs: Vec<&Component> = lines.iter().collect();
        let own = m.fault.map(|loc| f64::from(m.op.freqs.impact_rate(loc)));
        defect_family(&refs, m, own, &|f| (1.5 * 1.46f64).max(0.005 * f), 1000.0)
    }

    /// A stationary outer race has no load zone of its own, but a shaft-rate
    /// modulation the loop kept owns its sidebands as an inner race's zone does.
    #[test]
    fn a_kept_modulation_owns_its_sidebands() {
        let outer = model(DefectLocation::OuterRace);
        assert!(impact_modulations(&outer, DefectLocation::OuterRace).is_empty());
        let inner = model(DefectLocation::InnerRace);
        assert_eq!(
            impact_modulations(&inner, DefectLocation::InnerRace),
            vec![f64::from(inner.op.freqs.shaft)]
        );
        let kept = outer.with_effect(Effect::LoadZoneModulation { mod_hz: 29.95 }, &|_, _| None);
        assert_eq!(
            impact_modulations(&kept, DefectLocation::OuterRace),
            vec![29.95]
        );
    }

    /// A ball's envelope on an outer-race model: the cage rate's lines and 2·BSF with
    /// its cage sidebands, 1 % slow. It is named a ball at 2·BSF, the rate read
    /// through all of its lines.
    #[test]
    fn a_cage_modulated_ball_family_is_a_ball_at_its_own_rate() {
        let f = BearingGeometry::CWRU_6205_DE.frequencies(29.95);
        let (fd, fm) = (0.99 * 2.0 * f64::from(f.bsf), 0.99 * f64::from(f.ftf));
        let mut lines = vec![line(fm, 9.0), line(2.0 * fm, 7.0)];
        for k in 1..=2 {
            let tooth = f64::from(k) * fd;
            lines.extend([
                line(tooth - fm, 8.0),
                line(tooth, 12.0),
                line(tooth + fm, 8.0),
            ]);
        }
        let t = family(&lines, &model(DefectLocation::OuterRace)).expect("a family");
        assert_eq!(t.source, "ball");
        assert!(
            (t.rate_hz / fd - 1.0).abs() < 1e-3,
            "{} against {fd}",
            t.rate_hz
        );
        assert_eq!(t.lines.len(), lines.len());
    }

    /// A lone line at a defect rate the model lacks is that defect's; a lone line at
    /// its second harmonic, or at the model's own rate, or sidebands without their
    /// tooth, are not a family.
    #[test]
    fn a_family_needs_its_rate_line() {
        let f = BearingGeometry::CWRU_6205_DE.frequencies(29.95);
        let (bpfo, bpfi) = (f64::from(f.bpfo), f64::from(f.bpfi));
        let inner = model(DefectLocation::InnerRace);
        let t = family(&[line(1.005 * bpfo, 9.0)], &inner).expect("a lone fundamental");
        assert_eq!(t.source, "outer_race");
        assert!(family(&[line(2.0 * bpfo, 9.0)], &inner).is_none());
        let outer = model(DefectLocation::OuterRace);
        assert!(family(&[line(bpfo, 9.0), line(2.0 * bpfo, 9.0)], &outer).is_none());
        let sidebands = [line(bpfi - 29.95, 9.0), line(bpfi + 29.95, 9.0)];
        assert!(family(&sidebands, &outer).is_none());
        // Another defect's rate within 5 % of the modelled comb's (a multiple or
        // submultiple of it) cannot be told from that comb.
        let lone = [line(bpfo, 9.0)];
        let refs: Vec<&Component> = lone.iter().collect();
        let tol = |f: f64| (1.5 * 1.46f64).max(0.005 * f);
        assert!(defect_family(&refs, &inner, Some(1.03 * bpfo), &tol, 1000.0).is_none());
        assert!(defect_family(&refs, &inner, Some(0.51 * bpfo), &tol, 1000.0).is_none());
    }
}
