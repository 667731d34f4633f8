//! `pumptwin can-encode`: recordings → a `candump -l` log packed as a sensor map says,
//! so a user can replay their own data through the edge gateway.
//!
//! ```text
//! for each --input (in order, one after the other on the time line):
//!   load (.mat / .csv) → the part [--start, --start + --duration) of the record
//!   → rate: the map's fs; an integer multiple is anti-aliased (core FIR at 0.45·fs)
//!     and decimated; the map's band limit is the gateway's job, not the encoder's
//!   → per map channel, the record's channel of the same name (a channel the record
//!     lacks sends no frames: a real dropout the gateway reports)
//!   → frames of `samples_per_frame` samples (counts = x / scale, rounded, saturated to
//!     i16 — counted), the channel's u8 sequence counter, FD payloads padded to the
//!     next FD length
//!   → lines in time order: frame k of a channel is stamped when its last sample was
//!     taken, t0 + (n0 + (k+1)·spf) / fs
//! ```
//!
//! The log starts at `--t0` (Unix seconds) and each input follows the previous one
//! without a gap, so a gateway sees one continuous stream; the windows that straddle
//! two inputs mix them (expected, and visible in the output's timestamps).

use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, ensure, Context, Result};
use pumptwin_edge::candump::{format_line, Frame, FrameKind, CANFD_LENGTHS, CAN_MAX_DLEN};
use pumptwin_edge::sensor_map::SensorMap;

use pumptwin_data::preprocess::{preprocess, PreprocessConfig};
use pumptwin_data::record::load_recording;

/// `pumptwin can-encode`.
#[derive(Debug, Clone, clap::Args)]
pub struct CanEncodeArgs {
    /// Recordings (.mat in CWRU layout or .csv), encoded one after the other.
    #[arg(long, required = true, num_args = 1..)]
    pub input: Vec<PathBuf>,
    /// Sensor map (TOML, the edge gateway's).
    #[arg(long)]
    pub sensors: PathBuf,
    /// The candump log to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Sampling rate of the inputs, Hz (else a CSV's `# fs_hz=` line, a .mat's MANIFEST.tsv entry).
    #[arg(long)]
    pub fs: Option<f32>,
    /// Start of the encoded part of each input, as a fraction of its length.
    #[arg(long, default_value_t = 0.0)]
    pub start_fraction: f64,
    /// Seconds of each input to encode (default: to its end).
    #[arg(long)]
    pub duration_s: Option<f64>,
    /// Time of the first sample, Unix seconds.
    #[arg(long, default_value_t = 1_700_000_000.0)]
    pub t0: f64,
    /// Interface name written in the log.
    #[arg(long, default_value = "can0")]
    pub iface: String,
}

/// What was written.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct EncodeSummary {
    /// Frames written.
    pub frames: u64,
    /// Samples clipped to the i16 range.
    pub clipped: u64,
    /// Map channels an input did not have (input, channel).
    pub absent: Vec<(String, String)>,
}

/// Run `pumptwin can-encode`.
pub fn run_can_encode(args: &CanEncodeArgs) -> Result<()> {
    let map = SensorMap::load(&args.sensors)
        .with_context(|| format!("cannot read sensor map {}", args.sensors.display()))?;
    ensure!(
        (0.0..1.0).contains(&args.start_fraction),
        "--start-fraction must be in [0, 1)"
    );
    let fs = map.machine.fs_hz;
    let file = std::fs::File::create(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut w = std::io::BufWriter::new(file);
    let iface = heapless::String::<16>::try_from(args.iface.as_str())
        .map_err(|_| anyhow::anyhow!("interface name {:?} too long", args.iface))?;
    let mut summary = EncodeSummary::default();
    let mut seq = vec![0u8; map.channels.len()];
    let mut n0: u64 = 0; // first sample index of the current input on the time line
    for path in &args.input {
        let rec = load_recording(path, args.fs, None)
            .with_context(|| format!("cannot load {}", path.display()))?;
        // To the map's rate: integer ratios anti-aliased and decimated, as the
        // trainer does; no band limit (that is the gateway's job).
        let rec = preprocess(
            &rec,
            &PreprocessConfig {
                target_fs_hz: fs,
                band_limit_hz: None,
                ..PreprocessConfig::default()
            },
        )
        .with_context(|| format!("cannot bring {} to {fs} Hz", path.display()))?;
        let len = rec.len();
        let start = (args.start_fraction * len as f64) as usize;
        let end = match args.duration_s {
            Some(d) => (start + (d * f64::from(fs)) as usize).min(len),
            None => len,
        };
        if end <= start {
            bail!("{}: nothing to encode from sample {start}", path.display());
        }
        // (time index, channel, frame) for every frame of this input.
        let mut lines: Vec<(u64, usize, Frame)> = Vec::new();
        for (ci, ch) in map.channels.iter().enumerate() {
            let Some(src) = rec.channel(&ch.name) else {
                summary.absent.push((rec.name.clone(), ch.name.clone()));
                continue;
            };
            let spf = ch.samples_per_frame;
            for (k, chunk) in src.samples[start..end].chunks_exact(spf).enumerate() {
                summary.clipped += chunk
                    .iter()
                    .filter(|&&x| (x / ch.scale).round().abs() > 32767.0)
                    .count() as u64;
                let mut data = ch.encode(chunk, seq[ci]);
                seq[ci] = seq[ci].wrapping_add(1);
                let fd = ch.needs_fd();
                if fd {
                    let padded = CANFD_LENGTHS
                        .iter()
                        .copied()
                        .find(|&l| l >= data.len())
                        .unwrap_or(data.len());
                    let _ = data.resize(padded, 0);
                }
                let last = n0 + ((k + 1) * spf) as u64;
                let ts = args.t0 + last as f64 / f64::from(fs);
                lines.push((
                    last,
                    ci,
                    Frame {
                        ts_us: (ts * 1e6).round() as u64,
                        iface: iface.clone(),
                        id: ch.can_id,
                        extended: ch.extended,
                        fd: fd || data.len() > CAN_MAX_DLEN,
                        fd_flags: 0,
                        kind: FrameKind::Data,
                        data,
                    },
                ));
            }
        }
        lines.sort_by_key(|(t, c, _)| (*t, *c));
        for (_, _, f) in &lines {
            writeln!(w, "{}", format_line(f))?;
        }
        summary.frames += lines.len() as u64;
        n0 += (end - start) as u64;
        eprintln!(
            "{}: samples {start}..{end} of {len} ({:.2} s) at {fs} Hz, {} frames",
            path.display(),
            (end - start) as f64 / f64::from(fs),
            lines.len()
        );
    }
    w.flush()?;
    for (rec, ch) in &summary.absent {
        eprintln!(
            "note: {rec} has no channel {ch}: no frames for it (the gateway reports it missing)"
        );
    }
    eprintln!(
        "wrote {} frames to {}; {} samples clipped to the i16 range",
        summary.frames,
        args.out.display(),
        summary.clipped
    );
    Ok(())
}
