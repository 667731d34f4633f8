//! `pumptwin predict` on the shipped 1 s fixture of record 105 (inner race, 0.007"):
//! the int8 model through the core, and the burn float model, both call it IR007;
//! with only the DE channel the other nodes are masked, the output says so, and the
//! diagnosis still holds.

use std::path::{Path, PathBuf};

use pumptwin_trainer::cli::RecordArgs;
use pumptwin_trainer::predict::{run_predict, PredictArgs};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn predict(input: &Path, model: &str, out: &Path) -> serde_json::Value {
    run_predict(&PredictArgs {
        record: RecordArgs {
            input: input.to_owned(),
            fs: Some(12_000.0),
            rpm: Some(1797.0),
            bearing: "cwru-6205-de".into(),
        },
        model: root().join(model),
        out: Some(out.to_owned()),
    })
    .unwrap();
    serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap()
}

#[test]
fn predict_fixture_with_int8_and_float_models_and_a_channel_subset() {
    let dir = std::env::temp_dir().join(format!("pumptwin-predict-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let fixture = root().join("tests/data/cwru105_1s.csv");
    for model in [
        "models/dsstgat-cwru-tb.ptm",
        "models/dsstgat-cwru-tb.float/model.bpk",
    ] {
        let r = predict(&fixture, model, &dir.join("p.json"));
        assert_eq!(r["majority_class"], "IR007", "{model}");
        assert_eq!(r["windows"].as_array().unwrap().len(), 10);
        assert_eq!(r["missing_nodes"].as_array().unwrap().len(), 0);
    }
    // DE only: FE and BA masked and reported.
    let text = std::fs::read_to_string(&fixture).unwrap();
    let mut lines = text.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let de = header.iter().position(|h| h.trim() == "DE").unwrap();
    let mut only = String::from("DE\n");
    for l in lines {
        only.push_str(l.split(',').nth(de).unwrap());
        only.push('\n');
    }
    let de_only = dir.join("de_only.csv");
    std::fs::write(&de_only, only).unwrap();
    let r = predict(&de_only, "models/dsstgat-cwru-tb.ptm", &dir.join("q.json"));
    assert_eq!(r["missing_nodes"], serde_json::json!(["FE", "BA"]));
    assert_eq!(
        r["windows"][0]["masked_nodes"],
        serde_json::json!(["FE", "BA"])
    );
    assert_eq!(r["majority_class"], "IR007");
    let _ = std::fs::remove_dir_all(&dir);
}
