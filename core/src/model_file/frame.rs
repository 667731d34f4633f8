//! Framing: the header (magic, version, payload length) and the CRC-32 trailer around
//! the postcard payload — [`encode`], [`decode`], [`decode_into`], [`file_len`] and the
//! bound [`MAX_ENCODED_LEN`].

use crate::error::{Error, Result};
use crate::features::FEATURE_DIM;

use super::capacity::{
    MAX_CLASSES, MAX_CLASSIFIER_WEIGHTS, MAX_EMBED_WEIGHTS, MAX_GAT_WEIGHTS, MAX_GRU_WEIGHTS,
    MAX_HIDDEN, MAX_INDICATORS, MAX_INDICATOR_WEIGHTS, MAX_NODES, MAX_PRIOR,
    MAX_SENSOR_HEAD_WEIGHTS, NAME_LEN, TEXT_LEN,
};
use super::crc::crc32;
use super::in_place::DecodeInPlace;
use super::parts::ModelFile;

/// The first 8 bytes of every model file.
pub const MAGIC: [u8; 8] = *b"PTWINMDL";
/// The format version this core writes and reads.
pub const FORMAT_VERSION: u16 = 10;
/// Bytes before the payload: magic, version, payload length.
pub const HEADER_LEN: usize = 14;
/// Bytes after the payload: the CRC-32.
pub const CRC_LEN: usize = 4;

/// Postcard's varint length of `n`.
const fn varint_len(mut n: usize) -> usize {
    let mut len = 1;
    while n >= 0x80 {
        n >>= 7;
        len += 1;
    }
    len
}

/// Largest encoding of a sequence of at most `cap` elements of at most `elem` bytes.
const fn seq_max(cap: usize, elem: usize) -> usize {
    varint_len(cap) + cap * elem
}

/// Largest encoding of a [`QLinearParts<W, CH>`](super::QLinearParts).
const fn linear_max(w: usize, ch: usize) -> usize {
    4 + 4 + seq_max(ch, 4) + seq_max(ch, 5) + seq_max(w, 1)
}

/// Largest payload: every buffer full, every varint at its longest.
const MAX_PAYLOAD_LEN: usize = 2 * seq_max(TEXT_LEN, 1) // model_name, created
    + 8 * 3 // dims: 8 × u16
    + seq_max(MAX_CLASSES, seq_max(NAME_LEN, 1))
    + seq_max(MAX_NODES, seq_max(NAME_LEN, 1))
    + 2 * FEATURE_DIM * 4 // feature_norm
    + 4 + 4 + 3 + seq_max(MAX_PRIOR, 4) // graph
    + linear_max(MAX_EMBED_WEIGHTS, MAX_HIDDEN)
    + linear_max(MAX_GAT_WEIGHTS, MAX_HIDDEN)
    + 2 * (seq_max(MAX_HIDDEN, 1) + 4)
    + seq_max(MAX_HIDDEN, 5)
    + 4 + 4 // gat
    + 6 * linear_max(MAX_GRU_WEIGHTS, MAX_HIDDEN)
    + linear_max(MAX_HIDDEN, 1)
    + linear_max(MAX_CLASSIFIER_WEIGHTS, MAX_CLASSES)
    + linear_max(MAX_SENSOR_HEAD_WEIGHTS, MAX_CLASSES)
    + seq_max(MAX_INDICATORS, seq_max(NAME_LEN, 1)) + 2 * seq_max(MAX_INDICATORS, 4)
    + linear_max(MAX_INDICATOR_WEIGHTS, MAX_INDICATORS)
    + 7 * 8 // physics
    + 1 + 3 * 4 // geometry
    + 8 * 4; // diagnosis: 8 × f32

/// Upper bound of an encoded model file's length (a buffer this long always fits).
pub const MAX_ENCODED_LEN: usize = HEADER_LEN + MAX_PAYLOAD_LEN + CRC_LEN;

/// The total length a file declares in its header (`14 + L + 4`), after checking the
/// header's length, magic and version. For a file stored in a larger region (a flash
/// page padded with `0xFF`), decode its first `file_len(region)?` bytes (a region
/// shorter than that is [`Error::ModelTruncated`]).
///
/// # Errors
/// [`Error::ModelTruncated`] for fewer than [`HEADER_LEN`] bytes, [`Error::ModelMagic`],
/// [`Error::ModelVersion`].
pub fn file_len(bytes: &[u8]) -> Result<usize> {
    let truncated = Error::ModelTruncated {
        expected: HEADER_LEN,
        got: bytes.len(),
    };
    if bytes.len() < HEADER_LEN {
        return Err(truncated);
    }
    let (magic, rest) = bytes.split_first_chunk::<8>().ok_or(truncated)?;
    let (version, rest) = rest.split_first_chunk::<2>().ok_or(truncated)?;
    let (len, _) = rest.split_first_chunk::<4>().ok_or(truncated)?;
    if *magic != MAGIC {
        return Err(Error::ModelMagic);
    }
    let found = u16::from_le_bytes(*version);
    if found != FORMAT_VERSION {
        return Err(Error::ModelVersion {
            found,
            supported: FORMAT_VERSION,
        });
    }
    usize::try_from(u32::from_le_bytes(*len))
        .ok()
        .and_then(|l| l.checked_add(HEADER_LEN + CRC_LEN))
        .ok_or(Error::ModelTruncated {
            expected: usize::MAX,
            got: bytes.len(),
        })
}

/// Check the framing (steps 1–5 of the `model_file` module docs) and return the payload.
fn checked_payload(bytes: &[u8]) -> Result<&[u8]> {
    let total = file_len(bytes)?;
    if bytes.len() < total {
        return Err(Error::ModelTruncated {
            expected: total,
            got: bytes.len(),
        });
    }
    if bytes.len() > total {
        return Err(Error::ModelTrailingBytes {
            extra: bytes.len() - total,
        });
    }
    let body = bytes.get(HEADER_LEN..).unwrap_or_default();
    let (payload, crc) = body
        .split_last_chunk::<CRC_LEN>()
        .ok_or(Error::ModelTruncated {
            expected: total,
            got: bytes.len(),
        })?;
    let stored = u32::from_le_bytes(*crc);
    let computed = crc32(payload);
    if stored != computed {
        return Err(Error::ModelChecksum { stored, computed });
    }
    Ok(payload)
}

/// Why postcard refused a payload, in words.
fn decode_reason(e: postcard::Error) -> &'static str {
    match e {
        postcard::Error::DeserializeUnexpectedEnd => "payload ends inside a field",
        postcard::Error::DeserializeBadVarint => "malformed varint",
        postcard::Error::DeserializeBadBool => "malformed bool",
        postcard::Error::DeserializeBadChar => "malformed char",
        postcard::Error::DeserializeBadUtf8 => "a name is not UTF-8",
        postcard::Error::DeserializeBadOption => "malformed option tag",
        postcard::Error::DeserializeBadEnum => "malformed enum tag",
        postcard::Error::DeserializeBadEncoding => "malformed encoding",
        postcard::Error::SerdeDeCustom => {
            "a length exceeds its buffer's capacity or a value is out of its type's range"
        }
        _ => "postcard error",
    }
}

/// Decode and validate a model file into caller-owned storage (e.g. a `static`), the
/// MCU path: allocates nothing, needs only a few KiB of stack, never panics.
///
/// On error `out` holds partly overwritten, meaningless (but memory-safe) data.
///
/// # Errors
/// In the order checked: [`Error::ModelTruncated`], [`Error::ModelMagic`],
/// [`Error::ModelVersion`], [`Error::ModelTruncated`] / [`Error::ModelTrailingBytes`],
/// [`Error::ModelChecksum`], [`Error::ModelDecode`], [`Error::ModelDimensions`],
/// [`Error::ModelValue`] (see the `model_file` module docs).
pub fn decode_into(bytes: &[u8], out: &mut ModelFile) -> Result<()> {
    let payload = checked_payload(bytes)?;
    let mut de = postcard::Deserializer::from_bytes(payload);
    DecodeInPlace::decode_in_place(&mut de, out)
        .map_err(|e| Error::ModelDecode(decode_reason(e)))?;
    let rest = de
        .finalize()
        .map_err(|e| Error::ModelDecode(decode_reason(e)))?;
    if !rest.is_empty() {
        return Err(Error::ModelDecode("bytes left over after the model"));
    }
    out.validate()
}

/// Decode and validate a model file, returning it by value ([`decode_into`] on a
/// fresh [`ModelFile::default`]; the value itself is `size_of::<ModelFile>()` of
/// stack). Allocates nothing; never panics.
///
/// # Errors
/// Those of [`decode_into`].
pub fn decode(bytes: &[u8]) -> Result<ModelFile> {
    let mut model = ModelFile::default();
    decode_into(bytes, &mut model)?;
    Ok(model)
}

/// Validate `model` and write it as a model file into `out`; returns the number of
/// bytes written. Allocates nothing.
///
/// # Errors
/// The [`ModelFile::validate`] errors (a file [`decode`] would reject is never
/// written); [`Error::BufferSize`] if `out` is shorter than the file (`expected` is
/// the file's length, [`ModelFile::encoded_len`]; [`MAX_ENCODED_LEN`] always fits).
pub fn encode(model: &ModelFile, out: &mut [u8]) -> Result<usize> {
    model.validate()?;
    write_frame(model, out)
}

/// Postcard payload length of `model`.
fn payload_len(model: &ModelFile) -> Result<usize> {
    postcard::experimental::serialized_size(model)
        .map_err(|_| Error::InvalidParameter("postcard cannot size the model"))
}

/// Frame and write `model` without validating it.
fn write_frame(model: &ModelFile, out: &mut [u8]) -> Result<usize> {
    let len = payload_len(model)?;
    let len32 = u32::try_from(len)
        .map_err(|_| Error::ModelDimensions("payload longer than u32::MAX bytes"))?;
    let total = HEADER_LEN + len + CRC_LEN;
    let got = out.len();
    let frame = out.get_mut(..total).ok_or(Error::BufferSize {
        expected: total,
        got,
    })?;
    let (header, body) = frame.split_at_mut(HEADER_LEN);
    let (payload, crc) = body.split_at_mut(len);
    let mut h = [0u8; HEADER_LEN];
    h[..8].copy_from_slice(&MAGIC);
    h[8..10].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
    h[10..14].copy_from_slice(&len32.to_le_bytes());
    header.copy_from_slice(&h);
    let used = postcard::to_slice(model, payload)
        .map_err(|_| Error::InvalidParameter("postcard cannot serialize the model"))?
        .len();
    if used != len {
        return Err(Error::InvalidParameter(
            "postcard wrote a different length than it sized",
        ));
    }
    crc.copy_from_slice(&crc32(payload).to_le_bytes());
    Ok(total)
}

impl ModelFile {
    /// The postcard-encoded file length of this model ([`encode`] writes this many bytes).
    ///
    /// # Errors
    /// [`Error::InvalidParameter`] if postcard cannot size it (not expected).
    pub fn encoded_len(&self) -> Result<usize> {
        Ok(HEADER_LEN + payload_len(self)? + CRC_LEN)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bearing::BearingGeometry;
    use crate::layout::SENSOR_HEAD_INPUTS;
    use crate::model_file::capacity::MAX_STEPS;
    use crate::model_file::parts::{
        Dimensions, GeometryParts, GraphParts, LayerId, PhysicsParts, QLinearParts,
    };
    use crate::model_file::testkit::{
        kernels, model_from, name, test_model, C, F, HG, HR, K, N, T,
    };
    use crate::quant::linear::MAX_BIAS;
    use crate::quant::{GatLayer, GruCell};
    use crate::rng::Xoshiro128pp;
    use crate::simulator::BearingParams;
    use std::vec;
    use std::vec::Vec as StdVec;

    fn encode_vec(m: &ModelFile) -> StdVec<u8> {
        let mut buf = vec![0u8; MAX_ENCODED_LEN];
        let n = encode(m, &mut buf).unwrap();
        buf.truncate(n);
        buf
    }

    /// Frame without validation (to build files the encoder refuses).
    fn frame_vec(m: &ModelFile) -> StdVec<u8> {
        let mut buf = vec![0u8; MAX_ENCODED_LEN];
        let n = write_frame(m, &mut buf).unwrap();
        buf.truncate(n);
        buf
    }

    /// Rewrite the header length and CRC of a file whose payload starts at 14 and ends
    /// 4 bytes before the end, so that it passes the framing checks.
    fn reframe(payload: &[u8]) -> StdVec<u8> {
        let mut f = StdVec::with_capacity(payload.len() + HEADER_LEN + CRC_LEN);
        f.extend_from_slice(&MAGIC);
        f.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        f.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        f.extend_from_slice(payload);
        f.extend_from_slice(&crc32(payload).to_le_bytes());
        f
    }

    fn payload_of(file: &[u8]) -> &[u8] {
        &file[HEADER_LEN..file.len() - CRC_LEN]
    }

    #[test]
    fn round_trip_is_exact() {
        let k = kernels(7);
        let m = model_from(&k);
        m.validate().unwrap();
        let file = encode_vec(&m);
        assert_eq!(file.len(), m.encoded_len().unwrap());
        assert!(file.len() <= MAX_ENCODED_LEN);
        assert_eq!(&file[..8], b"PTWINMDL");
        assert_eq!(file_len(&file).unwrap(), file.len());
        let d = decode(&file).unwrap();
        assert_eq!(d, m);
        // The typed kernels rebuilt from the file equal the ones exported.
        assert_eq!(d.linear::<F, HG>(LayerId::Embed).unwrap(), k.embed);
        assert_eq!(d.gat_layer::<HG, HG>().unwrap(), k.gat);
        // The in-place builders give the same kernels.
        let mut g = GatLayer::<HG, HG>::EMPTY;
        d.gat_layer_into(&mut g).unwrap();
        assert_eq!(g, k.gat);
        let mut c = GruCell::<HG, HR>::EMPTY;
        d.gru_cell_into(&mut c).unwrap();
        assert_eq!(c, k.gru);
        let mut small = GruCell::<HG, 4>::EMPTY;
        assert!(matches!(
            d.gru_cell_into(&mut small),
            Err(Error::ModelDimensions(_))
        ));
        assert_eq!(d.linear::<HR, K>(LayerId::Indicator).unwrap(), k.indicator);
        assert_eq!(d.gru_cell::<HG, HR>().unwrap(), k.gru);
        assert_eq!(d.attention_pool::<HR>().unwrap(), k.pool);
        assert_eq!(d.classifier::<HR, C>().unwrap(), k.classifier);
        assert_eq!(d.class_name(3), Some("OR"));
        assert_eq!(d.class_name(4), None);
        assert_eq!(d.sensor_name(2), Some("BA"));
        assert_eq!(d.prior().len(), N * N);
        assert_eq!(
            d.bearing_params().unwrap(),
            BearingParams::default_housing()
        );
        assert_eq!(d.bearing_geometry().unwrap(), BearingGeometry::CWRU_6205_DE);
        assert_eq!(d.graph_config::<N>().unwrap().prior[0][2], 0.25);
        assert_eq!(d.feature_norm().unwrap().std[19], 0.5 + 19.0 * 0.125);
        std::println!(
            "[model_file] test model (N={N} F={F} T={T} H_gat={HG} H_gru={HR} C={C}): {} bytes encoded; \
             size_of::<ModelFile>() = {} bytes; MAX_ENCODED_LEN = {}",
            file.len(),
            core::mem::size_of::<ModelFile>(),
            MAX_ENCODED_LEN
        );
    }

    #[test]
    fn encoding_is_deterministic_and_reencodes_identically() {
        let m = test_model();
        let a = encode_vec(&m);
        let b = encode_vec(&decode(&a).unwrap());
        assert_eq!(a, b);
    }

    #[test]
    fn decode_into_overwrites_previous_contents() {
        let small = test_model();
        let mut other = model_from(&kernels(8));
        other.model_name = name("another model with a longer name");
        other.class_names.truncate(3);
        other.dims.classes = 3;
        other.classifier.weights.truncate(3 * HR);
        other.classifier.weight_scales.truncate(3);
        other.classifier.bias.truncate(3);
        other.sensor_head.weights.truncate(3 * SENSOR_HEAD_INPUTS);
        other.sensor_head.weight_scales.truncate(3);
        other.sensor_head.bias.truncate(3);
        let mut out = ModelFile::default();
        decode_into(&encode_vec(&other), &mut out).unwrap();
        assert_eq!(out, other);
        decode_into(&encode_vec(&small), &mut out).unwrap();
        assert_eq!(out, small);
        // The serde `Deserialize` impls (built on the in-place decoding) agree.
        let file = encode_vec(&small);
        let via_serde: ModelFile = postcard::from_bytes(payload_of(&file)).unwrap();
        assert_eq!(via_serde, small);
    }

    #[test]
    fn encode_reports_short_buffer() {
        let m = test_model();
        let need = m.encoded_len().unwrap();
        let mut buf = vec![0u8; need - 1];
        assert_eq!(
            encode(&m, &mut buf),
            Err(Error::BufferSize {
                expected: need,
                got: need - 1
            })
        );
    }

    #[test]
    fn encode_refuses_invalid_models() {
        let mut m = test_model();
        m.dims.classes = 5;
        let mut buf = vec![0u8; MAX_ENCODED_LEN];
        assert!(matches!(
            encode(&m, &mut buf),
            Err(Error::ModelDimensions(_))
        ));
    }

    #[test]
    fn every_single_byte_corruption_is_rejected() {
        let file = encode_vec(&test_model());
        let mut f = file.clone();
        for i in 0..file.len() {
            for mask in [0xFFu8, 0x01, 0x80] {
                f[i] ^= mask;
                let r = decode(&f);
                assert!(r.is_err(), "byte {i} ^ {mask:#04x} accepted");
                if i >= HEADER_LEN {
                    assert!(
                        matches!(r, Err(Error::ModelChecksum { .. })),
                        "byte {i}: {r:?}"
                    );
                }
                f[i] ^= mask;
            }
        }
        assert_eq!(f, file);
    }

    #[test]
    fn every_truncation_is_rejected() {
        let file = encode_vec(&test_model());
        for len in 0..file.len() {
            assert!(
                matches!(decode(&file[..len]), Err(Error::ModelTruncated { .. })),
                "prefix {len}"
            );
        }
        let mut long = file.clone();
        long.push(0xFF);
        assert_eq!(decode(&long), Err(Error::ModelTrailingBytes { extra: 1 }));
        // A padded region decodes through file_len.
        long.extend_from_slice(&[0xFF; 100]);
        assert_eq!(
            decode(&long[..file_len(&long).unwrap()]).unwrap(),
            test_model()
        );
    }

    #[test]
    fn diagnosis_settings_are_checked() {
        let mut m = test_model();
        let (t, revolutions) = decode(&encode_vec(&m))
            .unwrap()
            .diagnosis_settings()
            .unwrap();
        assert_eq!(t, crate::diagnosis::Thresholds::DEFAULT);
        assert_eq!(revolutions, crate::diagnosis::DEFAULT_REVOLUTIONS);
        // Refused when written (and when read: decoding validates the same way).
        let mut buf = vec![0u8; MAX_ENCODED_LEN];
        for bad in [f32::NAN, -1.0, 0.0] {
            m.diagnosis.line_db = bad;
            assert!(
                matches!(encode(&m, &mut buf), Err(Error::ModelValue(_))),
                "{bad}"
            );
        }
        m.diagnosis.line_db = 17.0;
        m.diagnosis.revolutions = 0.5;
        assert!(matches!(encode(&m, &mut buf), Err(Error::ModelValue(_))));
    }

    #[test]
    fn named_errors() {
        let m = test_model();
        let file = encode_vec(&m);

        let mut f = file.clone();
        f[0] = b'X';
        assert_eq!(decode(&f), Err(Error::ModelMagic));

        let mut f = file.clone();
        for old in [1u16, 2, 3, 4, 5, 6, 7, 8, 9, 11] {
            f[8..10].copy_from_slice(&old.to_le_bytes());
            assert_eq!(
                decode(&f),
                Err(Error::ModelVersion {
                    found: old,
                    supported: FORMAT_VERSION
                })
            );
        }

        let mut f = file.clone();
        let n = f.len();
        f[n - 1] ^= 0x10;
        assert!(matches!(decode(&f), Err(Error::ModelChecksum { .. })));
        let mut f = file.clone();
        f[HEADER_LEN + 3] ^= 0x10;
        let computed = crc32(payload_of(&f));
        let stored = crc32(payload_of(&file));
        assert_eq!(decode(&f), Err(Error::ModelChecksum { stored, computed }));

        let mut f = file.clone();
        f[10..14].copy_from_slice(&(u32::MAX).to_le_bytes());
        assert!(matches!(decode(&f), Err(Error::ModelTruncated { .. })));

        // Inconsistent dimensions (CRC valid: the file is framed without validation).
        let dims = |e: Error| matches!(e, Error::ModelDimensions(_));
        assert!(dims(rejected(&m, |b| b.dims.gat_hidden += 1)));
        assert_eq!(
            rejected(&m, |b| {
                b.gru.u_r.weights.pop();
            }),
            Error::ModelDimensions("gru.u_r: weight count != outputs × inputs")
        );
        assert!(dims(rejected(&m, |b| b.dims.heads = 2)));
        assert!(dims(rejected(&m, |b| b.dims.nodes = 9)));
        assert!(dims(rejected(&m, |b| b.dims.features = 19)));
        assert!(dims(rejected(&m, |b| b.dims.steps = 0)));
        assert!(dims(rejected(&m, |b| b.graph.window_steps = 5)));
        assert!(dims(rejected(&m, |b| {
            b.sensor_names.pop();
        })));
        assert!(dims(rejected(&m, |b| {
            b.gat.a_dst.pop();
        })));

        // Values.
        let value = |e: Error| matches!(e, Error::ModelValue(_));
        assert_eq!(
            rejected(&m, |b| b.gru.w_z.weight_scales[0] = f32::NAN),
            Error::ModelValue("gru.w_z: a scale is not finite and > 0")
        );
        assert!(value(rejected(&m, |b| b.classifier.output_scale = -1.0)));
        assert_eq!(
            rejected(&m, |b| b.sensor_head.output_scale *= 2.0),
            Error::ModelValue(
                "sensor_head: output scale != the classifier's (their logits are added)"
            )
        );
        assert!(value(rejected(&m, |b| b.gat.logit_scale = f32::INFINITY)));
        assert!(value(rejected(&m, |b| b.gat.a_src_scale = 0.0)));
        assert_eq!(
            rejected(&m, |b| b.feature_norm.std[5] = 0.0),
            Error::ModelValue("feature std must be > 0")
        );
        assert!(value(rejected(&m, |b| b.feature_norm.mean[0] = f32::NAN)));
        // P[0][1] != P[1][0]
        assert!(value(rejected(&m, |b| b.graph.prior[1] = 0.9)));
        assert!(value(rejected(&m, |b| b.graph.tau_corr = f32::NAN)));
        assert!(value(rejected(&m, |b| b.gru.w_n.bias[0] = MAX_BIAS + 1)));
        assert!(value(rejected(&m, |b| b.gat.project.weights[0] = i8::MIN)));
        assert_eq!(
            rejected(&m, |b| b.physics.mass = -1.0),
            Error::ModelValue("mass must be > 0")
        );
        assert!(value(
            rejected(&m, |b| b.physics.stiffness_radial = f64::NAN)
        ));
        assert!(value(rejected(&m, |b| b.geometry.n_elements = 2)));
        // Requantization ratio s_x·s_w/s_y below 2^-32.
        assert!(value(rejected(&m, |b| b.pool.input_scale = 1e-30)));
    }

    /// The error `decode` gives for `m` edited by `edit`, framed without validation
    /// (one model copy per call, so the debug-build test stack stays small).
    fn rejected(m: &ModelFile, edit: impl FnOnce(&mut ModelFile)) -> Error {
        let mut bad = m.clone();
        edit(&mut bad);
        decode(&frame_vec(&bad)).expect_err("edited model accepted")
    }

    #[test]
    fn postcard_level_errors() {
        let payload = payload_of(&encode_vec(&test_model())).to_vec();
        // Garbage payload with a valid CRC.
        assert!(matches!(
            decode(&reframe(&[0xFF, 0xFF, 0xFF])),
            Err(Error::ModelDecode(_))
        ));
        assert!(matches!(decode(&reframe(&[])), Err(Error::ModelDecode(_))));
        // A payload cut short, reframed.
        assert_eq!(
            decode(&reframe(&payload[..payload.len() - 1])),
            Err(Error::ModelDecode("payload ends inside a field"))
        );
        // Extra bytes after the model inside the payload.
        let mut longer = payload.clone();
        longer.push(0);
        assert_eq!(
            decode(&reframe(&longer)),
            Err(Error::ModelDecode("bytes left over after the model"))
        );
        // A name longer than its capacity: model_name is the first field.
        let mut p = StdVec::new();
        p.push(40u8);
        p.extend_from_slice(&[b'a'; 40]);
        p.extend_from_slice(&payload[1 + payload[0] as usize..]);
        assert!(matches!(decode(&reframe(&p)), Err(Error::ModelDecode(_))));
        // Invalid UTF-8 in the model name.
        let mut p = payload.clone();
        p[1] = 0xFF;
        assert_eq!(
            decode(&reframe(&p)),
            Err(Error::ModelDecode("a name is not UTF-8"))
        );
    }

    #[test]
    fn largest_model_fits_the_bounds() {
        let mut m = ModelFile {
            model_name: name(&"m".repeat(TEXT_LEN)),
            created: name(&"c".repeat(TEXT_LEN)),
            dims: Dimensions {
                nodes: MAX_NODES as u16,
                features: FEATURE_DIM as u16,
                steps: MAX_STEPS as u16,
                gat_hidden: MAX_HIDDEN as u16,
                gru_hidden: MAX_HIDDEN as u16,
                heads: 1,
                classes: MAX_CLASSES as u16,
                indicators: MAX_INDICATORS as u16,
            },
            ..ModelFile::default()
        };
        for _ in 0..MAX_CLASSES {
            m.class_names.push(name(&"k".repeat(NAME_LEN))).unwrap();
        }
        for _ in 0..MAX_NODES {
            m.sensor_names.push(name(&"s".repeat(NAME_LEN))).unwrap();
        }
        m.graph = GraphParts {
            prior_weight: 0.5,
            tau_corr: 0.5,
            window_steps: MAX_STEPS as u16,
            prior: core::iter::repeat_n(1.0, MAX_PRIOR).collect(),
        };
        fn fill<const W: usize, const CH: usize>(l: &mut QLinearParts<W, CH>, out: usize) {
            l.input_scale = 0.01;
            l.output_scale = 0.01;
            l.weight_scales = core::iter::repeat_n(0.01, out).collect();
            l.bias = core::iter::repeat_n(-MAX_BIAS, out).collect();
            l.weights = core::iter::repeat_n(-127, W).collect();
        }
        fill(&mut m.embed, MAX_HIDDEN);
        fill(&mut m.gat.project, MAX_HIDDEN);
        fill(&mut m.indicator.head, MAX_INDICATORS);
        for _ in 0..MAX_INDICATORS {
            m.indicator.names.push(name(&"i".repeat(NAME_LEN))).unwrap();
            m.indicator.mean.push(-1.5).unwrap();
            m.indicator.std.push(2.5).unwrap();
        }
        for l in [
            &mut m.gru.w_z,
            &mut m.gru.u_z,
            &mut m.gru.w_r,
            &mut m.gru.u_r,
            &mut m.gru.w_n,
            &mut m.gru.u_n,
        ] {
            fill(l, MAX_HIDDEN);
        }
        fill(&mut m.pool, 1);
        fill(&mut m.classifier, MAX_CLASSES);
        fill(&mut m.sensor_head, MAX_CLASSES);
        m.gat.a_src = core::iter::repeat_n(1, MAX_HIDDEN).collect();
        m.gat.a_dst = core::iter::repeat_n(1, MAX_HIDDEN).collect();
        m.gat.bias = core::iter::repeat_n(-MAX_BIAS, MAX_HIDDEN).collect();
        m.gat.a_src_scale = 0.01;
        m.gat.a_dst_scale = 0.01;
        m.gat.logit_scale = 0.01;
        m.gat.output_scale = 0.01;
        m.physics = PhysicsParts::from(&BearingParams::default_housing());
        m.geometry = GeometryParts::from(&BearingGeometry::CWRU_6205_DE);
        let file = encode_vec(&m);
        assert!(
            file.len() <= MAX_ENCODED_LEN,
            "{} > {MAX_ENCODED_LEN}",
            file.len()
        );
        // The bound is exact but for the 9 u16 varints (dims, graph window), counted
        // at 3 bytes each: here 1 byte each, but 2 for T = w = 8192.
        assert_eq!(MAX_ENCODED_LEN - file.len(), 7 * 2 + 2);
        assert_eq!(decode(&file).unwrap(), m);
        std::println!("[model_file] largest model: {} bytes", file.len());
    }

    #[test]
    fn fuzz_random_bytes_never_panic() {
        let mut rng = Xoshiro128pp::seed_from_u64(0x5EED_F11E);
        let valid_payload_len = payload_of(&encode_vec(&test_model())).len();
        let mut ok = 0;
        for i in 0..5000 {
            let len = (rng.next_u32() as usize) % (2 * valid_payload_len);
            let bytes: StdVec<u8> = (0..len).map(|_| rng.next_u32() as u8).collect();
            // Half the cases get a valid frame around the random bytes, so postcard
            // and the semantic checks see them.
            let file = if i % 2 == 0 { reframe(&bytes) } else { bytes };
            if decode(&file).is_ok() {
                ok += 1;
            }
        }
        assert_eq!(ok, 0);
    }

    #[test]
    fn fuzz_mutations_never_panic() {
        let file = encode_vec(&test_model());
        let payload = payload_of(&file).to_vec();
        let mut rng = Xoshiro128pp::seed_from_u64(0x0BAD_F00D);
        let mut reframed_ok = 0;
        for _ in 0..5000 {
            // 1. Raw mutations of the file: the framing or the CRC must catch them.
            let mut f = file.clone();
            mutate(&mut rng, &mut f);
            if f != file {
                assert!(decode(&f).is_err());
            }
            // 2. The same kind of mutation of the payload, reframed with a valid CRC,
            //    reaches postcard and the semantic checks.
            let mut p = payload.clone();
            mutate(&mut rng, &mut p);
            if let Ok(m) = decode(&reframe(&p)) {
                m.validate().unwrap();
                let again = encode_vec(&m);
                assert_eq!(decode(&again).unwrap(), m);
                reframed_ok += 1;
            }
        }
        std::println!(
            "[model_file] reframed mutations accepted as valid models: {reframed_ok} / 5000"
        );
    }

    /// Flip, overwrite, insert or delete a few random bytes, or cut the tail.
    fn mutate(rng: &mut Xoshiro128pp, b: &mut StdVec<u8>) {
        let edits = 1 + rng.next_u32() % 4;
        for _ in 0..edits {
            let len = b.len();
            let at = if len == 0 {
                0
            } else {
                rng.next_u32() as usize % len
            };
            match rng.next_u32() % 6 {
                0 | 1 if len > 0 => b[at] ^= 1 << (rng.next_u32() % 8),
                2 if len > 0 => b[at] = rng.next_u32() as u8,
                3 => b.insert(at, rng.next_u32() as u8),
                4 if len > 0 => {
                    b.remove(at);
                }
                5 => b.truncate(at),
                _ => {}
            }
        }
    }
}
