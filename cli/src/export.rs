//! `pumptwin export`: quantize a trained DS-STGAT into the postcard model file
//! ([`pumptwin_trainer::export`]).

use std::path::PathBuf;

use anyhow::{ensure, Result};
use pumptwin_trainer::export::{export_model, ExportSpec};

/// `pumptwin export`: quantize a trained model into the postcard model file.
#[derive(Debug, Clone, clap::Args)]
pub struct ExportArgs {
    /// The trained weights (`model.bpk`; `config.json` and `normalization.json` beside).
    #[arg(long)]
    pub model: PathBuf,
    /// The model file to write (e.g. `models/dsstgat-cwru-time-block.ptm`); the golden
    /// vectors and the model card go beside it (`.golden.json`, `.md`).
    #[arg(long)]
    pub out: PathBuf,
    /// Quantize to int8 (the model file holds the int8 network; this is the only
    /// mode, the flag is accepted for scripts that spell it out).
    #[arg(long, default_value_t = true)]
    pub quantize: bool,
    /// Data directory (MANIFEST.tsv) for calibration (training side) and parity (test side).
    #[arg(long)]
    pub data: PathBuf,
    /// Golden windows to ship with the model.
    #[arg(long, default_value_t = 12)]
    pub golden: usize,
}

/// Run `pumptwin export`.
pub fn run_export(args: &ExportArgs) -> Result<()> {
    ensure!(
        args.quantize,
        "the model file holds the int8 network; the float model stays in model.bpk"
    );
    export_model(&ExportSpec {
        model: args.model.clone(),
        out: args.out.clone(),
        data: args.data.clone(),
        golden: args.golden,
    })
}
