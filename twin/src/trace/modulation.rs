//! Modulations of the impacts: the load zone at a kinematic rate, or a rate read off
//! the envelope's sidebands.

use super::context::{
    evidence, load_zone_line, modulated_at, modulation_rates, TraceContext, MAX_MODULATIONS,
    NAMED_RATE_TOLERANCE, ZONE_SIDEBANDS_READ,
};
use crate::residual::Kind;
use crate::residual::{
    band_envelope_spectrum, Candidate, Check, Component, Evidence, ResidualAnalysis,
};
use crate::signature::{block_within, to_db};
use crate::twin::Effect;
use pumptwin_core::bearing::DefectLocation;
use pumptwin_core::features::peak_frequency;

/// An amplitude modulation of the impacts read off the residual's envelope.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredModulation {
    /// Modulation rate, Hz: the envelope line's frequency.
    pub rate_hz: f64,
    /// Sidebands `k·f_d ± rate` (k ≤ 5) matched.
    pub sidebands: usize,
    /// The line at the rate, then its sidebands.
    pub lines: Vec<Component>,
}

/// Fewest sidebands `k·f_d ± f_m` that make a low envelope line a modulation rate.
pub const MIN_MODULATION_SIDEBANDS: usize = 3;

/// The impacts' modulation rate as the residual's envelope shows it, where it need
/// not be a kinematic one. A product of the impact train (comb `k·f_d`) and a slow
/// modulation at `f_m` has envelope lines at `f_m` itself and at `k·f_d ± f_m`; a sum
/// of two sources (a second train, a tone) has no such sidebands, so the pattern —
/// a line below `f_d / 2` and at least [`MIN_MODULATION_SIDEBANDS`] sidebands at its
/// spacing, or both sidebands of one line the model has ([`sideband_pair`]) — names
/// a modulation and reads its rate. Candidate rates are the envelope
/// lines below `f_d / 2`, and the residual's rise at its low edge (`below_band`: a
/// rate of one or two envelope bins, where the Welch block cannot tell it from DC),
/// each read again by `refine` (on a longer block; the sidebands themselves sit a bin
/// or two from comb teeth, where the tooth's own lobe pulls their peaks outward, so
/// their spacing overstates the rate). Rates within 1.5 envelope bins of one in
/// `known` (the kinematic rate, the shaft) are left to the kinematic reading.
/// A sideband lies within 1.5 bins or 1 % of `k·f_d ± f_m` and more than `f_m / 2`
/// from the tooth (a tooth is not its own sideband); a rate under two bins puts its
/// sidebands inside the tooth's lobe, and the residual's peaks then sit at the lobe's
/// flanks, up to 1.5 bins outside `± f_m`. Of two rates found where one is a known
/// rate plus or minus the other, the weaker low line is their product, not a
/// modulation of its own.
pub fn measured_modulation(
    envelope: &[Component],
    fd: f64,
    known: &[f64],
    dfe: f64,
    refine: impl Fn(f64) -> Option<f64>,
) -> Option<MeasuredModulation> {
    let lines: Vec<&Component> = envelope.iter().filter(|c| c.kind == Kind::Line).collect();
    let tol = |f: f64| (1.5 * dfe).max(0.01 * f);
    let at = |f: f64| lines.iter().find(|c| (c.f_hz - f).abs() < tol(c.f_hz));
    let carriers = carriers(fd, known);
    let found: Vec<MeasuredModulation> = envelope
        .iter()
        .filter(|c| matches!(c.kind, Kind::Line | Kind::BelowBand) && c.f_hz < 0.5 * fd)
        .filter_map(|low| {
            let fm = refine(low.f_hz).unwrap_or(low.f_hz);
            if on_lattice(fm, &carriers, tol(fm)) {
                return None;
            }
            let side: Vec<Component> = lines
                .iter()
                .filter(|c| c.f_hz > 0.5 * fd)
                .filter(|c| {
                    (1..=5).any(|k| {
                        let off = (c.f_hz - f64::from(k) * fd).abs();
                        off > 0.5 * fm && (off - fm).abs() < tol(c.f_hz)
                    })
                })
                .map(|c| (*c).clone())
                .collect();
            let side = if side.len() >= MIN_MODULATION_SIDEBANDS {
                side
            } else {
                sideband_pair(fm, &carriers, &tol, &at)?
            };
            Some(MeasuredModulation {
                rate_hz: fm,
                sidebands: side.len(),
                lines: std::iter::once((*low).clone()).chain(side).collect(),
            })
        })
        .collect();
    // Two modulations of the same impacts multiply: a load zone at f_r and a pulsation
    // at f_p put lines at f_r ± f_p too, with sidebands of their own. Such a product
    // is no modulation of its own: a rate within 1.5 bins of |k ± f| for a known rate
    // k and another rate f found here is one of a pair, and the pair's product is
    // the weaker low line. An envelope (1 + a·cos 2πf_r t)(1 + b·cos 2πf_p t) has its
    // line at f_p at b and those at f_r ± f_p at a·b/2, at least 6 dB below (a ≤ 1).
    // The slower of the two is not the rule: a pulsation at 20 Hz on a shaft at
    // 29.95 Hz has its product at 9.95 Hz, below it. At equal levels the slower is
    // kept (a pulsation at 2.7 Hz on an inner race at 29.95 Hz was once read at
    // 27.1 Hz). A rate found at a known rate joins the pairs, though it is no
    // modulation to read: a ball's impacts modulated near the shaft rate (57.4 Hz on
    // a shaft at 57.8 Hz) put its product with the cage rate (24.5 Hz) at 81.9 Hz,
    // once read as a modulation of its own.
    let outranks = |o: &MeasuredModulation, m: &MeasuredModulation| {
        let (lo, lm) = (o.lines[0].excess_db, m.lines[0].excess_db);
        lo > lm || (lo == lm && o.rate_hz < m.rate_hz)
    };
    let product = |m: &MeasuredModulation| {
        found.iter().any(|o| {
            outranks(o, m)
                && known.iter().any(|k| {
                    [k + o.rate_hz, (k - o.rate_hz).abs()]
                        .iter()
                        .any(|p| (m.rate_hz - p).abs() <= 1.5 * dfe)
                })
        })
    };
    let is_known =
        |m: &MeasuredModulation| known.iter().any(|k| (m.rate_hz - k).abs() <= 1.5 * dfe);
    found
        .iter()
        .filter(|m| !is_known(m) && !product(m))
        .cloned()
        .max_by(|a, b| {
            a.sidebands
                .cmp(&b.sidebands)
                .then(a.lines[0].excess_db.total_cmp(&b.lines[0].excess_db))
        })
}

/// The lines the model's envelope has that a modulation's sidebands stand around:
/// the comb's teeth `k·f_d` (k ≤ 5) and the known rates.
fn carriers(fd: f64, known: &[f64]) -> Vec<f64> {
    (1..=5)
        .map(|k| f64::from(k) * fd)
        .chain(known.iter().copied())
        .collect()
}

/// Whether `fm` is the sum or difference of two distinct lines of the model's
/// (`carriers`), within `tol` (a line with itself is its own harmonic, the shape of
/// a load zone narrower than a turn, read as such): a ball's spin rate less the
/// cage's (BSF − FTF) is a line of the ball's own lattice, with sidebands at
/// BSF + FTF, 3·BSF − FTF … around the comb, which its render places a little off;
/// it is no modulation (seed 11 control 143: a ball read as modulated at
/// 98.7 Hz = 113.9 − 15.3 Hz, four sidebands).
fn on_lattice(fm: f64, carriers: &[f64], tol: f64) -> bool {
    carriers.iter().enumerate().any(|(i, a)| {
        carriers
            .iter()
            .take(i)
            .filter(|&b| (a - b).abs() >= tol)
            .any(|b| [a + b, (a - b).abs()].iter().any(|&c| (c - fm).abs() < tol))
    })
}

/// Both sidebands `s ± f_m` of one line `s` the model's envelope has (`carriers`),
/// where fewer than [`MIN_MODULATION_SIDEBANDS`] sidebands stand around the comb: a
/// weak modulation leaves the comb's sidebands under the floor but its products with a
/// strong load zone above it (an inner race's zone at the shaft rate f_r and a
/// pulsation at f_p: lines at f_p, f_r − f_p and f_r + f_p). A sum has no such pair,
/// unless its own harmonics fall there: a train at `f_m` has lines at `s ± f_m` when
/// `s` is one of its harmonics, so a carrier in a whole ratio (1–4) with `f_m` either
/// way is passed over, and so is a carrier closer than twice the tolerance `tol(s)`
/// to its sidebands: their windows would reach the carrier's own line, which a
/// render that places it a little off leaves in the residual (seed 3 case 88: 1.8 Hz
/// read from lines 2.5 Hz either side of the cage rate; it is the product of the cage
/// rate and a pulsation at 21.9 Hz). `at(f)`: the residual's envelope line within
/// tolerance of `f`.
fn sideband_pair<'c>(
    fm: f64,
    carriers: &[f64],
    tol: &impl Fn(f64) -> f64,
    at: &impl Fn(f64) -> Option<&'c &'c Component>,
) -> Option<Vec<Component>> {
    let related = |s: f64| {
        let r = if s > fm { s / fm } else { fm / s };
        (1..=4).any(|n| (r - f64::from(n)).abs() < 0.05 * f64::from(n))
    };
    carriers
        .iter()
        .copied()
        .filter(|&s| s > 0.0 && !related(s) && fm > 2.0 * tol(s))
        .find_map(|s| {
            let (lo, hi) = (at((s - fm).abs())?, at(s + fm)?);
            (lo.f_hz != hi.f_hz).then(|| vec![(*lo).clone(), (*hi).clone()])
        })
}

/// The rates a measured modulation must not be read at: the kinematic rate, the
/// shaft, and each rate the model already modulates its impacts at with its 2nd to
/// 4th harmonics. A modulation narrower than its period (a Harris load zone that
/// covers part of a turn) modulates the impacts at the harmonics of its rate too:
/// those lines are its shape, which the model already has, not a load of its own.
fn known_rates(kinematic: f64, shaft: f64, modelled: &[f64]) -> Vec<f64> {
    let harmonics = modelled
        .iter()
        .flat_map(|r| (1..=4).map(move |k| f64::from(k) * r));
    [kinematic, shaft].into_iter().chain(harmonics).collect()
}

/// Offer a modulation of the impacts (up to [`MAX_MODULATIONS`]): read off the
/// envelope's sidebands, or at the kinematic rate.
pub(super) fn trace(analysis: &ResidualAnalysis, ctx: &TraceContext<'_>, out: &mut Vec<Candidate>) {
    let model = ctx.model;
    let fs = ctx.cfg.fs_hz;
    let shaft = f64::from(model.op.freqs.shaft);
    // --- Envelope: modulation sidebands k·f_d ± m·f_mod.
    // Up to two: the load zone the defect turns through and a load that varies at a
    // rate of its own (a process pulsation on an inner-race fault) multiply the same
    // impacts; a second is read at a rate the model does not modulate at yet.
    let modulations = modulation_rates(model).len();
    if let (Some(loc), true) = (model.fault, modulations < MAX_MODULATIONS) {
        let fd = f64::from(model.op.freqs.impact_rate(loc));
        let fm = f64::from(model.op.freqs.modulation_rate(loc));
        let fm = if fm > 0.0 { fm } else { shaft };
        let fd = fd * (1.0 + model.get("rate_factor").unwrap_or(0.0));
        let dfe = f64::from(fs) / ctx.cfg.env_n as f64;
        let side: Vec<Component> = analysis
            .envelope
            .iter()
            .filter(|c| c.kind == Kind::Line)
            .filter(|c| {
                let tol = (2.0 * dfe).max(0.01 * c.f_hz);
                load_zone_line(c.f_hz, fd, fm, ZONE_SIDEBANDS_READ, tol)
            })
            .cloned()
            .collect();
        let kinematic = !modulated_at(model, fm)
            && (!side.is_empty() && loc != DefectLocation::OuterRace || side.len() >= 2);
        // A slow rate read again on the longest block the record holds (4 s at 12 kHz:
        // 0.37 Hz bins against the Welch block's 1.46 Hz), within a residual bin of
        // where the residual put it and three long bins clear of DC.
        let n_long = block_within(1 << 17, ctx.x.len(), 1);
        // In dB: a parabola through a Hann line's log levels finds its centre to a few
        // hundredths of a bin; through its powers, to a fifth. Computed only when a
        // candidate rate asks for it (most rounds have none).
        let long = std::cell::OnceCell::new();
        let refine = |f0: f64| -> Option<f64> {
            let (spec, dfl) = long
                .get_or_init(|| {
                    band_envelope_spectrum(
                        ctx.x,
                        fs,
                        ctx.cfg.env_band.lo_hz,
                        ctx.cfg.env_band.hi_hz,
                        n_long,
                    )
                    .map(|(spec, dfl)| (to_db(&spec, &spec), dfl))
                })
                .as_ref()?;
            let lo = (f0 - dfe).max(3.0 * f64::from(*dfl));
            let f = peak_frequency(spec, fs, lo as f32, (f0 + dfe) as f32).ok()?;
            Some(f64::from(f))
        };
        let mut known = known_rates(fm, shaft, &modulation_rates(model));
        // A rolling element strikes the two races in turn, unequally: its envelope
        // has lines at the odd multiples of the spin rate (f_d / 2) beside the comb,
        // the defect's own, not a load varying as it spins.
        if loc == DefectLocation::Ball {
            known.push(0.5 * fd);
        }
        let measured = measured_modulation(&analysis.envelope, fd, &known, dfe, refine)
            .filter(|m| !kinematic || m.sidebands > side.len());
        if let Some(m) = measured {
            let strength = m.lines.iter().map(|c| c.excess_db).fold(0.0, f32::max);
            let ftf = f64::from(model.op.freqs.ftf);
            let bsf = f64::from(model.op.freqs.bsf);
            let near = |f: f64| (m.rate_hz - f).abs() < (1.5 * dfe).max(NAMED_RATE_TOLERANCE * f);
            // A whole multiple of a rate the bearing or the shaft has: the load zone a
            // rotating defect passes is narrower than a turn, so it modulates the
            // impacts at the harmonics of its rate too (its shape, not a new load); on
            // a stationary outer-race defect, a load that turns with the shaft does.
            let rotating = loc != DefectLocation::OuterRace;
            let multiple = |f: f64| (2..=4).find(|&k| near(f64::from(k) * f));
            let source = if near(ftf) {
                "the cage rate: the load zone turns with the cage (a cage or rolling-element defect, or a cage that slips)".to_string()
            } else if let Some(k) = multiple(fm).filter(|_| rotating) {
                format!("{k} x the load zone's rate ({fm:.2} Hz): the load zone's shape, a zone of load narrower than a turn that modulates the impacts at the harmonics of its rate too")
            } else if near(bsf) {
                format!("{:.3} x shaft, the rolling elements' spin rate (BSF, {bsf:.1} Hz): the load varies as an element spins (an element of uneven size or surface)", m.rate_hz / shaft)
            } else if let Some(k) = multiple(shaft) {
                format!("{k} x the shaft rate: a load that turns with the shaft (an unbalance, a bent shaft, a misalignment) and modulates the impacts at its orders")
            } else {
                format!(
                    "{:.3} x shaft, no rate of the bearing or the shaft: the load on the bearing varies at this rate (a process pulsation, a beat with a machine running at a nearly equal speed, a belt or a foundation's rocking)",
                    m.rate_hz / shaft
                )
            };
            let mut figures = serde_json::Map::new();
            figures.insert("sidebands".into(), serde_json::json!(m.sidebands));
            figures.insert("kinematic_rate_hz".into(), serde_json::json!(fm));
            out.push(Candidate {
                effect: Effect::LoadZoneModulation { mod_hz: m.rate_hz },
                evidence: Evidence {
                    summary: format!(
                        "an envelope line at {:.2} Hz and {} sideband(s) k·{fd:.1} ± {:.2} Hz around the modelled comb: the impacts are amplitude-modulated at {:.2} Hz = {source}",
                        m.rate_hz, m.sidebands, m.rate_hz, m.rate_hz
                    ),
                    components: m.lines,
                    figures,
                },
                strength,
                check: Check::Lines,
            });
        } else if kinematic {
            let strength = side.iter().map(|c| c.excess_db).fold(0.0, f32::max);
            out.push(Candidate {
                effect: Effect::LoadZoneModulation { mod_hz: fm },
                evidence: evidence(format!("{} envelope line(s) at k·{fd:.1} ± m·{fm:.2} Hz sidebands or at m·{fm:.2} Hz: the impacts are amplitude-modulated", side.len()), side),
                strength,
                check: Check::Lines,
            });
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::residual::Domain;

    fn line(f_hz: f64) -> Component {
        Component {
            domain: Domain::Envelope,
            kind: Kind::Line,
            f_hz,
            width_hz: 1.46,
            excess_db: 12.0,
            order: f_hz / 29.95,
            centre_hz: None,
        }
    }

    const FD: f64 = 107.4;
    const DFE: f64 = 1.46;

    /// A product (the comb modulated at 4.1 Hz) has its rate and sidebands on both
    /// sides of each tooth; the rate is read from the low line, refined.
    #[test]
    fn a_product_of_comb_and_slow_rate_is_a_modulation() {
        let mut env = vec![line(4.05)];
        for k in 1..=3 {
            let tooth = f64::from(k) * FD;
            env.extend([line(tooth - 4.4), line(tooth + 4.3)]);
        }
        let m =
            measured_modulation(&env, FD, &[29.95], DFE, |f| Some(f + 0.05)).expect("a modulation");
        assert!((m.rate_hz - 4.1).abs() < 1e-9, "{}", m.rate_hz);
        assert_eq!((m.sidebands, m.lines.len()), (6, 7));
    }

    fn line_db(f_hz: f64, excess_db: f32) -> Component {
        Component {
            excess_db,
            ..line(f_hz)
        }
    }

    /// The envelope of impacts modulated at the shaft's 29.95 Hz and by a pulsation
    /// at `fp`: lines at `fp` (12 dB) and at the product `29.95 − fp` (6 dB weaker),
    /// each with sidebands around the comb (the product's with more here).
    fn two_modulations(fp: f64) -> Vec<Component> {
        let product = 29.95 - fp;
        let mut env = vec![line_db(fp, 12.0), line_db(product, 6.0)];
        for k in 1..=3 {
            let tooth = f64::from(k) * FD;
            env.extend([line(tooth - fp), line(tooth + fp)]);
            env.extend([line(tooth - product), line(tooth + product)]);
            env.push(line(tooth + product - 0.05));
        }
        env
    }

    /// A pulsation at 2.7 Hz puts its product with the shaft at 27.25 Hz: the rate is
    /// the pulsation's, the stronger low line.
    #[test]
    fn a_product_of_two_modulations_is_the_weaker_line() {
        let m = measured_modulation(&two_modulations(2.7), FD, &[29.95], DFE, |_| None)
            .expect("a modulation");
        assert!((m.rate_hz - 2.7).abs() < 1e-9, "{}", m.rate_hz);
    }

    /// A pulsation faster than half the shaft rate (20 Hz) puts its product below it
    /// (9.95 Hz): the rate is still the stronger line's, not the slower.
    #[test]
    fn a_product_below_the_pulsation_is_not_its_rate() {
        let m = measured_modulation(&two_modulations(20.0), FD, &[29.95], DFE, |_| None)
            .expect("a modulation");
        assert!((m.rate_hz - 20.0).abs() < 1e-9, "{}", m.rate_hz);
    }

    /// A ball (impacts at 370.5 Hz, its load zone at the cage's 24.5 Hz) modulated
    /// near the shaft rate (57.4 Hz on a shaft at 57.83 Hz): the line at 57.4 Hz is
    /// the shaft's to read, and its product with the cage rate at 81.9 Hz no
    /// modulation of its own.
    #[test]
    fn a_product_with_a_known_rate_is_not_read() {
        const BALL: f64 = 370.5;
        let mut env = vec![line_db(57.4, 12.0), line_db(81.9, 6.0)];
        for k in 1..=3 {
            let tooth = f64::from(k) * BALL;
            for f in [57.4, 81.9] {
                env.extend([line(tooth - f), line(tooth + f)]);
            }
        }
        assert!(measured_modulation(&env, BALL, &[24.5, 57.83], DFE, |_| None).is_none());
    }

    /// An inner race (teeth at 162.2 Hz, its zone at the shaft's 31.4 Hz) pulsing at
    /// 26.2 Hz, its comb's sidebands under the floor: the pulsation's products with
    /// the zone (5.2 and 57.6 Hz) make the pattern. A train at half the shaft rate
    /// (lines at 15.7, 47.1 Hz) has the same pair around the shaft: its harmonics.
    #[test]
    fn a_pair_around_the_modelled_zone_is_a_modulation() {
        const BPFI: f64 = 162.2;
        let known = [31.4, 31.4];
        let pulsing: Vec<Component> = [5.2, 26.2, 57.6].map(line).to_vec();
        let m = measured_modulation(&pulsing, BPFI, &known, DFE, |_| None).expect("a modulation");
        assert!((m.rate_hz - 26.2).abs() < 1e-9, "{}", m.rate_hz);
        assert_eq!(m.sidebands, 2);
        let half_orders: Vec<Component> = [15.7, 47.1].map(line).to_vec();
        assert!(measured_modulation(&half_orders, BPFI, &known, DFE, |_| None).is_none());
        let one_side: Vec<Component> = [26.2, 57.6].map(line).to_vec();
        assert!(measured_modulation(&one_side, BPFI, &known, DFE, |_| None).is_none());
        // 1.8 Hz from lines 2.5 Hz either side of the shaft: within the tolerance
        // twice over of the shaft's own line, no pair.
        let close: Vec<Component> = [1.8, 28.9, 33.9].map(line).to_vec();
        assert!(measured_modulation(&close, BPFI, &known, DFE, |_| None).is_none());
    }

    /// A ball (comb at 2·BSF = 162.2 Hz, the cage at 14.6 Hz, the spin rate 81.1 Hz
    /// known): lines at BSF − FTF (66.5 Hz) and BSF + FTF, 3·BSF − FTF around the
    /// comb's first tooth are the ball's own lattice, not a modulation at 66.5 Hz;
    /// nor are four such lines around the comb.
    #[test]
    fn a_ball_s_own_lines_are_no_pair() {
        const BALL: f64 = 162.2;
        let env: Vec<Component> = [66.5, 95.7, 228.7].map(line).to_vec();
        let known = [14.6, 36.96, 81.1];
        assert!(measured_modulation(&env, BALL, &known, DFE, |_| None).is_none());
        // Four sidebands of the comb at 2·BSF = 227.8 Hz: BSF ± FTF, 3·BSF ± FTF,
        // 5·BSF − FTF, with the cage at 15.3 Hz.
        let (bsf, ftf) = (113.9, 15.3);
        let lattice: Vec<Component> = [
            bsf - ftf,
            bsf + ftf,
            3.0 * bsf - ftf,
            3.0 * bsf + ftf,
            5.0 * bsf - ftf,
        ]
        .map(line)
        .to_vec();
        let known = [ftf, 36.19, bsf];
        assert!(measured_modulation(&lattice, 2.0 * bsf, &known, DFE, |_| None).is_none());
    }

    /// An inner race whose model already has its load zone at the shaft rate: the
    /// zone's second harmonic (59.9 Hz, with sidebands around each tooth) is the
    /// zone's shape, not a second modulation; without the zone in the model the same
    /// lines are one.
    #[test]
    fn a_modelled_zone_s_harmonic_is_not_a_new_modulation() {
        const BPFI: f64 = 162.2;
        let rate = 2.0 * 29.95;
        let mut env = vec![line(rate)];
        for k in 1..=3 {
            let tooth = f64::from(k) * BPFI;
            env.extend([line(tooth - rate), line(tooth + rate)]);
        }
        let bare = known_rates(29.95, 29.95, &[]);
        let with_zone = known_rates(29.95, 29.95, &[29.95]);
        let read = |known: &[f64]| measured_modulation(&env, BPFI, known, DFE, |_| None);
        assert!(read(&bare).is_some_and(|m| (m.rate_hz - rate).abs() < 1e-9));
        assert!(read(&with_zone).is_none());
    }

    /// A sum has no sidebands: a low line beside an unrelated train's harmonics (a
    /// second source at 47 Hz) is no modulation, nor is a low line at the shaft rate
    /// (the kinematic reading's), nor sidebands without the low line.
    #[test]
    fn a_sum_or_a_known_rate_is_not_a_measured_modulation() {
        let sum: Vec<Component> = [4.1, 47.0, 94.0, 141.0, 188.0].map(line).to_vec();
        assert!(measured_modulation(&sum, FD, &[29.95], DFE, |_| None).is_none());
        let mut shaft = vec![line(29.9)];
        for k in 1..=3 {
            let tooth = f64::from(k) * FD;
            shaft.extend([line(tooth - 29.95), line(tooth + 29.95)]);
        }
        assert!(measured_modulation(&shaft, FD, &[29.95], DFE, |_| None).is_none());
        let no_low: Vec<Component> = shaft[1..].to_vec();
        assert!(measured_modulation(&no_low, FD, &[29.95], DFE, |_| None).is_none());
    }
}
