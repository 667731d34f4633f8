//! Step 2 and 3 of the loop: the residual between measurement and model, its
//! significant components, and the effect each one is traced to, with evidence.
//!
//! A component is significant when it stands above a robust noise floor of the dB
//! residual `d(f) = measured − model`: `d > median(d) + max(6 dB, 4·1.4826·MAD(d))`.
//! Narrow runs (≤ 4 bins, a Hann main lobe) are lines; wider runs are bands.

use super::model::{Effect, TwinModel};
use super::signature::{to_db, Signature, SignatureConfig};
use pumptwin_core::bearing::DefectLocation;
use pumptwin_core::features::{envelope, peak_frequency, EnvelopeBand};
use pumptwin_core::fft::{fft_in_place, Complex32, Direction};

/// Minimum excess of a significant component, dB.
pub const MIN_EXCESS_DB: f32 = 6.0;
/// MAD multiplier of the noise floor.
pub const MAD_K: f32 = 4.0;
/// Electrical supply frequencies checked for line interference, Hz.
pub const MAINS_HZ: [f64; 2] = [50.0, 60.0];

/// One significant residual component.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Component {
    /// `psd` or `envelope`.
    pub domain: &'static str,
    /// `line` or `band`.
    pub kind: &'static str,
    /// Peak frequency, Hz.
    pub f_hz: f64,
    /// Width of the run above the floor, Hz.
    pub width_hz: f64,
    /// Peak excess over the floor, dB.
    pub excess_db: f32,
    /// `f_hz / f_r`.
    pub order: f64,
}

/// Evidence for an effect, as reported.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Evidence {
    /// What was seen, in words.
    pub summary: String,
    /// The residual components behind it.
    pub components: Vec<Component>,
    /// Extra numbers (widths, shifts…).
    pub figures: serde_json::Map<String, serde_json::Value>,
}

/// A candidate effect with its evidence and a strength used to order candidates.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    /// The effect to add.
    pub effect: Effect,
    /// Why.
    pub evidence: Evidence,
    /// Ordering key (dB-ish).
    pub strength: f32,
}

fn median(v: &mut [f32]) -> f32 {
    if v.is_empty() {
        return 0.0;
    }
    let mid = v.len() / 2;
    let (_, m, _) = v.select_nth_unstable_by(mid, |a, b| a.total_cmp(b));
    *m
}

/// Significant runs of `d[k]` over `bins`; `freq(k)` maps bins to Hz.
pub fn significant_components(
    d: &[f32],
    bins: std::ops::RangeInclusive<usize>,
    df: f64,
    shaft_hz: f64,
    domain: &'static str,
) -> (Vec<Component>, f32) {
    let mut vals: Vec<f32> = bins.clone().map(|k| d[k]).collect();
    let med = median(&mut vals);
    let mut dev: Vec<f32> = bins.clone().map(|k| (d[k] - med).abs()).collect();
    let mad = 1.4826 * median(&mut dev);
    let thr = med + MIN_EXCESS_DB.max(MAD_K * mad);
    let mut out = Vec::new();
    let (lo, hi) = (*bins.start(), *bins.end());
    let mut k = lo;
    while k <= hi {
        if d[k] <= thr {
            k += 1;
            continue;
        }
        let start = k;
        let mut end = k;
        let mut j = k + 1;
        // Allow single-bin dips inside a run.
        while j <= hi && (d[j] > thr || (j < hi && d[j + 1] > thr)) {
            if d[j] > thr {
                end = j;
            }
            j += 1;
        }
        let peak = (start..=end)
            .max_by(|&a, &b| d[a].total_cmp(&d[b]))
            .unwrap_or(start);
        let width_bins = end - start + 1;
        let f = peak as f64 * df;
        out.push(Component {
            domain,
            kind: if width_bins <= 4 { "line" } else { "band" },
            f_hz: f,
            width_hz: width_bins as f64 * df,
            excess_db: d[peak] - med,
            order: f / shaft_hz,
        });
        k = end + 1;
    }
    (out, thr - med)
}

/// Everything the tracer looks at.
#[derive(Debug, Clone)]
pub struct ResidualAnalysis {
    /// Significant PSD components.
    pub psd: Vec<Component>,
    /// Significant envelope components.
    pub envelope: Vec<Component>,
    /// Floor-relative threshold used in the PSD, dB.
    pub psd_threshold_db: f32,
    /// PSD residual `(f, measured − model dB)` for plots.
    pub psd_residual: Vec<(f32, f32)>,
}

/// Residual of the fitted model against the measurement at line resolution.
pub fn analyse(
    meas: &Signature,
    sim: &Signature,
    cfg: &SignatureConfig,
    shaft_hz: f64,
) -> ResidualAnalysis {
    let m = to_db(&meas.psd, &meas.psd);
    let s = to_db(&sim.psd, &meas.psd);
    let d: Vec<f32> = m.iter().zip(&s).map(|(a, b)| a - b).collect();
    let df = f64::from(cfg.fs_hz) / cfg.psd_n as f64;
    let (psd, thr) = significant_components(&d, cfg.psd_bins(), df, shaft_hz, "psd");
    let me = to_db(&meas.env, &meas.env);
    let se = to_db(&sim.env, &meas.env);
    let de: Vec<f32> = me.iter().zip(&se).map(|(a, b)| a - b).collect();
    let dfe = f64::from(cfg.fs_hz) / cfg.env_n as f64;
    let (envelope, _) = significant_components(&de, cfg.env_bins(), dfe, shaft_hz, "envelope");
    let psd_residual = cfg.psd_bins().map(|k| (cfg.psd_freq(k), d[k])).collect();
    ResidualAnalysis {
        psd,
        envelope,
        psd_threshold_db: thr,
        psd_residual,
    }
}

/// Envelope spectrum of `x` restricted to the band `[lo, hi]` (FFT-domain band-pass),
/// Welch-averaged over blocks of `n`. Returns `(spectrum, df)`.
fn band_envelope_spectrum(
    x: &[f32],
    fs: f32,
    lo: f32,
    hi: f32,
    n: usize,
) -> Option<(Vec<f32>, f32)> {
    if x.len() < n {
        return None;
    }
    let mut scratch = vec![Complex32::ZERO; n];
    let mut env = vec![0.0f32; n];
    let mut acc = vec![0.0f32; n / 2 + 1];
    let mut count = 0;
    for start in (0..=x.len() - n).step_by(n / 2) {
        envelope(
            &x[start..start + n],
            fs,
            EnvelopeBand {
                lo_hz: lo,
                hi_hz: hi,
            },
            &mut scratch,
            &mut env,
        )
        .ok()?;
        let mean = env.iter().sum::<f32>() / n as f32;
        for (z, e) in scratch.iter_mut().zip(&env) {
            *z = Complex32::new(e - mean, 0.0);
        }
        fft_in_place(&mut scratch, Direction::Forward).ok()?;
        for (a, z) in acc.iter_mut().zip(&scratch) {
            *a += z.norm_sqr();
        }
        count += 1;
    }
    acc.iter_mut().for_each(|a| *a /= count as f32);
    Some((acc, fs / n as f32))
}

/// Level (dB over the median) of the strongest line within ±tol of `f` in a spectrum.
fn line_level_db(spec: &[f32], df: f32, f: f32, tol: f32) -> f32 {
    let hi_bin = ((4.0 * f / df) as usize).min(spec.len() - 1).max(4);
    let mut v: Vec<f32> = spec[1..=hi_bin].to_vec();
    let floor = median(&mut v).max(f32::MIN_POSITIVE);
    let lo = (((f - tol) / df).floor() as usize).max(1);
    let hi = (((f + tol) / df).ceil() as usize).min(spec.len() - 1);
    let peak = spec[lo..=hi].iter().cloned().fold(0.0f32, f32::max);
    10.0 * (peak / floor).log10()
}

/// Does the measured band `[lo, hi]` carry the defect's impacts? Envelope line level at
/// the impact rate, dB over the floor.
pub fn band_carries_defect(x: &[f32], fs: f32, lo: f32, hi: f32, rate_hz: f32) -> f32 {
    match band_envelope_spectrum(x, fs, lo.max(1.0), hi.min(0.49 * fs), 8192) {
        Some((spec, df)) => line_level_db(&spec, df, rate_hz, (0.02 * rate_hz).max(df)),
        None => 0.0,
    }
}

/// Frequency of the envelope line near `f` in `x` (interpolated peak), or `None`.
fn envelope_line(x: &[f32], fs: f32, band: EnvelopeBand, f: f32, n: usize) -> Option<f32> {
    let (spec, df) = band_envelope_spectrum(x, fs, band.lo_hz, band.hi_hz, n)?;
    let one_sided: Vec<f32> = spec;
    let tol = (0.03 * f).max(2.0 * df);
    peak_frequency(&one_sided, fs, f - tol, f + tol).ok()
}

/// RMS width (Hz) of the envelope line around `f` within ±4 %: smearing measure.
fn line_width(spec: &[f32], df: f32, f: f32) -> f32 {
    let lo = (((0.96 * f) / df) as usize).max(1);
    let hi = (((1.04 * f) / df) as usize + 1).min(spec.len() - 1);
    let peak = spec[lo..=hi].iter().cloned().fold(0.0f32, f32::max);
    // Power above a quarter of the peak, its spread about the peak.
    let (mut w, mut m1, mut m2) = (0.0f32, 0.0f32, 0.0f32);
    for (k, &p) in spec.iter().enumerate().take(hi + 1).skip(lo) {
        if p >= 0.25 * peak {
            let fk = k as f32 * df;
            w += p;
            m1 += p * fk;
            m2 += p * fk * fk;
        }
    }
    if w <= 0.0 {
        return 0.0;
    }
    let mean = m1 / w;
    (m2 / w - mean * mean).max(0.0).sqrt()
}

/// Mean instantaneous frequency of the band `[lo, hi]` at high vs mid envelope
/// amplitude: `(f_high, f_mid)`. A hardening stiffness raises `f_high` above `f_mid`.
pub fn amplitude_frequency_dependence(x: &[f32], fs: f32, lo: f32, hi: f32) -> Option<(f32, f32)> {
    let n = 8192usize;
    if x.len() < n {
        return None;
    }
    let mut scratch = vec![Complex32::ZERO; n];
    let mut samples: Vec<(f32, f32)> = Vec::new();
    for start in (0..=x.len() - n).step_by(n) {
        let seg = &x[start..start + n];
        let mean = seg.iter().sum::<f32>() / n as f32;
        for (z, &v) in scratch.iter_mut().zip(seg) {
            *z = Complex32::new(v - mean, 0.0);
        }
        fft_in_place(&mut scratch, Direction::Forward).ok()?;
        let df = fs / n as f32;
        for (k, z) in scratch.iter_mut().enumerate() {
            let f = k as f32 * df;
            *z = if k > 0 && k < n / 2 && f >= lo && f <= hi {
                Complex32::new(2.0 * z.re, 2.0 * z.im)
            } else {
                Complex32::ZERO
            };
        }
        fft_in_place(&mut scratch, Direction::Inverse).ok()?;
        // Skip block edges (filter transients).
        for i in 64..n - 64 {
            let (a, b) = (scratch[i], scratch[i + 1]);
            let amp = a.norm();
            // Phase increment arg(b · conj(a)).
            let dphi = (b.im * a.re - b.re * a.im).atan2(b.re * a.re + b.im * a.im);
            samples.push((amp, dphi * fs / (2.0 * std::f32::consts::PI)));
        }
    }
    if samples.len() < 1000 {
        return None;
    }
    samples.sort_by(|a, b| a.0.total_cmp(&b.0));
    let n = samples.len();
    let avg = |s: &[(f32, f32)]| {
        let w: f32 = s.iter().map(|p| p.0 * p.0).sum();
        s.iter().map(|p| p.0 * p.0 * p.1).sum::<f32>() / w.max(f32::MIN_POSITIVE)
    };
    Some((
        avg(&samples[n * 95 / 100..]),
        avg(&samples[n * 40 / 100..n * 70 / 100]),
    ))
}

/// What the tracer is told about the measurement.
#[derive(Debug, Clone, Copy)]
pub struct TraceContext<'a> {
    /// Measured signal.
    pub x: &'a [f32],
    /// Simulated signal of the current model (same length or shorter).
    pub sim: &'a [f32],
    /// Current model.
    pub model: &'a TwinModel,
    /// Signature settings used for the residual.
    pub cfg: &'a SignatureConfig,
}

fn evidence(summary: String, components: Vec<Component>) -> Evidence {
    Evidence {
        summary,
        components,
        figures: serde_json::Map::new(),
    }
}

fn has(model: &TwinModel, name: &str) -> bool {
    model.effects.iter().any(|(e, _)| e.name() == name)
}

/// Trace the residual to candidate effects the model lacks (strongest first).
pub fn trace(analysis: &ResidualAnalysis, ctx: &TraceContext<'_>) -> Vec<Candidate> {
    let model = ctx.model;
    let fs = ctx.cfg.fs_hz;
    let shaft = f64::from(model.op.freqs.shaft);
    let df = f64::from(fs) / ctx.cfg.psd_n as f64;
    let mut out: Vec<Candidate> = Vec::new();

    // --- PSD lines: electrical families, shaft orders, the rest. Lines of the modelled
    // defect's own comb (k·rate) are the fault term's, not a missing effect: a small
    // rate mismatch moves high-order teeth by a bin and leaves ± spikes there.
    let comb = model.fault.map(|loc| {
        f64::from(model.op.freqs.impact_rate(loc)) * (1.0 + model.get("rate_factor").unwrap_or(0.0))
    });
    let on_comb = |c: &Component| {
        comb.is_some_and(|r| {
            let k = (c.f_hz / r).round();
            k >= 1.0 && (c.f_hz - k * r).abs() <= 2.0 * df + 0.002 * c.f_hz
        })
    };
    let lines: Vec<&Component> = analysis
        .psd
        .iter()
        .filter(|c| c.kind == "line" && !on_comb(c))
        .collect();
    let tol = |f: f64| (1.5 * df).max(0.004 * f);
    let is_order = |c: &Component| {
        let k = c.order.round();
        (1.0..=40.0).contains(&k) && (c.f_hz - k * shaft).abs() < tol(c.f_hz)
    };
    let mut used = vec![false; lines.len()];
    if !has(model, "line_interference") {
        for mains in MAINS_HZ {
            let members: Vec<usize> = (0..lines.len())
                .filter(|&i| {
                    let k = (lines[i].f_hz / mains).round();
                    (1.0..=20.0).contains(&k) && (lines[i].f_hz - k * mains).abs() < tol(lines[i].f_hz)
                })
                .collect();
            let not_shaft = members.iter().filter(|&&i| !is_order(lines[i])).count();
            if !members.is_empty() && not_shaft >= 1 {
                let comps: Vec<Component> = members.iter().map(|&i| lines[i].clone()).collect();
                members.iter().for_each(|&i| used[i] = true);
                let strength = comps.iter().map(|c| c.excess_db).fold(0.0, f32::max);
                let freqs: Vec<f64> = members
                    .iter()
                    .map(|&i| (lines[i].f_hz / mains).round() * mains)
                    .collect();
                out.push(Candidate {
                    effect: Effect::LineInterference { freqs: freqs.clone() },
                    evidence: evidence(
                        format!("{} line(s) at multiples of {mains} Hz ({:?} Hz), {not_shaft} of them not shaft-synchronous", comps.len(), freqs),
                        comps,
                    ),
                    strength,
                });
                break;
            }
        }
    }
    if !has(model, "shaft_harmonics") {
        let members: Vec<usize> = (0..lines.len())
            .filter(|&i| !used[i] && is_order(lines[i]) && lines[i].order < 12.5)
            .collect();
        if !members.is_empty() {
            let comps: Vec<Component> = members.iter().map(|&i| lines[i].clone()).collect();
            members.iter().for_each(|&i| used[i] = true);
            let mut orders: Vec<u32> = comps.iter().map(|c| c.order.round() as u32).collect();
            orders.sort_unstable();
            orders.dedup();
            let strength = comps.iter().map(|c| c.excess_db).fold(0.0, f32::max);
            out.push(Candidate {
                effect: Effect::ShaftHarmonics {
                    orders: orders.clone(),
                },
                evidence: evidence(
                    format!("line(s) at shaft orders {orders:?} (f_r = {shaft:.2} Hz)"),
                    comps,
                ),
                strength,
            });
        }
    }
    if !has(model, "unexplained_periodic") {
        if let Some(i) = (0..lines.len())
            .filter(|&i| !used[i])
            .max_by(|&a, &b| lines[a].excess_db.total_cmp(&lines[b].excess_db))
        {
            let c = lines[i].clone();
            out.push(Candidate {
                effect: Effect::UnexplainedPeriodic { f_hz: c.f_hz, order: c.order },
                evidence: evidence(
                    format!("line at {:.1} Hz = {:.3} x shaft, {:.1} dB above the floor, matching no shaft order, electrical line or defect rate", c.f_hz, c.order, c.excess_db),
                    vec![c.clone()],
                ),
                strength: c.excess_db - 3.0,
            });
        }
    }

    // --- PSD bands: a structural mode excited by the defect (or by the background in a
    // healthy bearing), else an unexplained band.
    let rate = model.fault.map(|loc| model.op.freqs.impact_rate(loc));
    if let Some(b) = analysis
        .psd
        .iter()
        .filter(|c| c.kind == "band")
        .max_by(|a, b| {
            (a.excess_db * a.width_hz as f32).total_cmp(&(b.excess_db * b.width_hz as f32))
        })
    {
        let (lo, hi) = ((b.f_hz - b.width_hz) as f32, (b.f_hz + b.width_hz) as f32);
        let carried = rate.map(|r| band_carries_defect(ctx.x, fs, lo, hi, r));
        let resonance_like = b.width_hz < 0.3 * b.f_hz;
        let structural = match carried {
            Some(level) => level >= 6.0,
            None => resonance_like,
        };
        let mut ev = evidence(
            format!(
                "band at {:.0} Hz, {:.0} Hz wide, {:.1} dB above the floor",
                b.f_hz, b.width_hz, b.excess_db
            ),
            vec![b.clone()],
        );
        if let Some(level) = carried {
            ev.figures.insert(
                "defect_rate_in_band_envelope_db".into(),
                serde_json::json!(level),
            );
        }
        let strength = b.excess_db + 3.0 * (b.width_hz / 100.0).min(5.0) as f32;
        if structural && !has(model, "extra_resonance") {
            ev.summary.push_str(if carried.is_some() {
                "; its envelope carries the defect rate: a structural mode"
            } else {
                "; resonance-shaped: a structural mode"
            });
            out.push(Candidate {
                effect: Effect::ExtraResonance { f_hz: b.f_hz },
                evidence: ev,
                strength,
            });
        } else if !structural && !has(model, "unexplained_band") {
            ev.summary
                .push_str("; not excited by the defect: unexplained");
            out.push(Candidate {
                effect: Effect::UnexplainedBand {
                    f_hz: b.f_hz,
                    bandwidth_hz: b.width_hz.max(2.0 * df),
                },
                evidence: ev,
                strength: strength - 2.0,
            });
        }
    }

    // --- Envelope: modulation sidebands k·f_d ± m·f_mod.
    if let (Some(loc), false) = (model.fault, has(model, "load_zone_modulation")) {
        let fd = f64::from(model.op.freqs.impact_rate(loc));
        let fm = f64::from(model.op.freqs.modulation_rate(loc));
        let fm = if fm > 0.0 { fm } else { shaft };
        let dfe = f64::from(fs) / ctx.cfg.env_n as f64;
        let side: Vec<Component> = analysis
            .envelope
            .iter()
            .filter(|c| {
                (1..=5).any(|k| {
                    (1..=2).any(|m| {
                        let a = (c.f_hz - (k as f64 * fd + m as f64 * fm)).abs();
                        let b = (c.f_hz - (k as f64 * fd - m as f64 * fm)).abs();
                        a.min(b) < (2.0 * dfe).max(0.01 * c.f_hz)
                    })
                }) || (1..=2)
                    .any(|m| (c.f_hz - m as f64 * fm).abs() < (2.0 * dfe).max(0.01 * c.f_hz))
            })
            .cloned()
            .collect();
        if !side.is_empty() && loc != DefectLocation::OuterRace || side.len() >= 2 {
            let strength = side.iter().map(|c| c.excess_db).fold(0.0, f32::max);
            out.push(Candidate {
                effect: Effect::LoadZoneModulation { mod_hz: fm },
                evidence: evidence(format!("{} envelope line(s) at k·{fd:.1} ± m·{fm:.2} Hz sidebands or at m·{fm:.2} Hz: the impacts are amplitude-modulated", side.len()), side),
                strength,
            });
        }
    }

    // --- Smearing of the defect harmonics: slip or speed drift.
    if let Some(loc) = model.fault {
        if !has(model, "slip") && !has(model, "speed_drift") {
            let fd = model.op.freqs.impact_rate(loc);
            let band = ctx.cfg.env_band;
            let n = 16384;
            if let (Some((ms, df_m)), Some((ss, _))) = (
                band_envelope_spectrum(ctx.x, fs, band.lo_hz, band.hi_hz, n),
                band_envelope_spectrum(ctx.sim, fs, band.lo_hz, band.hi_hz, n),
            ) {
                let orders = [1usize, 2, 3, 4];
                let wm: Vec<f32> = orders
                    .iter()
                    .map(|&h| line_width(&ms, df_m, h as f32 * fd))
                    .collect();
                let ws: Vec<f32> = orders
                    .iter()
                    .map(|&h| line_width(&ss, df_m, h as f32 * fd))
                    .collect();
                let excess: Vec<f32> = wm.iter().zip(&ws).map(|(a, b)| a - b).collect();
                let grows = excess[3] > excess[0] && excess[2] > 0.0 && excess[3] > 1.0 * df_m;
                if grows {
                    // Speed drift moves the line between the record's halves; slip does not.
                    let half = ctx.x.len() / 2;
                    let h = 3.0;
                    let f1 = envelope_line(&ctx.x[..half], fs, band, h * fd, 8192);
                    let f2 = envelope_line(&ctx.x[half..], fs, band, h * fd, 8192);
                    let shift = match (f1, f2) {
                        (Some(a), Some(b)) => (b - a) / (h * fd),
                        _ => 0.0,
                    };
                    let mut figures = serde_json::Map::new();
                    figures.insert("line_rms_width_hz_measured".into(), serde_json::json!(wm));
                    figures.insert("line_rms_width_hz_model".into(), serde_json::json!(ws));
                    figures.insert(
                        "relative_rate_shift_between_halves".into(),
                        serde_json::json!(shift),
                    );
                    let strength = 6.0 + 10.0 * (excess[3] / df_m).min(3.0);
                    if shift.abs() > 0.0025 {
                        out.push(Candidate {
                            effect: Effect::SpeedDrift,
                            evidence: Evidence { summary: format!("defect harmonics smeared in proportion to order, and the defect rate moves by {:+.2} % between the record's halves: the speed drifts", 100.0 * shift), components: vec![], figures },
                            strength,
                        });
                    } else {
                        out.push(Candidate {
                            effect: Effect::Slip,
                            evidence: Evidence { summary: format!("defect harmonics smeared more with order (RMS widths {:?} Hz vs model {:?} Hz) at a steady rate: rolling-element slip", round2(&wm), round2(&ws)), components: vec![], figures },
                            strength,
                        });
                    }
                }
            }
        }
    }

    // --- Amplitude-dependent resonance frequency: nonlinear stiffness.
    if !has(model, "nonlinear_stiffness") {
        let fn_hz = model.get("ln_fn_hz").map_or(3000.0, f64::exp) as f32;
        let (lo, hi) = (0.75 * fn_hz, (1.25 * fn_hz).min(0.45 * fs));
        if let (Some((mh, mm)), Some((sh, sm))) = (
            amplitude_frequency_dependence(ctx.x, fs, lo, hi),
            amplitude_frequency_dependence(ctx.sim, fs, lo, hi),
        ) {
            let meas_shift = mh / mm - 1.0;
            let model_shift = sh / sm - 1.0;
            if meas_shift - model_shift > 0.01 {
                let mut figures = serde_json::Map::new();
                figures.insert("inst_freq_high_amplitude_hz".into(), serde_json::json!(mh));
                figures.insert("inst_freq_mid_amplitude_hz".into(), serde_json::json!(mm));
                figures.insert(
                    "model_relative_shift".into(),
                    serde_json::json!(model_shift),
                );
                out.push(Candidate {
                    effect: Effect::NonlinearStiffness,
                    evidence: Evidence {
                        summary: format!("the resonance near {fn_hz:.0} Hz runs {:.1} % faster at high amplitude than at mid amplitude (model: {:.1} %): hardening stiffness", 100.0 * meas_shift, 100.0 * model_shift),
                        components: vec![],
                        figures,
                    },
                    strength: 6.0 + 300.0 * (meas_shift - model_shift),
                });
            }
        }
    }

    out.sort_by(|a, b| b.strength.total_cmp(&a.strength));
    out
}

fn round2(v: &[f32]) -> Vec<f32> {
    v.iter().map(|x| (x * 100.0).round() / 100.0).collect()
}
