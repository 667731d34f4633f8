//! Operations: the TOML config file for every flag (`--config FILE`), and the health
//! counters as a Prometheus text endpoint (`--metrics-addr HOST:PORT`).
//!
//! A config file holds the long flag names as keys (with `-` or `_`), e.g.
//!
//! ```toml
//! can = "can0"
//! sensors = "/etc/pumptwin/cwru-sensors.toml"
//! model = "/etc/pumptwin/dsstgat-cwru-tb.ptm"
//! out = "/var/lib/pumptwin/diagnoses.jsonl"
//! publish-id = "0x7E0"
//! mqtt = "mqtts://broker.plant.example:8883"
//! topic-prefix = "plant1/pump7"
//! mqtt-queue = "/var/lib/pumptwin/mqtt-queue"
//! metrics-addr = "127.0.0.1:9898"
//! ```
//!
//! Values are strings, numbers or booleans (`true` = the flag is given). Flags on the
//! command line override the file. An unknown key is an error naming it.
//!
//! `GET /metrics` answers (Prometheus text format 0.0.4) with the counters of the
//! latest window: `pumptwin_frames_total{bucket="used"|"unknown_id"|…}`,
//! `pumptwin_frames_seen_total`, `pumptwin_lost_frames_total`, `pumptwin_bad_lines_total`,
//! `pumptwin_windows_total`, `pumptwin_degraded_windows_total`,
//! `pumptwin_publish_failures_total` and the window latency quantiles
//! `pumptwin_window_latency_seconds{quantile="0.5"|"0.99"}`.
//!
//! And the message a command line prints for an error ([`error_message`]; the
//! `pumptwin` binary uses it too).

use std::io::{BufRead, BufReader, Write};
use std::net::{SocketAddr, TcpListener};
use std::path::Path;
use std::sync::{Arc, Mutex};

use crate::pipeline::Health;

/// Why a config file was refused.
#[derive(Debug, thiserror::Error)]
pub enum ConfigError {
    /// Unreadable.
    #[error("cannot read config {path}: {source}")]
    Read {
        /// The file.
        path: String,
        /// The I/O error.
        source: std::io::Error,
    },
    /// Not TOML.
    #[error("config {path} is not valid TOML: {source}")]
    Toml {
        /// The file.
        path: String,
        /// The parser's error.
        source: toml::de::Error,
    },
    /// A key that is no flag, or a value of the wrong kind.
    #[error("config {path}: {reason}")]
    Key {
        /// The file.
        path: String,
        /// What is wrong.
        reason: String,
    },
}

/// The flags a config file gives, as command-line arguments (`--key value`), checked
/// against `known` (the long flag names). Booleans `true` become `--key`.
///
/// # Errors
/// [`ConfigError`] for an unreadable or invalid file, an unknown key, a table or array
/// value.
pub fn config_args(path: &Path, known: &[&str]) -> Result<Vec<String>, ConfigError> {
    let shown = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| ConfigError::Read {
        path: shown.clone(),
        source,
    })?;
    let table: toml::Table = toml::from_str(&text).map_err(|source| ConfigError::Toml {
        path: shown.clone(),
        source,
    })?;
    let mut args = Vec::new();
    for (key, value) in table {
        let flag = key.replace('_', "-");
        if flag == "config" || !known.contains(&flag.as_str()) {
            return Err(ConfigError::Key {
                path: shown,
                reason: format!("unknown key {key:?} (keys are the long flag names)"),
            });
        }
        match value {
            toml::Value::String(s) => args.extend([format!("--{flag}"), s]),
            toml::Value::Integer(i) => args.extend([format!("--{flag}"), i.to_string()]),
            toml::Value::Float(f) => args.extend([format!("--{flag}"), f.to_string()]),
            toml::Value::Boolean(true) => args.push(format!("--{flag}")),
            toml::Value::Boolean(false) => {}
            other => {
                return Err(ConfigError::Key {
                    path: shown,
                    reason: format!("{key}: a {} is not a flag value", other.type_str()),
                })
            }
        }
    }
    Ok(args)
}

/// What the metrics endpoint shows, updated by the gateway after every window.
#[derive(Debug, Clone, Copy, Default)]
pub struct Metrics {
    /// The counters of the latest window.
    pub health: Health,
    /// Publisher failures.
    pub publish_failures: u64,
    /// Window latency p50 and p99, µs.
    pub latency_us: (u64, u64),
}

/// The Prometheus text exposition of `m`.
pub fn render(m: &Metrics) -> String {
    let h = &m.health;
    let mut s = String::new();
    s.push_str("# HELP pumptwin_frames_total CAN frames by bucket (they add up to pumptwin_frames_seen_total).\n# TYPE pumptwin_frames_total counter\n");
    for (bucket, v) in [
        ("used", h.used),
        ("duplicate", h.duplicate),
        ("out_of_sequence", h.out_of_sequence),
        ("unknown_id", h.unknown_id),
        ("other_interface", h.other_interface),
        ("malformed", h.malformed),
        ("late", h.late),
        ("remote", h.remote),
        ("error_frames", h.error_frames),
    ] {
        s.push_str(&format!(
            "pumptwin_frames_total{{bucket=\"{bucket}\"}} {v}\n"
        ));
    }
    for (name, help, v) in [
        (
            "pumptwin_frames_seen_total",
            "CAN frames received.",
            h.frames_total,
        ),
        (
            "pumptwin_lost_frames_total",
            "Frames sequence counters say never arrived.",
            h.lost_frames,
        ),
        (
            "pumptwin_bad_lines_total",
            "Log lines that were not frames.",
            h.bad_lines,
        ),
        ("pumptwin_windows_total", "Windows diagnosed.", h.windows),
        (
            "pumptwin_degraded_windows_total",
            "Windows with a missing, failed or discontinuous channel.",
            h.degraded_windows,
        ),
        (
            "pumptwin_publish_failures_total",
            "Diagnosis frames or MQTT hand-offs that failed.",
            m.publish_failures,
        ),
    ] {
        s.push_str(&format!(
            "# HELP {name} {help}\n# TYPE {name} counter\n{name} {v}\n"
        ));
    }
    s.push_str("# HELP pumptwin_window_latency_seconds Frame to window line latency.\n# TYPE pumptwin_window_latency_seconds summary\n");
    s.push_str(&format!(
        "pumptwin_window_latency_seconds{{quantile=\"0.5\"}} {}\npumptwin_window_latency_seconds{{quantile=\"0.99\"}} {}\n",
        m.latency_us.0 as f64 * 1e-6,
        m.latency_us.1 as f64 * 1e-6
    ));
    s
}

/// Serve `GET /metrics` on `addr` from a background thread.
///
/// # Errors
/// The address cannot be bound.
pub fn serve_metrics(
    addr: SocketAddr,
    metrics: Arc<Mutex<Metrics>>,
) -> std::io::Result<SocketAddr> {
    let listener = TcpListener::bind(addr)?;
    let local = listener.local_addr()?;
    std::thread::Builder::new()
        .name("metrics".into())
        .spawn(move || {
            for stream in listener.incoming().flatten() {
                let mut reader = BufReader::new(&stream);
                let mut request = String::new();
                if reader.read_line(&mut request).is_err() {
                    continue;
                }
                // Skip the headers.
                let mut line = String::new();
                while reader.read_line(&mut line).is_ok_and(|n| n > 2) {
                    line.clear();
                }
                let (status, body) = if request.starts_with("GET /metrics") {
                    let m = *metrics.lock().unwrap_or_else(|e| e.into_inner());
                    ("200 OK", render(&m))
                } else {
                    ("404 Not Found", "not found: try /metrics\n".to_string())
                };
                let mut w = &stream;
                let _ = write!(
                    w,
                    "HTTP/1.1 {status}\r\nContent-Type: text/plain; version=0.0.4\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
                    body.len()
                );
            }
        })?;
    Ok(local)
}

/// What `program` prints for a user's error: the error and each cause on a line of its
/// own, never a backtrace (whatever `RUST_BACKTRACE` says: that is for bugs, and a
/// panic keeps its own).
pub fn error_message(program: &str, e: &anyhow::Error) -> String {
    let mut s = format!("{program}: error: {e}");
    for cause in e.chain().skip(1) {
        s.push_str("\n  caused by: ");
        s.push_str(&cause.to_string());
    }
    s
}

/// The exit status of a command line's run: success, or the error printed as
/// [`error_message`] and status 1.
pub fn exit_status(program: &str, result: anyhow::Result<()>) -> std::process::ExitCode {
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{}", error_message(program, &e));
            std::process::ExitCode::FAILURE
        }
    }
}
