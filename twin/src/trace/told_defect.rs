//! A second defect read at the rates the bearing's geometry tells, where the
//! residual's line search finds none of its lines (a weaker compound fault).
//!
//! The residual's lines must stand 10 dB over their neighbours (`residual::analyse`)
//! because they are searched for at every frequency. A second defect's rate is not
//! searched for: the geometry and the speed tell it, and the first defect's fitted
//! rate factor tells the slip both share (the cage carries every element, so slip
//! scales every defect rate alike). At a told rate a family a few dB over its floor is
//! evidence, if the model's own realizations do not put it there as often: the first
//! defect's impacts, spread in strength and jittered by slip, raise the envelope's
//! floor and scatter lines over it. So the statistic, the family's level over its
//! local floor, is read on the record and on the model's draws (`super::null`), and a
//! second defect is offered only where the record stands [`NULL_Z`](super::null::NULL_Z)
//! above them and at least [`TOLD_MIN_DB`] over its floor. The refit still judges it
//! (its lines must fall by 3 dB and the cost by 1 %).

use super::context::{impact_modulations, load_zone_line, TraceContext};
use super::impact_train::{near_own_rate, SecondTrain};
use crate::residual::{band_envelope_spectrum, Component, Domain, Kind};
use crate::twin::fault_name;
use pumptwin_core::bearing::DefectLocation;

/// Least mean level of a told family's lines over their local floors, dB: the
/// physical minimum beside the null test (a line twice its floor's power; set before
/// any run and kept on `--seed 7`, not swept).
pub const TOLD_MIN_DB: f32 = 3.0;
/// Harmonics of the told rate read.
const HARMONICS: u32 = 3;
/// Half-width of the slip scanned about the first defect's rate factor, relative.
const SCAN: f64 = 0.01;
/// Step of that scan, relative.
const SCAN_STEP: f64 = 0.001;
/// Orders of the modulation a first defect's load zone puts sidebands at, read as its
/// own: Harris's zone spans ±66–90° of the turn (ε 0.3–0.5), under half of it, and a
/// pulse that narrow has sidebands out to about four orders (its spectrum's first
/// zero is near 360°/width ≈ 2–3 orders and it rolls off slowly after it). The
/// residual's tracers read ±2 (`context::ZONE_SIDEBANDS_READ`): their lines must stand
/// 10 dB out, which the outer ones do not; a told family is read a few dB over its
/// floor, where they do (on `--seed 7` case 24, a control, an inner race's fourth
/// lower sideband read as an outer race's rate, 5.7 dB).
const ZONE_SIDEBANDS: u32 = 4;
/// Envelope bins on each side of a member its floor is read over.
const FLOOR_BINS: usize = 32;

/// One scale of the slip scan: the scale and the frequencies of the family's members
/// there that no other source takes.
struct Scaled {
    scale: f64,
    members: Vec<f64>,
}

/// The told family read in one record's envelope spectrum: the scan's best scale,
/// its mean level over the members' floors (dB) and each member's `(frequency, level
/// dB)`.
struct Reading {
    level_db: f32,
    members: Vec<(f64, f32)>,
    scale: f64,
}

/// A second defect at a rate the geometry tells (see the module's docs), or `None`.
pub(super) fn told_defect(ctx: &TraceContext<'_>) -> Option<SecondTrain> {
    let model = ctx.model;
    let own = model.fault?;
    let fs = ctx.cfg.fs_hz;
    let band = ctx.cfg.env_band;
    let spectrum = |y: &[f32]| {
        band_envelope_spectrum(y, fs, band.lo_hz, band.hi_hz, ctx.cfg.env_n)
            .map(|(s, df)| (s, f64::from(df)))
    };
    let (meas, df) = spectrum(ctx.x)?;
    let freqs = &model.op.freqs;
    let shaft = f64::from(freqs.shaft);
    let own_rate = model.comb_rate_hz(own);
    let own_mods = impact_modulations(model, own);
    let tol = |f: f64| (1.5 * df).max(0.005 * f);
    // Lines the modelled defect and the shaft put in the envelope are theirs, and so
    // is any line the model's own simulation carries (its defect's intermodulation,
    // a ball's odd BSF harmonics): there the statistic would read how well the model
    // fits its own lines, which its realizations do not scatter.
    let (model_spec, _) = spectrum(ctx.sim)?;
    let taken = |f: f64| {
        let comb = (1..=10).any(|k| (f - f64::from(k) * own_rate).abs() < tol(f));
        let zone = own_mods
            .iter()
            .any(|&fm| load_zone_line(f, own_rate, fm, ZONE_SIDEBANDS, tol(f)));
        let orders = shaft > 0.0 && (f / shaft - (f / shaft).round()).abs() * shaft < tol(f);
        let modelled =
            member_level(&model_spec, df, f, tol(f)).is_some_and(|(_, db)| db >= TOLD_MIN_DB);
        comb || zone || orders || modelled
    };
    let env_max = f64::from(ctx.cfg.env_max_hz);
    let factor = 1.0 + model.get("rate_factor").unwrap_or(0.0);
    let mut best: Option<(f32, DefectLocation, Reading, super::null::NullTest)> = None;
    for loc in [
        DefectLocation::OuterRace,
        DefectLocation::InnerRace,
        DefectLocation::Ball,
    ] {
        let fd = f64::from(freqs.impact_rate(loc)) * factor;
        if loc == own || near_own_rate(fd, own_rate) {
            continue;
        }
        let fm = f64::from(freqs.modulation_rate(loc));
        // Which members are free is the same for the record and every draw.
        let family = family_members(fd, fm, env_max, &taken);
        let read = |spec: &[f32]| read_family(spec, df, &family, &tol);
        let Some(r) = read(&meas) else { continue };
        // An impact train's strongest envelope line is its fundamental: without it,
        // lines at its harmonics are other sources' (as in `defect_family`).
        let fundamental = fd * r.scale;
        let has_fundamental = r
            .members
            .iter()
            .any(|&(f, db)| (f - fundamental).abs() < tol(fundamental) && db >= TOLD_MIN_DB);
        if r.level_db < TOLD_MIN_DB || !has_fundamental {
            continue;
        }
        let null = ctx.nulls.test(r.level_db, |y| {
            spectrum(y).and_then(|(s, _)| read(&s)).map(|n| n.level_db)
        });
        let z = null.z();
        if null.significant() && best.as_ref().is_none_or(|b| z > b.0) {
            best = Some((z, loc, r, null));
        }
    }
    let (_, loc, r, null) = best?;
    let fd = f64::from(freqs.impact_rate(loc)) * factor * r.scale;
    let mut lines: Vec<Component> = r
        .members
        .iter()
        .filter(|&&(_, db)| db >= TOLD_MIN_DB)
        .map(|&(f, db)| Component {
            domain: Domain::Envelope,
            kind: Kind::Line,
            f_hz: f,
            width_hz: df,
            excess_db: db,
            order: f / shaft,
            centre_hz: None,
        })
        .collect();
    lines.sort_by(|a, b| a.f_hz.total_cmp(&b.f_hz));
    let mut harmonics: Vec<u32> = lines
        .iter()
        .map(|c| (c.f_hz / fd).round().max(1.0) as u32)
        .collect();
    harmonics.dedup();
    Some(SecondTrain {
        rate_hz: fd,
        source: fault_name(Some(loc)),
        harmonics,
        lines,
        null: Some(null),
    })
}

/// The family at `fd` (load zone `fm`, none for 0) over the slip scan ([`SCAN`]
/// about `fd`): at each scale, the members `k·fd + m·fm` (`k` ≤ [`HARMONICS`], `|m|`
/// ≤ 1) up to `env_max` that `taken` leaves free.
fn family_members(fd: f64, fm: f64, env_max: f64, taken: &dyn Fn(f64) -> bool) -> Vec<Scaled> {
    let steps = (SCAN / SCAN_STEP).round() as i32;
    let ms: &[i32] = if fm > 0.0 { &[-1, 0, 1] } else { &[0] };
    (-steps..=steps)
        .map(|step| {
            let scale = 1.0 + f64::from(step) * SCAN_STEP;
            let members = (1..=HARMONICS)
                .flat_map(|k| {
                    ms.iter()
                        .map(move |&m| f64::from(k) * fd * scale + f64::from(m) * fm)
                })
                .filter(|&f| f > 0.0 && f <= env_max && !taken(f))
                .collect();
            Scaled { scale, members }
        })
        .collect()
}

/// `family` read in `spec` (bin width `df`): each member as its peak within `tol`
/// over the median of [`FLOOR_BINS`] bins on either side; the scale whose mean level
/// is highest. `None` where no member can be read.
fn read_family(
    spec: &[f32],
    df: f64,
    family: &[Scaled],
    tol: &dyn Fn(f64) -> f64,
) -> Option<Reading> {
    let mut best: Option<Reading> = None;
    for s in family {
        let members: Vec<(f64, f32)> = s
            .members
            .iter()
            .filter_map(|&f| member_level(spec, df, f, tol(f)))
            .collect();
        if members.is_empty() {
            continue;
        }
        let mean = members
            .iter()
            .map(|&(_, db)| 10f32.powf(db / 10.0))
            .sum::<f32>()
            / members.len() as f32;
        let level_db = 10.0 * mean.log10();
        if best.as_ref().is_none_or(|b| level_db > b.level_db) {
            best = Some(Reading {
                level_db,
                members,
                scale: s.scale,
            });
        }
    }
    best
}

/// The strongest bin within `tol` of `f` over the median of the bins about it:
/// `(its frequency, level dB)`.
fn member_level(spec: &[f32], df: f64, f: f64, tol: f64) -> Option<(f64, f32)> {
    let lo = ((f - tol) / df).floor().max(1.0) as usize;
    let hi = (((f + tol) / df).ceil() as usize).min(spec.len().checked_sub(1)?);
    if lo > hi {
        return None;
    }
    let (k, peak) = (lo..=hi)
        .map(|k| (k, spec[k]))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    let a = lo.saturating_sub(FLOOR_BINS).max(1);
    let b = (hi + FLOOR_BINS).min(spec.len() - 1);
    let mut around: Vec<f32> = (a..=b)
        .filter(|j| *j < lo || *j > hi)
        .map(|j| spec[j])
        .collect();
    if around.is_empty() {
        return None;
    }
    let mid = around.len() / 2;
    let floor = *around.select_nth_unstable_by(mid, f32::total_cmp).1;
    (floor > 0.0).then(|| (k as f64 * df, 10.0 * (peak / floor).log10()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat_with_lines(lines: &[usize]) -> Vec<f32> {
        let mut spec = vec![1.0f32; 1000];
        for &k in lines {
            spec[k] = 10.0;
        }
        spec
    }

    /// The first defect's load zone owns its sidebands out to the fourth order on
    /// each side of every tooth, and the modulation's own lines; not the fifth.
    #[test]
    fn a_load_zone_owns_its_sidebands_to_the_fourth_order() {
        let (fd, fm, tol) = (333.4, 33.8, 1.0);
        let own = |f: f64| load_zone_line(f, fd, fm, ZONE_SIDEBANDS, tol);
        for m in 1..=ZONE_SIDEBANDS {
            let side = f64::from(m) * fm;
            for k in 1..=3 {
                let tooth = f64::from(k) * fd;
                assert!(own(tooth - side), "{k}·fd − {m}·fm");
                assert!(own(tooth + side), "{k}·fd + {m}·fm");
            }
            assert!(own(side), "{m}·fm");
        }
        assert!(!own(fd - 5.0 * fm));
        assert!(!own(fd + 0.5 * fm));
    }

    /// A family's lines read 10 dB over a flat floor wherever the slip puts them
    /// within the scan; a member another source takes is left out of the mean.
    #[test]
    fn a_family_reads_its_lines_over_their_floor_and_leaves_taken_ones() {
        let tol = |f: f64| 1.5f64.max(0.005 * f);
        let family = |taken: &dyn Fn(f64) -> bool| family_members(100.0, 0.0, 999.0, taken);
        let free = |_: f64| false;
        let on_rate = flat_with_lines(&[100, 200, 300]);
        let r = read_family(&on_rate, 1.0, &family(&free), &tol).expect("read");
        assert!((r.level_db - 10.0).abs() < 0.01, "{}", r.level_db);
        assert_eq!(r.members.len(), 3);
        let slow = flat_with_lines(&[99, 198, 297]);
        let r = read_family(&slow, 1.0, &family(&free), &tol).expect("read");
        assert!((r.level_db - 10.0).abs() < 0.01, "{}", r.level_db);
        assert!((r.scale - 0.99).abs() < 0.0015, "{}", r.scale);
        let taken = |f: f64| (f - 200.0).abs() < 3.0;
        let half = flat_with_lines(&[100, 300]);
        let r = read_family(&half, 1.0, &family(&taken), &tol).expect("read");
        assert_eq!(r.members.len(), 2);
        assert!((r.level_db - 10.0).abs() < 0.01, "{}", r.level_db);
        let r = read_family(&flat_with_lines(&[]), 1.0, &family(&free), &tol).expect("read");
        assert!(r.level_db.abs() < 0.01, "noise-free floor: {}", r.level_db);
    }
}
