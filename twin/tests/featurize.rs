//! The data crate's featurization glue on a record from the twin's simulator (moved here
//! from `pumptwin_data::featurize`: the data crate does not depend on the twin).
use pumptwin_core::bearing::{BearingGeometry, DefectLocation};
use pumptwin_core::features::FEATURE_DIM;
use pumptwin_core::graph::GraphConfig;
use pumptwin_data::featurize::{
    feature_config, fit_norm, window_features, window_graphs, MaskCounts,
};
use pumptwin_twin::sim::{simulate, SimulationSpec};

#[test]
fn features_and_graphs_of_a_simulated_record() {
    let rec = simulate(&SimulationSpec::cwru_like(
        Some(DefectLocation::OuterRace),
        1797.0,
        1.0,
        2,
    ))
    .unwrap();
    let cfg = feature_config(
        rec.fs_hz,
        1797.0 / 60.0,
        BearingGeometry::CWRU_6205_DE.orders(),
    );
    let starts: Vec<usize> = (0..4).map(|k| k * 1024).collect();
    let mut counts = MaskCounts::default();
    // "XX" is not a channel of the record: masked and counted.
    let w = window_features(&rec, &["DE", "FE", "XX"], &cfg, &starts, &mut counts);
    assert_eq!(w.len(), 4);
    assert_eq!(counts.missing_channel, 4);
    assert!(w.iter().all(|w| w.mask.0 == [true, true, false]));
    // Outer-race fault: env_bpfo stands out at DE.
    let bpfo_db = w[0].features[0][0][pumptwin_core::features::ENVELOPE_OFFSET + 1];
    assert!(bpfo_db > 10.0, "env_bpfo_db {bpfo_db}");
    let norm = fit_norm(&w);
    let (x, a) = window_graphs(&w[0], &norm, &GraphConfig::uniform()).unwrap();
    assert_eq!(x[0][2], [0.0; FEATURE_DIM]);
    assert_eq!(a[0].0[2], [0.0, 0.0, 1.0]);
    assert!(a[3].0[0][1] > 0.0);
}
