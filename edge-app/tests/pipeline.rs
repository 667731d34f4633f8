//! The gateway end to end on synthetic candump logs: round trip, the BPFI explanation,
//! health counters under injected faults, dropouts, dead sensors, the diagnoser hook.

mod common;

use common::*;
use pumptwin_edge::candump::{
    parse_line, CandumpError, CandumpReplay, Frame, FrameKind, LineErrorKind, SourceError,
};
use pumptwin_edge::diagnosis::{DiagnoseError, Diagnoser};
use pumptwin_edge::gateway::Gateway;
use pumptwin_edge::pace::{Pacer, Speed};
use pumptwin_edge::pipeline::{Disposition, Health, Pipeline, Window, ENV_BPFI_DB, HOP, WINDOW};
use pumptwin_edge::sensor_map::SensorMap;
use serde_json::Value;

/// Run frames (or errors) through a gateway; the JSON lines, parsed, and the counters.
fn run_bus(map_text: &str, items: Vec<Result<Frame, SourceError>>) -> (Vec<Value>, Health, String) {
    let mut gateway = Gateway::new(
        Pipeline::new(map(map_text)).unwrap(),
        Pacer::new(Speed::Max),
    );
    let mut out = Vec::new();
    let mut log = Vec::new();
    let health = gateway
        .run(&mut ScriptedBus(items.into_iter()), &mut out, &mut log)
        .unwrap();
    let lines = String::from_utf8(out)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    (lines, health, String::from_utf8(log).unwrap())
}

fn ok(frames: Vec<Frame>) -> Vec<Result<Frame, SourceError>> {
    frames.into_iter().map(Ok).collect()
}

fn windows_for(n: usize) -> usize {
    (n - WINDOW) / HOP + 1
}

fn names(v: &Value) -> Vec<&str> {
    v.as_array()
        .map(|a| a.iter().map(|s| s.as_str().unwrap()).collect())
        .unwrap_or_default()
}

fn assert_adds_up(h: &Health) {
    assert_eq!(h.frames_classified(), h.frames_total, "{h}");
}

fn bpfi_signals(n: usize) -> Vec<Vec<f32>> {
    let bpfi = bpfi_hz();
    vec![
        impact_signal(n, bpfi, 1.0, 0.05, 1),
        impact_signal(n, bpfi, 0.3, 0.05, 2),
    ]
}

#[test]
fn encoder_round_trips_through_candump_text() {
    let m = map(MAP_DE_FE);
    let signals = bpfi_signals(4000);
    let frames = encode(&m, &signals, 250);
    let text = log_text(&frames);
    let mut src = CandumpReplay::new(text.as_bytes());
    let mut decoded = [Vec::new(), Vec::new()];
    let mut out = heapless::Vec::new();
    let mut seqs = Vec::new();
    while let Some(f) = pumptwin_edge::candump::FrameSource::next_frame(&mut src) {
        let f = f.unwrap();
        let c = m.channel_of(&f).unwrap();
        let seq = m.channels[c].decode(&f.data, f.fd, &mut out).unwrap();
        if let Some(s) = seq {
            seqs.push(s);
        }
        decoded[c].extend_from_slice(&out);
    }
    for (a, b) in decoded.iter().zip(&signals) {
        assert_eq!(a.len(), b.len());
        let err = a
            .iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max);
        assert!(err <= 0.0005 + 1e-6, "quantization error {err}");
    }
    // The counter wraps 255 → 0.
    assert_eq!(&seqs[..8], &[250, 251, 252, 253, 254, 255, 0, 1]);
    // DE goes as CAN FD (9-byte layout padded to 12), FE as classic.
    assert!(text.contains(" 101##1") && text.contains(" 102#"));
}

/// Impacts at BPFI of the 6205 at 1797 rpm (3 kHz bursts at 162.2 Hz), encoded to a
/// candump log, replayed: every window is explained as BPFI, from the DE channel.
#[test]
fn end_to_end_bpfi_impacts_are_explained_as_bpfi() {
    let n = 24_000;
    let m = map(MAP_DE_FE);
    let log = log_text(&encode(&m, &bpfi_signals(n), 0));
    let mut gateway = Gateway::new(Pipeline::new(m).unwrap(), Pacer::new(Speed::Max));
    let mut out = Vec::new();
    let health = gateway
        .run(
            &mut CandumpReplay::new(log.as_bytes()),
            &mut out,
            &mut std::io::sink(),
        )
        .unwrap();
    let lines: Vec<Value> = String::from_utf8(out)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), windows_for(n));
    let bpfi = bpfi_hz();
    for (i, w) in lines.iter().enumerate() {
        assert_eq!(w["window"], i as u64);
        assert_eq!(w["status"], "ok", "{w}");
        assert!(w.get("missing").is_none());
        let e = &w["explanation"];
        assert_eq!(e["match"], "BPFI", "{w}");
        assert_eq!(e["harmonic"], 1);
        assert_eq!(e["channel"], "DE");
        assert_eq!(e["within_tolerance"], true);
        let peak = e["peak_hz"].as_f64().unwrap();
        assert!((peak - bpfi).abs() < 3.0, "peak {peak} vs BPFI {bpfi}");
        assert!(e["error_pct"].as_f64().unwrap().abs() < 2.0);
        assert!((e["peak_order"].as_f64().unwrap() - 5.415).abs() < 0.1);
        let de = &w["channels"]["DE"];
        let (bpfi_db, bpfo_db, bsf_db) = (
            de["env_bpfi_db"].as_f64().unwrap(),
            de["env_bpfo_db"].as_f64().unwrap(),
            de["env_bsf_db"].as_f64().unwrap(),
        );
        assert!(
            bpfi_db > 15.0 && bpfi_db > bpfo_db + 10.0 && bpfi_db > bsf_db + 10.0,
            "{de}"
        );
        assert!(de["kurtosis"].as_f64().unwrap() > 4.0, "impulsive: {de}");
        assert!(w["channels"]["FE"]["rms"].as_f64().unwrap() > 0.0);
        // Channel order follows the sensor map.
        let keys: Vec<&String> = w["channels"].as_object().unwrap().keys().collect();
        assert_eq!(keys.len(), 2);
        assert!(w.get("diagnosis").is_none());
    }
    let t0 = lines[0]["t_s"].as_f64().unwrap() - T0_US as f64 / 1e6;
    assert!((t0 - 2047.0 / FS).abs() < 1e-3, "first window at {t0} s");
    assert_eq!(health.frames_total as usize, 2 * n / 4);
    assert_eq!(health.used, health.frames_total);
    assert_eq!(health.windows as usize, lines.len());
    assert_eq!(health.degraded_windows, 0);
    assert_adds_up(&health);
}

#[test]
fn counters_add_up_with_injected_faults() {
    let n = 12_000;
    let m = map(MAP_DE_FE);
    let mut frames = encode(&m, &bpfi_signals(n), 0);
    let base = frames.len() as u64;
    let de_at = |frames: &[Frame], j: usize| {
        frames
            .iter()
            .enumerate()
            .filter(|(_, f)| f.id == 0x101)
            .nth(j)
            .unwrap()
            .0
    };
    // Sequence gap: DE frames 600 and 601 never arrive.
    // (Frames interleave DE j, FE j, DE j+1, …)
    let i = de_at(&frames, 600);
    assert_eq!((frames[i + 1].id, frames[i + 2].id), (0x102, 0x101));
    frames.remove(i + 2);
    frames.remove(i);
    // Backwards timestamp: an FE frame stamped before its predecessor (dropped).
    let j = de_at(&frames, 1500) + 1;
    assert_eq!(frames[j].id, 0x102);
    frames[j].ts_us = frames[j - 1].ts_us - 5_000;
    // Extra frames: unknown ids, malformed payloads, a remote and an error frame.
    let ts = frames[100].ts_us;
    let mut extra = vec![
        raw_frame(ts, 0x7AB, &[1, 2, 3]),
        raw_frame(ts, 0x1234_5678, &[0; 8]),
        raw_frame(ts, 0x103, &[]),
        raw_frame(ts, 0x101, &[0, 1, 2]), // DE layout is 9 (12) bytes
        raw_frame(ts, 0x102, &[1, 2, 3, 4, 5, 6, 7]), // FE layout is 8 bytes
    ];
    let mut remote = raw_frame(ts, 0x101, &[]);
    remote.kind = FrameKind::Remote { dlc: 8 };
    let mut error = raw_frame(ts, 0x80, &[0; 8]);
    error.kind = FrameKind::Error;
    extra.push(remote);
    extra.push(error);
    for (k, f) in extra.into_iter().enumerate() {
        frames.insert(100 + k, f);
    }
    let mut items = ok(frames);
    items.insert(
        50,
        Err(CandumpError {
            line: 51,
            kind: LineErrorKind::OddDataDigits,
        }
        .into()),
    );
    let (lines, h, log) = run_bus(MAP_DE_FE, items);
    assert_adds_up(&h);
    assert_eq!(h.frames_total, base - 2 + 7);
    assert_eq!(h.unknown_id, 3);
    assert_eq!(h.malformed, 2);
    assert_eq!(h.remote, 1);
    assert_eq!(h.error_frames, 1);
    assert_eq!(h.out_of_sequence, 1, "the DE frame after the gap");
    assert_eq!(h.lost_frames, 2);
    assert_eq!(h.late, 1);
    assert_eq!(h.bad_lines, 1);
    assert_eq!(h.used, base - 2 - 1 - 1);
    assert!(log.contains("candump line 51"), "{log}");
    // The windows holding the junctions are degraded, their values still reported.
    let disc: Vec<(u64, Vec<&str>)> = lines
        .iter()
        .filter(|w| w["status"] == "degraded")
        .map(|w| (w["window"].as_u64().unwrap(), names(&w["discontinuous"])))
        .collect();
    assert!(!disc.is_empty());
    for w in lines.iter().filter(|w| w["status"] == "degraded") {
        assert!(w.get("missing").is_none());
        assert!(w["channels"]["DE"]["rms"].is_number() && w["channels"]["FE"]["rms"].is_number());
    }
    // DE sample 2400 (frame 600) falls in windows 1 (1024..3072) and 2 (2048..4096).
    assert!(
        disc.iter().any(|(i, c)| *i == 1 && c.contains(&"DE")),
        "{disc:?}"
    );
    assert!(disc.iter().any(|(_, c)| c.contains(&"FE")), "{disc:?}");
    // Health is a snapshot per window and ends at the final counters.
    let last = &lines.last().unwrap()["health"];
    assert!(last["frames_total"].as_u64().unwrap() <= h.frames_total);
    assert_eq!(lines.len() as u64, h.windows);
}

#[test]
fn each_frame_reports_its_bucket() {
    let mut p = Pipeline::new(map(MAP_DE_FE)).unwrap();
    let m = map(MAP_DE_FE);
    let enc = |seq: u8| m.channels[0].encode(&[0.1, 0.2, 0.3, 0.4], seq);
    let padded = |seq: u8, ts: u64| {
        let mut d = enc(seq);
        d.resize(12, 0).unwrap();
        raw_frame(ts, 0x101, &d)
    };
    let cases = [
        (padded(7, 10), Disposition::Used { channel: 0 }),
        (padded(8, 20), Disposition::Used { channel: 0 }),
        (
            padded(11, 30),
            Disposition::OutOfSequence {
                channel: 0,
                lost: 2,
            },
        ),
        (padded(11, 40), Disposition::Duplicate { channel: 0 }),
        // The same counter with other samples is no copy: a backward step.
        (
            {
                let mut d = m.channels[0].encode(&[0.5, 0.6, 0.7, 0.8], 11);
                d.resize(12, 0).unwrap();
                raw_frame(45, 0x101, &d)
            },
            Disposition::OutOfSequence {
                channel: 0,
                lost: 0,
            },
        ),
        (padded(12, 35), Disposition::Late { channel: 0 }),
        (padded(13, 50), Disposition::Used { channel: 0 }),
        (
            raw_frame(60, 0x102, &[0; 8]),
            Disposition::Used { channel: 1 },
        ),
        (raw_frame(70, 0x555, &[0; 8]), Disposition::UnknownId),
    ];
    for (frame, want) in cases {
        assert_eq!(p.push(&frame).disposition, want, "{frame:?}");
    }
    let malformed = p.push(&raw_frame(80, 0x102, &[0; 6])).disposition;
    assert!(
        matches!(malformed, Disposition::Malformed { channel: 1, .. }),
        "{malformed:?}"
    );
    let h = p.health();
    assert_eq!(
        (
            h.used,
            h.duplicate,
            h.out_of_sequence,
            h.late,
            h.lost_frames
        ),
        (4, 1, 2, 1, 2)
    );
    assert_adds_up(&h);
}

#[test]
fn dropout_degrades_windows_and_never_invents_values() {
    let n = 36_000;
    let m = map(MAP_DE_FE);
    let frames = encode(&m, &bpfi_signals(n), 0);
    // FE is silent for its samples 10 000 .. 20 000 (0.83 s).
    let lo = T0_US + (10_000.0 / FS * 1e6) as u64;
    let hi = T0_US + (20_000.0 / FS * 1e6) as u64;
    let frames: Vec<Frame> = frames
        .into_iter()
        .filter(|f| !(f.id == 0x102 && (lo..hi).contains(&f.ts_us)))
        .collect();
    let (lines, h, _) = run_bus(MAP_DE_FE, ok(frames));
    assert_adds_up(&h);
    let degraded: Vec<&Value> = lines.iter().filter(|w| w["status"] == "degraded").collect();
    assert!(degraded.len() >= 8, "{} degraded", degraded.len());
    for w in &degraded {
        assert_eq!(names(&w["missing"]), ["FE"], "{w}");
        assert!(
            w["channels"].get("FE").is_none(),
            "no value for a missing channel: {w}"
        );
        assert!(w["channels"]["DE"]["rms"].is_number());
        assert_eq!(w["explanation"]["channel"], "DE");
        assert_eq!(w["explanation"]["match"], "BPFI");
    }
    // Before and well after the dropout, windows are whole again.
    assert_eq!(lines[0]["status"], "ok");
    assert_eq!(lines.last().unwrap()["status"], "ok");
    assert!(lines
        .iter()
        .rev()
        .take(5)
        .all(|w| w["channels"]["FE"]["rms"].is_number()));
    assert_eq!(h.realignments, 1);
    assert_eq!(h.degraded_windows as usize, degraded.len());
    // Window numbers and starts stay contiguous through the dropout.
    for (i, w) in lines.iter().enumerate() {
        assert_eq!(w["window"], i as u64);
        assert_eq!(w["start_sample"], (i * HOP) as u64);
    }
}

#[test]
fn a_channel_that_never_sends_is_missing_from_every_window() {
    let text = format!(
        "{MAP_DE_FE}\n[[channel]]\nname = \"BA\"\ncan_id = 0x103\nsamples_per_frame = 4\nscale = 0.001\n"
    );
    let n = 20_000;
    // BA has no signal at all: encode only DE and FE.
    let frames = encode(&map(MAP_DE_FE), &bpfi_signals(n), 0);
    let (lines, h, _) = run_bus(&text, ok(frames));
    assert!(lines.len() >= windows_for(n) - 3, "{} windows", lines.len());
    for w in &lines {
        assert_eq!(w["status"], "degraded");
        assert_eq!(names(&w["missing"]), ["BA"]);
        assert!(w["channels"].get("BA").is_none());
        assert!(w["channels"]["DE"].is_object() && w["channels"]["FE"].is_object());
    }
    assert_eq!(h.degraded_windows, h.windows);
}

#[test]
fn a_stuck_sensor_fails_instead_of_reporting_numbers() {
    let n = 8_192;
    let m = map(MAP_DE_FE);
    let signals = vec![impact_signal(n, bpfi_hz(), 1.0, 0.05, 3), vec![0.25; n]];
    let (lines, h, _) = run_bus(MAP_DE_FE, ok(encode(&m, &signals, 0)));
    assert_eq!(lines.len(), windows_for(n));
    for w in &lines {
        assert_eq!(w["status"], "degraded");
        assert!(
            w["failed"]["FE"]
                .as_str()
                .unwrap()
                .contains("zero variance"),
            "{w}"
        );
        assert!(w["channels"].get("FE").is_none());
        assert!(w.get("missing").is_none());
    }
    assert_eq!(h.used, h.frames_total);
}

/// A stand-in for the model: flags an inner-race fault from the envelope feature.
struct EnvelopeRule {
    seen: usize,
}

impl Diagnoser for EnvelopeRule {
    fn diagnose(&mut self, window: &Window) -> Result<Value, DiagnoseError> {
        self.seen += 1;
        let f = window.features("DE").ok_or_else(|| DiagnoseError {
            window: window.index,
            reason: "DE missing".into(),
        })?;
        let db = f.envelope_feature(ENV_BPFI_DB);
        Ok(serde_json::json!({
            "class": if db > 10.0 { "inner_race" } else { "normal" },
            "nodes": window.channels.len(),
        }))
    }
}

#[test]
fn a_diagnoser_plugs_in_without_changing_the_rest() {
    let n = 6_144;
    let m = map(MAP_DE_FE);
    let frames = encode(&m, &bpfi_signals(n), 0);
    let mut gateway = Gateway::new(Pipeline::new(m).unwrap(), Pacer::new(Speed::Max))
        .with_diagnoser(Box::new(EnvelopeRule { seen: 0 }));
    let mut out = Vec::new();
    gateway
        .run(
            &mut ScriptedBus(ok(frames).into_iter()),
            &mut out,
            &mut std::io::sink(),
        )
        .unwrap();
    let lines: Vec<Value> = String::from_utf8(out)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), windows_for(n));
    for w in &lines {
        assert_eq!(w["diagnosis"]["class"], "inner_race");
        assert_eq!(w["diagnosis"]["nodes"], 2);
        assert_eq!(w["explanation"]["match"], "BPFI");
    }
}

#[test]
fn an_unreadable_source_stops_the_run() {
    let items: Vec<Result<Frame, SourceError>> =
        vec![Err(SourceError::Io(std::io::Error::other("bus gone")))];
    let mut gateway = Gateway::new(
        Pipeline::new(map(MAP_DE_FE)).unwrap(),
        Pacer::new(Speed::Max),
    );
    let e = gateway
        .run(
            &mut ScriptedBus(items.into_iter()),
            &mut Vec::new(),
            &mut Vec::new(),
        )
        .unwrap_err();
    assert!(e.to_string().contains("bus gone"), "{e}");
}

#[test]
fn parse_line_is_the_public_entry_for_one_line() {
    let f = parse_line(b"(1.000000) can0 101##1000000000000000000000000")
        .unwrap()
        .unwrap();
    assert!(f.fd && f.data.len() == 12);
}

/// Slow sensors from a DBC file: a speed frame changes the shaft rate of the windows
/// after it, temperature and pressure appear under "slow", the DBC frames count as
/// used, a short one as malformed, and the counters add up.
#[test]
fn dbc_slow_signals_update_speed_and_report_values() {
    let dir = std::env::temp_dir().join(format!("pumptwin-edge-dbc-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("pump.dbc"),
        "VERSION \"\"\n\nNS_ :\n\nBS_:\n\nBU_: PUMP\n\n\
         BO_ 1536 PumpSlow: 8 PUMP\n \
         SG_ ShaftSpeed : 0|16@1+ (0.25,0) [0|16000] \"rpm\" Vector__XXX\n \
         SG_ BearingTemp : 16|12@1- (0.1,-20) [-40|150] \"degC\" Vector__XXX\n \
         SG_ DischargePressure : 39|16@0+ (0.001,0) [0|60] \"bar\" Vector__XXX\n\n",
    )
    .unwrap();
    let text = format!(
        "{MAP_DE_FE}\n[dbc]\nfile = \"pump.dbc\"\nrpm = \"ShaftSpeed\"\n\
         temperature = \"BearingTemp\"\npressure = \"DischargePressure\"\n"
    );
    let m = SensorMap::from_toml_str_in(&text, &dir).unwrap();
    let n = 4 * WINDOW;
    let signals = vec![
        impact_signal(n, bpfi_hz(), 1.0, 0.05, 1),
        impact_signal(n, bpfi_hz(), 0.3, 0.05, 2),
    ];
    let mut frames = encode(&m, &signals, 0);
    // 1500 rpm (raw 6000 = 0x1770), 35 °C, 4.2 bar, after the first window's samples.
    let at = T0_US + ((WINDOW + 10) as f64 / FS * 1e6) as u64;
    frames.push(raw_frame(
        at,
        1536,
        &[0x70, 0x17, 0x26, 0x02, 0x10, 0x68, 0, 0],
    ));
    frames.push(raw_frame(at + 1, 1536, &[0x70]));
    frames.sort_by_key(|f| f.ts_us);
    let total = frames.len() as u64;
    let mut gateway = Gateway::new(Pipeline::new(m).unwrap(), Pacer::new(Speed::Max));
    let mut out = Vec::new();
    let health = gateway
        .run(
            &mut ScriptedBus(frames.into_iter().map(Ok).collect::<Vec<_>>().into_iter()),
            &mut out,
            &mut Vec::new(),
        )
        .unwrap();
    let lines: Vec<Value> = String::from_utf8(out)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(health.frames_total, total);
    assert_eq!(health.frames_classified(), total);
    assert_eq!(health.malformed, 1);
    let first = &lines[0];
    assert!((first["shaft_hz"].as_f64().unwrap() - 1797.0 / 60.0).abs() < 1e-3);
    let last = lines.last().unwrap();
    assert!(
        (last["shaft_hz"].as_f64().unwrap() - 25.0).abs() < 1e-4,
        "{last}"
    );
    assert!((last["slow"]["temperature"]["value"].as_f64().unwrap() - 35.0).abs() < 1e-9);
    assert_eq!(last["slow"]["pressure"]["unit"], "bar");
    assert!((last["slow"]["rpm"]["value"].as_f64().unwrap() - 1500.0).abs() < 1e-9);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The same BPFI impacts through a gateway writing for people: one line per window
/// with its status and, from the second window on, the physics of the window before
/// it (inner race); the tally counts every window's physics once.
#[test]
fn human_output_names_the_physics_of_the_window_before() {
    let n = 24_000;
    let m = map(MAP_DE_FE);
    let log = log_text(&encode(&m, &bpfi_signals(n), 0));
    let mut gateway =
        Gateway::new(Pipeline::new(m).unwrap(), Pacer::new(Speed::Max)).with_human_output(true);
    let mut out = Vec::new();
    gateway
        .run(
            &mut CandumpReplay::new(log.as_bytes()),
            &mut out,
            &mut std::io::sink(),
        )
        .unwrap();
    let text = String::from_utf8(out).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), windows_for(n));
    assert!(
        lines[0].contains("#0") && lines[0].contains("physics —"),
        "{}",
        lines[0]
    );
    for (k, l) in lines.iter().enumerate().skip(1) {
        assert!(l.contains(&format!("physics #{} inner_race", k - 1)), "{l}");
        assert!(serde_json::from_str::<Value>(l).is_err(), "not JSON: {l}");
    }
    assert_eq!(
        gateway.tally.physics.get("inner_race"),
        Some(&(lines.len() as u64 - 1))
    );
    assert!(
        gateway.tally.summary().contains("physics over"),
        "{}",
        gateway.tally.summary()
    );
}
