//! Load a data directory and build a protocol's featurized data, reporting sizes and
//! timings on stderr.

use std::path::Path;

use anyhow::{Context, Result};
use pumptwin_core::features::FeatureNorm;

use crate::dataset::{Corpus, IndicatorNorm, ProtocolData};
use pumptwin_core::graph::GraphConfig;
use pumptwin_data::preprocess::PreprocessConfig;
use pumptwin_data::windows::{Protocol, WindowConfig};

/// Load and preprocess every record of a data directory, reporting on stderr.
pub fn load_corpus(data_dir: &Path) -> Result<Corpus> {
    let corpus = Corpus::load(data_dir, &PreprocessConfig::default())
        .with_context(|| format!("cannot load {}", data_dir.display()))?;
    eprintln!(
        "loaded {} records from {} in {:.1} s",
        corpus.records.len(),
        data_dir.display(),
        corpus.load_seconds
    );
    Ok(corpus)
}

/// Build a protocol's data from a corpus with graph construction `graph`, reporting
/// sizes and timings on stderr.
pub fn build_protocol<const N: usize>(
    corpus: &Corpus,
    protocol: Protocol,
    norms: Option<(FeatureNorm, IndicatorNorm)>,
    graph: GraphConfig<N>,
    nodes: [&'static str; N],
) -> Result<ProtocolData<N>> {
    let data = ProtocolData::build(
        corpus,
        protocol,
        &WindowConfig::default(),
        norms,
        graph,
        nodes,
    )
    .with_context(|| format!("cannot build the {protocol} data"))?;
    let n = data.train.len() + data.test.len();
    eprintln!(
        "protocol {protocol}, nodes {}: {}\n{}features + graphs of {n} windows in {:.2} s \
         ({:.2} ms per window); masked node-windows: {} missing channel, {} rejected signal",
        nodes.join(", "),
        protocol.description(),
        data.counts_table(),
        data.featurize_seconds,
        1e3 * data.featurize_seconds / n.max(1) as f64,
        data.mask_counts.missing_channel,
        data.mask_counts.rejected_signal,
    );
    Ok(data)
}

/// Load the corpus and build a protocol's data for `nodes` with graph construction
/// `graph`.
pub fn load_protocol<const N: usize>(
    data_dir: &Path,
    protocol: Protocol,
    norms: Option<(FeatureNorm, IndicatorNorm)>,
    graph: GraphConfig<N>,
    nodes: [&'static str; N],
) -> Result<(Corpus, ProtocolData<N>)> {
    let corpus = load_corpus(data_dir)?;
    let data = build_protocol(&corpus, protocol, norms, graph, nodes)?;
    Ok((corpus, data))
}
