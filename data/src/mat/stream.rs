//! The byte stream of a MAT file: element tags (regular and small), the data type
//! numbers, and the sub-elements every array shares (dimensions, names).

use super::error::{MatError, Position};
use super::types::ByteOrder;

/// MAT data type numbers (the `miXXX` constants of the format description).
pub(super) mod data_type {
    pub const INT8: u32 = 1;
    pub const UINT8: u32 = 2;
    pub const INT16: u32 = 3;
    pub const UINT16: u32 = 4;
    pub const INT32: u32 = 5;
    pub const UINT32: u32 = 6;
    pub const SINGLE: u32 = 7;
    pub const DOUBLE: u32 = 9;
    pub const INT64: u32 = 12;
    pub const UINT64: u32 = 13;
    pub const MATRIX: u32 = 14;
    pub const COMPRESSED: u32 = 15;
    pub const UTF8: u32 = 16;
    pub const UTF16: u32 = 17;
}

/// A byte sequence of elements: the file itself, or the data inflated from one
/// compressed element.
pub(super) struct Stream<'a> {
    pub(super) bytes: &'a [u8],
    pub(super) order: ByteOrder,
    pub(super) compressed_element: Option<usize>,
}

/// One data element located in a [`Stream`].
pub(super) struct Element<'a> {
    pub(super) data_type: u32,
    pub(super) data: &'a [u8],
    /// Offset of the tag.
    pub(super) start: usize,
    /// Offset of the data.
    pub(super) data_start: usize,
    /// Offset just past the data and its padding.
    pub(super) next: usize,
}

/// What follows the name of a matrix element: where it starts and ends, and how many
/// values (or struct elements) its dimensions call for.
#[derive(Clone, Copy)]
pub(super) struct Body {
    /// Where the matrix element starts.
    pub(super) at: Position,
    /// Offset just past the name sub-element.
    pub(super) offset: usize,
    /// Offset where the matrix element's data ends.
    pub(super) end: usize,
    /// Product of the dimensions.
    pub(super) expected: usize,
}

impl<'a> Stream<'a> {
    pub(super) fn pos(&self, offset: usize) -> Position {
        Position {
            offset,
            compressed_element: self.compressed_element,
        }
    }

    pub(super) fn u32_at(&self, offset: usize) -> u32 {
        // Callers have checked that offset + 4 <= len.
        let mut a = [0u8; 4];
        a.copy_from_slice(&self.bytes[offset..offset + 4]);
        match self.order {
            ByteOrder::Little => u32::from_le_bytes(a),
            ByteOrder::Big => u32::from_be_bytes(a),
        }
    }

    /// The error for something at `offset` needing `needed` bytes where only
    /// `end - offset` remain: truncation at stream level (`end` is the end of the
    /// stream), an overrun inside a parent element.
    fn short(
        &self,
        offset: usize,
        what: &'static str,
        needed: usize,
        end: Option<usize>,
    ) -> MatError {
        let Some(end) = end else {
            return MatError::Truncated {
                at: self.pos(offset),
                what,
                needed,
                available: self.bytes.len().saturating_sub(offset),
            };
        };
        MatError::ElementOverrun {
            at: self.pos(offset),
            what,
            needed,
            parent_end: end,
        }
    }

    /// The element at `offset` inside the parent ending at `end` that holds 8-bit text
    /// (an array's name, a struct's field names): miINT8, miUINT8 or miUTF8, else
    /// [`MatError::UnexpectedDataType`] naming `what` of the variable `name`.
    pub(super) fn text_element(
        &self,
        offset: usize,
        end: usize,
        name: &str,
        what: &'static str,
    ) -> Result<Element<'a>, MatError> {
        let el = self.element(offset, Some(end), what)?;
        if !matches!(
            el.data_type,
            data_type::INT8 | data_type::UINT8 | data_type::UTF8
        ) {
            return Err(MatError::UnexpectedDataType {
                at: self.pos(el.start),
                name: name.to_string(),
                what,
                data_type: el.data_type,
                expected: "miINT8",
            });
        }
        Ok(el)
    }

    /// Locate the element whose tag starts at `offset`, inside the parent element
    /// ending at `parent_end`, or at stream level when that is `None`.
    pub(super) fn element(
        &self,
        offset: usize,
        parent_end: Option<usize>,
        what: &'static str,
    ) -> Result<Element<'a>, MatError> {
        let end = parent_end.unwrap_or(self.bytes.len());
        let available = end.saturating_sub(offset);
        // A small element occupies 8 bytes in all; a regular tag is 8 bytes too.
        if available < 4 {
            return Err(self.short(offset, what, 8, parent_end));
        }
        let first = self.u32_at(offset);
        let small_len = (first >> 16) as usize;
        if small_len != 0 {
            if small_len > 4 {
                return Err(MatError::BadSmallElement {
                    at: self.pos(offset),
                    declared: small_len,
                });
            }
            if available < 8 {
                return Err(self.short(offset, what, 8, parent_end));
            }
            return Ok(Element {
                data_type: first & 0xffff,
                data: &self.bytes[offset + 4..offset + 4 + small_len],
                start: offset,
                data_start: offset + 4,
                next: offset + 8,
            });
        }
        if available < 8 {
            return Err(self.short(offset, what, 8, parent_end));
        }
        let data_type = first;
        let len = self.u32_at(offset + 4) as usize;
        // Compressed elements are not padded; everything else is, to 8 bytes.
        let padded = if data_type == data_type::COMPRESSED {
            Some(len)
        } else {
            len.checked_next_multiple_of(8)
        };
        let needed = padded.and_then(|p| p.checked_add(8));
        match needed {
            Some(needed) if needed <= available => Ok(Element {
                data_type,
                data: &self.bytes[offset + 8..offset + 8 + len],
                start: offset,
                data_start: offset + 8,
                next: offset + needed,
            }),
            _ => Err(self.short(offset, what, needed.unwrap_or(usize::MAX), parent_end)),
        }
    }

    /// Decode the dimensions sub-element (miINT32, non-negative, at least one).
    pub(super) fn dims(&self, el: &Element<'a>, at: Position) -> Result<Vec<usize>, MatError> {
        if el.data_type != data_type::INT32 {
            return Err(MatError::UnexpectedDataType {
                at: self.pos(el.start),
                name: String::new(),
                what: "dimensions",
                data_type: el.data_type,
                expected: "miINT32",
            });
        }
        if el.data.is_empty() || el.data.len() % 4 != 0 {
            return Err(MatError::BadDims {
                at,
                name: String::new(),
                reason: format!(
                    "{} bytes of dimensions, need a non-zero multiple of 4",
                    el.data.len()
                ),
            });
        }
        el.data
            .chunks_exact(4)
            .map(|c| {
                let mut a = [0u8; 4];
                a.copy_from_slice(c);
                let d = match self.order {
                    ByteOrder::Little => i32::from_le_bytes(a),
                    ByteOrder::Big => i32::from_be_bytes(a),
                };
                usize::try_from(d).map_err(|_| MatError::BadDims {
                    at,
                    name: String::new(),
                    reason: format!("negative dimension {d}"),
                })
            })
            .collect()
    }

    /// The name of a skipped array: the first miINT8 sub-element after the flags.
    pub(super) fn name_best_effort(&self, mut offset: usize, end: usize) -> String {
        // Dimensions then name for most classes; name directly for opaque objects.
        for _ in 0..2 {
            let Ok(el) = self.element(offset, Some(end), "array name") else {
                return String::new();
            };
            if el.data_type == data_type::INT8 {
                return String::from_utf8_lossy(el.data).into_owned();
            }
            offset = el.next;
        }
        String::new()
    }
}
