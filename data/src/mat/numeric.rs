//! Numeric arrays: converting a real part of any storage type to `f64`.

use super::error::MatError;
use super::stream::{data_type, Element, Stream};
use super::types::ByteOrder;

impl<'a> Stream<'a> {
    /// Convert a numeric sub-element of any storage type to `f64`.
    pub(super) fn numeric(
        &self,
        el: &Element<'a>,
        name: &str,
        what: &'static str,
    ) -> Result<Vec<f64>, MatError> {
        let size = match el.data_type {
            data_type::INT8 | data_type::UINT8 => 1,
            data_type::INT16 | data_type::UINT16 => 2,
            data_type::INT32 | data_type::UINT32 | data_type::SINGLE => 4,
            data_type::DOUBLE | data_type::INT64 | data_type::UINT64 => 8,
            other => {
                return Err(MatError::UnexpectedDataType {
                    at: self.pos(el.start),
                    name: name.to_string(),
                    what,
                    data_type: other,
                    expected: "a numeric type (miINT8 … miUINT64, miSINGLE, miDOUBLE)",
                })
            }
        };
        if el.data.len() % size != 0 {
            return Err(MatError::RaggedData {
                at: self.pos(el.start),
                name: name.to_string(),
                what,
                bytes: el.data.len(),
                element_size: size,
            });
        }
        let order = self.order;
        let d = el.data;
        Ok(match el.data_type {
            data_type::INT8 => d.iter().map(|&b| f64::from(b as i8)).collect(),
            data_type::UINT8 => d.iter().map(|&b| f64::from(b)).collect(),
            data_type::INT16 => convert(d, order, |a| f64::from(i16::from_le_bytes(a))),
            data_type::UINT16 => convert(d, order, |a| f64::from(u16::from_le_bytes(a))),
            data_type::INT32 => convert(d, order, |a| f64::from(i32::from_le_bytes(a))),
            data_type::UINT32 => convert(d, order, |a| f64::from(u32::from_le_bytes(a))),
            data_type::SINGLE => convert(d, order, |a| f64::from(f32::from_le_bytes(a))),
            data_type::INT64 => convert(d, order, |a| i64::from_le_bytes(a) as f64),
            data_type::UINT64 => convert(d, order, |a| u64::from_le_bytes(a) as f64),
            _ => convert(d, order, f64::from_le_bytes),
        })
    }
}

/// Convert `N`-byte values: bytes are brought to little-endian order, then `f` decodes.
fn convert<const N: usize>(data: &[u8], order: ByteOrder, f: impl Fn([u8; N]) -> f64) -> Vec<f64> {
    data.chunks_exact(N)
        .map(|c| {
            let mut a = [0u8; N];
            a.copy_from_slice(c);
            if order == ByteOrder::Big {
                a.reverse();
            }
            f(a)
        })
        .collect()
}
