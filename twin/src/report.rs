//! Writing a loop's results: `report.json` and the before/after plots.

use super::closed_loop::{envelope_pairs, psd_pairs, LoopArtifacts, LoopReport};
use crate::plot::{line_plot, PlotSpec, Series};
use std::path::Path;

/// Write `dir/report.json`, `psd_before.png`, `psd_after.png`, `envelope_before.png`,
/// `envelope_after.png`, `residual.png`, and the power spectra behind the plots as
/// `psd.csv` (`f_hz,measured_db,model_first_db,model_final_db`) for re-plotting.
pub fn write(
    dir: &Path,
    report: &LoopReport,
    a: &LoopArtifacts,
    markers: &[(f32, String)],
) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir)?;
    std::fs::write(
        dir.join("report.json"),
        serde_json::to_string_pretty(report)? + "\n",
    )?;
    let (first, last) = (psd_pairs(a, &a.initial), psd_pairs(a, &a.final_));
    for (name, sig, psd_points, when) in [
        ("before", &a.initial, &first, "first fit"),
        ("after", &a.final_, &last, "final model"),
    ] {
        let psd = PlotSpec {
            title: "",
            x_label: "frequency [Hz]",
            y_label: "PSD [dB]",
            y_db: false,
            markers: &[],
        };
        plot_pair(
            &dir.join(format!("psd_{name}.png")),
            "power spectrum",
            &psd,
            psd_points,
            when,
        )?;
        let env = PlotSpec {
            title: "",
            x_label: "frequency [Hz]",
            y_label: "envelope power",
            y_db: false,
            markers,
        };
        plot_pair(
            &dir.join(format!("envelope_{name}.png")),
            "envelope spectrum",
            &env,
            &envelope_pairs(a, sig),
            when,
        )?;
    }
    let mut csv = String::from("f_hz,measured_db,model_first_db,model_final_db\n");
    for (p, q) in first.iter().zip(&last) {
        csv.push_str(&format!("{:.3},{:.3},{:.3},{:.3}\n", p.0, p.1, p.2, q.2));
    }
    std::fs::write(dir.join("psd.csv"), csv)?;
    let series = vec![Series {
        label: "measured − final model".into(),
        points: a.residual.psd_residual.clone(),
    }];
    let floor = format!(
        "residual (threshold {:.1} dB over the median)",
        a.residual.psd_threshold_db
    );
    line_plot(
        &dir.join("residual.png"),
        &PlotSpec {
            title: &floor,
            x_label: "frequency [Hz]",
            y_label: "dB",
            y_db: false,
            markers: &[],
        },
        &series,
    )?;
    Ok(())
}

/// One plot of `(f, measured, model)` triples: "<what>, measured vs model (<when>)".
fn plot_pair(
    path: &Path,
    what: &str,
    spec: &PlotSpec<'_>,
    pairs: &[(f32, f32, f32)],
    when: &str,
) -> anyhow::Result<()> {
    let series = [
        Series {
            label: "measured".into(),
            points: pairs.iter().map(|p| (p.0, p.1)).collect(),
        },
        Series {
            label: format!("model ({when})"),
            points: pairs.iter().map(|p| (p.0, p.2)).collect(),
        },
    ];
    let title = format!("{what}, measured vs model ({when})");
    line_plot(
        path,
        &PlotSpec {
            title: &title,
            ..spec.clone()
        },
        &series,
    )?;
    Ok(())
}
