//! Struct arrays (flattened into `struct.field` variables) and char arrays (text).

use super::error::MatError;
use super::stream::{data_type, Body, Stream};
use super::types::{ByteOrder, MatFile};

/// How deep structs may nest in structs: a top-level struct is at depth 0, and a struct
/// deeper than `MAX_STRUCT_DEPTH - 1` is a [`MatError::TooDeep`] (bounds the recursion
/// on hostile input; MATLAB files of measurements nest one or two levels).
pub const MAX_STRUCT_DEPTH: usize = 16;

impl<'a> Stream<'a> {
    /// The rest of a struct: field-name length, field names, then one `miMATRIX` per
    /// field and element, each parsed with [`Self::matrix`] one level deeper.
    pub(super) fn structure(
        &self,
        body: &Body,
        name: &str,
        depth: usize,
        out: &mut MatFile,
    ) -> Result<(), MatError> {
        let Body {
            at,
            end,
            expected: count,
            ..
        } = *body;
        if depth >= MAX_STRUCT_DEPTH {
            return Err(MatError::TooDeep {
                at,
                name: name.to_string(),
                limit: MAX_STRUCT_DEPTH,
            });
        }
        let (fields, mut offset) = self.field_names(body, name)?;

        // Every (element, field) pair takes at least one 8-byte element, so a huge
        // `count` runs out of input long before it runs out of time.
        if fields.is_empty() {
            return Ok(());
        }
        for k in 0..count {
            let prefix = if count == 1 {
                name.to_string()
            } else {
                format!("{name}({})", k + 1)
            };
            for field in &fields {
                let full = format!("{prefix}.{field}");
                if offset >= end {
                    return Err(MatError::MissingSubelement {
                        at,
                        name: full,
                        what: "field value",
                    });
                }
                let el = self.element(offset, Some(end), "field value")?;
                if el.data_type != data_type::MATRIX {
                    return Err(MatError::UnexpectedDataType {
                        at: self.pos(el.start),
                        name: full,
                        what: "field value",
                        data_type: el.data_type,
                        expected: "miMATRIX",
                    });
                }
                self.matrix(&el, Some(&full), depth + 1, out)?;
                offset = el.next;
            }
        }
        Ok(())
    }

    /// The field names of the struct `name` whose body is `body` (field-name length,
    /// miINT32, then the NUL-padded names), and the offset just past them.
    fn field_names(&self, body: &Body, name: &str) -> Result<(Vec<String>, usize), MatError> {
        let Body {
            at,
            mut offset,
            end,
            ..
        } = *body;
        let bad = |reason: String| MatError::BadStruct {
            at,
            name: name.to_string(),
            reason,
        };
        let missing = |what: &'static str| MatError::MissingSubelement {
            at,
            name: name.to_string(),
            what,
        };

        if offset >= end {
            return Err(missing("field-name length"));
        }
        let len_el = self.element(offset, Some(end), "field-name length")?;
        if len_el.data_type != data_type::INT32 || len_el.data.len() != 4 {
            return Err(MatError::UnexpectedDataType {
                at: self.pos(len_el.start),
                name: name.to_string(),
                what: "field-name length",
                data_type: len_el.data_type,
                expected: "miINT32 holding one value",
            });
        }
        let name_len = self.u32_at(len_el.data_start) as i32;
        let name_len = usize::try_from(name_len)
            .ok()
            .filter(|&n| n > 0)
            .ok_or_else(|| bad(format!("field-name length {name_len} is not positive")))?;
        offset = len_el.next;

        if offset >= end {
            return Err(missing("field names"));
        }
        let names_el = self.text_element(offset, end, name, "field names")?;
        if names_el.data.len() % name_len != 0 {
            return Err(bad(format!(
                "{} bytes of field names are not a whole number of {name_len}-byte names",
                names_el.data.len()
            )));
        }
        let fields = names_el
            .data
            .chunks_exact(name_len)
            .enumerate()
            .map(|(i, raw)| {
                let used = raw.iter().position(|&b| b == 0).unwrap_or(raw.len());
                if used == 0 {
                    Err(bad(format!("field {} has an empty name", i + 1)))
                } else {
                    Ok(String::from_utf8_lossy(&raw[..used]).into_owned())
                }
            })
            .collect::<Result<Vec<_>, _>>()?;
        Ok((fields, names_el.next))
    }

    /// The characters of a char array: code units in column-major order, rows joined
    /// by `'\n'`.
    pub(super) fn text(&self, body: &Body, name: &str, dims: &[usize]) -> Result<String, MatError> {
        let Body {
            at,
            offset,
            end,
            expected,
        } = *body;
        if offset >= end {
            if expected != 0 {
                return Err(MatError::MissingSubelement {
                    at,
                    name: name.to_string(),
                    what: "characters",
                });
            }
            return Ok(String::new());
        }
        let el = self.element(offset, Some(end), "characters")?;
        let units: Vec<u16> = match el.data_type {
            data_type::UINT16 | data_type::UTF16 | data_type::INT16 => {
                if el.data.len() % 2 != 0 {
                    return Err(MatError::RaggedData {
                        at: self.pos(el.start),
                        name: name.to_string(),
                        what: "characters",
                        bytes: el.data.len(),
                        element_size: 2,
                    });
                }
                el.data
                    .chunks_exact(2)
                    .map(|c| match self.order {
                        ByteOrder::Little => u16::from_le_bytes([c[0], c[1]]),
                        ByteOrder::Big => u16::from_be_bytes([c[0], c[1]]),
                    })
                    .collect()
            }
            data_type::UTF8 => String::from_utf8_lossy(el.data).encode_utf16().collect(),
            // 8-bit text: Latin-1.
            data_type::INT8 | data_type::UINT8 => el.data.iter().map(|&b| u16::from(b)).collect(),
            other => {
                return Err(MatError::UnexpectedDataType {
                    at: self.pos(el.start),
                    name: name.to_string(),
                    what: "characters",
                    data_type: other,
                    expected: "miUINT16, miUTF16, miUTF8 or 8-bit text",
                })
            }
        };
        if units.len() != expected {
            return Err(MatError::DataLength {
                at,
                name: name.to_string(),
                dims: dims.to_vec(),
                expected,
                got: units.len(),
            });
        }
        let rows = dims.first().copied().unwrap_or(1);
        if rows <= 1 || units.is_empty() {
            return Ok(String::from_utf16_lossy(&units));
        }
        let cols = units.len() / rows;
        let lines: Vec<String> = (0..rows)
            .map(|r| {
                let row: Vec<u16> = (0..cols).map(|c| units[c * rows + r]).collect();
                String::from_utf16_lossy(&row)
            })
            .collect();
        Ok(lines.join("\n"))
    }
}
