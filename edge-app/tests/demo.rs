//! The README's main command: the shipped demo log (1 s from the test side — the last
//! 30 % — of each 0 HP CWRU record, in the order below) replayed through the shipped
//! sensor map and int8 model. Every record's majority class over the windows that lie
//! wholly inside it is the record's label, and most such windows are right. The
//! physical diagnosis, over the 16 shaft revolutions (8 192 samples) ending with a
//! window, names the race of every inner- and outer-race record whose stretch lies
//! wholly inside it.

use std::path::Path;
use std::process::Command;

/// The demo's records, in log order, with their labels.
const SEGMENTS: [&str; 10] = [
    "normal", "IR007", "IR014", "IR021", "B007", "B014", "B021", "OR007", "OR014", "OR021",
];
/// Samples per segment (1.0 s at 12 kHz).
const SEGMENT: u64 = 12_000;
/// The band-limit filter's delay: window samples lag the log by this many.
const FIR_DELAY: u64 = 50;

#[test]
fn demo_log_diagnoses_match_the_records_labels() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = Command::new(env!("CARGO_BIN_EXE_pumptwin-edge"))
        .current_dir(&root)
        .args([
            "--replay",
            "models/demo.log",
            "--sensors",
            "models/cwru-sensors.toml",
            "--model",
            "models/dsstgat-cwru-tb.ptm",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut votes = vec![std::collections::BTreeMap::<String, usize>::new(); SEGMENTS.len()];
    let (mut inside, mut right) = (0, 0);
    let mut starts = std::collections::BTreeMap::new();
    let mut physics_checked = 0;
    let mut classes = std::collections::BTreeMap::new();
    let mut warned = 0;
    for line in String::from_utf8(out.stdout).unwrap().lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        classes.insert(
            v["window"].as_u64().unwrap(),
            v["diagnosis"]["class"].as_str().unwrap().to_string(),
        );
        // A line warns exactly where the physics of a window does not support the
        // network's class of that window, or names another defect.
        if let (Some(n), Some(t)) = (
            v["physics"]["window"].as_u64(),
            v["physics"]["fault_type"].as_str(),
        ) {
            let net = match &classes[&n][..2] {
                "IR" => "inner_race",
                "OR" => "outer_race",
                "no" => "normal",
                _ => "ball",
            };
            let defect = |t: &str| matches!(t, "inner_race" | "outer_race" | "ball");
            let disagree = (defect(net) && t == "normal") || (defect(t) && net != t);
            let warnings = v["warnings"].as_array().map_or(0, Vec::len);
            assert_eq!(warnings > 0, disagree, "window {n}: {} vs {t}", classes[&n]);
            warned += usize::from(disagree);
        }
        starts.insert(
            v["window"].as_u64().unwrap(),
            v["start_sample"].as_u64().unwrap(),
        );
        // The physics of an earlier window (it runs after each line).
        if let Some(n) = v["physics"]["window"].as_u64() {
            let end = starts[&n] + 2048 - FIR_DELAY;
            let first = end.saturating_sub(8192);
            let seg = (first / SEGMENT) as usize;
            let want = match SEGMENTS.get(seg).map(|s| &s[..2]) {
                Some("IR") => Some("inner_race"),
                Some("OR") if SEGMENTS[seg] != "OR014" => Some("outer_race"),
                _ => None,
            };
            if let Some(want) = want.filter(|_| end <= (seg as u64 + 1) * SEGMENT) {
                assert_eq!(
                    v["physics"]["fault_type"], want,
                    "{}: {}",
                    SEGMENTS[seg], v["physics"]
                );
                physics_checked += 1;
            }
        }
        // The indicators under their full names (the file keeps 16 bytes of each).
        let ind = v["diagnosis"]["indicators"].as_object().unwrap();
        let names: Vec<&str> = ind.keys().map(String::as_str).collect();
        let mut want = pumptwin_core::model_file::INDICATOR_NAMES.to_vec();
        want.sort_unstable();
        assert_eq!(names, want);
        let start = v["start_sample"].as_u64().unwrap();
        let first = start.saturating_sub(FIR_DELAY);
        let last = start + 2048 - FIR_DELAY;
        let seg = (first / SEGMENT) as usize;
        if seg >= SEGMENTS.len() || last > (seg as u64 + 1) * SEGMENT {
            continue; // straddles two records
        }
        let class = v["diagnosis"]["class"].as_str().unwrap().to_string();
        inside += 1;
        right += usize::from(class == SEGMENTS[seg]);
        *votes[seg].entry(class).or_default() += 1;
    }
    for (seg, v) in votes.iter().enumerate() {
        let (best, n) = v.iter().max_by_key(|(_, n)| **n).unwrap();
        println!(
            "{:>7}: majority {best} ({n} of {})",
            SEGMENTS[seg],
            v.values().sum::<usize>()
        );
        assert_eq!(best, SEGMENTS[seg], "segment {seg}: {v:?}");
    }
    println!("{right} of {inside} whole-record windows right");
    assert!(
        physics_checked >= 10,
        "{physics_checked} physics windows checked"
    );
    assert!(right * 10 >= inside * 9, "{right}/{inside}");
    // The ball records (CWRU's ball faults show no line at the drive end) warn.
    assert!(warned >= 10, "{warned} lines warned");
}
