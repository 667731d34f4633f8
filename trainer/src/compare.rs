//! The comparison table (`pumptwin compare`): every model of the comparison (the DS-STGAT, its three
//! ablations and the four baselines) on every protocol, in one table; below it, apart,
//! the DS-STGAT with the paper's derived temperature and pressure nodes (section 6.2,
//! [`pumptwin_data::derived`]), which sees five nodes computed from three sensors.
//!
//! Each (protocol, model) run lives in `RUNS/<protocol>/<model>/` as `pumptwin train`
//! writes it; a run whose `metrics.json` exists is reused, a missing one is trained
//! (same data, splits, seed and epochs for all). The table is written as
//! `OUT/compare.md` and `OUT/compare.json`, with `OUT/radar.png` (accuracy per
//! protocol and under noise, per model) and `OUT/ablation.png`.

use std::path::Path;

use anyhow::Result;
use plotters::prelude::*;
use serde::Serialize;

use crate::dataset::NodeSet;
use crate::training::artifacts::METRICS_FILE;
use crate::training::config::{run_name, value_name, Ablation, Arch};
use pumptwin_data::windows::Protocol;
use pumptwin_twin::plot::{draw_legend, register_font};

/// The models of the table, in row order.
pub const MODELS: [(Arch, Ablation); 8] = [
    (Arch::DsStgat, Ablation::None),
    (Arch::DsStgat, Ablation::NoCoadapt),
    (Arch::DsStgat, Ablation::NoPhysics),
    (Arch::DsStgat, Ablation::StaticGraph),
    (Arch::GcnGru, Ablation::None),
    (Arch::CoFusionCnn, Ablation::None),
    (Arch::Tst, Ablation::None),
    (Arch::Wdcnn, Ablation::None),
];

/// The models reported apart from the table (different inputs): the DS-STGAT with
/// the derived temperature and pressure nodes.
pub const SEPARATE: [(Arch, Ablation, NodeSet); 1] =
    [(Arch::DsStgat, Ablation::None, NodeSet::Derived)];

/// The run name of a model (`dsstgat`, `dsstgat-no-coadapt`, `wdcnn`,
/// `dsstgat+derived-nodes`, …): [`run_name`], as its `metrics.json` reports it.
pub fn model_name(arch: Arch, ablation: Ablation, nodes: NodeSet) -> String {
    run_name(
        &value_name(&arch),
        &value_name(&ablation),
        &value_name(&nodes),
    )
}

/// One row of the table.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// Model name.
    pub model: String,
    /// Accuracy per protocol (`null` where the run is missing), in `protocols` order.
    pub accuracy: Vec<Option<f64>>,
    /// Fault-only accuracy per protocol.
    pub fault_only_accuracy: Vec<Option<f64>>,
    /// Weighted F1 per protocol.
    pub f1_weighted: Vec<Option<f64>>,
    /// Time-block noise curve `(snr_db, accuracy)`.
    pub noise: Vec<(f32, f64)>,
    /// Time-block spectral consistency (DS-STGAT with co-adaptation).
    pub spectral_consistency: Option<f64>,
    /// Time-block response MSE, dB².
    pub response_mse: Option<f64>,
    /// Time-block parameter drift, z-units.
    pub parameter_drift: Option<f64>,
    /// Time-block training wall time, s.
    pub train_seconds: Option<f64>,
    /// Training / test windows per protocol.
    pub windows: Vec<Option<(usize, usize)>>,
}

/// The whole comparison.
#[derive(Debug, Clone, Serialize)]
pub struct Comparison {
    /// Protocol names, in column order.
    pub protocols: Vec<String>,
    /// One row per model ([`MODELS`]).
    pub rows: Vec<Row>,
    /// The models reported apart ([`SEPARATE`]), same columns.
    pub separate: Vec<Row>,
}

/// A run's `metrics.json`, if it exists and parses.
pub fn read_metrics(dir: &Path) -> Option<serde_json::Value> {
    let text = std::fs::read_to_string(dir.join(METRICS_FILE)).ok()?;
    serde_json::from_str(&text).ok()
}

/// The row of model `name` from its runs' `metrics.json` (one per protocol, `None`
/// where the run is missing).
pub fn row_from_metrics(
    name: String,
    protocols: &[Protocol],
    metrics: &[Option<serde_json::Value>],
) -> Row {
    let f = |m: &Option<serde_json::Value>, key: &str| {
        m.as_ref()
            .and_then(|v| v.get(key))
            .and_then(serde_json::Value::as_f64)
    };
    let tb = protocols
        .iter()
        .position(|p| *p == Protocol::TimeBlock)
        .and_then(|k| metrics[k].clone());
    let noise = tb
        .as_ref()
        .and_then(|v| v.get("noise"))
        .and_then(serde_json::Value::as_array)
        .map(|a| {
            a.iter()
                .filter_map(|p| {
                    Some((
                        p.get("snr_db")?.as_f64()? as f32,
                        p.get("accuracy")?.as_f64()?,
                    ))
                })
                .collect()
        })
        .unwrap_or_default();
    Row {
        model: name,
        accuracy: metrics.iter().map(|m| f(m, "accuracy")).collect(),
        fault_only_accuracy: metrics
            .iter()
            .map(|m| f(m, "fault_only_accuracy"))
            .collect(),
        f1_weighted: metrics.iter().map(|m| f(m, "f1_weighted")).collect(),
        noise,
        spectral_consistency: f(&tb, "spectral_consistency"),
        response_mse: f(&tb, "response_mse"),
        parameter_drift: f(&tb, "parameter_drift"),
        train_seconds: f(&tb, "train_seconds"),
        windows: metrics
            .iter()
            .map(|m| {
                Some((
                    f(m, "n_train_windows")? as usize,
                    f(m, "n_test_windows")? as usize,
                ))
            })
            .collect(),
    }
}

fn pct(v: Option<f64>) -> String {
    v.map_or_else(|| "–".into(), |a| format!("{:.2}", 100.0 * a))
}

fn num(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "–".into(), |a| format!("{a:.digits$}"))
}

/// The table as markdown, with the separately reported models in a second table.
pub fn markdown(cmp: &Comparison) -> String {
    let mut s = table(&cmp.protocols, &cmp.rows);
    s.push_str("\nWindows (train / test) per protocol: ");
    let w: Vec<String> = cmp
        .protocols
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let n = cmp.rows.iter().find_map(|r| r.windows[k]);
            n.map_or_else(|| format!("{p} –"), |(a, b)| format!("{p} {a} / {b}"))
        })
        .collect();
    s.push_str(&w.join(", "));
    s.push('\n');
    if !cmp.separate.is_empty() {
        s.push_str(
            "\nReported separately — the DS-STGAT with the paper's derived temperature and \
             pressure nodes (section 6.2, `--nodes derived`): five nodes, the two extra ones \
             computed per window from the DE signal (no sensor behind them; float only):\n\n",
        );
        s.push_str(&table(&cmp.protocols, &cmp.separate));
    }
    s
}

/// One markdown table of `rows`.
fn table(protocols: &[String], rows: &[Row]) -> String {
    let mut s = String::new();
    s.push_str("| model |");
    for p in protocols {
        s.push_str(&format!(" {p} acc % | {p} fault-only % |"));
    }
    s.push_str(" TB F1w | TB 0 dB % | TB −4 dB % | spectral consistency | response MSE dB² | parameter drift | train s |\n|---|");
    for _ in protocols {
        s.push_str("---|---|");
    }
    s.push_str("---|---|---|---|---|---|---|\n");
    for r in rows {
        s.push_str(&format!("| {} |", r.model));
        for k in 0..protocols.len() {
            s.push_str(&format!(
                " {} | {} |",
                pct(r.accuracy[k]),
                pct(r.fault_only_accuracy[k])
            ));
        }
        let at = |db: f32| {
            r.noise
                .iter()
                .find(|(s, _)| (*s - db).abs() < 1e-3)
                .map(|p| p.1)
        };
        let tb_f1 = protocols
            .iter()
            .position(|p| p == "time-block")
            .and_then(|k| r.f1_weighted[k]);
        s.push_str(&format!(
            " {} | {} | {} | {} | {} | {} | {} |\n",
            num(tb_f1, 4),
            pct(at(0.0)),
            pct(at(-4.0)),
            num(r.spectral_consistency, 3),
            num(r.response_mse, 1),
            num(r.parameter_drift, 3),
            num(r.train_seconds, 0)
        ));
    }
    s
}

fn chart_err(path: &Path, e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("cannot draw {}: {e}", path.display())
}

/// Radar chart: one polygon per model over the protocols' accuracies and the
/// time-block accuracies at 0 and −4 dB.
pub fn radar(path: &Path, cmp: &Comparison) -> Result<()> {
    register_font();
    let mut axes: Vec<String> = cmp.protocols.clone();
    axes.push("TB 0 dB".into());
    axes.push("TB −4 dB".into());
    let values = |r: &Row| -> Vec<f64> {
        let mut v: Vec<f64> = r.accuracy.iter().map(|a| a.unwrap_or(0.0)).collect();
        for db in [0.0f32, -4.0] {
            v.push(
                r.noise
                    .iter()
                    .find(|(s, _)| (*s - db).abs() < 1e-3)
                    .map_or(0.0, |p| p.1),
            );
        }
        v
    };
    let root = BitMapBackend::new(path, (900, 800)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| chart_err(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "accuracy by protocol and noise (1 = 100 %)",
            ("sans-serif", 20),
        )
        .margin(20)
        .build_cartesian_2d(-1.45f64..1.45, -1.3f64..1.3)
        .map_err(|e| chart_err(path, e))?;
    let n = axes.len();
    let angle =
        |k: usize| std::f64::consts::FRAC_PI_2 - 2.0 * std::f64::consts::PI * k as f64 / n as f64;
    for ring in [0.25, 0.5, 0.75, 1.0] {
        let pts: Vec<(f64, f64)> = (0..=n)
            .map(|k| (ring * angle(k % n).cos(), ring * angle(k % n).sin()))
            .collect();
        chart
            .draw_series(LineSeries::new(pts, BLACK.mix(0.2)))
            .map_err(|e| chart_err(path, e))?;
    }
    for (k, name) in axes.iter().enumerate() {
        let (c, s) = (angle(k).cos(), angle(k).sin());
        chart
            .draw_series(LineSeries::new([(0.0, 0.0), (c, s)], BLACK.mix(0.3)))
            .map_err(|e| chart_err(path, e))?;
        chart
            .draw_series(std::iter::once(Text::new(
                name.clone(),
                (1.1 * c - 0.12, 1.1 * s + 0.03),
                ("sans-serif", 15),
            )))
            .map_err(|e| chart_err(path, e))?;
    }
    for (i, r) in cmp.rows.iter().enumerate() {
        let v = values(r);
        let color = Palette99::pick(i).to_rgba();
        let pts: Vec<(f64, f64)> = (0..=n)
            .map(|k| {
                let a = v[k % n];
                (a * angle(k % n).cos(), a * angle(k % n).sin())
            })
            .collect();
        chart
            .draw_series(LineSeries::new(pts, color.stroke_width(2)))
            .map_err(|e| chart_err(path, e))?
            .label(r.model.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
    }
    draw_legend(&mut chart, SeriesLabelPosition::LowerRight).map_err(|e| chart_err(path, e))?;
    root.present().map_err(|e| chart_err(path, e))?;
    Ok(())
}

/// Ablation chart: accuracy per protocol of the DS-STGAT and its ablations.
pub fn ablation_chart(path: &Path, cmp: &Comparison) -> Result<()> {
    register_font();
    let rows: Vec<&Row> = cmp
        .rows
        .iter()
        .filter(|r| r.model.starts_with("dsstgat"))
        .collect();
    let groups = cmp.protocols.len();
    let root = BitMapBackend::new(path, (1000, 500)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| chart_err(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(
            "DS-STGAT ablations: test accuracy per protocol",
            ("sans-serif", 20),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..groups as f64, 0f64..100.0)
        .map_err(|e| chart_err(path, e))?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(groups * 2 + 1)
        .x_label_formatter(&|x| {
            let k = x.floor() as usize;
            if (x - k as f64 - 0.5).abs() < 0.26 {
                cmp.protocols.get(k).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .y_desc("accuracy [%]")
        .draw()
        .map_err(|e| chart_err(path, e))?;
    let width = 0.8 / rows.len().max(1) as f64;
    for (i, r) in rows.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series((0..groups).map(|g| {
                let x0 = g as f64 + 0.1 + i as f64 * width;
                let a = 100.0 * r.accuracy[g].unwrap_or(0.0);
                Rectangle::new([(x0, 0.0), (x0 + width * 0.9, a)], color.filled())
            }))
            .map_err(|e| chart_err(path, e))?
            .label(r.model.clone())
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], color.filled()));
    }
    draw_legend(&mut chart, SeriesLabelPosition::LowerRight).map_err(|e| chart_err(path, e))?;
    root.present().map_err(|e| chart_err(path, e))?;
    Ok(())
}
