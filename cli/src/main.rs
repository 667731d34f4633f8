//! `pumptwin`: the host-side command line. A thin layer: each subcommand parses its
//! flags and calls the library.
use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, Parser, Subcommand};
use pumptwin::can_encode::{run_can_encode, CanEncodeArgs};
use pumptwin::commands::{
    is_broken_pipe, run_features, run_simulate, run_twin, FeaturesArgs, SimulateArgs, TwinCmd,
};
use pumptwin::compare::{run_compare, CompareArgs};
use pumptwin::eval::{run_eval, EvalArgs};
use pumptwin::export::{run_export, ExportArgs};
use pumptwin::generalization::{run_generalization, GeneralizationArgs};
use pumptwin::predict::{run_predict, PredictArgs};
use pumptwin::report::{run_report, ReportArgs};
use pumptwin::train::{run_train, TrainArgs};
use pumptwin_data::preprocess::{PreprocessConfig, MODEL_FS_HZ};
use pumptwin_data::rig_summary::{is_rig_manifest, summarize_rig};
use pumptwin_data::summary::summarize;
use pumptwin_data::windows::{Protocol, WindowConfig, DEFAULT_HOP, DEFAULT_WINDOW_LEN};
use std::io::Write;

/// Physics-informed bearing fault diagnosis: data, training, evaluation, export.
#[derive(Debug, Parser)]
#[command(
    name = "pumptwin",
    version,
    about,
    after_help = "Examples:\n  \
        pumptwin predict --input 105.mat --model models/dsstgat-cwru-tb.ptm\n  \
        pumptwin predict --input rec.mat --var bearing.gs --fs 48828 --rpm 1500 \\\n      \
        --bearing 8,0.235,1.245,0 --model models/dsstgat-cwru-tb.ptm\n  \
        pumptwin twin loop --input 105.mat --bearing cwru-6205-de --out out/loop\n  \
        pumptwin eval-generalization --out docs/evaluation-generalization.md"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Top-level subcommands.
#[derive(Debug, Subcommand)]
enum Command {
    /// Inspect data sets.
    #[command(
        subcommand,
        after_help = "Example:\n  pumptwin data summary --data ../shared/data/cwru"
    )]
    Data(DataCmd),
    /// Simulate a multi-node record with the 2-DOF bearing model (CSV + PNG plots).
    #[command(
        after_help = "Example:\n  pumptwin simulate --fault ir --rpm 1797 --duration 2 --out out/sim"
    )]
    Simulate(SimulateArgs),
    /// Print (or write) the core's node features and dynamic graphs of a record.
    #[command(
        after_help = "Example:\n  pumptwin features --input tests/data/cwru105_1s.csv --fs 12000 --rpm 1797 --bearing cwru-6205-de"
    )]
    Features(FeaturesArgs),
    /// The closed loop between measurement and the bearing model.
    #[command(
        subcommand,
        after_help = "Example:\n  pumptwin twin loop --input 105.mat --bearing cwru-6205-de --out out/loop"
    )]
    Twin(TwinCmd),
    /// Train the DS-STGAT on a protocol's split and evaluate it (writes config.json,
    /// model.bpk, metrics.json).
    #[command(
        after_help = "Example:\n  pumptwin train --data ../shared/data/cwru --protocol time-block --out out/train-tb"
    )]
    Train(TrainArgs),
    /// Evaluate a trained DS-STGAT (burn `model.bpk` or int8 model file) on a
    /// protocol's test side (metrics.json).
    #[command(
        after_help = "Example:\n  pumptwin eval --model models/dsstgat-cwru-tb.ptm --data ../shared/data/cwru --protocol time-block --out out/eval-int8"
    )]
    Eval(EvalArgs),
    /// Score the physical diagnosis, the plain envelope rule and an int8 model on
    /// records of other fault sizes and other rigs (CWRU, MFPT, HIT-SM): the report
    /// `docs/evaluation-generalization.md`.
    #[command(
        after_help = "Example:\n  pumptwin eval-generalization --out docs/evaluation-generalization.md"
    )]
    EvalGeneralization(GeneralizationArgs),
    /// Quantize a trained DS-STGAT to int8 and write the postcard model file, its
    /// golden vectors, parity figures and model card.
    #[command(
        after_help = "Example:\n  pumptwin export --model out/train-tb/model.bpk --data ../shared/data/cwru --out models/NAME.ptm"
    )]
    Export(ExportArgs),
    /// Turn recordings into a candump log packed as an edge sensor map says.
    #[command(
        after_help = "Example:\n  pumptwin can-encode --input A.mat B.mat --sensors models/cwru-sensors.toml --out my.log"
    )]
    CanEncode(CanEncodeArgs),
    /// Diagnose one recording: per-window class and probabilities, majority class.
    #[command(
        after_help = "Example:\n  pumptwin predict --input tests/data/cwru105_1s.csv --fs 12000 --rpm 1797 --model models/dsstgat-cwru-tb.ptm"
    )]
    Predict(PredictArgs),
    /// Train (where missing) and tabulate the DS-STGAT, its ablations and the baselines
    /// on every protocol (markdown + JSON table, radar and ablation charts).
    #[command(
        after_help = "Example:\n  pumptwin compare --data ../shared/data/cwru --runs out/runs --out docs/compare"
    )]
    Compare(CompareArgs),
    /// Draw the history of the edge's JSON lines (class and confidence, physics,
    /// severity, tracked stiffness and damping, health counters) as PNGs and a
    /// one-page HTML.
    #[command(
        after_help = "Example:\n  pumptwin-edge --replay models/demo.log --sensors models/cwru-sensors.toml \\\n      --model models/dsstgat-cwru-tb.ptm --out diagnoses.jsonl\n  pumptwin report --input diagnoses.jsonl --out out/report"
    )]
    Report(ReportArgs),
}

/// `pumptwin data …`
#[derive(Debug, Subcommand)]
enum DataCmd {
    /// Records, windows and split sizes of a data directory with a MANIFEST.tsv (CWRU);
    /// for the MFPT and HIT-SM layouts, every record as read (fault, speed, rate,
    /// samples, load or fault size, RMS, kurtosis) or refused.
    #[command(after_help = "Example:\n  pumptwin data summary --data ../shared/data/hit_sm")]
    Summary(SummaryArgs),
}

#[derive(Debug, Args)]
struct SummaryArgs {
    /// Data directory holding MANIFEST.tsv (CWRU, MFPT or HIT-SM).
    #[arg(long)]
    data: PathBuf,
    /// Show only this protocol's split (default: all).
    #[arg(long, value_enum)]
    protocol: Option<Protocol>,
    /// Model sampling rate in Hz.
    #[arg(long, default_value_t = MODEL_FS_HZ)]
    model_fs: f32,
    /// Window length in samples at the model rate.
    #[arg(long, default_value_t = DEFAULT_WINDOW_LEN)]
    window: usize,
    /// Hop between windows in samples.
    #[arg(long, default_value_t = DEFAULT_HOP)]
    hop: usize,
}

fn data_summary(args: &SummaryArgs) -> anyhow::Result<()> {
    if is_rig_manifest(&args.data) {
        let summary = summarize_rig(&args.data)
            .with_context(|| format!("cannot summarize {}", args.data.display()))?;
        write!(std::io::stdout().lock(), "{summary}")?;
        return Ok(());
    }
    let protocols: Vec<Protocol> = match args.protocol {
        Some(p) => vec![p],
        None => Protocol::ALL.to_vec(),
    };
    let preprocess = PreprocessConfig {
        target_fs_hz: args.model_fs,
        ..PreprocessConfig::default()
    };
    let windows = WindowConfig {
        len: args.window,
        hop: args.hop,
    };
    let summary = summarize(&args.data, &protocols, &preprocess, &windows)
        .with_context(|| format!("cannot summarize {}", args.data.display()))?;
    write!(std::io::stdout().lock(), "{summary}")?;
    Ok(())
}

/// A user's error is one message and its causes, never a backtrace whatever
/// `RUST_BACKTRACE` says (a bug, a panic, keeps its backtrace); exit status 1.
fn main() -> std::process::ExitCode {
    pumptwin_edge::ops::exit_status("pumptwin", run())
}

fn run() -> anyhow::Result<()> {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Data(DataCmd::Summary(args)) => data_summary(args),
        Command::Simulate(args) => run_simulate(args),
        Command::Features(args) => run_features(args),
        Command::Twin(cmd) => run_twin(cmd),
        Command::Train(args) => run_train(args),
        Command::Eval(args) => run_eval(args),
        Command::EvalGeneralization(args) => run_generalization(args),
        Command::Export(args) => run_export(args),
        Command::CanEncode(args) => run_can_encode(args),
        Command::Predict(args) => run_predict(args),
        Command::Compare(args) => run_compare(args),
        Command::Report(args) => run_report(args),
    };
    match result {
        Err(e) if is_broken_pipe(&e) => Ok(()),
        other => other,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// clap's own consistency checks over every subcommand: no flag named twice (a
    /// flattened argument group beside a command's own flag), defaults that parse.
    #[test]
    fn the_command_line_is_consistent() {
        Cli::command().debug_assert();
    }

    /// No help text shows a rustdoc link (`` [`NAME`] ``): help is for people.
    #[test]
    fn help_texts_hold_no_rustdoc_links() {
        fn walk(cmd: &mut clap::Command, path: &str) {
            let help = cmd.render_long_help().to_string();
            assert!(!help.contains("[`"), "{path} --help: {help}");
            for sub in cmd.get_subcommands_mut() {
                let name = format!("{path} {}", sub.get_name());
                walk(sub, &name);
            }
        }
        walk(&mut Cli::command(), "pumptwin");
    }

    /// `--rpm -5` is a value (refused later with its reason), not an unknown flag.
    #[test]
    fn negative_numbers_parse_as_values() {
        let cli = Cli::try_parse_from([
            "pumptwin", "predict", "--input", "x.csv", "--rpm", "-5", "--fs", "-1", "--model",
            "m.ptm",
        ])
        .unwrap();
        let Command::Predict(args) = cli.command else {
            panic!("not predict");
        };
        assert_eq!(args.record.rpm, Some(-5.0));
        assert_eq!(args.record.fs, Some(-1.0));
    }

    /// A user's error: the message and each cause on a line, no backtrace.
    #[test]
    fn errors_are_one_message_and_their_causes() {
        let e = anyhow::anyhow!("No such file").context("cannot read x.csv");
        let msg = pumptwin_edge::ops::error_message("pumptwin", &e);
        assert_eq!(
            msg,
            "pumptwin: error: cannot read x.csv\n  caused by: No such file"
        );
    }
}
