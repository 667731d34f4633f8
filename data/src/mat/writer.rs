//! Test helper: writes MAT level-5 byte streams, so tests build their inputs here
//! instead of relying on files.

use super::types::ByteOrder;
use std::io::Write;

/// Data type numbers used by the writer.
pub const MI_INT8: u32 = 1;
pub const MI_INT16: u32 = 3;
pub const MI_UINT32: u32 = 6;
pub const MI_SINGLE: u32 = 7;
pub const MI_INT32: u32 = 5;
pub const MI_DOUBLE: u32 = 9;
pub const MI_UINT8: u32 = 2;
pub const MI_UINT16: u32 = 4;
pub const MI_MATRIX: u32 = 14;
pub const MI_COMPRESSED: u32 = 15;

/// Class numbers used by the writer.
pub const MX_CELL: u8 = 1;
pub const MX_STRUCT: u8 = 2;
pub const MX_CHAR: u8 = 4;
pub const MX_DOUBLE: u8 = 6;
pub const MX_SINGLE: u8 = 7;
pub const MX_INT16: u8 = 10;

pub fn u32_bytes(order: ByteOrder, v: u32) -> [u8; 4] {
    match order {
        ByteOrder::Little => v.to_le_bytes(),
        ByteOrder::Big => v.to_be_bytes(),
    }
}

pub fn header(order: ByteOrder) -> Vec<u8> {
    let mut h = b"MATLAB 5.0 MAT-file, written by the pumptwin test writer".to_vec();
    h.resize(116, b' ');
    h.extend_from_slice(&[0u8; 8]);
    match order {
        ByteOrder::Little => h.extend_from_slice(&[0x00, 0x01, b'I', b'M']),
        ByteOrder::Big => h.extend_from_slice(&[0x01, 0x00, b'M', b'I']),
    }
    h
}

/// A regular element: tag, data, zero padding to 8 bytes.
pub fn element(order: ByteOrder, data_type: u32, data: &[u8]) -> Vec<u8> {
    let mut e = Vec::new();
    e.extend_from_slice(&u32_bytes(order, data_type));
    e.extend_from_slice(&u32_bytes(order, data.len() as u32));
    e.extend_from_slice(data);
    while e.len() % 8 != 0 {
        e.push(0);
    }
    e
}

/// A small element (at most 4 data bytes).
pub fn small_element(order: ByteOrder, data_type: u32, data: &[u8]) -> Vec<u8> {
    assert!(data.len() <= 4);
    let mut e = Vec::new();
    e.extend_from_slice(&u32_bytes(order, ((data.len() as u32) << 16) | data_type));
    e.extend_from_slice(data);
    e.resize(8, 0);
    e
}

/// Encode values with the given per-value encoder.
pub fn encode<T: Copy>(values: &[T], f: impl Fn(T) -> Vec<u8>) -> Vec<u8> {
    values.iter().flat_map(|&v| f(v)).collect()
}

pub fn f64_bytes(order: ByteOrder, values: &[f64]) -> Vec<u8> {
    encode(values, |v| match order {
        ByteOrder::Little => v.to_le_bytes().to_vec(),
        ByteOrder::Big => v.to_be_bytes().to_vec(),
    })
}

/// A numeric matrix element.
pub fn matrix(
    order: ByteOrder,
    class: u8,
    flags_extra: u32,
    dims: &[i32],
    name: &str,
    small_name: bool,
    data_type: u32,
    data: &[u8],
) -> Vec<u8> {
    let mut body = Vec::new();
    let mut flags = u32_bytes(order, u32::from(class) | flags_extra).to_vec();
    flags.extend_from_slice(&[0u8; 4]);
    body.extend(element(order, MI_UINT32, &flags));
    let dims_bytes = encode(dims, |d| match order {
        ByteOrder::Little => d.to_le_bytes().to_vec(),
        ByteOrder::Big => d.to_be_bytes().to_vec(),
    });
    body.extend(element(order, MI_INT32, &dims_bytes));
    if small_name {
        body.extend(small_element(order, MI_INT8, name.as_bytes()));
    } else {
        body.extend(element(order, MI_INT8, name.as_bytes()));
    }
    body.extend(element(order, data_type, data));
    element(order, MI_MATRIX, &body)
}

/// A char array of UTF-16 code units (column-major), stored as miUINT16.
pub fn char_matrix(order: ByteOrder, dims: &[i32], name: &str, units: &[u16]) -> Vec<u8> {
    let data = encode(units, |u| match order {
        ByteOrder::Little => u.to_le_bytes().to_vec(),
        ByteOrder::Big => u.to_be_bytes().to_vec(),
    });
    matrix(order, MX_CHAR, 0, dims, name, false, MI_UINT16, &data)
}

/// A struct: the field-name length `name_len` (small miINT32), the field names each
/// NUL-padded (or cut) to `name_len` bytes, then `values` (whole `miMATRIX`
/// elements, one per field and struct element, in file order).
pub fn struct_matrix(
    order: ByteOrder,
    dims: &[i32],
    name: &str,
    name_len: i32,
    fields: &[&str],
    values: &[Vec<u8>],
) -> Vec<u8> {
    let mut body = Vec::new();
    let mut flags = u32_bytes(order, u32::from(MX_STRUCT)).to_vec();
    flags.extend_from_slice(&[0u8; 4]);
    body.extend(element(order, MI_UINT32, &flags));
    let dims_bytes = encode(dims, |d| match order {
        ByteOrder::Little => d.to_le_bytes().to_vec(),
        ByteOrder::Big => d.to_be_bytes().to_vec(),
    });
    body.extend(element(order, MI_INT32, &dims_bytes));
    body.extend(element(order, MI_INT8, name.as_bytes()));
    let len_bytes = match order {
        ByteOrder::Little => name_len.to_le_bytes(),
        ByteOrder::Big => name_len.to_be_bytes(),
    };
    body.extend(small_element(order, MI_INT32, &len_bytes));
    let width = usize::try_from(name_len).unwrap_or(0);
    let mut names = Vec::new();
    for f in fields {
        let mut n = f.as_bytes().to_vec();
        n.resize(width, 0);
        names.extend(n);
    }
    body.extend(element(order, MI_INT8, &names));
    for v in values {
        body.extend_from_slice(v);
    }
    element(order, MI_MATRIX, &body)
}

/// A double field value of a struct (its own name is empty, as MATLAB writes it).
pub fn double_field(order: ByteOrder, dims: &[i32], values: &[f64]) -> Vec<u8> {
    matrix(
        order,
        MX_DOUBLE,
        0,
        dims,
        "",
        false,
        MI_DOUBLE,
        &f64_bytes(order, values),
    )
}

/// A compressed element wrapping `inner` (itself one or more elements).
pub fn compressed(order: ByteOrder, inner: &[u8]) -> Vec<u8> {
    let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    z.write_all(inner).expect("write to Vec");
    let zdata = z.finish().expect("finish zlib");
    let mut e = Vec::new();
    e.extend_from_slice(&u32_bytes(order, MI_COMPRESSED));
    e.extend_from_slice(&u32_bytes(order, zdata.len() as u32));
    e.extend_from_slice(&zdata);
    e
}

/// A complete little-endian file holding column vectors of doubles.
pub fn double_vectors(vars: &[(&str, &[f64])]) -> Vec<u8> {
    let order = ByteOrder::Little;
    let mut file = header(order);
    for (name, data) in vars {
        file.extend(matrix(
            order,
            MX_DOUBLE,
            0,
            &[data.len() as i32, 1],
            name,
            false,
            MI_DOUBLE,
            &f64_bytes(order, data),
        ));
    }
    file
}
