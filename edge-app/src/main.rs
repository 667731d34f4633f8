//! `pumptwin-edge`: the pumptwin edge gateway.
//!
//! Replays a `candump -l` log through the sensor map, cuts every channel into windows
//! of 2048 samples (hop 1024), computes the core's features and the envelope-spectrum
//! physics explanation per window, and writes one JSON object per window.
//!
//! ```text
//! pumptwin-edge (--replay FILE.log | --can IFACE) --sensors MAP.toml [--model MODEL.ptm]
//!               [--out FILE.jsonl] [--speed max|realtime] [--publish-id ID] [--idle-exit S]
//!
//!   --replay FILE.log   candump -l log to replay; `-` reads standard input
//!   --can IFACE         read live from a SocketCAN interface (classic and FD frames);
//!                       reopens it with backoff when it goes down
//!   --publish-id ID     (with --can) send a compact 8-byte diagnosis frame with this
//!                       id after every window (layout: `network::DiagnosisFrameEncoder`)
//!   --idle-exit S       (with --can) end after S seconds without a frame
//!   --sensors MAP.toml  sensor map (machine speed, bearing, fs; channel ids and layouts)
//!   --model MODEL.ptm   int8 model file: adds the model's diagnosis to every window
//!   --out FILE.jsonl    append the JSON lines here instead of standard output
//!   --speed max         as fast as possible (default)
//!   --speed realtime    sleep to follow the log's timestamps
//! ```
//!
//! A sensor map:
//!
//! ```toml
//! [machine]
//! rpm = 1797.0              # nominal speed
//! bearing = "cwru-6205-de"  # or "cwru-6203-fe", or { n = 9, d = 0.3126, pitch = 1.537, angle = 0.0 }
//! fs_hz = 12000.0
//!
//! [[channel]]
//! name = "DE"
//! can_id = 0x101
//! samples_per_frame = 4     # k little-endian i16 samples per frame
//! scale = 0.001             # g per count
//! sequence_byte = 0         # optional u8 counter at this byte; samples follow it
//! ```
//!
//! One output line per window (abridged; the full schema is in the library's `report`
//! module):
//!
//! ```text
//! {"t_s":1700000000.17,"window":0,"start_sample":0,"status":"ok","shaft_hz":29.95,
//!  "channels":{"DE":{"rms":0.21,"kurtosis":7.9,"env_bpfo_db":1.2,"env_bpfi_db":24.3,…}},
//!  "explanation":{"channel":"DE","peak_hz":162.0,"peak_order":5.41,"match":"BPFI",
//!                 "harmonic":1,"error_pct":-0.1,"within_tolerance":true,…},
//!  "health":{"frames_total":1024,"used":1024,…}}
//! ```
//!
//! A window a channel dropped out of says `"status":"degraded"` and lists the channel
//! under `"missing"`; no value is made up for it. Bad log lines are skipped and counted
//! (the first few are described on standard error), an unreadable log stops the run
//! with exit status 1, and a health summary goes to standard error at the end.
//! SIGINT or SIGTERM ends the run between frames: every line written is flushed and
//! the exit status is 0.

use anyhow::Context;
use clap::{Parser, ValueEnum};
use pumptwin_core::fir::{BAND_LIMIT_HZ, MAX_CUTOFF_FRACTION};
use pumptwin_edge::candump::{CandumpReplay, FrameSource};
use pumptwin_edge::gateway::{Gateway, Publisher};
use pumptwin_edge::live::{BusPublisher, SocketCanSource};
use pumptwin_edge::mqtt::{MqttConfig, MqttSink};
use pumptwin_edge::network::{DiagnosisFrameEncoder, ModelDiagnoser};
use pumptwin_edge::ops::{serve_metrics, Metrics};
use pumptwin_edge::pace::{Pacer, Speed};
use pumptwin_edge::pipeline::Pipeline;
use pumptwin_edge::report::window_json;
use pumptwin_edge::sensor_map::SensorMap;
use std::fs::{File, OpenOptions};
use std::io::IsTerminal;
use std::io::{self, BufRead, BufReader, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::time::Duration;

/// Replay speed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum SpeedArg {
    /// As fast as possible.
    Max,
    /// Follow the log's timestamps.
    Realtime,
}

/// pumptwin edge gateway: CAN frames (candump replay or live SocketCAN) → windows →
/// features, physics explanation, the model's diagnosis and health, one JSON object
/// per window.
#[derive(Debug, Parser)]
#[command(
    name = "pumptwin-edge",
    version,
    about,
    args_override_self = true,
    after_help = "Examples:\n  \
        pumptwin-edge --replay models/demo.log --sensors models/cwru-sensors.toml \\\n      \
        --model models/dsstgat-cwru-tb.ptm\n  \
        pumptwin-edge --can can0 --sensors MAP.toml --model models/dsstgat-cwru-tb.ptm \\\n      \
        --out diagnoses.jsonl\n  \
        pumptwin-edge --config /etc/pumptwin/pumptwin-edge.toml"
)]
struct Cli {
    /// candump -l log to replay (`-` for standard input).
    #[arg(
        long,
        value_name = "FILE.log",
        required_unless_present = "can",
        conflicts_with = "can"
    )]
    replay: Option<PathBuf>,
    /// Live SocketCAN interface (e.g. can0, vcan0).
    #[arg(long, value_name = "IFACE")]
    can: Option<String>,
    /// Sensor map (TOML).
    #[arg(long, value_name = "MAP.toml")]
    sensors: PathBuf,
    /// Append JSON lines to this file instead of standard output.
    #[arg(long, value_name = "FILE.jsonl")]
    out: Option<PathBuf>,
    /// JSON lines on standard output even on a terminal (where the default is one
    /// line for people per window; piped, the output is always JSON lines).
    #[arg(long)]
    json: bool,
    /// Replay speed.
    #[arg(long, value_enum, default_value_t = SpeedArg::Max)]
    speed: SpeedArg,
    /// Int8 model file (`pumptwin export`): adds a `"diagnosis"` to every window.
    #[arg(long, value_name = "MODEL.ptm")]
    model: Option<PathBuf>,
    /// Send a compact diagnosis frame with this CAN id after every window (with --can).
    #[arg(long, value_name = "ID", value_parser = parse_id, requires = "can")]
    publish_id: Option<u32>,
    /// Read flags from this TOML file (keys: the long flag names); the command line
    /// overrides it.
    #[arg(long, value_name = "FILE.toml")]
    config: Option<PathBuf>,
    /// Serve the health counters for Prometheus at http://ADDR/metrics.
    #[arg(long, value_name = "HOST:PORT")]
    metrics_addr: Option<std::net::SocketAddr>,
    /// End a live run after this many seconds without a frame (with --can).
    #[arg(long, value_name = "S", requires = "can")]
    idle_exit: Option<f64>,
    /// Publish every window line (QoS 1) and periodic health to an MQTT broker:
    /// mqtt://host[:port] or mqtts://host[:port] (TLS).
    #[arg(long, value_name = "URL")]
    mqtt: Option<String>,
    /// Topic prefix: P/diagnosis, P/health.
    #[arg(long, value_name = "P", default_value = "pumptwin", requires = "mqtt")]
    topic_prefix: String,
    /// MQTT username (password from --mqtt-password or PUMPTWIN_MQTT_PASSWORD).
    #[arg(long, requires = "mqtt")]
    mqtt_user: Option<String>,
    /// MQTT password.
    #[arg(
        long,
        env = "PUMPTWIN_MQTT_PASSWORD",
        requires = "mqtt_user",
        hide_env_values = true
    )]
    mqtt_password: Option<String>,
    /// CA certificate (PEM) for mqtts://.
    #[arg(long, requires = "mqtt")]
    mqtt_ca: Option<PathBuf>,
    /// MQTT client id.
    #[arg(long, default_value = "pumptwin-edge", requires = "mqtt")]
    mqtt_client_id: String,
    /// Store-and-forward queue directory (survives restarts).
    #[arg(long, default_value = "pumptwin-mqtt-queue", requires = "mqtt")]
    mqtt_queue: PathBuf,
    /// Most queued entries; beyond it the oldest is dropped and counted.
    #[arg(long, default_value_t = 100_000, requires = "mqtt")]
    mqtt_queue_capacity: usize,
    /// Seconds the end of a run waits for the queue to drain.
    #[arg(long, default_value_t = 30.0, requires = "mqtt")]
    mqtt_drain_timeout: f64,
}

fn parse_id(s: &str) -> Result<u32, String> {
    let v = match s.strip_prefix("0x").or_else(|| s.strip_prefix("0X")) {
        Some(hex) => u32::from_str_radix(hex, 16),
        None => s.parse(),
    }
    .map_err(|e| format!("{s:?} is not a CAN id: {e}"))?;
    if v > 0x1FFF_FFFF {
        return Err(format!("{s}: CAN ids have at most 29 bits"));
    }
    Ok(v)
}

/// The command line, with a `--config` file's flags before it (so it overrides them).
fn parse_cli() -> anyhow::Result<Cli> {
    let argv: Vec<String> = std::env::args().collect();
    // The config file is looked up before parsing: the flags it gives may be the
    // required ones.
    let path = argv.iter().enumerate().find_map(|(i, a)| {
        a.strip_prefix("--config=")
            .map(PathBuf::from)
            .or_else(|| (a == "--config").then(|| argv.get(i + 1).map(PathBuf::from))?)
    });
    let Some(path) = path else {
        return Ok(Cli::parse_from(argv));
    };
    let cmd = <Cli as clap::CommandFactory>::command();
    let known: Vec<String> = cmd
        .get_arguments()
        .filter_map(|a| a.get_long().map(str::to_string))
        .collect();
    let known: Vec<&str> = known.iter().map(String::as_str).collect();
    let from_file = pumptwin_edge::ops::config_args(&path, &known)?;
    let mut args = vec![argv[0].clone()];
    args.extend(from_file);
    args.extend(argv.into_iter().skip(1));
    Ok(Cli::parse_from(args))
}

/// A user's error is one message and its causes, never a backtrace whatever
/// `RUST_BACKTRACE` says (a bug, a panic, keeps its backtrace); exit status 1.
fn main() -> std::process::ExitCode {
    pumptwin_edge::ops::exit_status("pumptwin-edge", run())
}

fn run() -> anyhow::Result<()> {
    let cli = parse_cli()?;
    let stop = stop_on_signals()?;
    let map = SensorMap::load(&cli.sensors)?;
    let mut out = open_output(cli.out.as_deref())?;
    let speed = match cli.speed {
        SpeedArg::Max => Speed::Max,
        SpeedArg::Realtime => Speed::Realtime,
    };
    let mut mqtt = start_mqtt(&cli)?;
    let mut pipeline = Pipeline::new(map).context("building the signal path")?;
    let diagnoser = cli
        .model
        .as_deref()
        .map(|path| load_diagnoser(path, &pipeline))
        .transpose()?;
    if let Some(d) = &diagnoser {
        // The physics decides with the settings the model file ships with.
        let (thresholds, revolutions) = d.diagnosis_settings();
        pipeline.set_diagnosis(thresholds, revolutions);
    }
    // People on a terminal, machines everywhere else (as ripgrep does).
    let human = cli.out.is_none() && !cli.json && io::stdout().is_terminal();
    let mut gateway = Gateway::new(pipeline, Pacer::new(speed))
        .with_stop(Arc::clone(&stop))
        .with_human_output(human);
    let mut encoder = DiagnosisFrameEncoder::new(Vec::new(), Vec::new());
    if let Some(diagnoser) = diagnoser {
        encoder = DiagnosisFrameEncoder::for_model(&diagnoser);
        gateway = gateway.with_diagnoser(Box::new(diagnoser));
    }
    let Input {
        mut source,
        what,
        bus,
    } = open_input(&cli, &stop)?;
    let metrics = start_metrics(cli.metrics_addr)?;
    gateway = gateway.with_metrics(Arc::clone(&metrics));
    gateway = gateway.with_publisher(publisher(mqtt.as_mut(), bus, encoder));
    let result = gateway.run(&mut *source, &mut out, &mut io::stderr());
    out.flush().context("flushing the output")?;
    print_health_and_latency(&gateway);
    eprintln!("pumptwin-edge: {}", gateway.tally.summary());
    let no_window = gateway.pipeline().why_no_window();
    let publish_failures = gateway.publish_failures;
    drop(gateway);
    if let Some(m) = mqtt {
        finish_mqtt(m);
    }
    if publish_failures > 0 {
        eprintln!("pumptwin-edge: {publish_failures} diagnosis frames could not be sent");
    }
    result.map(|_| ()).with_context(|| what.clone())?;
    // Nothing silent: a run that diagnosed nothing fails and says why.
    if let Some(why) = no_window {
        anyhow::bail!("{what}: no window diagnosed: {why}");
    }
    Ok(())
}

/// A flag SIGINT and SIGTERM set: the gateway ends the run between frames.
fn stop_on_signals() -> anyhow::Result<Arc<AtomicBool>> {
    let stop = Arc::new(AtomicBool::new(false));
    for sig in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(sig, Arc::clone(&stop))
            .context("installing signal handlers")?;
    }
    Ok(stop)
}

/// Where the JSON lines go: appended to `path`, or standard output.
fn open_output(path: Option<&Path>) -> anyhow::Result<Box<dyn Write>> {
    Ok(match path {
        Some(path) => Box::new(BufWriter::new(
            OpenOptions::new()
                .create(true)
                .append(true)
                .open(path)
                .with_context(|| format!("opening output {}", path.display()))?,
        )),
        None => Box::new(io::stdout().lock()),
    })
}

/// The MQTT telemetry sink, started when `--mqtt` is given.
fn start_mqtt(cli: &Cli) -> anyhow::Result<Option<MqttSink>> {
    Ok(match &cli.mqtt {
        Some(url) => Some(
            MqttSink::start(MqttConfig {
                url: url.clone(),
                topic_prefix: cli.topic_prefix.clone(),
                client_id: cli.mqtt_client_id.clone(),
                credentials: cli
                    .mqtt_user
                    .clone()
                    .map(|u| (u, cli.mqtt_password.clone().unwrap_or_default())),
                ca_file: cli.mqtt_ca.clone(),
                queue_dir: cli.mqtt_queue.clone(),
                capacity: cli.mqtt_queue_capacity.max(1),
                drain_timeout: Duration::from_secs_f64(cli.mqtt_drain_timeout.max(0.0)),
            })
            .context("starting MQTT telemetry")?,
        ),
        None => None,
    })
}

/// The int8 model at `path`, its sensors mapped to `pipeline`'s channels (those not in
/// the sensor map are named on standard error and masked); refused when the sensor
/// map's rate cannot reach the model's band limit.
fn load_diagnoser(path: &Path, pipeline: &Pipeline) -> anyhow::Result<ModelDiagnoser> {
    // The model reads features up to the common band limit (its training data were
    // low-passed there): a rate whose anti-alias cutoff (0.45·fs) falls below it
    // would feed it other features than it learned, so it is refused, not run.
    let reach = pipeline.feature_config().envelope_band.hi_hz;
    anyhow::ensure!(
        reach >= BAND_LIMIT_HZ,
        "model {}: it reads features up to the common {BAND_LIMIT_HZ} Hz band limit, but \
         the sensor map's fs_hz = {} Hz reaches {reach} Hz (0.45·fs); the sensors must \
         sample at {:.0} Hz or more",
        path.display(),
        pipeline.feature_config().fs_hz,
        (BAND_LIMIT_HZ / MAX_CUTOFF_FRACTION).ceil()
    );
    let diagnoser = ModelDiagnoser::load(path, pipeline.channel_names())?;
    let unmapped: Vec<&str> = diagnoser.unmapped().collect();
    if !unmapped.is_empty() {
        eprintln!("pumptwin-edge: model sensors {unmapped:?} are not in the sensor map: masked");
    }
    Ok(diagnoser)
}

/// The frame source of a run.
struct Input {
    /// The frames.
    source: Box<dyn FrameSource>,
    /// What the run reads, for its error context (`replaying FILE`, `reading IFACE`).
    what: String,
    /// The bus the diagnosis frames are sent on (`--can` with `--publish-id`).
    bus: Option<BusPublisher>,
}

/// Open the candump log (`--replay`) or the SocketCAN interface (`--can`, with its
/// diagnosis publisher when `--publish-id` is given).
fn open_input(cli: &Cli, stop: &Arc<AtomicBool>) -> anyhow::Result<Input> {
    let mut bus: Option<BusPublisher> = None;
    let (source, what): (Box<dyn FrameSource>, String) = match (&cli.replay, &cli.can) {
        (Some(path), _) => {
            let input: Box<dyn BufRead> = if path.as_os_str() == "-" {
                Box::new(io::stdin().lock())
            } else {
                let file = File::open(path)
                    .with_context(|| format!("opening candump log {}", path.display()))?;
                Box::new(BufReader::new(file))
            };
            (
                Box::new(CandumpReplay::new(input)),
                format!("replaying {}", path.display()),
            )
        }
        (None, Some(iface)) => {
            if let Some(id) = cli.publish_id {
                bus = Some(
                    BusPublisher::open(iface, id)
                        .with_context(|| format!("opening {iface} to publish diagnoses"))?,
                );
            }
            let idle = cli.idle_exit.map(Duration::from_secs_f64);
            (
                Box::new(SocketCanSource::new(
                    iface,
                    Arc::clone(stop),
                    idle,
                    cli.publish_id,
                )),
                format!("reading {iface}"),
            )
        }
        (None, None) => anyhow::bail!("give --replay FILE or --can IFACE"),
    };
    Ok(Input { source, what, bus })
}

/// The health counters the gateway updates, served for Prometheus at `addr` when
/// given (the address bound is said on standard error).
fn start_metrics(addr: Option<std::net::SocketAddr>) -> anyhow::Result<Arc<Mutex<Metrics>>> {
    let metrics = Arc::new(Mutex::new(Metrics::default()));
    if let Some(addr) = addr {
        let bound = serve_metrics(addr, Arc::clone(&metrics))
            .with_context(|| format!("serving metrics on {addr}"))?;
        eprintln!("pumptwin-edge: metrics at http://{bound}/metrics");
    }
    Ok(metrics)
}

/// What the gateway does with every window after its line: the line and health to
/// MQTT (when started), the compact diagnosis frame to the bus (when publishing).
fn publisher<'d>(
    mut mqtt: Option<&'d mut MqttSink>,
    bus: Option<BusPublisher>,
    mut encoder: DiagnosisFrameEncoder,
) -> Publisher<'d> {
    Box::new(move |w, d| {
        if let Some(m) = mqtt.as_deref_mut() {
            let line = window_json(w, d).map_err(io::Error::other)?;
            let health = serde_json::to_value(w.health).map_err(io::Error::other)?;
            m.send_window(&line, &health);
        }
        match &bus {
            Some(b) => b.send(&encoder.encode(w, d)),
            None => Ok(()),
        }
    })
}

/// The run's health summary and frame → line latency on standard error.
fn print_health_and_latency(gateway: &Gateway<'_>) {
    let health = gateway.pipeline().health();
    eprintln!("pumptwin-edge: {health}");
    if let (Some(p50), Some(p99)) = (
        gateway.latency.quantile_us(0.5),
        gateway.latency.quantile_us(0.99),
    ) {
        eprintln!(
            "pumptwin-edge: frame -> window line latency over {} windows: p50 {p50} us, p99 {p99} us, max {} us",
            gateway.latency.count(),
            gateway.latency.quantile_us(1.0).unwrap_or(0)
        );
    }
}

/// Drain the MQTT queue (up to its timeout) and say what was delivered.
fn finish_mqtt(mqtt: MqttSink) {
    let s = mqtt.finish();
    eprintln!(
        "pumptwin-edge: mqtt: produced {}, delivered {}, dropped {}, pending {}, resent {}, connects {}",
        s.produced, s.delivered, s.dropped, s.pending, s.resent, s.connects
    );
}
