//! `pumptwin report`: the history a plant engineer looks at, from the edge's JSON lines
//! (`pumptwin-edge … --out diagnoses.jsonl`, or `--json` piped to a file).
//!
//! ```text
//! JSON lines (one per window; docs/output.md) → History: per window its time, status,
//!   the network's class and confidence; per physics run (deduplicated by the window
//!   it ran on, placed at that window's time) type, confidence, severity ± u, width;
//!   per tracking update (same) the stiffness and damping ratios to nominal; the
//!   health counters as they accumulate
//! → DIR/class.png, physics.png, severity.png, tracking.png, health.png (those with
//!   something to draw) and DIR/index.html: a summary table, the plots, how to read
//!   each, and every line that could not be read (counted, the first ones quoted)
//! ```
//!
//! A line that is not a JSON object or has no time is counted and reported, never
//! silently skipped; a file with no readable line is an error.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context, Result};
use serde_json::Value;

use crate::report_plot::{draw_categories, draw_lines, Category, Line};

/// `pumptwin report` flags.
#[derive(Debug, Clone, clap::Args)]
pub struct ReportArgs {
    /// The edge's JSON lines (one object per window).
    #[arg(long)]
    pub input: PathBuf,
    /// Output directory (PNGs and index.html).
    #[arg(long)]
    pub out: PathBuf,
}

/// One window's line, as far as the report reads it.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct WindowLine {
    /// Epoch seconds.
    pub t_s: f64,
    /// Window index.
    pub window: Option<u64>,
    /// `ok`, `degraded`, …
    pub status: String,
    /// The network's class and confidence.
    pub class: Option<(String, f64)>,
}

/// A physics run, at the time of the window it ran on.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PhysicsPoint {
    /// Epoch seconds.
    pub t_s: f64,
    /// Fault type and confidence.
    pub fault_type: String,
    /// Confidence.
    pub confidence: f64,
    /// Impact over background, dB, and its uncertainty.
    pub severity_db: Option<(f64, f64)>,
    /// Defect width, degrees, and whether it is only an upper bound.
    pub width_deg: Option<(f64, bool)>,
}

/// A tracking update, at the time of the window it ran on.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TrackingPoint {
    /// Epoch seconds.
    pub t_s: f64,
    /// Radial stiffness over nominal.
    pub stiffness_rel: f64,
    /// Radial damping over nominal.
    pub damping_rel: f64,
}

/// The history in a file of JSON lines.
#[derive(Debug, Clone, Default)]
pub struct History {
    /// Windows, in file order.
    pub windows: Vec<WindowLine>,
    /// Physics runs, one per window they ran on.
    pub physics: Vec<PhysicsPoint>,
    /// Tracking updates, one per window they ran on.
    pub tracking: Vec<TrackingPoint>,
    /// Health counters over time: name → (epoch seconds, value).
    pub health: BTreeMap<String, Vec<(f64, f64)>>,
    /// Lines that could not be read: (1-based line, why).
    pub bad_lines: Vec<(usize, String)>,
}

/// Read the history from JSON lines (module docs).
pub fn read_history(text: &str) -> History {
    let mut h = History::default();
    let mut time_of: BTreeMap<u64, f64> = BTreeMap::new();
    let mut physics_seen: BTreeSet<u64> = BTreeSet::new();
    let mut tracking_seen: BTreeSet<u64> = BTreeSet::new();
    let mut last_window = None;
    for (i, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let v: Value = match serde_json::from_str(line) {
            Ok(v @ Value::Object(_)) => v,
            Ok(_) => {
                h.bad_lines.push((i + 1, "not a JSON object".into()));
                continue;
            }
            Err(e) => {
                h.bad_lines.push((i + 1, format!("not JSON: {e}")));
                continue;
            }
        };
        let Some(t_s) = v["t_s"].as_f64().filter(|t| t.is_finite()) else {
            h.bad_lines
                .push((i + 1, "no `t_s` (not an edge window line)".into()));
            continue;
        };
        let window = v["window"].as_u64();
        // A window number that goes back is a restarted edge appending to the same
        // file: a new run, whose windows count from 0 again.
        if window.is_some() && window < last_window {
            time_of.clear();
            physics_seen.clear();
            tracking_seen.clear();
        }
        last_window = window.or(last_window);
        if let Some(w) = window {
            time_of.insert(w, t_s);
        }
        let class = v["diagnosis"]["class"].as_str().map(|c| {
            (
                c.to_string(),
                v["diagnosis"]["confidence"].as_f64().unwrap_or(f64::NAN),
            )
        });
        h.windows.push(WindowLine {
            t_s,
            window,
            status: v["status"].as_str().unwrap_or("").to_string(),
            class,
        });
        let at = |w: &Value| {
            w.as_u64()
                .and_then(|w| time_of.get(&w).copied())
                .unwrap_or(t_s)
        };
        let p = &v["physics"];
        if let (Some(ft), Some(w)) = (p["fault_type"].as_str(), p["window"].as_u64()) {
            if physics_seen.insert(w) {
                h.physics.push(physics_point(p, ft, at(&p["window"])));
            }
        }
        let tr = &v["tracking"];
        if let (Some("updated"), Some(w)) = (tr["status"].as_str(), tr["window"].as_u64()) {
            if tracking_seen.insert(w) {
                h.tracking.push(TrackingPoint {
                    t_s: at(&tr["window"]),
                    stiffness_rel: tr["stiffness_rel"].as_f64().unwrap_or(f64::NAN),
                    damping_rel: tr["damping_rel"].as_f64().unwrap_or(f64::NAN),
                });
            }
        }
        if let Some(counters) = v["health"].as_object() {
            for (name, value) in counters {
                if let Some(x) = value.as_f64() {
                    h.health.entry(name.clone()).or_default().push((t_s, x));
                }
            }
        }
    }
    h
}

fn physics_point(p: &Value, fault_type: &str, t_s: f64) -> PhysicsPoint {
    PhysicsPoint {
        t_s,
        fault_type: fault_type.to_string(),
        confidence: p["confidence"].as_f64().unwrap_or(f64::NAN),
        severity_db: p["severity_db"]
            .as_f64()
            .map(|s| (s, p["severity_uncertainty_db"].as_f64().unwrap_or(0.0))),
        width_deg: p["width"]["degrees"]
            .as_f64()
            .map(|d| (d, p["width"]["upper_bound"].as_bool().unwrap_or(false))),
    }
}

/// The time axis: seconds, hours or days since the first window, by the span.
#[derive(Debug, Clone, Copy)]
struct TimeAxis {
    t0: f64,
    unit_s: f64,
    label: &'static str,
}

impl TimeAxis {
    fn of(h: &History) -> Self {
        let t0 = h
            .windows
            .iter()
            .map(|w| w.t_s)
            .fold(f64::INFINITY, f64::min);
        let t1 = h
            .windows
            .iter()
            .map(|w| w.t_s)
            .fold(f64::NEG_INFINITY, f64::max);
        let (unit_s, label) = match t1 - t0 {
            s if s > 2.0 * 86_400.0 => (86_400.0, "time since the first window [days]"),
            s if s > 2.0 * 3_600.0 => (3_600.0, "time since the first window [h]"),
            _ => (1.0, "time since the first window [s]"),
        };
        Self { t0, unit_s, label }
    }

    fn x(&self, t_s: f64) -> f32 {
        ((t_s - self.t0) / self.unit_s) as f32
    }
}

/// Counts of each value, most frequent first.
fn counts<'a>(items: impl Iterator<Item = &'a str>) -> Vec<(String, usize)> {
    let mut m: BTreeMap<&str, usize> = BTreeMap::new();
    items.for_each(|s| *m.entry(s).or_default() += 1);
    let mut v: Vec<(String, usize)> = m.into_iter().map(|(k, n)| (k.to_string(), n)).collect();
    v.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(&b.0)));
    v
}

/// The PNGs the history has something for, each with what it shows.
fn draw_all(h: &History, axis: TimeAxis, dir: &Path) -> Result<Vec<(&'static str, &'static str)>> {
    let mut drawn = Vec::new();
    let network: Vec<Category> = h
        .windows
        .iter()
        .filter_map(|w| {
            w.class.as_ref().map(|(c, p)| Category {
                x: axis.x(w.t_s),
                name: c.clone(),
                confidence: *p as f32,
            })
        })
        .collect();
    if !network.is_empty() {
        draw_categories(
            &dir.join("class.png"),
            "The network's class per window",
            axis.label,
            &network,
        )?;
        drawn.push(("class.png", "The int8 DS-STGAT's class per window (top) and its confidence (bottom). A class the physics does not support is not a finding on its own: compare with the physics below."));
    }
    let physics: Vec<Category> = h
        .physics
        .iter()
        .map(|p| Category {
            x: axis.x(p.t_s),
            name: p.fault_type.clone(),
            confidence: p.confidence as f32,
        })
        .collect();
    if !physics.is_empty() {
        draw_categories(
            &dir.join("physics.png"),
            "The physical diagnosis (drive end)",
            axis.label,
            &physics,
        )?;
        drawn.push(("physics.png", "The physics' fault type from the envelope lines of the told bearing's defect rates (top) and its calibrated confidence (bottom); `no_clear_signature` when no defect's evidence stands out."));
    }
    let sev: Vec<(f32, f32, f32)> = h
        .physics
        .iter()
        .filter_map(|p| {
            p.severity_db
                .map(|(s, u)| (axis.x(p.t_s), s as f32, u as f32))
        })
        .collect();
    let width: Vec<(f32, f32)> = h
        .physics
        .iter()
        .filter_map(|p| p.width_deg.map(|(d, _)| (axis.x(p.t_s), d as f32)))
        .collect();
    if !sev.is_empty() {
        let mut lines = vec![
            Line::new(
                "impact over background [dB]",
                sev.iter().map(|&(x, s, _)| (x, s)).collect(),
            ),
            Line::new(
                "+ uncertainty",
                sev.iter().map(|&(x, s, u)| (x, s + u)).collect(),
            )
            .thin(),
            Line::new(
                "− uncertainty",
                sev.iter().map(|&(x, s, u)| (x, s - u)).collect(),
            )
            .thin(),
        ];
        if !width.is_empty() {
            lines.push(Line::new("defect width [°] (bound or estimate)", width.clone()).dots());
        }
        draw_lines(
            &dir.join("severity.png"),
            "Severity trend",
            axis.label,
            "dB  /  degrees",
            &lines,
        )?;
        drawn.push(("severity.png", "Impact power over the band's background (dB, with its uncertainty from the envelope spectrum's scatter) and the defect width in degrees of the damaged race where the entry-to-exit delay is read (often only an upper bound). A rising trend at constant speed and load is the warning sign, not one value."));
    }
    if !h.tracking.is_empty() {
        let x: Vec<f32> = h.tracking.iter().map(|p| axis.x(p.t_s)).collect();
        let bound = |v: f32| {
            Line::new(
                if v < 1.0 { "clamp 0.5" } else { "clamp 1.5" },
                x.iter().map(|&x| (x, v)).collect(),
            )
            .thin()
        };
        let lines = vec![
            Line::new(
                "stiffness / nominal",
                h.tracking
                    .iter()
                    .map(|p| (axis.x(p.t_s), p.stiffness_rel as f32))
                    .collect(),
            ),
            Line::new(
                "damping / nominal",
                h.tracking
                    .iter()
                    .map(|p| (axis.x(p.t_s), p.damping_rel as f32))
                    .collect(),
            ),
            bound(0.5),
            bound(1.5),
        ];
        draw_lines(
            &dir.join("tracking.png"),
            "Tracked bearing stiffness and damping",
            axis.label,
            "ratio to nominal",
            &lines,
        )?;
        drawn.push(("tracking.png", "The edge's on-line update of the radial stiffness and damping of the bearing model (eq. 10), as ratios to nominal. A ratio at 0.5 or 1.5 is the tracker's clamp, not a measurement: the record wants more than the tracker allows."));
    }
    let health = health_lines(h, axis);
    if !health.is_empty() {
        draw_lines(
            &dir.join("health.png"),
            "Health counters (cumulative)",
            axis.label,
            "count",
            &health,
        )?;
        drawn.push(("health.png", "Windows and degraded windows, and every counter of rejected or missing input that is not zero (malformed frames, unknown identifiers, lost frames, …): a rising counter means the data path, not the bearing, needs attention."));
    }
    Ok(drawn)
}

/// The health counters worth a line: windows, degraded windows, and every other
/// counter of trouble that is ever non-zero.
fn health_lines(h: &History, axis: TimeAxis) -> Vec<Line> {
    const VOLUME: [&str; 2] = ["frames_total", "used"];
    h.health
        .iter()
        .filter(|(name, pts)| {
            !VOLUME.contains(&name.as_str())
                && (matches!(name.as_str(), "windows" | "degraded_windows")
                    || pts.iter().any(|&(_, v)| v != 0.0))
        })
        .map(|(name, pts)| {
            Line::new(
                name,
                pts.iter().map(|&(t, v)| (axis.x(t), v as f32)).collect(),
            )
        })
        .collect()
}

/// HTML-escape text.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The one-page summary beside the plots.
fn html(h: &History, input: &Path, axis: TimeAxis, drawn: &[(&str, &str)]) -> String {
    let mut s = String::new();
    let span = h.windows.last().map_or(0.0, |w| axis.x(w.t_s));
    let _ = write!(
        s,
        "<!doctype html>\n<html><head><meta charset=\"utf-8\"><title>pumptwin report</title>\n\
         <style>body{{font-family:sans-serif;max-width:1040px;margin:auto}}\
         table{{border-collapse:collapse}}td,th{{border:1px solid #bbb;padding:3px 8px;text-align:left}}\
         img{{max-width:100%}}</style></head><body>\n<h1>Bearing history</h1>\n\
         <p>From <code>{}</code>: {} windows over {span:.2} {}. Every field is explained in \
         <code>docs/output.md</code> of the pumptwin repository.</p>\n",
        esc(&input.display().to_string()),
        h.windows.len(),
        axis.label.rsplit('[').next().unwrap_or("").trim_end_matches(']'),
    );
    let table = |s: &mut String, title: &str, rows: &[(String, usize)], total: usize| {
        let _ = write!(
            s,
            "<h2>{}</h2>\n<table><tr><th></th><th>windows</th><th>share</th></tr>\n",
            esc(title)
        );
        for (k, n) in rows {
            let _ = writeln!(
                s,
                "<tr><td>{}</td><td>{n}</td><td>{:.0} %</td></tr>",
                esc(k),
                100.0 * *n as f64 / total.max(1) as f64
            );
        }
        s.push_str("</table>\n");
    };
    let classes = counts(
        h.windows
            .iter()
            .filter_map(|w| w.class.as_ref().map(|c| c.0.as_str())),
    );
    table(&mut s, "The network's classes", &classes, h.windows.len());
    let types = counts(h.physics.iter().map(|p| p.fault_type.as_str()));
    table(&mut s, "The physics' types", &types, h.physics.len());
    let status = counts(h.windows.iter().map(|w| w.status.as_str()));
    table(&mut s, "Window status", &status, h.windows.len());
    if let Some(last) = h.physics.last() {
        let _ = write!(
            s,
            "<p>Latest physics: <b>{}</b> at confidence {:.2}",
            esc(&last.fault_type),
            last.confidence
        );
        if let Some((sev, u)) = last.severity_db {
            let _ = write!(s, ", severity {sev:.1} ± {u:.1} dB");
        }
        s.push_str(".</p>\n");
    }
    for (file, what) in drawn {
        let _ = write!(
            s,
            "<h2>{file}</h2>\n<p>{}</p>\n<img src=\"{file}\" alt=\"{file}\">\n",
            esc(what)
        );
    }
    if !h.bad_lines.is_empty() {
        let _ = write!(s, "<h2>Lines not read: {}</h2>\n<ul>\n", h.bad_lines.len());
        for (line, why) in h.bad_lines.iter().take(20) {
            let _ = writeln!(s, "<li>line {line}: {}</li>", esc(why));
        }
        s.push_str("</ul>\n");
    }
    s.push_str("</body></html>\n");
    s
}

/// `pumptwin report`.
pub fn run_report(args: &ReportArgs) -> Result<()> {
    let bytes =
        std::fs::read(&args.input).with_context(|| format!("read {}", args.input.display()))?;
    // A damaged byte spoils its line (counted as not read), not the whole history.
    let h = read_history(&String::from_utf8_lossy(&bytes));
    if h.windows.is_empty() {
        let why = h
            .bad_lines
            .first()
            .map_or("the file is empty".to_string(), |(l, w)| {
                format!("line {l}: {w}")
            });
        bail!(
            "{}: no window line to report ({} lines not read; {why})",
            args.input.display(),
            h.bad_lines.len()
        );
    }
    std::fs::create_dir_all(&args.out).with_context(|| format!("create {}", args.out.display()))?;
    let axis = TimeAxis::of(&h);
    let drawn = draw_all(&h, axis, &args.out)?;
    let page = args.out.join("index.html");
    std::fs::write(&page, html(&h, &args.input, axis, &drawn))
        .with_context(|| format!("write {}", page.display()))?;
    eprintln!(
        "pumptwin report: {} windows, {} physics runs, {} tracking updates; {} plots and {}",
        h.windows.len(),
        h.physics.len(),
        h.tracking.len(),
        drawn.len(),
        page.display()
    );
    if !h.bad_lines.is_empty() {
        eprintln!(
            "pumptwin report: warning: {} lines not read (first: line {}: {})",
            h.bad_lines.len(),
            h.bad_lines[0].0,
            h.bad_lines[0].1
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const LINES: &str = r#"{"t_s":100.0,"window":0,"status":"degraded","diagnosis":{"class":"normal","confidence":1.0},"physics":null,"tracking":{"status":"skipped","window":null},"health":{"frames_total":10,"windows":1,"degraded_windows":1,"malformed":0}}
not json
{"t_s":100.5,"window":1,"status":"ok","diagnosis":{"class":"IR007","confidence":0.9},"physics":{"window":0,"fault_type":"inner_race","confidence":0.95,"severity_db":1.5,"severity_uncertainty_db":0.2,"width":{"degrees":4.0,"upper_bound":true}},"tracking":{"status":"updated","window":0,"stiffness_rel":0.9,"damping_rel":1.2},"health":{"frames_total":20,"windows":2,"degraded_windows":1,"malformed":2}}
{"t_s":101.0,"window":2,"status":"ok","diagnosis":{"class":"IR007","confidence":0.8},"physics":{"window":0,"fault_type":"inner_race","confidence":0.95},"tracking":{"status":"updated","window":0,"stiffness_rel":0.9,"damping_rel":1.2},"health":{"frames_total":30,"windows":3,"degraded_windows":1,"malformed":2}}
[1,2]
"#;

    #[test]
    fn history_reads_windows_dedupes_runs_and_counts_bad_lines() {
        let h = read_history(LINES);
        assert_eq!(h.windows.len(), 3);
        assert_eq!(h.windows[1].class, Some(("IR007".into(), 0.9)));
        assert_eq!(h.physics.len(), 1, "one run per window it ran on");
        assert_eq!(
            h.physics[0].t_s, 100.0,
            "at the time of the window it ran on"
        );
        assert_eq!(h.physics[0].severity_db, Some((1.5, 0.2)));
        assert_eq!(h.tracking.len(), 1);
        assert_eq!(h.bad_lines.iter().map(|b| b.0).collect::<Vec<_>>(), [2, 5]);
        let axis = TimeAxis::of(&h);
        let lines = health_lines(&h, axis);
        let names: Vec<&str> = lines.iter().map(|l| l.label.as_str()).collect();
        assert_eq!(names, ["degraded_windows", "malformed", "windows"]);
    }

    /// A restarted edge appending to the same file counts its windows from 0 again:
    /// its physics and tracking are a new run's, not duplicates; a value no chart can
    /// place (review finding: 3.3e38 hung plotters' tick search) is left out.
    #[test]
    fn a_restarted_run_is_read_and_huge_values_do_not_hang_the_plots() {
        let twice = format!("{LINES}{LINES}");
        let h = read_history(&twice);
        assert_eq!(h.windows.len(), 6);
        assert_eq!((h.physics.len(), h.tracking.len()), (2, 2));
        let huge = LINES.replace(r#""stiffness_rel":0.9"#, r#""stiffness_rel":3.3e38"#);
        let dir = std::env::temp_dir().join(format!("pumptwin-report-huge-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let input = dir.join("d.jsonl");
        std::fs::write(&input, huge).unwrap();
        run_report(&ReportArgs {
            input,
            out: dir.join("out"),
        })
        .unwrap();
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn report_writes_plots_and_a_page_or_refuses_an_empty_history() {
        let dir = std::env::temp_dir().join(format!("pumptwin-report-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let input = dir.join("d.jsonl");
        std::fs::write(&input, LINES).unwrap();
        let out = dir.join("out");
        run_report(&ReportArgs {
            input: input.clone(),
            out: out.clone(),
        })
        .unwrap();
        for f in [
            "class.png",
            "physics.png",
            "severity.png",
            "tracking.png",
            "health.png",
        ] {
            let b = std::fs::read(out.join(f)).unwrap();
            assert_eq!(&b[1..4], b"PNG", "{f}");
        }
        let page = std::fs::read_to_string(out.join("index.html")).unwrap();
        assert!(page.contains("Lines not read: 2") && page.contains("inner_race"));
        std::fs::write(&input, "garbage\n").unwrap();
        let err = run_report(&ReportArgs { input, out }).unwrap_err();
        assert!(err.to_string().contains("no window line"), "{err}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}
