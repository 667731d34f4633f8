//! The trend plots of `pumptwin report` (PNG, plotters with the embedded DejaVu font
//! that `pumptwin_twin::plot` registers, so they render alike on a bare machine).

use std::path::Path;

use anyhow::{anyhow, Result};
use plotters::prelude::*;
use pumptwin_twin::plot::register_font;

/// One categorical observation: a class or type at a time, with its confidence.
#[derive(Debug, Clone, PartialEq)]
pub struct Category {
    /// Time axis value.
    pub x: f32,
    /// The class or type.
    pub name: String,
    /// Its confidence, 0–1.
    pub confidence: f32,
}

/// How a line is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Style {
    Solid,
    Thin,
    Dots,
}

/// A named series of points.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    /// Legend label.
    pub label: String,
    points: Vec<(f32, f32)>,
    style: Style,
}

impl Line {
    /// A solid line.
    pub fn new(label: &str, points: Vec<(f32, f32)>) -> Self {
        Self {
            label: label.to_string(),
            points,
            style: Style::Solid,
        }
    }

    /// Drawn thin and pale (bounds, uncertainty).
    pub fn thin(self) -> Self {
        Self {
            style: Style::Thin,
            ..self
        }
    }

    /// Drawn as dots (sparse estimates).
    pub fn dots(self) -> Self {
        Self {
            style: Style::Dots,
            ..self
        }
    }
}

fn draw_err(path: &Path) -> impl Fn(&dyn std::fmt::Display) -> anyhow::Error + '_ {
    move |e| anyhow!("cannot draw {}: {e}", path.display())
}

/// Whether a chart can place `v`: finite and within ±1e30 (beyond, the axis' padding
/// overflows f32 and plotters' search for tick marks never ends). A value past it is
/// left out of the plot, as a non-finite one is.
fn drawable(v: f32) -> bool {
    v.is_finite() && v.abs() <= 1e30
}

/// The drawable range of values, widened when it is a point.
fn range(values: impl Iterator<Item = f32>) -> Option<(f32, f32)> {
    let (lo, hi) = values
        .filter(|&v| drawable(v))
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    if !lo.is_finite() {
        return None;
    }
    let pad = 0.05 * (hi - lo).max(1e-3);
    Some(if hi > lo {
        (lo - pad, hi + pad)
    } else {
        (lo - 0.5, hi + 0.5)
    })
}

/// Lines over time into a PNG (1000 × 420 px).
pub fn draw_lines(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    lines: &[Line],
) -> Result<()> {
    register_font();
    let err = draw_err(path);
    let pts = || lines.iter().flat_map(|l| l.points.iter());
    let (Some(xr), Some(yr)) = (range(pts().map(|p| p.0)), range(pts().map(|p| p.1))) else {
        return Err(anyhow!("{}: nothing to plot", path.display()));
    };
    let root = BitMapBackend::new(path, (1000, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(xr.0..xr.1, yr.0..yr.1)
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| err(&e))?;
    for (i, l) in lines.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let finite = l
            .points
            .iter()
            .copied()
            .filter(|&(x, y)| drawable(x) && drawable(y));
        let anno = match l.style {
            Style::Dots => chart
                .draw_series(finite.map(|p| Circle::new(p, 3, color.filled())))
                .map_err(|e| err(&e))?,
            Style::Solid | Style::Thin => {
                let style = if l.style == Style::Thin {
                    color.mix(0.45).stroke_width(1)
                } else {
                    color.stroke_width(2)
                };
                chart
                    .draw_series(LineSeries::new(finite, style))
                    .map_err(|e| err(&e))?
            }
        };
        anno.label(l.label.clone()).legend(move |(x, y)| {
            PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
        });
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// Classes over time (top: one row per class, a dot per window) and the confidence
/// (bottom) into a PNG (1000 × 560 px).
pub fn draw_categories(path: &Path, title: &str, x_label: &str, points: &[Category]) -> Result<()> {
    register_font();
    let err = draw_err(path);
    let Some(xr) = range(points.iter().map(|p| p.x)) else {
        return Err(anyhow!("{}: nothing to plot", path.display()));
    };
    let mut names: Vec<&str> = points.iter().map(|p| p.name.as_str()).collect();
    names.sort_unstable();
    names.dedup();
    let row = |n: &str| names.iter().position(|m| *m == n).unwrap_or(0) as f32;
    let root = BitMapBackend::new(path, (1000, 560)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(title, ("sans-serif", 20))
        .map_err(|e| err(&e))?;
    let (top, bottom) = root.split_vertically(330);
    let label_of = |y: &f32| {
        let k = y.round();
        if (y - k).abs() < 1e-3 && k >= 0.0 {
            names
                .get(k as usize)
                .map_or(String::new(), |s| s.to_string())
        } else {
            String::new()
        }
    };
    let mut chart = ChartBuilder::on(&top)
        .margin(10)
        .x_label_area_size(25)
        .y_label_area_size(150)
        .build_cartesian_2d(xr.0..xr.1, -0.5f32..(names.len() as f32 - 0.5))
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .y_labels(names.len() * 2 + 1)
        .y_label_formatter(&label_of)
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| err(&e))?;
    for (i, name) in names.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(
                points
                    .iter()
                    .filter(|p| p.name == *name && drawable(p.x))
                    .map(|p| Circle::new((p.x, row(&p.name)), 3, color.filled())),
            )
            .map_err(|e| err(&e))?;
    }
    let mut conf = ChartBuilder::on(&bottom)
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(150)
        .build_cartesian_2d(xr.0..xr.1, 0f32..1.05f32)
        .map_err(|e| err(&e))?;
    conf.configure_mesh()
        .x_desc(x_label)
        .y_desc("confidence")
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| err(&e))?;
    for (i, name) in names.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        conf.draw_series(
            points
                .iter()
                .filter(|p| p.name == *name && drawable(p.x) && p.confidence.is_finite())
                .map(|p| Circle::new((p.x, p.confidence), 2, color.filled())),
        )
        .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}
