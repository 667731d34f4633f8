//! The shipped int8 models against their golden vectors: every model file in
//! `models/` decodes, its sha256 is the one its golden file names, the core's int8
//! network reproduces the exported int8 logit codes exactly (integer arithmetic), and
//! the burn float model's logits within the golden file's stated relative tolerance.
//! Also: a damaged copy of each shipped file is refused with a named error.

use std::path::{Path, PathBuf};

use pumptwin_core::dsstgat::Output;
use pumptwin_core::features::FEATURE_DIM;
use pumptwin_core::graph::{Adjacency, NodeMask};
use pumptwin_core::model_file;
use pumptwin_core::Error;
use pumptwin_trainer::export::{load_model_file, Golden};

fn models_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../models")
}

fn shipped() -> Vec<(PathBuf, PathBuf)> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(models_dir()).expect("models/ exists") {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "ptm") {
            let golden = path.with_extension("golden.json");
            assert!(golden.is_file(), "{} has no golden vectors", path.display());
            out.push((path, golden));
        }
    }
    assert!(!out.is_empty(), "no model file in models/");
    out
}

fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::{Digest, Sha256};
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

#[test]
fn shipped_models_match_their_golden_vectors() {
    for (model_path, golden_path) in shipped() {
        let bytes = std::fs::read(&model_path).unwrap();
        let golden: Golden =
            serde_json::from_str(&std::fs::read_to_string(&golden_path).unwrap()).unwrap();
        assert_eq!(
            sha256_hex(&bytes),
            golden.model_sha256,
            "{}",
            model_path.display()
        );
        let loaded = load_model_file(&model_path).unwrap();
        let classes = loaded.model.classes();
        assert_eq!(golden.shape, [8, 3, FEATURE_DIM]);
        assert_eq!(loaded.model.logit_scale().get(), golden.logit_scale);
        let mut scratch = Box::new((Default::default(), Default::default()));
        let mut worst = 0.0f32;
        for (k, w) in golden.windows.iter().enumerate() {
            let x: [[[f32; FEATURE_DIM]; 3]; 8] = std::array::from_fn(|t| {
                std::array::from_fn(|i| std::array::from_fn(|f| w.x[(t * 3 + i) * FEATURE_DIM + f]))
            });
            let adj: [Adjacency<3>; 8] = std::array::from_fn(|t| {
                Adjacency(std::array::from_fn(|i| {
                    std::array::from_fn(|j| w.adj[(t * 3 + i) * 3 + j])
                }))
            });
            let mask = NodeMask(std::array::from_fn(|i| w.mask[i]));
            let mut out = Output::default();
            loaded
                .model
                .forward(&x, &adj, &mask, &mut out, &mut scratch)
                .unwrap();
            assert_eq!(
                &out.logits[..classes],
                &w.int8_logits[..],
                "window {k}: codes"
            );
            assert_eq!(out.class, w.int8_class, "window {k}: class");
            let range = w.float_logits.iter().fold(1.0f32, |m, v| m.max(v.abs()));
            for (c, &f) in w.float_logits.iter().enumerate() {
                let rel = (f - golden.logit_scale * out.logits[c] as f32).abs() / range;
                worst = worst.max(rel);
                assert!(
                    rel <= golden.relative_tolerance,
                    "window {k} class {c}: float {f}, int8 {} (relative {rel})",
                    golden.logit_scale * out.logits[c] as f32
                );
            }
        }
        println!(
            "{}: {} golden windows, int8 codes exact, max relative logit difference to burn {:.4} \
             (stated tolerance {})",
            model_path.display(),
            golden.windows.len(),
            worst,
            golden.relative_tolerance
        );
    }
}

#[test]
fn damaged_shipped_models_are_refused_by_name() {
    for (model_path, _) in shipped() {
        let bytes = std::fs::read(&model_path).unwrap();
        let mut out = Box::<model_file::ModelFile>::default();
        model_file::decode_into(&bytes, &mut out).unwrap();
        // A flipped payload byte: checksum.
        let mut bad = bytes.clone();
        bad[bytes.len() / 2] ^= 0x40;
        assert!(matches!(
            model_file::decode_into(&bad, &mut out),
            Err(Error::ModelChecksum { .. })
        ));
        // Truncated.
        assert!(matches!(
            model_file::decode_into(&bytes[..bytes.len() - 1], &mut out),
            Err(Error::ModelTruncated { .. })
        ));
        // Another format version.
        let mut bad = bytes.clone();
        bad[8] = 1;
        assert!(matches!(
            model_file::decode_into(&bad, &mut out),
            Err(Error::ModelVersion { found: 1, .. })
        ));
        // Not a model file at all.
        assert_eq!(
            model_file::decode_into(b"candump log, not a model", &mut out),
            Err(Error::ModelMagic)
        );
    }
}
