//! `pumptwin report` on the README's main command's output: the shipped demo log
//! replayed by the edge (`--out` JSON lines), then drawn: every plot a PNG, the page
//! names each, the counts are the edge's.

use std::path::{Path, PathBuf};
use std::process::Command;

use pumptwin::report::{read_history, run_report, ReportArgs};

/// The edge binary `cargo test --workspace` builds beside this test's own.
fn edge_binary() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let dir = exe.parent()?.parent()?;
    let bin = dir.join(format!("pumptwin-edge{}", std::env::consts::EXE_SUFFIX));
    bin.is_file().then_some(bin)
}

#[test]
fn report_draws_the_demo_history() {
    let Some(edge) = edge_binary() else {
        println!("skip: pumptwin-edge is not built beside the tests (run `cargo test --workspace --release`)");
        return;
    };
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = std::env::temp_dir().join(format!("pumptwin-report-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let jsonl = dir.join("diagnoses.jsonl");
    let status = Command::new(edge)
        .current_dir(&root)
        .args([
            "--replay",
            "models/demo.log",
            "--sensors",
            "models/cwru-sensors.toml",
        ])
        .args(["--model", "models/dsstgat-cwru-tb.ptm", "--out"])
        .arg(&jsonl)
        .status()
        .unwrap();
    assert!(status.success());
    let text = std::fs::read_to_string(&jsonl).unwrap();
    let h = read_history(&text);
    assert_eq!(h.windows.len(), 116);
    assert!(h.bad_lines.is_empty());
    assert!(h.physics.len() > 100 && h.tracking.len() > 100);
    let out = dir.join("report");
    run_report(&ReportArgs {
        input: jsonl,
        out: out.clone(),
    })
    .unwrap();
    let page = std::fs::read_to_string(out.join("index.html")).unwrap();
    for png in [
        "class.png",
        "physics.png",
        "severity.png",
        "tracking.png",
        "health.png",
    ] {
        let bytes = std::fs::read(out.join(png)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG", "{png}");
        assert!(
            bytes.len() > 10_000,
            "{png}: {} bytes, nothing drawn?",
            bytes.len()
        );
        assert!(page.contains(&format!("<img src=\"{png}\"")), "{png}");
    }
    assert!(page.contains("116 windows") && page.contains("inner_race"));
    let _ = std::fs::remove_dir_all(&dir);
}
