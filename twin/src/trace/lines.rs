//! PSD lines the model lacks: mains families, shaft orders (a force through the
//! bearing, or tones by another path), half orders, and the fallback tone (a line
//! that keeps its phase over the record).

use super::context::{evidence, has, modulated_at, TraceContext, MAX_UNEXPLAINED_TONES};
use super::impact_train::SecondTrain;
use crate::residual::Kind;
use crate::residual::{
    on_model_comb, Candidate, Check, Component, ResidualAnalysis, MAINS_HZ, MAX_TONES,
    TOOTH_TOL_BINS, TOOTH_TOL_REL,
};
use crate::twin::EffectKind;
use crate::twin::{Effect, TwinModel};

/// Offer the PSD lines' readings (in this order: mains, shaft harmonics, shaft-order
/// tones, half orders, one unexplained tone); `train`'s lines are its own evidence.
pub(super) fn trace(
    analysis: &ResidualAnalysis,
    ctx: &TraceContext<'_>,
    train: Option<&SecondTrain>,
    out: &mut Vec<Candidate>,
) {
    let mut lines = LineTracer::new(analysis, ctx, train);
    lines.mains(out);
    lines.shaft_orders(out);
    lines.half_orders(out);
    lines.unexplained_tone(out);
}

/// The residual's PSD lines no modelled term accounts for, and which of them a
/// reading has taken already (a defect's unmodelled sidebands from the start).
struct LineTracer<'a> {
    model: &'a TwinModel,
    /// The record, to read a line's frequency at its full resolution.
    x: &'a [f32],
    fs: f64,
    shaft: f64,
    df: f64,
    /// Samples per block of the periodicity test: the residual spectrum's segment.
    block: usize,
    lines: Vec<&'a Component>,
    used: Vec<bool>,
}

impl<'a> LineTracer<'a> {
    /// The PSD lines of `analysis` that are not the modelled comb's teeth, the
    /// unmodelled load zone's sidebands, a modelled sinusoid's misfit, or `train`'s.
    fn new(
        analysis: &'a ResidualAnalysis,
        ctx: &TraceContext<'a>,
        train: Option<&SecondTrain>,
    ) -> Self {
        let model = ctx.model;
        let fs = ctx.cfg.fs_hz;
        let shaft = f64::from(model.op.freqs.shaft);
        let df = f64::from(fs) / ctx.cfg.psd_n as f64;
        // --- PSD lines: electrical families, shaft orders, the rest. Lines of the modelled
        // defect's own comb (k·rate) are the fault term's, not a missing effect: a small
        // rate mismatch moves high-order teeth by a bin and leaves ± spikes there.
        let span_s = ctx.x.len() as f64 / f64::from(fs);
        let on_comb = |c: &Component| on_model_comb(model, c, df, span_s);
        // Before the model has its load zone, a rotating defect's (inner race: shaft rate;
        // ball: cage rate) sidebands k·f_d ± m·f_mod (m = 1, 2) stand in the PSD too; they
        // are the evidence of `load_zone_modulation` (read from the envelope), not tones. A
        // stationary outer-race defect has no load zone to pass through.
        let sideband = |c: &Component| {
            let Some(loc) = model.fault else {
                return false;
            };
            let fd = model.comb_rate_hz(loc);
            let fm = f64::from(model.op.freqs.modulation_rate(loc));
            if fm <= 0.0 || modulated_at(model, fm) {
                return false;
            }
            let tol = 1.5 * df + 0.001 * c.f_hz;
            [-2.0, -1.0, 1.0, 2.0].iter().any(|m: &f64| {
                let f = c.f_hz - m * fm;
                let k = (f / fd).round();
                k >= 1.0 && (f - k * fd).abs() < tol
            })
        };
        // A line on a sinusoid the model already has is that term's misfit.
        let tones = model.tone_frequencies();
        let modelled = |c: &Component| {
            tones
                .iter()
                .any(|f| (c.f_hz - f).abs() <= TOOTH_TOL_BINS * df + TOOTH_TOL_REL * c.f_hz)
        };
        let lines: Vec<&Component> = analysis
            .psd
            .iter()
            .filter(|c| c.kind == Kind::Line && !on_comb(c) && !modelled(c))
            .collect();
        // A sideband is taken already, except by mains: a line at the grid's frequency
        // read off the whole record is a far narrower match than a sideband's ±1.5 bins.
        let mut used: Vec<bool> = lines.iter().map(|c| sideband(c)).collect();
        // A second impact train puts lines at k·r in the PSD too: those are its evidence,
        // not unexplained tones.
        if let Some(t) = train {
            for (i, c) in lines.iter().enumerate() {
                let k = (c.f_hz / t.rate_hz).round();
                if k >= 1.0 && (c.f_hz - k * t.rate_hz).abs() < line_tol(df, c.f_hz) {
                    used[i] = true;
                }
            }
        }
        Self {
            model,
            x: ctx.x,
            fs: f64::from(fs),
            shaft,
            df,
            block: ctx.cfg.psd_n,
            lines,
            used,
        }
    }

    /// How far a line may lie from a frequency and still be at it.
    fn tol(&self, f: f64) -> f64 {
        line_tol(self.df, f)
    }

    /// Is `c` at one of the shaft's first 40 orders?
    fn is_order(&self, c: &Component) -> bool {
        let k = c.order.round();
        (1.0..=40.0).contains(&k) && (c.f_hz - k * self.shaft).abs() < self.tol(c.f_hz)
    }

    /// Is a line at `f_record_hz` (its frequency read off the whole record,
    /// [`Self::record_hz`]) off every shaft order by more than the speed's uncertainty? The PSD's bins (2.5 Hz at 10 kHz) cannot tell 60 Hz
    /// mains from a 3rd order at 61.5 Hz, the record (1/T = 0.17 Hz for 6 s) can.
    fn clearly_off_orders(&self, f_record_hz: f64) -> bool {
        let f = f_record_hz;
        let k = (f / self.shaft).round().max(1.0);
        (f - k * self.shaft).abs() > (SPEED_REL_TOL * f).max(self.resolution())
    }

    /// `c`'s frequency read off the whole record.
    fn record_hz(&self, c: &Component) -> f64 {
        record_peak_hz(self.x, self.fs, c.f_hz, 1.5 * self.df)
    }

    /// The record's frequency resolution, 1/T.
    fn resolution(&self) -> f64 {
        self.fs / self.x.len().max(1) as f64
    }

    /// Where every line is also a harmonic of a mains frequency (60 Hz and 2 × 29.93 Hz
    /// at 1796 rpm: 0.13 Hz apart), the record cannot tell the two apart; the shaft is
    /// the reading kept, and the evidence says so.
    fn mains_too(&self, comps: &[Component]) -> Option<f64> {
        MAINS_HZ.into_iter().find(|&mains| {
            comps.iter().all(|c| {
                let k = (c.f_hz / mains).round();
                (1.0..=20.0).contains(&k) && (c.f_hz - k * mains).abs() < self.tol(c.f_hz)
            })
        })
    }

    /// Do `members` (lines at multiples of `mains`, each also a shaft order) have the
    /// pattern of mains rather than of a shaft? Where the grid's frequency is itself
    /// the shaft's k-th order (k ≥ 2: 50 Hz at 1500 rpm is 2×), the record cannot tell
    /// the lines apart one by one, but the family can: pickup from a mains-fed circuit
    /// carries the fundamental and odd harmonics (1, 3, 5…), which as shaft orders are
    /// k, 3k, 5k… — a force at the shaft's orders that skipped every order between. So
    /// the mains reading wins where the fundamental and an odd harmonic stand, no even
    /// harmonic does, and no other shaft order below the family's top has a line (1×
    /// is where unbalance puts its line first; with it, the shaft may own them all and
    /// the shaft reading stays, noting the ambiguity).
    fn mains_pattern(&self, members: &[usize], mains: f64) -> bool {
        let k0 = (mains / self.shaft).round();
        if k0 < 2.0 || (mains - k0 * self.shaft).abs() >= self.tol(mains) {
            return false;
        }
        let harmonic = |i: usize| (self.lines[i].f_hz / mains).round();
        let odd_only = members.iter().all(|&i| harmonic(i) % 2.0 == 1.0);
        let fundamental = members.iter().any(|&i| harmonic(i) == 1.0);
        if members.len() < 2 || !odd_only || !fundamental {
            return false;
        }
        let top = members.iter().map(|&i| harmonic(i)).fold(0.0, f64::max) * k0;
        let between = (0..self.lines.len()).any(|i| {
            let c = self.lines[i];
            !members.contains(&i) && self.is_order(c) && c.order.round() < top
        });
        !between
    }

    /// A family's strongest `MAX_TONES` lines, and the strongest one's excess: every
    /// tone is a parameter the refit differentiates by simulation, and a measured record
    /// can carry dozens of shaft-order lines (CWRU 118: 18); the weaker ones stay in the
    /// residual for a later step.
    fn strongest(&self, members: &[usize]) -> (Vec<Component>, f32) {
        let mut members = members.to_vec();
        members.sort_by(|&a, &b| self.lines[b].excess_db.total_cmp(&self.lines[a].excess_db));
        members.truncate(MAX_TONES);
        let comps: Vec<Component> = members.iter().map(|&i| self.lines[i].clone()).collect();
        let strength = comps.iter().map(|c| c.excess_db).fold(0.0, f32::max);
        (comps, strength)
    }

    /// A family of shaft-order lines: its strongest lines, their orders, the strength,
    /// and a note when each is also a mains harmonic.
    fn family(&self, members: &[usize]) -> (Vec<Component>, Vec<u32>, f32, String) {
        let (comps, strength) = self.strongest(members);
        let mut orders: Vec<u32> = comps.iter().map(|c| c.order.round() as u32).collect();
        orders.sort_unstable();
        orders.dedup();
        let note = self.mains_too(&comps).map_or(String::new(), |mains| {
            format!("; each is also a harmonic of {mains} Hz mains, which this speed and resolution cannot tell from the shaft's orders")
        });
        (comps, orders, strength, note)
    }

    /// A mains family: the fundamental or a low harmonic of 50 or 60 Hz, two lines at
    /// least off the shaft's orders.
    fn mains(&mut self, out: &mut Vec<Candidate>) {
        let model = self.model;
        if !has(model, EffectKind::LineInterference) {
            for mains in MAINS_HZ {
                let members: Vec<usize> = (0..self.lines.len())
                    .filter(|&i| {
                        let k = (self.lines[i].f_hz / mains).round();
                        (1.0..=20.0).contains(&k)
                            && (self.lines[i].f_hz - k * mains).abs() < self.tol(self.lines[i].f_hz)
                    })
                    .collect();
                // Mains interference carries its fundamental or its low harmonics (the 3rd
                // of a rectifier's or a saturated transformer's current), and two of its
                // lines at least must not be shaft orders: among the dozens of lines a
                // measured record carries, a single 50 Hz multiple off the shaft's orders is
                // a coincidence (CWRU 118, a 60 Hz rig: 150, 250, 450 and 750 Hz).
                let low = members
                    .iter()
                    .any(|&i| (self.lines[i].f_hz / mains).round() <= 3.0);
                if !low {
                    continue;
                }
                // A line off the orders by the PSD's own tolerance is off them; one the PSD
                // cannot tell from an order is read off the whole record (a DFT of the
                // record around it each).
                let off =
                    |c: &Component| !self.is_order(c) || self.clearly_off_orders(self.record_hz(c));
                let not_shaft = members.iter().filter(|&&i| off(self.lines[i])).count();
                // Or the fundamental alone, off the shaft's orders and at the grid's own
                // frequency within its tolerance: a tone that happened to fall there is
                // far less likely than mains (a weak family's higher harmonics drown).
                let fundamental = not_shaft < 2
                    && members.iter().any(|&i| {
                        let c = self.lines[i];
                        (c.f_hz / mains).round() == 1.0 && {
                            let f = self.record_hz(c);
                            self.clearly_off_orders(f)
                                && (f - mains).abs()
                                    <= (MAINS_REL_TOL * mains).max(self.resolution())
                        }
                    });
                // Or a family the record cannot place off the orders but whose pattern is
                // mains' and not a shaft's (`mains_pattern`).
                let pattern = not_shaft < 2 && !fundamental && self.mains_pattern(&members, mains);
                if not_shaft >= 2 || fundamental || pattern {
                    let comps: Vec<Component> =
                        members.iter().map(|&i| self.lines[i].clone()).collect();
                    members.iter().for_each(|&i| self.used[i] = true);
                    let strength = comps.iter().map(|c| c.excess_db).fold(0.0, f32::max);
                    let freqs: Vec<f64> = members
                        .iter()
                        .map(|&i| (self.lines[i].f_hz / mains).round() * mains)
                        .collect();
                    out.push(Candidate {
                        effect: Effect::LineInterference { freqs: freqs.clone() },
                        evidence: evidence(
                            format!("{} line(s) at multiples of {mains} Hz ({:?} Hz), {not_shaft} of them not shaft-synchronous{}", comps.len(), freqs, if pattern { "; each is also a shaft order, but the family is mains' (its fundamental and odd harmonics only, no line at the shaft's orders between)" } else { "" }),
                            comps,
                        ),
                        strength,
                        check: Check::Lines,
                    });
                    break;
                }
            }
        }
    }

    /// Lines at shaft orders: a force through the bearing (to 12.5×) and, weaker, tones
    /// by another path.
    fn shaft_orders(&mut self, out: &mut Vec<Candidate>) {
        let (model, shaft) = (self.model, self.shaft);
        // Lines at shaft orders. Up to 12× they are first offered as a force through the
        // bearing (unbalance, misalignment: `shaft_harmonics`); every order line (to 40×)
        // is also offered, weaker, as tones that reach the sensor by another path
        // (`shaft_order_tones`: a pump's vane pass, a mesh), so when the force is rejected —
        // its Hertzian contact modulates the impacts at the tone's rate, and a measurement
        // whose envelope lacks that says the tone never loaded the bearing — the tones get
        // their turn in the same round. Lines above 12× go to the tones alone.
        let order_lines: Vec<usize> = (0..self.lines.len())
            .filter(|&i| !self.used[i] && self.is_order(self.lines[i]))
            .collect();
        let force: Vec<usize> = order_lines
            .iter()
            .copied()
            .filter(|&i| self.lines[i].order < 12.5)
            .collect();
        if !force.is_empty() && !has(model, EffectKind::ShaftHarmonics) {
            force.iter().for_each(|&i| self.used[i] = true);
            let (comps, orders, strength, note) = self.family(&force);
            out.push(Candidate {
                effect: Effect::ShaftHarmonics {
                    orders: orders.clone(),
                },
                evidence: evidence(
                    format!("line(s) at shaft orders {orders:?} (f_r = {shaft:.2} Hz): a force at the shaft's orders through the bearing (unbalance, misalignment){note}"),
                    comps,
                ),
                strength,
                check: Check::Lines,
            });
        }
        if !order_lines.is_empty() && !has(model, EffectKind::ShaftOrderTones) {
            let offered_as_force = order_lines.iter().any(|i| force.contains(i))
                && !has(model, EffectKind::ShaftHarmonics);
            order_lines.iter().for_each(|&i| self.used[i] = true);
            let (comps, orders, strength, note) = self.family(&order_lines);
            out.push(Candidate {
                effect: Effect::ShaftOrderTones {
                    orders: orders.clone(),
                },
                evidence: evidence(
                    format!("line(s) at shaft orders {orders:?} (f_r = {shaft:.2} Hz) as tones that do not load the bearing: a vane or blade pass (vanes x shaft rate), a coupling's or gear's mesh{}{note}", if offered_as_force { ", the alternative to a force through the bearing" } else { "" }),
                    comps,
                ),
                // Below the force, so that the force is tried first.
                strength: if offered_as_force { strength - 1.0 } else { strength },
                check: Check::Lines,
            });
        }
    }

    /// Lines at half orders: a force repeating every second turn.
    fn half_orders(&mut self, out: &mut Vec<Candidate>) {
        let (model, shaft) = (self.model, self.shaft);
        // Lines at half orders (k + ½)·f_r up to 12.5×, two or more of them: a force that
        // repeats every second turn — a loose seat or mount, a rub. One such line alone is
        // left to the fallback (a tone that happens to sit there).
        if !has(model, EffectKind::HalfOrders) {
            let members: Vec<usize> = (0..self.lines.len())
                .filter(|&i| {
                    let c = self.lines[i];
                    let h = (c.order - 0.5).round() + 0.5;
                    !self.used[i]
                        && (0.5..=12.5).contains(&h)
                        && (c.f_hz - h * shaft).abs() < self.tol(c.f_hz)
                })
                .collect();
            if members.len() >= 2 {
                members.iter().for_each(|&i| self.used[i] = true);
                let (comps, strength) = self.strongest(&members);
                let mut orders: Vec<f64> = comps
                    .iter()
                    .map(|c| (c.order - 0.5).round() + 0.5)
                    .collect();
                orders.sort_by(f64::total_cmp);
                out.push(Candidate {
                    effect: Effect::HalfOrders {
                        orders: orders.clone(),
                    },
                    evidence: evidence(
                        format!("line(s) at half orders {orders:?} of the shaft (f_r = {shaft:.2} Hz): a force repeating every second turn, mechanical looseness of the bearing's seat or mount, or a rub"),
                        comps,
                    ),
                    strength,
                    check: Check::Lines,
                });
            }
        }
    }

    /// The strongest line left that keeps its phase over the record ([`periodicity`]):
    /// a tone nobody declared, named where it can be (a mesh or pass frequency, the cage
    /// rate, a sub-synchronous whirl).
    fn unexplained_tone(&self, out: &mut Vec<Candidate>) {
        let (model, shaft, df) = (self.model, self.shaft, self.df);
        if model.effects_of(EffectKind::UnexplainedPeriodic).len() < MAX_UNEXPLAINED_TONES {
            // A periodic component keeps its phase from one block of the record to the
            // next; a line that does not (a comb tooth that slip has broadened, a mode
            // rung by noise) is a narrow band of the base, not a tone anybody added.
            let periodic = |i: usize| {
                periodicity(self.x, self.fs, self.lines[i].f_hz, self.block)
                    .filter(|&z| z >= PERIODIC_MIN_Z)
                    .map(|z| (i, z))
            };
            if let Some((i, z)) = (0..self.lines.len())
                .filter(|&i| !self.used[i])
                .filter_map(periodic)
                .max_by(|a, b| {
                    self.lines[a.0]
                        .excess_db
                        .total_cmp(&self.lines[b.0].excess_db)
                })
            {
                let c = self.lines[i].clone();
                // Shaft orders above 12 are not the shaft-harmonics effect (unbalance,
                // misalignment): a line there is a mesh or pass frequency (teeth, vanes or
                // blades times the shaft rate), which the loop says rather than "no order".
                let on_any_order = {
                    let k = c.order.round();
                    k >= 1.0 && (c.f_hz - k * shaft).abs() < 0.75 * df
                };
                let ftf = f64::from(model.op.freqs.ftf);
                let what = if self.is_order(&c) || on_any_order {
                    format!("shaft order {} (above the 1-12x of unbalance and misalignment: a mesh or vane/blade-pass frequency, teeth or vanes x shaft rate), no electrical line or defect rate", c.order.round())
                } else if (c.f_hz - ftf).abs() < self.tol(c.f_hz).max(0.01 * ftf) {
                    // Whirl (0.42-0.48x) and the cage (about 0.4x) lie a bin or less apart at
                    // a short record's resolution: say so rather than pick one.
                    let whirl = (0.42 * shaft - self.tol(c.f_hz)..=0.48 * shaft + self.tol(c.f_hz))
                        .contains(&c.f_hz);
                    format!(
                        "at the cage rate (FTF {ftf:.2} Hz): the cage turning out of balance or worn, a force the bearing model does not have{}",
                        if whirl { format!("; or a sub-synchronous whirl of a seal or journal (0.42-0.48x), which this resolution ({:.1} Hz) cannot tell from it", self.tol(c.f_hz)) } else { String::new() }
                    )
                } else if c.order < 1.0 {
                    "below the shaft rate, matching no cage rate or electrical line: sub-synchronous (a seal's or journal's fluid whirl at 0.42-0.48x, a pump's rotating stall, a belt's rate)".to_string()
                } else {
                    "matching no shaft order, electrical line or defect rate".to_string()
                };
                out.push(Candidate {
                    effect: Effect::UnexplainedPeriodic {
                        f_hz: c.f_hz,
                        order: c.order,
                    },
                    evidence: evidence(
                        format!(
                            "line at {:.1} Hz = {:.3} x shaft, {:.1} dB above the floor, phase-coherent over the record's {} blocks (p = {:.1e}), {what}",
                            c.f_hz,
                            c.order,
                            c.excess_db,
                            self.x.len() / self.block,
                            (-z).exp(),
                        ),
                        vec![c.clone()],
                    ),
                    strength: c.excess_db - 3.0,
                    check: Check::Lines,
                });
            }
        }
    }
}

/// Relative uncertainty of the shaft's rate as the record's speed gives it: a line
/// nearer than this to a shaft order may be that order.
const SPEED_REL_TOL: f64 = 0.004;

/// How far a grid's frequency strays from its nominal 50 or 60 Hz: ±0.2 %, the
/// continental European grid's ±0.1 Hz band of normal operation, doubled.
const MAINS_REL_TOL: f64 = 0.002;

/// The frequency of the highest peak of the Hann-windowed record's spectrum within
/// `f_hz ± half_span_hz`, at the record's full resolution: the spectrum on a grid of
/// half its resolution (1/(2T)), refined by a parabola through the log magnitudes
/// around the highest point. `f_hz` itself if the record is too short to say more.
fn record_peak_hz(x: &[f32], fs: f64, f_hz: f64, half_span_hz: f64) -> f64 {
    let n = x.len();
    if n < 2 {
        return f_hz;
    }
    let step = 0.5 * fs / n as f64;
    let points = (2.0 * half_span_hz / step).ceil() as usize + 1;
    let lo = (f_hz - half_span_hz).max(step);
    let mag: Vec<f64> = (0..points)
        .map(|j| {
            dft_magnitude(x, fs, lo + j as f64 * step)
                .max(f64::MIN_POSITIVE)
                .ln()
        })
        .collect();
    let Some(j) = (0..points).max_by(|&a, &b| mag[a].total_cmp(&mag[b])) else {
        return f_hz;
    };
    if j == 0 || j + 1 == points {
        return lo + j as f64 * step;
    }
    let (a, b, c) = (mag[j - 1], mag[j], mag[j + 1]);
    let denom = a - 2.0 * b + c;
    let delta = if denom < 0.0 {
        0.5 * (a - c) / denom
    } else {
        0.0
    };
    lo + (j as f64 + delta.clamp(-0.5, 0.5)) * step
}

/// `|Σ w(i)·x(i)·e^{−2πi f i/fs}|` with a Hann window `w`.
fn dft_magnitude(x: &[f32], fs: f64, f_hz: f64) -> f64 {
    let (re, im) = hann_dft(x, fs, f_hz);
    re.hypot(im)
}

/// Least phase coherence ([`periodicity`]) of a line for the loop to offer it as a tone
/// nobody declared: 6.9, a chance of 0.001 that noise at the line (or a band of it, as
/// wide as a block's bin or wider) keeps its phase as well.
pub const PERIODIC_MIN_Z: f64 = 6.9;

/// How well the record keeps its phase at `f_hz` from one block of `block` samples to
/// the next: `Z = |Σ_b X_b·X*_{b−1}|² / Σ_b |X_b|²·|X_{b−1}|²` over the Hann-windowed
/// blocks' spectra `X_b` at `f_hz`. A sinusoid within a block's bin of `f_hz` advances
/// its phase by the same angle every block, so `Z` reaches the number of block pairs;
/// where the bin holds noise, or a band wider than a block's bin (a defect's comb tooth
/// that slip has turned into a Lorentzian k²·π·σ²·rate wide, a lightly damped mode
/// rung by noise), the increments are independent and uniform, `|Σ|²` is a sum of
/// random phasors and `Z` is exponential with mean 1: its chance of reaching `z` is
/// `e^{−z}` (Rayleigh). A slowly wandering tone (a drive's speed) keeps its increment
/// from one block to the next and passes. `None` with fewer than three blocks.
pub fn periodicity(x: &[f32], fs: f64, f_hz: f64, block: usize) -> Option<f64> {
    let m = x.len() / block.max(1);
    if m < 3 || block < 2 {
        return None;
    }
    let spectra: Vec<(f64, f64)> = x
        .chunks_exact(block)
        .map(|b| hann_dft(b, fs, f_hz))
        .collect();
    let (mut re, mut im, mut power) = (0.0, 0.0, 0.0);
    for w in spectra.windows(2) {
        let ((a, b), (c, d)) = (w[1], w[0]);
        // X_b · conj(X_{b−1})
        re += a * c + b * d;
        im += b * c - a * d;
        power += (a * a + b * b) * (c * c + d * d);
    }
    (power > 0.0).then(|| (re * re + im * im) / power)
}

/// `Σ w(i)·x(i)·e^{−2πi f i/fs}` with a Hann window `w`, as (re, im), by a rotating
/// phasor.
fn hann_dft(x: &[f32], fs: f64, f_hz: f64) -> (f64, f64) {
    let n = x.len();
    let (ds, dc) = (2.0 * std::f64::consts::PI * f_hz / fs).sin_cos();
    let (ws, wc) = (2.0 * std::f64::consts::PI / (n - 1) as f64).sin_cos();
    let (mut s, mut c) = (0.0f64, 1.0f64);
    let (mut hs, mut hc) = (0.0f64, 1.0f64);
    let (mut re, mut im) = (0.0f64, 0.0f64);
    for &v in x {
        let w = 0.5 * (1.0 - hc) * f64::from(v);
        re += w * c;
        im -= w * s;
        (s, c) = (s * dc + c * ds, c * dc - s * ds);
        (hs, hc) = (hs * wc + hc * ws, hc * wc - hs * ws);
    }
    (re, im)
}

/// Line frequencies are interpolated between bins (significant_components): three
/// quarters of a bin, or 0.4 % for the speed's own uncertainty at high orders.
fn line_tol(df: f64, f: f64) -> f64 {
    (0.75 * df).max(0.004 * f)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 59.95 Hz tone in noise, 6 s at 10 240 Hz, looked for around a PSD bin's
    /// 60.5 Hz: the whole record puts it within 0.01 Hz, where the PSD's 2.5 Hz bins
    /// could not tell it from a shaft order at 61.5 Hz.
    #[test]
    fn a_line_is_read_at_the_records_resolution() {
        let fs = 10_240.0;
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let x: Vec<f32> = (0..6 * 10_240)
            .map(|i| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let noise = (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                let t = f64::from(i) / fs;
                (0.05 * (2.0 * std::f64::consts::PI * 59.95 * t + 0.3).sin() + 0.2 * noise) as f32
            })
            .collect();
        let f = record_peak_hz(&x, fs, 60.5, 3.75);
        assert!((f - 59.95).abs() < 0.01, "{f}");
    }

    /// Uniform in [−0.5, 0.5) from a xorshift state.
    fn uniform(state: &mut u64) -> f64 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }

    /// 6 s at 12 kHz read in 4096-sample blocks (17 of them): a tone 11 dB over the
    /// noise in a block's bin keeps its phase (Z = 15 of at most 16); the noise beside it
    /// does not; and neither does the 10th tooth of a 300 Hz impact train whose intervals
    /// jitter by 1 % (slip: a Lorentzian π·k²·σ²·rate ≈ 9 Hz wide: Z = 2.3), though it
    /// stands far above the noise.
    #[test]
    fn a_tone_keeps_its_phase_and_a_slipping_tooth_does_not() {
        let (fs, n, block) = (12_000.0, 72_000, 4096);
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let tone: Vec<f32> = (0..n)
            .map(|i| {
                let t = i as f64 / fs;
                let s = 0.02 * (2.0 * std::f64::consts::PI * 1437.3 * t + 0.3).sin();
                (s + 0.5 * uniform(&mut state)) as f32
            })
            .collect();
        let z_tone = periodicity(&tone, fs, 1437.3, block).unwrap();
        let z_noise = periodicity(&tone, fs, 1000.0, block).unwrap();
        // An impact train with a random-walk timing, each impact a 3 kHz ring-down.
        let mut train = vec![0.0f32; n];
        let mut next = 0.0;
        while next < n as f64 / fs {
            let start = (next * fs) as usize;
            for (j, v) in train[start..].iter_mut().take(200).enumerate() {
                let t = j as f64 / fs;
                *v += ((-600.0 * t).exp() * (2.0 * std::f64::consts::PI * 3000.0 * t).sin()) as f32;
            }
            next += (1.0 + 0.01 * 3.46 * uniform(&mut state)) / 300.0;
        }
        let z_tooth = periodicity(&train, fs, 3000.0, block).unwrap();
        assert!(z_tone > 12.0, "tone: {z_tone}");
        assert!(z_noise < PERIODIC_MIN_Z, "noise: {z_noise}");
        assert!(z_tooth < PERIODIC_MIN_Z, "tooth: {z_tooth}");
        assert!(periodicity(&tone[..2 * block], fs, 1437.3, block).is_none());
    }
}
