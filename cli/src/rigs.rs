//! The labelled measured records of the three rigs (CWRU, MFPT, HIT-SM) at the model
//! rate, as the generalization protocols and the closed loop's measured bench read
//! them.

use std::path::Path;

use anyhow::{Context, Result};
use pumptwin_core::bearing::{BearingGeometry, DefectOrders};
use pumptwin_core::diagnosis::FaultType;
use pumptwin_data::datasets::{read_dataset_manifest, DatasetFault};
use pumptwin_data::manifest::{read_manifest, FaultType as CwruType};
use pumptwin_data::preprocess::{preprocess, PreprocessConfig};
use pumptwin_data::recording::Recording;

/// One record of a protocol, at the model rate.
#[derive(Clone)]
pub(crate) struct Case {
    pub(crate) protocol: &'static str,
    pub(crate) record: String,
    pub(crate) truth: FaultType,
    /// True defect size and its unit, where the data set states one.
    pub(crate) size: Option<(f32, &'static str)>,
    /// Records of one rig, fault type and operating condition: severity is ranked
    /// against size inside a group.
    pub(crate) group: String,
    pub(crate) rec: Recording,
    /// The record at its own rate (HIT-SM only: the native-rate width experiment).
    pub(crate) native: Option<Recording>,
    pub(crate) rpm: f32,
    pub(crate) orders: DefectOrders,
    /// The bearing's geometry.
    pub(crate) bearing: BearingGeometry,
}

impl Case {
    /// The rig a measured record comes from: `cwru`, `mfpt`, `hit_sm` (`sim` for a
    /// simulated one).
    pub(crate) fn protocol_rig(&self) -> &'static str {
        match self.protocol {
            "cross-rig-mfpt" => "mfpt",
            "cross-rig-hit" => "hit_sm",
            "sim-dev" | "sim-only" => "sim",
            _ => "cwru",
        }
    }
}

pub(crate) fn preprocess_to_model_rate(raw: &Recording) -> Result<Recording> {
    preprocess(raw, &PreprocessConfig::default()).context("preprocess")
}

/// Every record of the protocols (a data set that is absent is skipped with a notice).
pub(crate) fn load_cases(data: &Path) -> Result<Vec<Case>> {
    let mut cases = Vec::new();
    let cwru = data.join("cwru");
    if cwru.join("MANIFEST.tsv").exists() {
        for e in read_manifest(&cwru)? {
            let truth = match e.fault_type {
                CwruType::Normal => FaultType::Normal,
                CwruType::InnerRace => FaultType::InnerRace,
                CwruType::OuterRace => FaultType::OuterRace,
                CwruType::Ball => FaultType::Ball,
            };
            let raw = pumptwin_data::entry::load_entry(&e)?;
            let rec = preprocess_to_model_rate(&raw)?;
            let rpm = rec
                .rpm
                .or(e.rpm_recorded)
                .context("CWRU record without a speed")?;
            let mils = e.fault_size_mils();
            cases.push(Case {
                protocol: if mils == 14 { "fault-size" } else { "cwru-dev" },
                record: e.label.clone(),
                truth,
                size: (mils > 0).then_some((e.fault_size_in, "in")),
                group: format!("cwru {} {} HP", e.fault_type.as_str(), e.load_hp),
                rec,
                native: None,
                rpm,
                orders: BearingGeometry::CWRU_6205_DE.orders(),
                bearing: BearingGeometry::CWRU_6205_DE,
            });
        }
    } else {
        eprintln!("notice: {} absent, CWRU protocols skipped", cwru.display());
    }
    let rigs: [(&str, &'static str, BearingGeometry); 2] = [
        (
            "mfpt",
            "cross-rig-mfpt",
            BearingGeometry::new(8, 0.235, 1.245, 0.0)?,
        ),
        ("hit_sm", "cross-rig-hit", BearingGeometry::CWRU_6205_DE),
    ];
    for (dir, protocol, bearing) in rigs {
        let path = data.join(dir);
        if !path.join("MANIFEST.tsv").exists() {
            eprintln!("notice: {} absent, {protocol} skipped", path.display());
            continue;
        }
        for e in read_dataset_manifest(&path)? {
            let truth = match e.fault {
                DatasetFault::Normal => FaultType::Normal,
                DatasetFault::InnerRace => FaultType::InnerRace,
                DatasetFault::OuterRace => FaultType::OuterRace,
                DatasetFault::Unknown => continue,
            };
            let raw = if dir == "mfpt" {
                pumptwin_data::mfpt::load_mfpt(&e)?.recording
            } else {
                pumptwin_data::hit_sm::load_hit_sm(&e)?.recording
            };
            let size = pumptwin_data::hit_sm::fault_size_deg(&e.label)
                .filter(|_| dir == "hit_sm")
                .map(|d| (d as f32, "deg"));
            cases.push(Case {
                protocol,
                record: e.file.clone(),
                truth,
                size,
                group: format!("{dir} {} {} rpm", e.fault.as_str(), e.rpm),
                rec: preprocess_to_model_rate(&raw)?,
                native: (dir == "hit_sm").then(|| raw.clone()),
                rpm: e.rpm,
                orders: bearing.orders(),
                bearing,
            });
        }
    }
    Ok(cases)
}
