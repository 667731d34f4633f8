//! `pumptwin compare`: train whatever run of the comparison is missing under `--runs`,
//! then write the table and charts ([`pumptwin_trainer::compare`]).

use std::path::PathBuf;

use anyhow::{Context, Result};
use pumptwin_data::windows::Protocol;
use pumptwin_trainer::compare::{
    ablation_chart, markdown, model_name, radar, read_metrics, row_from_metrics, Comparison, Row,
    MODELS, SEPARATE,
};
use pumptwin_trainer::dataset::NodeSet;
use pumptwin_trainer::training::{Ablation, Arch};

use crate::train::{run_train, TrainArgs};

/// `pumptwin compare`.
#[derive(Debug, Clone, clap::Args)]
pub struct CompareArgs {
    /// Data directory holding MANIFEST.tsv.
    #[arg(long)]
    pub data: PathBuf,
    /// Where the runs live (trained here when missing).
    #[arg(long, default_value = "out/runs")]
    pub runs: PathBuf,
    /// Output directory of the table and charts.
    #[arg(long)]
    pub out: PathBuf,
    /// Protocols (default: all three).
    #[arg(long, value_enum, num_args = 1..)]
    pub protocols: Vec<Protocol>,
    /// Epochs for runs trained here (default: the training default).
    #[arg(long)]
    pub epochs: Option<usize>,
    /// Seed for runs trained here.
    #[arg(long, default_value_t = 42)]
    pub seed: u64,
    /// Only tabulate the runs that exist; train nothing.
    #[arg(long)]
    pub no_train: bool,
}

/// Run `pumptwin compare`.
pub fn run_compare(args: &CompareArgs) -> Result<()> {
    let protocols: Vec<Protocol> = if args.protocols.is_empty() {
        Protocol::ALL.to_vec()
    } else {
        args.protocols.clone()
    };
    let mut rows = Vec::new();
    for (arch, ablation) in MODELS {
        rows.push(model_row(
            args,
            &protocols,
            arch,
            ablation,
            NodeSet::Measured,
        )?);
    }
    let mut separate = Vec::new();
    for (arch, ablation, nodes) in SEPARATE {
        separate.push(model_row(args, &protocols, arch, ablation, nodes)?);
    }
    let cmp = Comparison {
        protocols: protocols.iter().map(|p| p.name().to_string()).collect(),
        rows,
        separate,
    };
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let md = markdown(&cmp);
    std::fs::write(args.out.join("compare.md"), &md)?;
    std::fs::write(
        args.out.join("compare.json"),
        serde_json::to_string_pretty(&cmp)? + "\n",
    )?;
    radar(&args.out.join("radar.png"), &cmp)?;
    ablation_chart(&args.out.join("ablation.png"), &cmp)?;
    print!("{md}");
    eprintln!("wrote {}", args.out.display());
    Ok(())
}

/// The row of one model: its runs read, or trained where missing (unless
/// `--no-train`).
fn model_row(
    args: &CompareArgs,
    protocols: &[Protocol],
    arch: Arch,
    ablation: Ablation,
    nodes: NodeSet,
) -> Result<Row> {
    let name = model_name(arch, ablation, nodes);
    let mut metrics = Vec::new();
    for &p in protocols {
        let dir = args.runs.join(p.name()).join(&name);
        if read_metrics(&dir).is_none() && !args.no_train {
            eprintln!("== training {name} on {}", p.name());
            run_train(&TrainArgs {
                data: args.data.clone(),
                protocol: p,
                out: dir.clone(),
                config: None,
                epochs: args.epochs,
                seed: Some(args.seed),
                no_monitor: true,
                arch,
                ablation,
                nodes,
                theta_cache: args.runs.join("cache").join("theta"),
                no_figures: false,
            })
            .with_context(|| format!("training {name} on {}", p.name()))?;
        }
        metrics.push(read_metrics(&dir));
    }
    Ok(row_from_metrics(name, protocols, &metrics))
}
