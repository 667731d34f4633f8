//! The figures of a training or evaluation run (the paper's figures 4–9 are the
//! model): confusion matrix, noise curve, loss curves, a t-SNE map of the state
//! embeddings coloured by class, and the correlation heatmap of the node features;
//! the model radar and the ablation chart come from `pumptwin compare`
//! ([`crate::compare`]).
//!
//! t-SNE (van der Maaten & Hinton 2008), exact, as written here:
//!
//! ```text
//! p_j|i = exp(−‖x_i − x_j‖² / 2σ_i²) / Σ_k≠i exp(−‖x_i − x_k‖² / 2σ_i²)   σ_i by bisection
//!                                                                       to perplexity 30
//! P_ij  = (p_j|i + p_i|j) / 2n
//! q_ij  = (1 + ‖y_i − y_j‖²)⁻¹ / Σ_k≠l (1 + ‖y_k − y_l‖²)⁻¹
//! ∂C/∂y_i = 4 Σ_j (α·P_ij − q_ij)(y_i − y_j)(1 + ‖y_i − y_j‖²)⁻¹          α = 12 for the
//!                                                                       first 100 steps
//! ```
//! gradient descent with momentum (0.5, then 0.8) and learning rate 200, 600 steps;
//! at most 600 points (a deterministic stride over the test windows).

use std::path::Path;

use anyhow::{Context, Result};
use plotters::prelude::*;
use pumptwin_core::features::{FEATURE_DIM, FEATURE_NAMES};
use pumptwin_core::rng::Xoshiro128pp;

use crate::dataset::{ProtocolData, STEPS};
use crate::metrics::MetricsReport;
use crate::training::fit::EpochStats;
use crate::training::inference::Inference;
use pumptwin_twin::plot::{draw_legend, line_plot, register_font, PlotSpec, Series};

fn draw_err(path: &Path, e: impl std::fmt::Display) -> anyhow::Error {
    anyhow::anyhow!("cannot draw {}: {e}", path.display())
}

/// A heatmap of `values[row][col]` with optional cell annotations.
pub fn heatmap(
    path: &Path,
    title: &str,
    rows: &[String],
    cols: &[String],
    values: &[Vec<f64>],
    range: (f64, f64),
    annotate: &dyn Fn(usize, usize) -> Option<String>,
) -> Result<()> {
    register_font();
    let (nr, nc) = (rows.len(), cols.len());
    let cell = if nr.max(nc) > 12 { 34 } else { 56 };
    let size = ((170 + cell * nc) as u32, (110 + cell * nr + 90) as u32);
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_err(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(90)
        .y_label_area_size(150)
        .build_cartesian_2d(0f64..nc as f64, 0f64..nr as f64)
        .map_err(|e| draw_err(path, e))?;
    // Labels at the cell centres, drawn in pixels (the axis ticks would sit on the
    // cell borders).
    for (c, name) in cols.iter().enumerate() {
        let (px, py) = chart.backend_coord(&(c as f64 + 0.5, 0.0));
        root.draw(&Text::new(
            name.clone(),
            (px - 6, py + 6),
            ("sans-serif", 12)
                .into_font()
                .transform(FontTransform::Rotate90),
        ))
        .map_err(|e| draw_err(path, e))?;
    }
    for (r, name) in rows.iter().enumerate() {
        let (px, py) = chart.backend_coord(&(0.0, (nr - 1 - r) as f64 + 0.5));
        root.draw(&Text::new(
            name.clone(),
            (px - 140, py - 6),
            ("sans-serif", 12),
        ))
        .map_err(|e| draw_err(path, e))?;
    }
    let span = (range.1 - range.0).max(1e-12);
    for r in 0..nr {
        for c in 0..nc {
            let v = values[r][c];
            let t = ((v - range.0) / span).clamp(0.0, 1.0);
            let color = if range.0 < 0.0 {
                // Diverging: blue (−) → white → red (+).
                let s = 2.0 * t - 1.0;
                if s >= 0.0 {
                    RGBColor(255, (255.0 * (1.0 - s)) as u8, (255.0 * (1.0 - s)) as u8)
                } else {
                    RGBColor((255.0 * (1.0 + s)) as u8, (255.0 * (1.0 + s)) as u8, 255)
                }
            } else {
                RGBColor(
                    (255.0 * (1.0 - 0.8 * t)) as u8,
                    (255.0 * (1.0 - 0.55 * t)) as u8,
                    255,
                )
            };
            let (x, y) = (c as f64, (nr - 1 - r) as f64);
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(x, y), (x + 1.0, y + 1.0)],
                    color.filled(),
                )))
                .map_err(|e| draw_err(path, e))?;
            if let Some(text) = annotate(r, c) {
                chart
                    .draw_series(std::iter::once(Text::new(
                        text,
                        (x + 0.3, y + 0.65),
                        ("sans-serif", 12),
                    )))
                    .map_err(|e| draw_err(path, e))?;
            }
        }
    }
    root.present().map_err(|e| draw_err(path, e))?;
    Ok(())
}

/// Exact t-SNE of `x` (rows) to 2-D; see the module docs.
pub fn tsne(x: &[Vec<f32>], seed: u64) -> Vec<(f32, f32)> {
    let n = x.len();
    if n < 3 {
        return vec![(0.0, 0.0); n];
    }
    let d2 = |a: &[f32], b: &[f32]| -> f64 {
        a.iter().zip(b).map(|(u, v)| f64::from(u - v).powi(2)).sum()
    };
    let dist: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| d2(&x[i], &x[j])).collect())
        .collect();
    let perplexity = 30.0f64.min((n as f64 - 1.0) / 3.0);
    let target = perplexity.ln();
    let mut p = vec![vec![0.0f64; n]; n];
    for i in 0..n {
        let (mut lo, mut hi, mut beta) = (0.0f64, f64::INFINITY, 1.0f64);
        for _ in 0..60 {
            let mut sum = 0.0;
            let mut h = 0.0;
            for j in 0..n {
                if j != i {
                    let w = (-dist[i][j] * beta).exp();
                    p[i][j] = w;
                    sum += w;
                    h += beta * dist[i][j] * w;
                }
            }
            let sum = sum.max(1e-300);
            let entropy = sum.ln() + h / sum;
            for j in 0..n {
                p[i][j] /= sum;
            }
            if (entropy - target).abs() < 1e-5 {
                break;
            }
            if entropy > target {
                lo = beta;
                beta = if hi.is_finite() {
                    0.5 * (beta + hi)
                } else {
                    2.0 * beta
                };
            } else {
                hi = beta;
                beta = 0.5 * (beta + lo);
            }
        }
    }
    let mut pij = vec![vec![0.0f64; n]; n];
    for i in 0..n {
        for j in 0..n {
            pij[i][j] = ((p[i][j] + p[j][i]) / (2.0 * n as f64)).max(1e-12);
        }
    }
    let mut rng = Xoshiro128pp::seed_from_u64(seed);
    let mut y: Vec<[f64; 2]> = (0..n)
        .map(|_| [1e-4 * rng.normal(), 1e-4 * rng.normal()])
        .collect();
    let mut vel = vec![[0.0f64; 2]; n];
    let mut num = vec![vec![0.0f64; n]; n];
    for step in 0..600 {
        let exaggeration = if step < 100 { 12.0 } else { 1.0 };
        let momentum = if step < 250 { 0.5 } else { 0.8 };
        let mut z = 0.0;
        for i in 0..n {
            for j in (i + 1)..n {
                let dy0 = y[i][0] - y[j][0];
                let dy1 = y[i][1] - y[j][1];
                let q = 1.0 / (1.0 + dy0 * dy0 + dy1 * dy1);
                num[i][j] = q;
                num[j][i] = q;
                z += 2.0 * q;
            }
        }
        for i in 0..n {
            let mut g = [0.0f64; 2];
            for j in 0..n {
                if j == i {
                    continue;
                }
                let q = num[i][j];
                let m = (exaggeration * pij[i][j] - q / z) * q;
                g[0] += 4.0 * m * (y[i][0] - y[j][0]);
                g[1] += 4.0 * m * (y[i][1] - y[j][1]);
            }
            for k in 0..2 {
                vel[i][k] = momentum * vel[i][k] - 200.0 * g[k];
            }
        }
        for i in 0..n {
            y[i][0] += vel[i][0];
            y[i][1] += vel[i][1];
        }
    }
    y.iter().map(|p| (p[0] as f32, p[1] as f32)).collect()
}

/// A scatter of 2-D points coloured by class.
pub fn class_scatter(
    path: &Path,
    title: &str,
    points: &[(f32, f32)],
    labels: &[usize],
    classes: &[String],
) -> Result<()> {
    register_font();
    let (mut x0, mut x1, mut y0, mut y1) = (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
    for &(x, y) in points {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !(x0 < x1 && y0 < y1) {
        anyhow::bail!("no spread to plot in {}", path.display());
    }
    // Room on the right for the legend.
    let x1 = x1 + 0.3 * (x1 - x0);
    let root = BitMapBackend::new(path, (900, 760)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| draw_err(path, e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(30)
        .y_label_area_size(40)
        .build_cartesian_2d(x0..x1, y0..y1)
        .map_err(|e| draw_err(path, e))?;
    chart
        .configure_mesh()
        .disable_mesh()
        .draw()
        .map_err(|e| draw_err(path, e))?;
    for (c, name) in classes.iter().enumerate() {
        let color = Palette99::pick(c).to_rgba();
        chart
            .draw_series(
                points
                    .iter()
                    .zip(labels)
                    .filter(|(_, l)| **l == c)
                    .map(|(&(x, y), _)| Circle::new((x, y), 3, color.filled())),
            )
            .map_err(|e| draw_err(path, e))?
            .label(name.clone())
            .legend(move |(x, y)| Circle::new((x + 8, y), 4, color.filled()));
    }
    draw_legend(&mut chart, SeriesLabelPosition::UpperRight).map_err(|e| draw_err(path, e))?;
    root.present().map_err(|e| draw_err(path, e))?;
    Ok(())
}

/// Pearson correlation matrix of the node features over the training windows
/// (normalized features of present nodes, every step).
pub fn feature_correlation<const N: usize>(data: &ProtocolData<N>) -> Vec<Vec<f64>> {
    let ds = &data.train;
    let mut rows: Vec<&[f32]> = Vec::new();
    for k in 0..ds.len() {
        for t in 0..STEPS {
            for i in 0..N {
                if ds.mask[k * N + i] {
                    let o = ((k * STEPS + t) * N + i) * FEATURE_DIM;
                    rows.push(&ds.x[o..o + FEATURE_DIM]);
                }
            }
        }
    }
    let n = rows.len().max(1) as f64;
    let mean: Vec<f64> = (0..FEATURE_DIM)
        .map(|f| rows.iter().map(|r| f64::from(r[f])).sum::<f64>() / n)
        .collect();
    let mut c = vec![vec![0.0f64; FEATURE_DIM]; FEATURE_DIM];
    for a in 0..FEATURE_DIM {
        for b in a..FEATURE_DIM {
            let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
            for r in &rows {
                let (x, y) = (f64::from(r[a]) - mean[a], f64::from(r[b]) - mean[b]);
                sab += x * y;
                saa += x * x;
                sbb += y * y;
            }
            let v = if saa > 0.0 && sbb > 0.0 {
                sab / (saa * sbb).sqrt()
            } else {
                0.0
            };
            c[a][b] = v;
            c[b][a] = v;
        }
    }
    c
}

/// Write every figure of a run into `dir`.
pub fn run_figures<const N: usize>(
    dir: &Path,
    report: &MetricsReport,
    history: &[EpochStats],
    inference: &Inference,
    data: &ProtocolData<N>,
) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let classes = &report.classes;
    // Confusion matrix, row-normalized colours, counts written.
    let conf: Vec<Vec<f64>> = report
        .confusion
        .iter()
        .map(|row| {
            let s = row.iter().sum::<usize>().max(1) as f64;
            row.iter().map(|&v| v as f64 / s).collect()
        })
        .collect();
    heatmap(
        &dir.join("confusion.png"),
        &format!(
            "{} on {}: confusion (rows = true), accuracy {:.2} %",
            report.arch,
            report.protocol,
            100.0 * report.accuracy
        ),
        classes,
        classes,
        &conf,
        (0.0, 1.0),
        &|r, c| Some(report.confusion[r][c].to_string()),
    )?;
    // Noise curve.
    let pts: Vec<(f32, f32)> = report
        .noise
        .iter()
        .map(|p| (p.snr_db, 100.0 * p.accuracy as f32))
        .collect();
    line_plot(
        &dir.join("noise.png"),
        &PlotSpec {
            title: &format!(
                "{}: accuracy under white noise (clean-trained)",
                report.arch
            ),
            x_label: "SNR [dB]",
            y_label: "accuracy [%]",
            y_db: false,
            markers: &[],
        },
        &[Series {
            label: report.arch.clone(),
            points: pts,
        }],
    )?;
    // Loss curves.
    if !history.is_empty() {
        let curve = |label: &str, f: &dyn Fn(&EpochStats) -> f64| Series {
            label: label.to_string(),
            points: history
                .iter()
                .map(|s| (s.epoch as f32, f(s) as f32))
                .collect(),
        };
        let mut series = vec![
            curve("total loss", &|s| s.loss),
            curve("cross-entropy", &|s| s.cross_entropy),
        ];
        if history.iter().any(|s| s.spectral_loss > 0.0) {
            series.push(curve("L_phy (spectral)", &|s| s.spectral_loss));
            series.push(curve("F_map (Θ)", &|s| s.theta_loss));
        }
        series.push(curve("1 − train accuracy", &|s| 1.0 - s.train_accuracy));
        line_plot(
            &dir.join("loss.png"),
            &PlotSpec {
                title: &format!("{} on {}: training", report.arch, report.protocol),
                x_label: "epoch",
                y_label: "loss",
                y_db: false,
                markers: &[],
            },
            &series,
        )?;
    }
    // t-SNE of the state embeddings.
    let n = inference.embeddings.len();
    if n >= 10 {
        let stride = n.div_ceil(600);
        let pick: Vec<usize> = (0..n).step_by(stride).collect();
        let x: Vec<Vec<f32>> = pick
            .iter()
            .map(|&k| inference.embeddings[k].clone())
            .collect();
        let labels: Vec<usize> = pick.iter().map(|&k| data.test.label[k] as usize).collect();
        let y = tsne(&x, 7);
        class_scatter(
            &dir.join("embedding_tsne.png"),
            &format!(
                "{} on {}: t-SNE of the test-side state embeddings (true class)",
                report.arch, report.protocol
            ),
            &y,
            &labels,
            classes,
        )?;
    }
    // Feature correlation heatmap.
    let names: Vec<String> = FEATURE_NAMES.iter().map(|s| s.to_string()).collect();
    heatmap(
        &dir.join("feature_correlation.png"),
        "node feature correlation (training windows, present nodes)",
        &names,
        &names,
        &feature_correlation(data),
        (-1.0, 1.0),
        &|_, _| None,
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tsne_separates_two_clusters() {
        let mut rng = Xoshiro128pp::seed_from_u64(3);
        let x: Vec<Vec<f32>> = (0..60)
            .map(|k| {
                let c = if k < 30 { 0.0 } else { 10.0 };
                (0..5).map(|_| c + rng.normal() as f32).collect()
            })
            .collect();
        let y = tsne(&x, 1);
        let centre = |r: std::ops::Range<usize>| {
            let n = r.len() as f32;
            let (sx, sy) = r.fold((0.0, 0.0), |a, k| (a.0 + y[k].0, a.1 + y[k].1));
            (sx / n, sy / n)
        };
        let (a, b) = (centre(0..30), centre(30..60));
        let between = ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt();
        let within = (0..30)
            .map(|k| ((y[k].0 - a.0).powi(2) + (y[k].1 - a.1).powi(2)).sqrt())
            .sum::<f32>()
            / 30.0;
        assert!(between > 3.0 * within, "between {between}, within {within}");
    }
}
