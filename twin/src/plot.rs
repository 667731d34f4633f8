//! PNG line plots (time signals, spectra, envelope spectra) with an embedded font,
//! so plots render the same on a bare CI machine as on a workstation.

use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

/// A named series of `(x, y)` points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Points.
    pub points: Vec<(f32, f32)>,
}

/// Axis labels and scale of one plot.
#[derive(Debug, Clone)]
pub struct PlotSpec<'a> {
    /// Title above the plot.
    pub title: &'a str,
    /// X axis label.
    pub x_label: &'a str,
    /// Y axis label.
    pub y_label: &'a str,
    /// Plot `10·log10(y)` instead of `y` (y ≤ 0 is clamped to the smallest positive value).
    pub y_db: bool,
    /// Vertical marker lines `(x, label)`, e.g. defect frequencies.
    pub markers: &'a [(f32, String)],
}

/// Errors from plotting.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The drawing backend failed (file system, encoding).
    #[error("cannot draw {path}: {message}")]
    Draw {
        /// Output file.
        path: String,
        /// Backend message.
        message: String,
    },
    /// Nothing to plot.
    #[error("no finite points to plot in {0}")]
    Empty(String),
}

static FONT: Once = Once::new();

pub fn register_font() {
    FONT.call_once(|| {
        // DejaVu Sans from the `dejavu` crate; a failure leaves plotters without text
        // (it would then error at draw time, which `line_plot` reports).
        let _ = plotters::style::register_font(
            "sans-serif",
            FontStyle::Normal,
            dejavu::sans::regular(),
        );
    });
}

/// Draw the series legend of `chart` at `position` (white box, black border, 13 px).
pub fn draw_legend<'a, CT>(
    chart: &mut ChartContext<'a, BitMapBackend<'a>, CT>,
    position: SeriesLabelPosition,
) -> Result<(), String>
where
    CT: CoordTranslate,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 13))
        .draw()
        .map_err(|e| e.to_string())
}

/// Draw `series` as lines into a PNG at `path` (1000 × 420 px).
pub fn line_plot(path: &Path, spec: &PlotSpec<'_>, series: &[Series]) -> Result<(), PlotError> {
    register_font();
    let shown = path.display().to_string();
    let err = |e: &dyn std::fmt::Display| PlotError::Draw {
        path: shown.clone(),
        message: e.to_string(),
    };
    let tf = |y: f32| {
        if spec.y_db {
            10.0 * y.max(1e-30).log10()
        } else {
            y
        }
    };
    let mut x_range = (f32::INFINITY, f32::NEG_INFINITY);
    let mut y_range = (f32::INFINITY, f32::NEG_INFINITY);
    for s in series {
        for &(x, y) in &s.points {
            let y = tf(y);
            if x.is_finite() && y.is_finite() {
                x_range = (x_range.0.min(x), x_range.1.max(x));
                y_range = (y_range.0.min(y), y_range.1.max(y));
            }
        }
    }
    if !(x_range.0.is_finite() && x_range.1.is_finite()) {
        return Err(PlotError::Empty(shown));
    }
    if x_range.0 >= x_range.1 {
        // One x value (e.g. the loss curve of a one-epoch run): give it a width.
        x_range = (x_range.0 - 0.5, x_range.1 + 0.5);
    }
    if spec.y_db {
        y_range.0 = y_range.0.max(y_range.1 - 80.0);
    }
    let pad = 0.05 * (y_range.1 - y_range.0).max(1e-12);
    let root = BitMapBackend::new(path, (1000, 420)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(spec.title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(70)
        .build_cartesian_2d(x_range.0..x_range.1, (y_range.0 - pad)..(y_range.1 + pad))
        .map_err(|e| err(&e))?;
    chart
        .configure_mesh()
        .x_desc(spec.x_label)
        .y_desc(if spec.y_db {
            format!("{} [dB]", spec.y_label)
        } else {
            spec.y_label.to_string()
        })
        .label_style(("sans-serif", 14))
        .draw()
        .map_err(|e| err(&e))?;
    for (x, label) in spec.markers {
        chart
            .draw_series(LineSeries::new(
                [(*x, y_range.0 - pad), (*x, y_range.1 + pad)],
                ShapeStyle::from(&BLACK.mix(0.35)).stroke_width(1),
            ))
            .map_err(|e| err(&e))?;
        chart
            .draw_series(std::iter::once(Text::new(
                label.clone(),
                (*x, y_range.1),
                ("sans-serif", 13),
            )))
            .map_err(|e| err(&e))?;
    }
    for (i, s) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(
                s.points
                    .iter()
                    .map(|&(x, y)| (x, tf(y)))
                    .filter(|(x, y)| x.is_finite() && y.is_finite()),
                color.stroke_width(1),
            ))
            .map_err(|e| err(&e))?
            .label(s.label.clone())
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()
        .map_err(|e| err(&e))?;
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_a_png() {
        let dir = std::env::temp_dir().join(format!("pumptwin-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("t.png");
        let s = Series {
            label: "sine".into(),
            points: (0..100)
                .map(|i| (i as f32, (i as f32 / 10.0).sin()))
                .collect(),
        };
        let spec = PlotSpec {
            title: "t",
            x_label: "x",
            y_label: "y",
            y_db: false,
            markers: &[(50.0, "m".into())],
        };
        line_plot(&path, &spec, &[s]).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        let empty = Series {
            label: "e".into(),
            points: vec![],
        };
        assert!(matches!(
            line_plot(&path, &spec, &[empty]),
            Err(PlotError::Empty(_))
        ));
        // A single point still draws.
        let one = Series {
            label: "one".into(),
            points: vec![(1.0, 0.5)],
        };
        line_plot(&path, &spec, &[one]).unwrap();
    }
}
