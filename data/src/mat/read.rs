//! The entry points: the file header, then the top-level elements.

use std::path::Path;

use super::error::{MatError, Position};
use super::inflate::inflate;
use super::stream::{data_type, Stream};
use super::types::{ByteOrder, MatFile, SkipReason, SkippedVariable};

/// Length of the fixed file header.
pub const HEADER_LEN: usize = 128;

/// Read a MAT file from disk. See [`read_mat`].
pub fn read_mat_file(path: impl AsRef<Path>) -> Result<MatFile, MatError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| MatError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    read_mat(&bytes)
}

/// Parse a level-5 MAT file held in memory.
///
/// Returns the real numeric variables (struct fields flattened), the char arrays, and a
/// list of what was skipped. Fails on a bad
/// header, on any element that runs past its parent or the end of the input, on bad
/// dimensions, and on a corrupt compressed element.
pub fn read_mat(bytes: &[u8]) -> Result<MatFile, MatError> {
    if bytes.len() < HEADER_LEN {
        return Err(MatError::Truncated {
            at: Position {
                offset: 0,
                compressed_element: None,
            },
            what: "128-byte header",
            needed: HEADER_LEN,
            available: bytes.len(),
        });
    }
    let byte_order = match &bytes[126..128] {
        b"IM" => ByteOrder::Little,
        b"MI" => ByteOrder::Big,
        other => {
            return Err(MatError::BadHeader {
                reason: format!(
                    "endian indicator is {:?}, expected \"IM\" or \"MI\" \
                     (MAT level-4 files have no such header and are not supported)",
                    String::from_utf8_lossy(other)
                ),
            })
        }
    };
    let version = match byte_order {
        ByteOrder::Little => u16::from_le_bytes([bytes[124], bytes[125]]),
        ByteOrder::Big => u16::from_be_bytes([bytes[124], bytes[125]]),
    };
    if version != 0x0100 {
        return Err(MatError::UnsupportedVersion { version });
    }
    let header_text = String::from_utf8_lossy(&bytes[..116])
        .trim_end_matches([' ', '\0'])
        .to_string();
    let subsystem_offset = {
        let field = &bytes[116..124];
        if field.iter().all(|&b| b == 0) || field.iter().all(|&b| b == b' ') {
            None
        } else {
            let mut a = [0u8; 8];
            a.copy_from_slice(field);
            let raw = match byte_order {
                ByteOrder::Little => u64::from_le_bytes(a),
                ByteOrder::Big => u64::from_be_bytes(a),
            };
            usize::try_from(raw).ok()
        }
    };

    let mut out = MatFile {
        header_text,
        byte_order,
        variables: Vec::new(),
        texts: Vec::new(),
        skipped: Vec::new(),
    };
    let stream = Stream {
        bytes,
        order: byte_order,
        compressed_element: None,
    };
    stream.parse_top_level(HEADER_LEN, subsystem_offset, &mut out)?;
    Ok(out)
}

impl Stream<'_> {
    /// Parse the elements from `offset` to the end of the stream into `out`.
    fn parse_top_level(
        &self,
        mut offset: usize,
        subsystem_offset: Option<usize>,
        out: &mut MatFile,
    ) -> Result<(), MatError> {
        let end = self.bytes.len();
        while offset < end {
            let element = self.element(offset, None, "data element")?;
            let at = self.pos(element.start);
            match element.data_type {
                _ if self.compressed_element.is_none() && subsystem_offset == Some(offset) => {
                    out.skipped.push(SkippedVariable {
                        name: String::new(),
                        at,
                        reason: SkipReason::SubsystemData,
                    });
                }
                data_type::MATRIX => self.matrix(&element, None, 0, out)?,
                data_type::COMPRESSED => {
                    if self.compressed_element.is_some() {
                        out.skipped.push(SkippedVariable {
                            name: String::new(),
                            at,
                            reason: SkipReason::NestedCompression,
                        });
                    } else {
                        let inflated = inflate(element.data, element.start)?;
                        let inner = Stream {
                            bytes: &inflated,
                            order: self.order,
                            compressed_element: Some(element.start),
                        };
                        inner.parse_top_level(0, None, out)?;
                    }
                }
                other => out.skipped.push(SkippedVariable {
                    name: String::new(),
                    at,
                    reason: SkipReason::NotAMatrix(other),
                }),
            }
            offset = element.next;
        }
        Ok(())
    }
}
