//! The `pumptwin-edge` binary on files: output to --out (appended), summary on stderr,
//! clear errors for bad input.

mod common;

use common::*;
use std::path::PathBuf;
use std::process::Command;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("pumptwin-edge-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_pumptwin-edge"))
}

#[test]
fn replays_a_log_into_a_jsonl_file() {
    let dir = temp_dir("replay");
    let m = map(MAP_DE_FE);
    let n = 6_144;
    let bpfi = bpfi_hz();
    let signals = vec![
        impact_signal(n, bpfi, 1.0, 0.05, 1),
        impact_signal(n, bpfi, 0.3, 0.05, 2),
    ];
    let mut log = log_text(&encode(&m, &signals, 0));
    log.push_str("(1700000009.000000) can0 this-is-not-a-frame\n");
    std::fs::write(dir.join("run.log"), log).unwrap();
    std::fs::write(dir.join("map.toml"), MAP_DE_FE).unwrap();
    let out = dir.join("out.jsonl");
    let _ = std::fs::remove_file(&out);
    for _ in 0..2 {
        let r = bin()
            .arg("--replay")
            .arg(dir.join("run.log"))
            .arg("--sensors")
            .arg(dir.join("map.toml"))
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
        assert!(r.stdout.is_empty());
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(err.contains("candump line"), "{err}");
        assert!(err.contains("3072 frames: 3072 used"), "{err}");
        assert!(err.contains("1 bad lines; 5 windows (0 degraded)"), "{err}");
    }
    // Appended, not overwritten: two runs, five windows each.
    let text = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<serde_json::Value> = text
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 10);
    assert!(lines.iter().all(|w| w["explanation"]["match"] == "BPFI"));
    // Standard output when there is no --out.
    let r = bin()
        .args(["--replay", "-", "--sensors"])
        .arg(dir.join("map.toml"))
        .stdin(std::fs::File::open(dir.join("run.log")).unwrap())
        .output()
        .unwrap();
    assert!(r.status.success());
    assert_eq!(String::from_utf8_lossy(&r.stdout).lines().count(), 5);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_inputs_fail_with_a_clear_message() {
    let dir = temp_dir("bad");
    std::fs::write(dir.join("dup.toml"), MAP_DE_FE.replace("0x102", "0x101")).unwrap();
    let r = bin()
        .arg("--replay")
        .arg(dir.join("missing.log"))
        .arg("--sensors")
        .arg(dir.join("dup.toml"))
        .output()
        .unwrap();
    assert!(!r.status.success());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains("both use CAN id 0x101"), "{err}");
    std::fs::write(dir.join("ok.toml"), MAP_DE_FE).unwrap();
    let r = bin()
        .arg("--replay")
        .arg(dir.join("missing.log"))
        .arg("--sensors")
        .arg(dir.join("ok.toml"))
        .output()
        .unwrap();
    assert!(!r.status.success());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(err.contains("opening candump log"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// SIGINT (and SIGTERM) end a run between frames: exit status 0, every line written is
/// whole and flushed, the health summary is printed.
#[test]
fn sigint_and_sigterm_flush_and_exit_zero() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for sig in ["-INT", "-TERM"] {
        let child = bin()
            .current_dir(&root)
            .args([
                "--replay",
                "models/demo.log",
                "--sensors",
                "models/cwru-sensors.toml",
                "--speed",
                "realtime",
            ])
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        std::thread::sleep(std::time::Duration::from_millis(1500));
        let killed = Command::new("kill")
            .arg(sig)
            .arg(child.id().to_string())
            .status()
            .unwrap();
        assert!(killed.success());
        let out = child.wait_with_output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{sig}: {:?}\n{stderr}", out.status);
        let stdout = String::from_utf8(out.stdout).unwrap();
        let lines: Vec<&str> = stdout.lines().collect();
        // ~1.5 s of a 12 kHz log at recorded pace: some windows, not all 116.
        assert!(
            !lines.is_empty() && lines.len() < 100,
            "{sig}: {} lines",
            lines.len()
        );
        for l in &lines {
            serde_json::from_str::<serde_json::Value>(l).expect("whole JSON lines");
        }
        assert!(
            stderr.contains("frames:"),
            "{sig}: no health summary\n{stderr}"
        );
    }
}

/// `--config FILE.toml` gives the flags; `--metrics-addr` serves the counters for
/// Prometheus while the run goes on, and they add up; an unknown key is an error.
#[test]
fn config_file_and_metrics_endpoint() {
    use std::io::{Read, Write};
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = temp_dir("config");
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let conf = dir.join("edge.toml");
    std::fs::write(
        &conf,
        format!(
            "replay = \"models/demo.log\"\nsensors = \"models/cwru-sensors.toml\"\n\
             speed = \"realtime\"\nmetrics_addr = \"127.0.0.1:{port}\"\n"
        ),
    )
    .unwrap();
    let child = bin()
        .current_dir(&root)
        .arg("--config")
        .arg(&conf)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(2500));
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.write_all(b"GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n")
        .unwrap();
    let mut body = String::new();
    s.read_to_string(&mut body).unwrap();
    let _ = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    assert!(body.starts_with("HTTP/1.1 200 OK"), "{body}");
    let value = |name: &str| -> u64 {
        body.lines()
            .find(|l| l.starts_with(name))
            .and_then(|l| l.rsplit(' ').next())
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("{name} missing:\n{body}"))
    };
    assert!(value("pumptwin_windows_total") > 0);
    let buckets: u64 = body
        .lines()
        .filter(|l| l.starts_with("pumptwin_frames_total{"))
        .map(|l| l.rsplit(' ').next().unwrap().parse::<u64>().unwrap())
        .sum();
    assert_eq!(buckets, value("pumptwin_frames_seen_total"));
    // An unknown key is refused by name.
    std::fs::write(&conf, "sensorz = \"x\"\n").unwrap();
    let r = bin().arg("--config").arg(&conf).output().unwrap();
    assert!(!r.status.success());
    assert!(String::from_utf8_lossy(&r.stderr).contains("sensorz"));
}

/// A model trained on the 5 kHz band limit is not run on sensors that cannot reach
/// it (10 kHz: anti-alias cutoff 4.5 kHz): a clear error, before any frame.
#[test]
fn a_model_is_refused_below_its_band_limit() {
    let dir = temp_dir("slow-rate");
    let map_path = dir.join("map.toml");
    std::fs::write(
        &map_path,
        MAP_DE_FE.replace("fs_hz = 12000.0", "fs_hz = 10000.0"),
    )
    .unwrap();
    let log = dir.join("empty.log");
    std::fs::write(&log, "").unwrap();
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = bin()
        .args(["--replay"])
        .arg(&log)
        .arg("--sensors")
        .arg(&map_path)
        .arg("--model")
        .arg(root.join("models/dsstgat-cwru-tb.ptm"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("band limit") && stderr.contains("11112 Hz"),
        "{stderr}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Nothing silent: an empty log, and a log whose identifiers the sensor map does not
/// name, end with a non-zero status and say why (the identifiers seen against the
/// map's); a user's error never prints a backtrace, whatever RUST_BACKTRACE says.
#[test]
fn a_run_that_diagnoses_nothing_fails_and_says_why() {
    let dir = temp_dir("nothing");
    std::fs::write(dir.join("map.toml"), MAP_DE_FE).unwrap();
    std::fs::write(dir.join("empty.log"), "").unwrap();
    let m = map(MAP_DE_FE);
    let signals = vec![
        impact_signal(4_096, bpfi_hz(), 1.0, 0.05, 1),
        impact_signal(4_096, bpfi_hz(), 0.3, 0.05, 2),
    ];
    // Every frame moved to an identifier the map does not name.
    let mut frames = encode(&m, &signals, 0);
    for f in &mut frames {
        f.id = 0x7AB;
    }
    std::fs::write(dir.join("wrong-ids.log"), log_text(&frames)).unwrap();
    for (file, why) in [
        ("empty.log", "the input held no CAN frame"),
        ("wrong-ids.log", "seen 0x7AB, the map's"),
    ] {
        let r = bin()
            .env("RUST_BACKTRACE", "1")
            .arg("--replay")
            .arg(dir.join(file))
            .arg("--sensors")
            .arg(dir.join("map.toml"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&r.stderr);
        assert!(!r.status.success(), "{file}: {err}");
        assert!(err.contains("no window diagnosed"), "{file}: {err}");
        assert!(err.contains(why), "{file}: {err}");
        assert!(
            !err.contains("stack backtrace") && !err.contains("Stack backtrace"),
            "{err}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}
