//! `pumptwin eval-generalization` on the measured records of `../shared/data` (skipped
//! with a notice where they are absent): the physical diagnosis, whose every setting
//! was chosen on CWRU's 0.007" and 0.021" records, types every MFPT fault record and
//! every HIT-SM record (normal against fault without reading amplitude, then inner
//! against outer race) by the majority of its windows, and ≥ 90 % of their windows.

use std::path::{Path, PathBuf};

use pumptwin::generalization::{run_generalization, GeneralizationArgs};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The summary row of `protocol`: (physics windows %, physics records right, records).
fn physics_row(report: &str, protocol: &str) -> (f64, usize, usize) {
    let row = report
        .lines()
        .find(|l| l.starts_with(&format!("| `{protocol}` |")))
        .unwrap_or_else(|| panic!("no row for {protocol}"));
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    let windows: f64 = cells[4].trim_end_matches(" %").parse().unwrap();
    let (right, of) = cells[5].split_once(" of ").unwrap();
    (windows, right.parse().unwrap(), of.parse().unwrap())
}

#[test]
fn the_physics_types_other_rigs_it_was_never_tuned_on() {
    let data = root().join("../shared/data");
    if !data.join("mfpt/MANIFEST.tsv").exists() || !data.join("hit_sm/MANIFEST.tsv").exists() {
        eprintln!("skipped: no MFPT / HIT-SM data under {}", data.display());
        return;
    }
    let out = std::env::temp_dir().join(format!("pumptwin-gen-{}.md", std::process::id()));
    run_generalization(&GeneralizationArgs {
        data,
        model: root().join("models/dsstgat-cwru-tb.ptm"),
        fault_size_model: None,
        wdcnn: None,
        fault_size_wdcnn: None,
        out: out.clone(),
        windows_tsv: None,
        sim_records: 0,
        sim_seed: 1,
        sim_thresholds: None,
        segment: None,
    })
    .unwrap();
    let report = std::fs::read_to_string(&out).unwrap();
    let _ = std::fs::remove_file(&out);
    for (protocol, records) in [("cross-rig-mfpt", 14), ("cross-rig-hit", 21)] {
        let (windows, right, of) = physics_row(&report, protocol);
        assert_eq!((right, of), (records, records), "{protocol}");
        assert!(windows >= 90.0, "{protocol}: {windows} % of windows");
    }
}
