//! Tests of the struct and char-array reading of [`super`]: files built with the test
//! writer, read back, and malformed on purpose.

use super::error::MatError;
use super::read::{read_mat, HEADER_LEN};
use super::structs::MAX_STRUCT_DEPTH;
use super::types::{ByteOrder, MatClass, SkipReason};
use super::writer::*;
use pumptwin_core::rng::Xoshiro128pp;

fn units(text: &str) -> Vec<u16> {
    text.encode_utf16().collect()
}

/// An MFPT-like `bearing` struct: `rate` (double class in uint8 storage), `load` (char),
/// `gs` (a column of doubles), `sr` (uint16 storage).
fn bearing(order: ByteOrder, gs: &[f64]) -> Vec<u8> {
    let rate = matrix(order, MX_DOUBLE, 0, &[1, 1], "", false, MI_UINT8, &[25]);
    let load = char_matrix(order, &[1, 6], "", &units("25 lbs"));
    let signal = double_field(order, &[gs.len() as i32, 1], gs);
    let sr_bytes = match order {
        ByteOrder::Little => 48828u16.to_le_bytes(),
        ByteOrder::Big => 48828u16.to_be_bytes(),
    };
    let sr = matrix(
        order,
        MX_DOUBLE,
        0,
        &[1, 1],
        "",
        false,
        MI_UINT16,
        &sr_bytes,
    );
    struct_matrix(
        order,
        &[1, 1],
        "bearing",
        32,
        &["rate", "load", "gs", "sr"],
        &[rate, load, signal, sr],
    )
}

/// `levels` structs nested in one another (`s.f.f…`), the innermost holding `x = 1`.
fn nested(levels: usize) -> Vec<u8> {
    let order = ByteOrder::Little;
    let mut inner = struct_matrix(
        order,
        &[1, 1],
        "",
        8,
        &["x"],
        &[double_field(order, &[1, 1], &[1.0])],
    );
    for level in 1..levels {
        let name = if level + 1 == levels { "s" } else { "" };
        inner = struct_matrix(order, &[1, 1], name, 8, &["f"], &[inner]);
    }
    let mut file = header(order);
    file.extend(inner);
    file
}

/// A 1×1 struct with numeric and char fields reads as `struct.field` variables and
/// texts, in both byte orders, and a variable after it still reads.
#[test]
fn reads_struct_fields_and_char_arrays() {
    for order in [ByteOrder::Little, ByteOrder::Big] {
        let gs = [0.5, -0.25, 1.0, -2.0, 0.125];
        let mut file = header(order);
        file.extend(bearing(order, &gs));
        file.extend(matrix(
            order,
            MX_DOUBLE,
            0,
            &[1, 1],
            "after",
            false,
            MI_DOUBLE,
            &f64_bytes(order, &[7.0]),
        ));
        let mat = read_mat(&file).expect("valid struct file");
        let names: Vec<&str> = mat.variables.iter().map(|v| v.name.as_str()).collect();
        assert_eq!(names, ["bearing.rate", "bearing.gs", "bearing.sr", "after"]);
        let signal = mat.variable("bearing.gs").expect("gs");
        assert_eq!(signal.dims, vec![5, 1]);
        assert!(signal.is_vector());
        assert_eq!(signal.data, gs.to_vec());
        assert_eq!(signal.class, MatClass::Double);
        assert_eq!(mat.variable("bearing.sr").expect("sr").data, vec![48828.0]);
        assert_eq!(mat.variable("bearing.rate").expect("rate").data, vec![25.0]);
        assert_eq!(mat.text("bearing.load"), Some("25 lbs"));
        assert_eq!(mat.texts.len(), 1);
        assert_eq!(mat.texts[0].dims, vec![1, 6]);
        assert_eq!(mat.variable("after").expect("after").data, vec![7.0]);
        assert!(mat.skipped.is_empty(), "{:?}", mat.skipped);
    }
}

/// A struct inside a compressed element (as MATLAB's `save -v7` writes it) reads the
/// same as an uncompressed one.
#[test]
fn reads_compressed_struct() {
    let order = ByteOrder::Little;
    let gs: Vec<f64> = (0..500).map(|i| (f64::from(i) * 0.1).cos()).collect();
    let mut plain = header(order);
    plain.extend(bearing(order, &gs));
    let mut zipped = header(order);
    zipped.extend(compressed(order, &bearing(order, &gs)));
    assert!(
        zipped.len() < plain.len(),
        "the test struct should compress"
    );
    assert_eq!(
        read_mat(&zipped).expect("compressed"),
        read_mat(&plain).expect("plain")
    );
}

/// Nested structs give dotted names; struct arrays index their elements from 1; cells,
/// empty fields, complex fields inside a struct are skipped under their full names.
#[test]
fn nested_structs_arrays_and_skipped_fields() {
    let order = ByteOrder::Little;
    let inner = struct_matrix(
        order,
        &[1, 1],
        "",
        16,
        &["c", "note"],
        &[
            double_field(order, &[1, 2], &[3.0, 4.0]),
            char_matrix(order, &[1, 2], "", &units("hi")),
        ],
    );
    let mut cell_body = Vec::new();
    cell_body.extend(element(order, MI_UINT32, &[MX_CELL, 0, 0, 0, 0, 0, 0, 0]));
    cell_body.extend(element(
        order,
        MI_INT32,
        &encode(&[1i32, 1], |d| d.to_le_bytes().to_vec()),
    ));
    cell_body.extend(element(order, MI_INT8, b""));
    let cell = element(order, MI_MATRIX, &cell_body);
    let outer = struct_matrix(
        order,
        &[1, 1],
        "a",
        16,
        &["b", "cell", "none"],
        &[inner, cell, element(order, MI_MATRIX, &[])],
    );
    // A 1×2 struct array: elements in order, each with all fields.
    let array = struct_matrix(
        order,
        &[1, 2],
        "s",
        8,
        &["x", "y"],
        &[
            double_field(order, &[1, 1], &[1.0]),
            double_field(order, &[1, 1], &[2.0]),
            double_field(order, &[1, 1], &[3.0]),
            double_field(order, &[1, 1], &[4.0]),
        ],
    );
    // A struct with no fields, and an empty struct array, hold nothing.
    let bare = struct_matrix(order, &[1, 1], "bare", 8, &[], &[]);
    let none = struct_matrix(order, &[0, 0], "none", 8, &["x"], &[]);
    let mut file = header(order);
    for part in [outer, array, bare, none] {
        file.extend(part);
    }
    let mat = read_mat(&file).expect("valid file");
    let got: Vec<(&str, &[f64])> = mat
        .variables
        .iter()
        .map(|v| (v.name.as_str(), v.data.as_slice()))
        .collect();
    assert_eq!(
        got,
        vec![
            ("a.b.c", &[3.0, 4.0][..]),
            ("s(1).x", &[1.0][..]),
            ("s(1).y", &[2.0][..]),
            ("s(2).x", &[3.0][..]),
            ("s(2).y", &[4.0][..]),
        ]
    );
    assert_eq!(mat.text("a.b.note"), Some("hi"));
    let skipped: Vec<(&str, SkipReason)> = mat
        .skipped
        .iter()
        .map(|s| (s.name.as_str(), s.reason))
        .collect();
    assert_eq!(
        skipped,
        vec![
            ("a.cell", SkipReason::UnsupportedClass(MatClass::Cell)),
            ("a.none", SkipReason::EmptyMatrix),
        ]
    );
}

/// A multi-row char array reads row by row; an empty one as ""; 8-bit and UTF-8
/// storage read too.
#[test]
fn char_array_layouts() {
    let order = ByteOrder::Little;
    let mut file = header(order);
    // Rows "abc" and "def", column-major: a d b e c f.
    file.extend(char_matrix(order, &[2, 3], "rows", &units("adbecf")));
    file.extend(char_matrix(order, &[0, 0], "empty", &[]));
    file.extend(matrix(
        order,
        MX_CHAR,
        0,
        &[1, 3],
        "latin",
        false,
        MI_UINT8,
        b"lbs",
    ));
    file.extend(matrix(
        order,
        MX_CHAR,
        0,
        &[1, 2],
        "utf8",
        false,
        16,
        "µm".as_bytes(),
    ));
    let mat = read_mat(&file).expect("valid file");
    assert_eq!(mat.text("rows"), Some("abc\ndef"));
    assert_eq!(mat.text("empty"), Some(""));
    assert_eq!(mat.text("latin"), Some("lbs"));
    assert_eq!(mat.text("utf8"), Some("µm"));
    assert!(mat.variables.is_empty());
}

/// Malformed char arrays are errors that say what is wrong.
#[test]
fn malformed_char_arrays_are_errors() {
    let order = ByteOrder::Little;
    let mut short = header(order);
    short.extend(char_matrix(order, &[1, 5], "t", &units("abc")));
    assert!(
        matches!(
            read_mat(&short),
            Err(MatError::DataLength {
                expected: 5,
                got: 3,
                ..
            })
        ),
        "{:?}",
        read_mat(&short)
    );
    let mut odd = header(order);
    odd.extend(matrix(
        order,
        MX_CHAR,
        0,
        &[1, 1],
        "t",
        false,
        MI_UINT16,
        &[b'a', 0, b'b'],
    ));
    assert!(matches!(
        read_mat(&odd),
        Err(MatError::RaggedData {
            element_size: 2,
            ..
        })
    ));
    let mut wrong = header(order);
    wrong.extend(matrix(
        order,
        MX_CHAR,
        0,
        &[1, 1],
        "t",
        false,
        MI_DOUBLE,
        &f64_bytes(order, &[1.0]),
    ));
    assert!(matches!(
        read_mat(&wrong),
        Err(MatError::UnexpectedDataType {
            what: "characters",
            ..
        })
    ));
}

/// Bad field-name lengths, names, and field values are errors naming the struct.
#[test]
fn malformed_structs_are_errors() {
    let order = ByteOrder::Little;
    let one = || vec![double_field(order, &[1, 1], &[1.0])];
    let read = |part: Vec<u8>| {
        let mut file = header(order);
        file.extend(part);
        read_mat(&file)
    };
    for bad_len in [0, -8] {
        let err = read(struct_matrix(order, &[1, 1], "b", bad_len, &[], &[]))
            .expect_err("non-positive field-name length");
        assert!(
            matches!(&err, MatError::BadStruct { name, reason, .. }
                if name == "b" && reason.contains("field-name length")),
            "{err}"
        );
    }
    // Names of 8 bytes each, but the field-name length says 5.
    let mut file = struct_matrix(order, &[1, 1], "b", 8, &["x"], &one());
    let len_at = 8 + 16 + 16 + 16; // matrix tag, flags, dims, name "b"
    file[len_at + 4..len_at + 8].copy_from_slice(&5i32.to_le_bytes());
    let err = read(file).expect_err("ragged names");
    assert!(
        matches!(&err, MatError::BadStruct { reason, .. } if reason.contains("whole number")),
        "{err}"
    );
    // Field-name length stored as miINT16.
    let mut file = struct_matrix(order, &[1, 1], "b", 8, &["x"], &one());
    file[len_at] = MI_INT16 as u8;
    let err = read(file).expect_err("wrong length type");
    assert!(
        matches!(
            err,
            MatError::UnexpectedDataType {
                what: "field-name length",
                ..
            }
        ),
        "{err}"
    );
    let err = read(struct_matrix(order, &[1, 1], "b", 8, &[""], &one())).expect_err("empty");
    assert!(
        matches!(&err, MatError::BadStruct { reason, .. } if reason.contains("empty name")),
        "{err}"
    );
    let err = read(struct_matrix(order, &[1, 1], "b", 8, &["x", "y"], &one()))
        .expect_err("a field value is missing");
    assert!(
        matches!(&err, MatError::MissingSubelement { name, what: "field value", .. }
            if name == "b.y"),
        "{err}"
    );
    let not_matrix = element(order, MI_DOUBLE, &f64_bytes(order, &[1.0]));
    let err = read(struct_matrix(order, &[1, 1], "b", 8, &["x"], &[not_matrix]))
        .expect_err("a field value that is not a matrix");
    assert!(
        matches!(&err, MatError::UnexpectedDataType { name, what: "field value", .. }
            if name == "b.x"),
        "{err}"
    );
    // An error inside a field names the field.
    let bad_field = matrix(order, MX_DOUBLE, 0, &[1, 3], "", false, MI_DOUBLE, &[0; 8]);
    let err = read(struct_matrix(order, &[1, 1], "b", 8, &["x"], &[bad_field]))
        .expect_err("field data shorter than its dims");
    assert!(
        matches!(&err, MatError::DataLength { name, .. } if name == "b.x"),
        "{err}"
    );
    // A huge struct array with one field runs out of input, not out of memory or time.
    let err = read(struct_matrix(
        order,
        &[i32::MAX, i32::MAX],
        "b",
        8,
        &["x"],
        &one(),
    ))
    .expect_err("element 2 missing");
    assert!(
        matches!(&err, MatError::MissingSubelement { name, .. } if name == "b(2).x"),
        "{err}"
    );
}

/// Structs may nest `MAX_STRUCT_DEPTH` deep; one more is an error, not a stack overflow.
#[test]
fn struct_depth_is_limited() {
    let mat = read_mat(&nested(MAX_STRUCT_DEPTH)).expect("at the limit");
    let name = format!("s{}.x", ".f".repeat(MAX_STRUCT_DEPTH - 1));
    assert_eq!(mat.variable(&name).expect("innermost").data, vec![1.0]);
    let err = read_mat(&nested(MAX_STRUCT_DEPTH + 1)).expect_err("too deep");
    assert!(
        matches!(err, MatError::TooDeep { limit, .. } if limit == MAX_STRUCT_DEPTH),
        "{err}"
    );
    assert!(err.to_string().contains("nested deeper"), "{err}");
}

/// Every proper prefix of a struct file fails (the struct is one element), except the
/// bare header; none panics.
#[test]
fn truncated_struct_fails_at_every_prefix() {
    let order = ByteOrder::Little;
    let mut file = header(order);
    file.extend(bearing(order, &[1.0, 2.0, 3.0]));
    assert!(read_mat(&file).is_ok());
    for len in 0..file.len() {
        match read_mat(&file[..len]) {
            Ok(mat) if len == HEADER_LEN => assert!(mat.variables.is_empty()),
            Ok(mat) => panic!("prefix of {len} bytes parsed: {mat:?}"),
            Err(_) => {}
        }
    }
    // The struct's own length cut short: its last field overruns it.
    let mut cut = file.clone();
    let body_len = u32::from_le_bytes([cut[132], cut[133], cut[134], cut[135]]);
    cut[132..136].copy_from_slice(&(body_len - 8).to_le_bytes());
    cut.truncate(cut.len() - 8);
    assert!(matches!(
        read_mat(&cut),
        Err(MatError::ElementOverrun { .. })
    ));
}

#[test]
fn random_corruption_of_structs_never_panics() {
    let order = ByteOrder::Little;
    let mut file = header(order);
    file.extend(bearing(order, &[1.0, 2.0, 3.0]));
    file.extend(compressed(order, &bearing(order, &[4.0])));
    let mut rng = Xoshiro128pp::seed_from_u64(0x7374_7275);
    for _ in 0..3000 {
        let mut m = file.clone();
        for _ in 0..1 + rng.next_u32() % 4 {
            let i = HEADER_LEN + (rng.next_u32() as usize) % (m.len() - HEADER_LEN);
            m[i] = rng.next_u32() as u8;
        }
        if let Ok(mat) = read_mat(&m) {
            for v in &mat.variables {
                let product = v.dims.iter().try_fold(1usize, |a, &d| a.checked_mul(d));
                assert_eq!(product, Some(v.data.len()), "{}", v.name);
            }
        }
    }
}

/// The fuzz seed with a struct (`fuzz/seeds/mat/struct.mat`, built by a one-off Python script, not by
/// `make_seeds.py`)
/// reads as an MFPT-like `bearing` struct, so the fuzzer starts inside the struct code.
#[test]
fn struct_fuzz_seed_reads() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../fuzz/seeds/mat/struct.mat");
    let Ok(bytes) = std::fs::read(path) else {
        eprintln!("skipping: no fuzz seed at {path}");
        return;
    };
    let mat = read_mat(&bytes).expect("seed reads");
    assert_eq!(mat.text("bearing.load"), Some("25 lbs"));
    assert_eq!(mat.variable("bearing.sr").expect("sr").data, vec![48828.0]);
    assert_eq!(mat.variable("bearing.rate").expect("rate").data, vec![25.0]);
    assert_eq!(mat.variable("bearing.gs").expect("gs").data.len(), 8);
}
