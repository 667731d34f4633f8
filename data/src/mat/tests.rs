//! Tests of [`super`]: numeric arrays, byte orders, compression, skipping and
//! malformed input, built with the test writer; and the real CWRU files when present.

use super::error::{MatError, Position};
use super::read::{read_mat, read_mat_file, HEADER_LEN};
use super::types::{ByteOrder, MatClass, SkipReason};
use super::writer::*;
use pumptwin_core::rng::Xoshiro128pp;
use std::path::PathBuf;

fn cwru_dir() -> Option<PathBuf> {
    let dir = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/cwru"
    ));
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("skipping: CWRU data not found at {}", dir.display());
        None
    }
}

#[test]
fn reads_double_vector_both_byte_orders() {
    for order in [ByteOrder::Little, ByteOrder::Big] {
        let values = [1.5, -2.25, 1e300, 0.0, -0.0];
        let mut file = header(order);
        file.extend(matrix(
            order,
            MX_DOUBLE,
            0,
            &[5, 1],
            "x",
            false,
            MI_DOUBLE,
            &f64_bytes(order, &values),
        ));
        let mat = read_mat(&file).expect("valid file");
        assert_eq!(mat.byte_order, order);
        assert_eq!(mat.variables.len(), 1);
        let v = &mat.variables[0];
        assert_eq!(v.name, "x");
        assert_eq!(v.dims, vec![5, 1]);
        assert_eq!(v.class, MatClass::Double);
        assert_eq!(v.data, values.to_vec());
        assert!(mat.header_text.starts_with("MATLAB 5.0"));
    }
}

#[test]
fn reads_single_and_int16_and_narrow_storage() {
    let order = ByteOrder::Little;
    let singles = [0.5f32, -3.75, 1e-20];
    let ints = [-32768i16, -1, 0, 7, 32767, 12];
    let mut file = header(order);
    file.extend(matrix(
        order,
        MX_SINGLE,
        0,
        &[1, 3],
        "s",
        false,
        MI_SINGLE,
        &encode(&singles, |v| v.to_le_bytes().to_vec()),
    ));
    // A 2×3 int16 array (column-major).
    file.extend(matrix(
        order,
        MX_INT16,
        0,
        &[2, 3],
        "i",
        false,
        MI_INT16,
        &encode(&ints, |v| v.to_le_bytes().to_vec()),
    ));
    // A double-class array stored as miUINT8, as MATLAB does for small integers.
    file.extend(matrix(
        order,
        MX_DOUBLE,
        0,
        &[3, 1],
        "u",
        false,
        MI_UINT8,
        &[0, 200, 255],
    ));
    let mat = read_mat(&file).expect("valid file");
    let s = mat.variable("s").expect("s");
    assert_eq!(s.class, MatClass::Single);
    assert_eq!(
        s.data,
        singles.iter().map(|&v| f64::from(v)).collect::<Vec<_>>()
    );
    let i = mat.variable("i").expect("i");
    assert_eq!(i.dims, vec![2, 3]);
    assert_eq!(
        i.data,
        ints.iter().map(|&v| f64::from(v)).collect::<Vec<_>>()
    );
    let u = mat.variable("u").expect("u");
    assert_eq!(u.class, MatClass::Double);
    assert_eq!(u.data, vec![0.0, 200.0, 255.0]);
}

#[test]
fn reads_small_element_format() {
    for order in [ByteOrder::Little, ByteOrder::Big] {
        // Name "RPM" (3 bytes) and a 1×1 int16 value (2 bytes) both in small format.
        let mut body = Vec::new();
        let mut flags = u32_bytes(order, u32::from(MX_INT16)).to_vec();
        flags.extend_from_slice(&[0; 4]);
        body.extend(element(order, MI_UINT32, &flags));
        let mut dims = Vec::new();
        for d in [1i32, 1] {
            dims.extend_from_slice(&match order {
                ByteOrder::Little => d.to_le_bytes(),
                ByteOrder::Big => d.to_be_bytes(),
            });
        }
        body.extend(element(order, MI_INT32, &dims));
        body.extend(small_element(order, MI_INT8, b"RPM"));
        let v: i16 = -1797;
        let vb = match order {
            ByteOrder::Little => v.to_le_bytes(),
            ByteOrder::Big => v.to_be_bytes(),
        };
        body.extend(small_element(order, MI_INT16, &vb));
        let mut file = header(order);
        file.extend(element(order, MI_MATRIX, &body));
        let mat = read_mat(&file).expect("valid file");
        let rpm = mat.variable("RPM").expect("RPM present");
        assert_eq!(rpm.data, vec![-1797.0]);
        assert_eq!(rpm.class, MatClass::Int16);
    }
}

#[test]
fn reads_compressed_element() {
    let order = ByteOrder::Little;
    let values: Vec<f64> = (0..1000).map(|i| (i as f64 * 0.01).sin()).collect();
    let inner = matrix(
        order,
        MX_DOUBLE,
        0,
        &[1000, 1],
        "X001_DE_time",
        false,
        MI_DOUBLE,
        &f64_bytes(order, &values),
    );
    let mut file = header(order);
    file.extend(compressed(order, &inner));
    file.extend(matrix(
        order,
        MX_DOUBLE,
        0,
        &[1, 1],
        "after",
        false,
        MI_DOUBLE,
        &f64_bytes(order, &[42.0]),
    ));
    assert!(
        file.len() < HEADER_LEN + inner.len(),
        "the test data should compress"
    );
    let mat = read_mat(&file).expect("valid file");
    assert_eq!(mat.variables.len(), 2);
    assert_eq!(mat.variables[0].name, "X001_DE_time");
    assert_eq!(mat.variables[0].data, values);
    assert_eq!(mat.variables[1].data, vec![42.0]);
}

#[test]
fn skips_and_lists_unsupported_classes() {
    let order = ByteOrder::Little;
    let mut file = header(order);
    // A char array, a complex double, a cell holding an empty matrix.
    file.extend(matrix(
        order,
        MX_CHAR,
        0,
        &[1, 2],
        "label",
        false,
        4, /* miUINT16 */
        &[b'o', 0, b'k', 0],
    ));
    let mut cplx = matrix(
        order,
        MX_DOUBLE,
        0x0800,
        &[1, 1],
        "z",
        false,
        MI_DOUBLE,
        &f64_bytes(order, &[1.0]),
    );
    // A complex array has an imaginary part too; append it inside the matrix.
    let imag = element(order, MI_DOUBLE, &f64_bytes(order, &[2.0]));
    let body_len = u32::from_le_bytes([cplx[4], cplx[5], cplx[6], cplx[7]]) as usize + imag.len();
    cplx[4..8].copy_from_slice(&(body_len as u32).to_le_bytes());
    cplx.extend(imag);
    file.extend(cplx);
    let mut cell_body = Vec::new();
    cell_body.extend(element(order, MI_UINT32, &[MX_CELL, 0, 0, 0, 0, 0, 0, 0]));
    cell_body.extend(element(
        order,
        MI_INT32,
        &encode(&[1i32, 1], |d| d.to_le_bytes().to_vec()),
    ));
    cell_body.extend(small_element(order, MI_INT8, b"c"));
    cell_body.extend(element(order, MI_MATRIX, &[]));
    file.extend(element(order, MI_MATRIX, &cell_body));
    file.extend(element(order, MI_MATRIX, &[]));
    file.extend(matrix(
        order,
        MX_DOUBLE,
        0,
        &[1, 1],
        "ok",
        false,
        MI_DOUBLE,
        &f64_bytes(order, &[3.0]),
    ));
    let mat = read_mat(&file).expect("file with extras is still readable");
    assert_eq!(mat.variables.len(), 1);
    assert_eq!(mat.variables[0].name, "ok");
    // The char array is read as text, no longer skipped.
    assert_eq!(mat.text("label"), Some("ok"));
    let skipped: Vec<(&str, SkipReason)> = mat
        .skipped
        .iter()
        .map(|s| (s.name.as_str(), s.reason))
        .collect();
    assert_eq!(
        skipped,
        vec![
            ("z", SkipReason::Complex),
            ("c", SkipReason::UnsupportedClass(MatClass::Cell)),
            ("", SkipReason::EmptyMatrix),
        ]
    );
}

#[test]
fn truncation_at_every_prefix_fails_unless_at_an_element_boundary() {
    let order = ByteOrder::Little;
    let values: Vec<f64> = (0..37).map(|i| i as f64 - 10.5).collect();
    let first = matrix(
        order,
        MX_DOUBLE,
        0,
        &[37, 1],
        "a",
        false,
        MI_DOUBLE,
        &f64_bytes(order, &values),
    );
    let second = compressed(
        order,
        &matrix(
            order,
            MX_SINGLE,
            0,
            &[1, 3],
            "b",
            true,
            MI_SINGLE,
            &encode(&[1.0f32, 2.0, 3.0], |v| v.to_le_bytes().to_vec()),
        ),
    );
    let mut file = header(order);
    let boundary_1 = file.len();
    file.extend(first);
    let boundary_2 = file.len();
    file.extend(second);
    let full = read_mat(&file).expect("full file");
    assert_eq!(full.variables.len(), 2);
    for len in 0..file.len() {
        match read_mat(&file[..len]) {
            Ok(mat) if len == boundary_1 => assert!(mat.variables.is_empty()),
            Ok(mat) if len == boundary_2 => {
                assert_eq!(mat.variables, full.variables[..1].to_vec());
            }
            Ok(mat) => panic!(
                "prefix of {len} bytes parsed as {} variables",
                mat.variables.len()
            ),
            Err(_) => {}
        }
    }
}

#[test]
fn errors_name_the_problem_and_offset() {
    let file = double_vectors(&[("x", &[1.0, 2.0])]);
    let err = read_mat(&file[..file.len() - 3]).expect_err("truncated");
    assert!(
        matches!(
            err,
            MatError::Truncated {
                at: Position { offset: 128, .. },
                ..
            }
        ),
        "{err}"
    );

    let mut bad = file.clone();
    bad[126] = b'X';
    assert!(matches!(read_mat(&bad), Err(MatError::BadHeader { .. })));

    let mut v73 = file.clone();
    v73[124..126].copy_from_slice(&0x0200u16.to_le_bytes());
    assert!(matches!(
        read_mat(&v73),
        Err(MatError::UnsupportedVersion { version: 0x0200 })
    ));

    // Dimensions element claiming more bytes than the matrix holds.
    let mut overrun = file.clone();
    let dims_len_at = 128 + 8 + 16 + 4;
    overrun[dims_len_at..dims_len_at + 4].copy_from_slice(&1000u32.to_le_bytes());
    let err = read_mat(&overrun).expect_err("overrun");
    assert!(
        matches!(
            err,
            MatError::ElementOverrun {
                what: "dimensions",
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("byte 152"), "{err}");

    // Negative dimension.
    let mut neg = file.clone();
    neg[128 + 8 + 16 + 8..128 + 8 + 16 + 12].copy_from_slice(&(-2i32).to_le_bytes());
    assert!(matches!(read_mat(&neg), Err(MatError::BadDims { .. })));

    // Dimensions that disagree with the data.
    let mut wrong = file.clone();
    wrong[128 + 8 + 16 + 8..128 + 8 + 16 + 12].copy_from_slice(&3i32.to_le_bytes());
    assert!(matches!(
        read_mat(&wrong),
        Err(MatError::DataLength {
            expected: 3,
            got: 2,
            ..
        })
    ));

    // Corrupt zlib data.
    let order = ByteOrder::Little;
    let mut z = header(order);
    let mut c = compressed(
        order,
        &matrix(
            order,
            MX_DOUBLE,
            0,
            &[1, 1],
            "q",
            false,
            MI_DOUBLE,
            &f64_bytes(order, &[1.0]),
        ),
    );
    let mid = c.len() / 2;
    c[mid] ^= 0xff;
    c[mid + 1] ^= 0x55;
    z.extend(c);
    assert!(read_mat(&z).is_err());
}

#[test]
fn huge_size_fields_do_not_allocate() {
    let mut file = header(ByteOrder::Little);
    file.extend_from_slice(&14u32.to_le_bytes());
    file.extend_from_slice(&u32::MAX.to_le_bytes());
    file.extend_from_slice(&[0u8; 64]);
    let err = read_mat(&file).expect_err("declared size beyond input");
    assert!(
        matches!(err, MatError::Truncated { needed, .. } if needed > u32::MAX as usize),
        "{err}"
    );
}

#[test]
fn random_corruption_never_panics() {
    let order = ByteOrder::Little;
    let mut file = double_vectors(&[("a", &[1.0, 2.0, 3.0]), ("b", &[4.0])]);
    file.extend(compressed(
        order,
        &matrix(
            order,
            MX_INT16,
            0,
            &[2, 1],
            "c",
            true,
            MI_INT16,
            &[1, 0, 2, 0],
        ),
    ));
    let mut rng = Xoshiro128pp::seed_from_u64(0x6d61_7431);
    for _ in 0..3000 {
        let mut m = file.clone();
        let flips = 1 + rng.next_u32() % 4;
        for _ in 0..flips {
            let i = HEADER_LEN + (rng.next_u32() as usize) % (m.len() - HEADER_LEN);
            m[i] = rng.next_u32() as u8;
        }
        // Only the absence of a panic is asserted; most mutations are errors.
        let _ = read_mat(&m);
    }
}

#[test]
fn reads_cwru_105() {
    let Some(dir) = cwru_dir() else { return };
    let mat = read_mat_file(dir.join("12k_DE/105.mat")).expect("105.mat");
    let de = mat.variable("X105_DE_time").expect("DE channel");
    assert_eq!(de.dims, vec![121_265, 1]);
    assert_eq!(de.data.len(), 121_265);
    assert!(de.data.iter().all(|x| x.is_finite()));
    let rms = (de.data.iter().map(|x| x * x).sum::<f64>() / de.data.len() as f64).sqrt();
    assert!(rms > 0.01 && rms < 10.0, "DE rms {rms} g is implausible");
    let rpm = mat.variable("X105RPM").expect("RPM");
    assert_eq!(rpm.data.len(), 1);
    assert!((rpm.data[0] - 1797.0).abs() < 1.0, "rpm {}", rpm.data[0]);
    for ch in ["FE", "BA"] {
        assert!(mat.variable(&format!("X105_{ch}_time")).is_some(), "{ch}");
    }
}
