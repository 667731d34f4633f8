//! The core's model-file decoder. The input is tried twice: as a whole file (header,
//! length and CRC checks), and as a postcard payload framed with a valid header and
//! CRC, so that mutations reach the payload decoder and `validate` instead of dying
//! at the checksum. A file that decodes is built into the int8 network and run once.
#![no_main]

use libfuzzer_sys::fuzz_target;
use pumptwin_core::dsstgat::{DsStgat, Output, Scratch};
use pumptwin_core::features::FEATURE_DIM;
use pumptwin_core::graph::{Adjacency, NodeMask};
use pumptwin_core::model_file::{self, crc32, ModelFile, FORMAT_VERSION, MAGIC};

/// The shipped model's shapes (the gateway's): F = 28, H = 32, ≤ 16 classes, ≤ 8
/// indicators; 8 steps, 3 nodes.
type Net = DsStgat<FEATURE_DIM, 32, 16, 8>;

fn framed(payload: &[u8]) -> Vec<u8> {
    let mut f = Vec::with_capacity(payload.len() + 18);
    f.extend_from_slice(&MAGIC);
    f.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    f.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    f.extend_from_slice(payload);
    f.extend_from_slice(&crc32(payload).to_le_bytes());
    f
}

fn exercise(bytes: &[u8], model: &mut ModelFile) {
    if model_file::decode_into(bytes, model).is_err() {
        return;
    }
    // A decoded file is valid: every accessor the gateway uses must answer.
    let _ = model.feature_norm();
    let _ = model.graph_config::<3>();
    let _ = model.encoded_len();
    let mut encoded = vec![0u8; model_file::MAX_ENCODED_LEN];
    let n = model_file::encode(model, &mut encoded).expect("a decoded model re-encodes");
    let mut again = Box::<ModelFile>::default();
    model_file::decode_into(&encoded[..n], &mut again).expect("a re-encoded model decodes");
    let mut net = Box::new(Net::EMPTY);
    if net.load(model).is_err() {
        return;
    }
    let x = [[[0.25f32; FEATURE_DIM]; 3]; 8];
    let mut eye = Adjacency::<3>::ZERO;
    for i in 0..3 {
        eye.0[i][i] = 1.0;
    }
    let adj = [eye; 8];
    let mut out = Output::<16, 8>::default();
    let mut scratch = Box::new(Scratch::<8, 3, FEATURE_DIM, 32>::new());
    let _ = net.forward::<8, 3>(&x, &adj, &NodeMask::ALL, &mut out, &mut scratch);
}

fuzz_target!(|data: &[u8]| {
    let mut model = Box::<ModelFile>::default();
    exercise(data, &mut model);
    exercise(&framed(data), &mut model);
});
