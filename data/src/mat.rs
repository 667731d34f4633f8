//! A reader for MATLAB level-5 MAT files (the format of `save -v6` / `save -v7`, and of
//! every file in the CWRU bearing data set).
//!
//! Written from the published format description (MathWorks, "MAT-File Format",
//! level 5), not from another project's code. What it reads:
//!
//! ```text
//! file     = header (128 bytes) , { element }
//! header   = text (116) , subsystem data offset (8) , version (2) , endian indicator (2)
//! element  = tag (8: u32 data type, u32 byte count) , data , padding to 8 bytes
//!          | small tag (4: u16 byte count, u16 data type) , data (≤ 4 bytes, padded to 4)
//! miCOMPRESSED (15) = zlib stream holding further elements (no padding after it)
//! miMATRIX (14)     = array flags , dimensions , name , real part [, imaginary part]
//! ```
//!
//! The endian indicator is the 16-bit value `'M' << 8 | 'I'` written in the writer's
//! byte order: the bytes `IM` mean a little-endian file, `MI` a big-endian one. A small
//! element is recognised by a non-zero upper half of its first tag word.
//!
//! Numeric arrays of every real class (double, single, int8 … uint64) are returned as
//! `f64` in column-major order. MATLAB may store an array in a narrower type than its
//! class (a `double` array of small integers is often written as `miUINT8`), so the
//! storage type is converted independently of the class. 64-bit integers beyond 2^53
//! lose precision in the conversion.
//!
//! Cells, structs, objects, char arrays, sparse and complex arrays are not needed for
//! measured signals; they are skipped and listed in [`MatFile::skipped`] rather than
//! failing the whole file, because real files often carry such extras.
//!
//! Robustness: every size field is checked against the bytes that actually remain in
//! its parent before anything is sliced or allocated, so a corrupt or truncated file
//! gives a [`MatError`] with a byte offset, never a panic and never an allocation
//! sized by an untrusted field. Decompressed output grows only with the data actually
//! inflated and is capped at [`MAX_DECOMPRESSED_BYTES`].

use std::fmt;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Length of the fixed file header.
pub const HEADER_LEN: usize = 128;

/// Largest amount of data one `miCOMPRESSED` element may inflate to (1 GiB). Guards
/// against decompression bombs; a measured record is far smaller.
pub const MAX_DECOMPRESSED_BYTES: usize = 1 << 30;

/// MAT data type numbers (the `miXXX` constants of the format description).
mod data_type {
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
}

/// Array-flags bit that marks a complex array.
const FLAG_COMPLEX: u32 = 0x0800;

/// Byte order of a MAT file, from its endian indicator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ByteOrder {
    /// Indicator bytes `IM`.
    Little,
    /// Indicator bytes `MI`.
    Big,
}

/// Where a byte offset points: into the file itself, or into the data inflated from a
/// `miCOMPRESSED` element (whose own file offset is then given too).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Position {
    /// Byte offset in the file, or in the inflated data when `compressed_element` is set.
    pub offset: usize,
    /// File offset of the `miCOMPRESSED` element the offset lies in, if any.
    pub compressed_element: Option<usize>,
}

impl fmt::Display for Position {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.compressed_element {
            None => write!(f, "byte {}", self.offset),
            Some(at) => write!(
                f,
                "byte {} of the data inflated from the compressed element at byte {at}",
                self.offset
            ),
        }
    }
}

/// MATLAB array class, from the low byte of the array flags.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatClass {
    /// `mxCELL_CLASS` (1).
    Cell,
    /// `mxSTRUCT_CLASS` (2).
    Struct,
    /// `mxOBJECT_CLASS` (3).
    Object,
    /// `mxCHAR_CLASS` (4).
    Char,
    /// `mxSPARSE_CLASS` (5).
    Sparse,
    /// `mxDOUBLE_CLASS` (6).
    Double,
    /// `mxSINGLE_CLASS` (7).
    Single,
    /// `mxINT8_CLASS` (8).
    Int8,
    /// `mxUINT8_CLASS` (9), also used for logical arrays.
    UInt8,
    /// `mxINT16_CLASS` (10).
    Int16,
    /// `mxUINT16_CLASS` (11).
    UInt16,
    /// `mxINT32_CLASS` (12).
    Int32,
    /// `mxUINT32_CLASS` (13).
    UInt32,
    /// `mxINT64_CLASS` (14).
    Int64,
    /// `mxUINT64_CLASS` (15).
    UInt64,
    /// Any other class number (function handles, opaque objects, …).
    Other(u8),
}

impl MatClass {
    fn from_flags(flags: u32) -> Self {
        match (flags & 0xff) as u8 {
            1 => Self::Cell,
            2 => Self::Struct,
            3 => Self::Object,
            4 => Self::Char,
            5 => Self::Sparse,
            6 => Self::Double,
            7 => Self::Single,
            8 => Self::Int8,
            9 => Self::UInt8,
            10 => Self::Int16,
            11 => Self::UInt16,
            12 => Self::Int32,
            13 => Self::UInt32,
            14 => Self::Int64,
            15 => Self::UInt64,
            other => Self::Other(other),
        }
    }

    /// Whether this class is a plain numeric array that [`read_mat`] returns.
    pub fn is_numeric(self) -> bool {
        !matches!(
            self,
            Self::Cell | Self::Struct | Self::Object | Self::Char | Self::Sparse | Self::Other(_)
        )
    }
}

/// One real numeric variable.
#[derive(Debug, Clone, PartialEq)]
pub struct MatVariable {
    /// Variable name as stored (e.g. `X105_DE_time`).
    pub name: String,
    /// Dimensions, at least one (MATLAB writes at least two).
    pub dims: Vec<usize>,
    /// Values in column-major order, converted to `f64`; `data.len()` is the product of `dims`.
    pub data: Vec<f64>,
    /// The array's MATLAB class (the storage type may have been narrower).
    pub class: MatClass,
}

impl MatVariable {
    /// Whether the variable is a vector (at most one dimension larger than 1).
    pub fn is_vector(&self) -> bool {
        self.dims.iter().filter(|&&d| d > 1).count() <= 1
    }
}

/// Why a variable was skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SkipReason {
    /// A class this reader does not convert (cell, struct, object, char, sparse, …).
    UnsupportedClass(MatClass),
    /// A numeric array with an imaginary part.
    Complex,
    /// A top-level element that is not a matrix (data type number given).
    NotAMatrix(u32),
    /// A `miMATRIX` element with no content (MATLAB writes these for empty cells).
    EmptyMatrix,
    /// A compressed element inside a compressed element (not produced by MATLAB).
    NestedCompression,
    /// The subsystem data block the header points to (class information for objects).
    SubsystemData,
}

impl fmt::Display for SkipReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::UnsupportedClass(class) => write!(f, "unsupported class {class:?}"),
            Self::Complex => f.write_str("complex array"),
            Self::NotAMatrix(t) => write!(f, "top-level element of data type {t} is not a matrix"),
            Self::EmptyMatrix => f.write_str("empty matrix element"),
            Self::NestedCompression => f.write_str("compressed element nested in another"),
            Self::SubsystemData => f.write_str("subsystem data"),
        }
    }
}

/// A variable (or element) that was present but not returned.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SkippedVariable {
    /// Its name, when it could be read (empty otherwise).
    pub name: String,
    /// Where its element starts.
    pub at: Position,
    /// Why it was skipped.
    pub reason: SkipReason,
}

/// Everything read from one MAT file.
#[derive(Debug, Clone, PartialEq)]
pub struct MatFile {
    /// The descriptive text of the header, trailing blanks removed.
    pub header_text: String,
    /// Byte order of the file.
    pub byte_order: ByteOrder,
    /// Real numeric variables, in file order.
    pub variables: Vec<MatVariable>,
    /// Variables and elements that were skipped, in file order.
    pub skipped: Vec<SkippedVariable>,
}

impl MatFile {
    /// The variable called `name`, if present.
    pub fn variable(&self, name: &str) -> Option<&MatVariable> {
        self.variables.iter().find(|v| v.name == name)
    }
}

/// Everything that can go wrong reading a MAT file.
#[non_exhaustive]
#[derive(Debug, thiserror::Error)]
pub enum MatError {
    /// The file could not be read from disk.
    #[error("cannot read MAT file {}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// The header is not that of a level-5 MAT file.
    #[error("not a MAT level-5 file: {reason}")]
    BadHeader {
        /// What is wrong.
        reason: String,
    },
    /// A MAT version this reader does not handle.
    #[error(
        "MAT file version {version:#06x} is not supported (level 5 is 0x0100; \
         v7.3 files are HDF5 — re-save them with `save -v7`)"
    )]
    UnsupportedVersion {
        /// The version field.
        version: u16,
    },
    /// The input ends inside something.
    #[error("truncated: the {what} at {at} needs {needed} bytes but only {available} remain")]
    Truncated {
        /// Where the thing starts.
        at: Position,
        /// What was being read.
        what: &'static str,
        /// Bytes it needs from `at`.
        needed: usize,
        /// Bytes left from `at`.
        available: usize,
    },
    /// A sub-element claims more bytes than its parent has left.
    #[error(
        "the {what} at {at} needs {needed} bytes, which overruns its parent element \
         (ends at byte {parent_end})"
    )]
    ElementOverrun {
        /// Where the sub-element starts.
        at: Position,
        /// What it is.
        what: &'static str,
        /// Bytes it needs from `at`, padding included.
        needed: usize,
        /// Offset where the parent element ends (same space as `at`).
        parent_end: usize,
    },
    /// A small data element declares more than 4 bytes.
    #[error("the small data element at {at} declares {declared} bytes (at most 4 allowed)")]
    BadSmallElement {
        /// Where it starts.
        at: Position,
        /// The declared byte count.
        declared: usize,
    },
    /// Bad dimensions of a variable.
    #[error("variable `{name}` at {at}: bad dimensions: {reason}")]
    BadDims {
        /// Where the matrix element starts.
        at: Position,
        /// Variable name, if already read.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// A sub-element has a data type that cannot hold what it should.
    #[error(
        "variable `{name}` at {at}: the {what} has data type {data_type}, expected {expected}"
    )]
    UnexpectedDataType {
        /// Where the sub-element starts.
        at: Position,
        /// Variable name, if already read.
        name: String,
        /// Which sub-element.
        what: &'static str,
        /// Its data type number.
        data_type: u32,
        /// What was expected.
        expected: &'static str,
    },
    /// A numeric sub-element's byte count is not a whole number of its elements.
    #[error(
        "variable `{name}` at {at}: the {what} holds {bytes} bytes, not a multiple of \
         its {element_size}-byte element size"
    )]
    RaggedData {
        /// Where the sub-element starts.
        at: Position,
        /// Variable name, if already read.
        name: String,
        /// Which sub-element.
        what: &'static str,
        /// Its byte count.
        bytes: usize,
        /// Size of one element of its data type.
        element_size: usize,
    },
    /// A required sub-element of a matrix is missing.
    #[error("variable `{name}` at {at}: missing {what}")]
    MissingSubelement {
        /// Where the matrix element starts.
        at: Position,
        /// Variable name, if already read.
        name: String,
        /// Which sub-element.
        what: &'static str,
    },
    /// The number of values does not match the dimensions.
    #[error(
        "variable `{name}` at {at}: dimensions {dims:?} call for {expected} values, \
         but the real part holds {got}"
    )]
    DataLength {
        /// Where the matrix element starts.
        at: Position,
        /// Variable name.
        name: String,
        /// Its dimensions.
        dims: Vec<usize>,
        /// Product of the dimensions.
        expected: usize,
        /// Values present.
        got: usize,
    },
    /// The zlib stream of a compressed element is corrupt or truncated.
    #[error("cannot inflate the compressed element at byte {offset}")]
    Decompression {
        /// File offset of the element.
        offset: usize,
        /// The zlib error.
        #[source]
        source: std::io::Error,
    },
    /// A compressed element inflates to more than [`MAX_DECOMPRESSED_BYTES`].
    #[error("the compressed element at byte {offset} inflates to more than {limit} bytes")]
    DecompressedTooLarge {
        /// File offset of the element.
        offset: usize,
        /// The limit.
        limit: usize,
    },
}

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
/// Returns the real numeric variables and a list of what was skipped. Fails on a bad
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

/// A byte sequence of elements: the file itself, or the data inflated from one
/// compressed element.
struct Stream<'a> {
    bytes: &'a [u8],
    order: ByteOrder,
    compressed_element: Option<usize>,
}

/// One data element located in a [`Stream`].
struct Element<'a> {
    data_type: u32,
    data: &'a [u8],
    /// Offset of the tag.
    start: usize,
    /// Offset of the data.
    data_start: usize,
    /// Offset just past the data and its padding.
    next: usize,
}

/// What parsing a matrix element produced.
enum Parsed {
    Variable(MatVariable),
    Skipped(SkippedVariable),
}

impl<'a> Stream<'a> {
    fn pos(&self, offset: usize) -> Position {
        Position {
            offset,
            compressed_element: self.compressed_element,
        }
    }

    fn u32_at(&self, offset: usize) -> u32 {
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

    /// Locate the element whose tag starts at `offset`, inside the parent element
    /// ending at `parent_end`, or at stream level when that is `None`.
    fn element(
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
                data_type::MATRIX => match self.matrix(&element)? {
                    Parsed::Variable(v) => out.variables.push(v),
                    Parsed::Skipped(s) => out.skipped.push(s),
                },
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

    /// Parse one `miMATRIX` element.
    fn matrix(&self, element: &Element<'a>) -> Result<Parsed, MatError> {
        let at = self.pos(element.start);
        if element.data.is_empty() {
            return Ok(Parsed::Skipped(SkippedVariable {
                name: String::new(),
                at,
                reason: SkipReason::EmptyMatrix,
            }));
        }
        let end = element.data_start + element.data.len();
        let mut offset = element.data_start;

        // Array flags: miUINT32, two words (flags, nzmax).
        let flags_el = self.element(offset, Some(end), "array flags")?;
        if flags_el.data_type != data_type::UINT32 || flags_el.data.len() < 4 {
            return Err(MatError::UnexpectedDataType {
                at: self.pos(flags_el.start),
                name: String::new(),
                what: "array flags",
                data_type: flags_el.data_type,
                expected: "miUINT32 with at least 4 bytes",
            });
        }
        let flags = self.u32_at(flags_el.data_start);
        let class = MatClass::from_flags(flags);
        offset = flags_el.next;

        if !class.is_numeric() {
            // Layouts differ by class (opaque objects have no dimensions); take the
            // name where it can be found and move on.
            let name = self.name_best_effort(offset, end);
            return Ok(Parsed::Skipped(SkippedVariable {
                name,
                at,
                reason: SkipReason::UnsupportedClass(class),
            }));
        }

        // Dimensions: miINT32, at least one.
        if offset >= end {
            return Err(MatError::MissingSubelement {
                at,
                name: String::new(),
                what: "dimensions",
            });
        }
        let dims_el = self.element(offset, Some(end), "dimensions")?;
        let dims = self.dims(&dims_el, at)?;
        offset = dims_el.next;

        // Name: miINT8 (ASCII), possibly in the small format.
        if offset >= end {
            return Err(MatError::MissingSubelement {
                at,
                name: String::new(),
                what: "array name",
            });
        }
        let name_el = self.element(offset, Some(end), "array name")?;
        if !matches!(
            name_el.data_type,
            data_type::INT8 | data_type::UINT8 | data_type::UTF8
        ) {
            return Err(MatError::UnexpectedDataType {
                at: self.pos(name_el.start),
                name: String::new(),
                what: "array name",
                data_type: name_el.data_type,
                expected: "miINT8",
            });
        }
        let name = String::from_utf8_lossy(name_el.data).into_owned();
        offset = name_el.next;

        if flags & FLAG_COMPLEX != 0 {
            return Ok(Parsed::Skipped(SkippedVariable {
                name,
                at,
                reason: SkipReason::Complex,
            }));
        }

        let expected = dims
            .iter()
            .try_fold(1usize, |acc, &d| acc.checked_mul(d))
            .ok_or_else(|| MatError::BadDims {
                at,
                name: name.clone(),
                reason: format!("the product of {dims:?} overflows"),
            })?;

        // Real part. An empty array may omit it.
        let data = if offset >= end {
            if expected != 0 {
                return Err(MatError::MissingSubelement {
                    at,
                    name,
                    what: "real part",
                });
            }
            Vec::new()
        } else {
            let real_el = self.element(offset, Some(end), "real part")?;
            self.numeric(&real_el, &name, "real part")?
        };
        if data.len() != expected {
            return Err(MatError::DataLength {
                at,
                name,
                dims,
                expected,
                got: data.len(),
            });
        }
        Ok(Parsed::Variable(MatVariable {
            name,
            dims,
            data,
            class,
        }))
    }

    /// Decode the dimensions sub-element (miINT32, non-negative, at least one).
    fn dims(&self, el: &Element<'a>, at: Position) -> Result<Vec<usize>, MatError> {
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
    fn name_best_effort(&self, mut offset: usize, end: usize) -> String {
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

    /// Convert a numeric sub-element of any storage type to `f64`.
    fn numeric(
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

/// Inflate the zlib stream of the compressed element at file offset `offset`.
fn inflate(data: &[u8], offset: usize) -> Result<Vec<u8>, MatError> {
    let limit = MAX_DECOMPRESSED_BYTES;
    let mut out = Vec::new();
    flate2::read::ZlibDecoder::new(data)
        .take(limit as u64 + 1)
        .read_to_end(&mut out)
        .map_err(|source| MatError::Decompression { offset, source })?;
    if out.len() > limit {
        return Err(MatError::DecompressedTooLarge { offset, limit });
    }
    Ok(out)
}

/// Test helper: writes MAT level-5 byte streams, so tests build their inputs here
/// instead of relying on files.
#[cfg(test)]
pub(crate) mod writer {
    use super::ByteOrder;
    use std::io::Write;

    /// Data type numbers used by the writer.
    pub const MI_INT8: u32 = 1;
    pub const MI_INT16: u32 = 3;
    pub const MI_UINT32: u32 = 6;
    pub const MI_SINGLE: u32 = 7;
    pub const MI_INT32: u32 = 5;
    pub const MI_DOUBLE: u32 = 9;
    pub const MI_UINT8: u32 = 2;
    pub const MI_MATRIX: u32 = 14;
    pub const MI_COMPRESSED: u32 = 15;

    /// Class numbers used by the writer.
    pub const MX_CELL: u8 = 1;
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
}

#[cfg(test)]
mod tests {
    use super::writer::*;
    use super::*;
    use pumptwin_core::rng::Xoshiro128pp;

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
        let body_len =
            u32::from_le_bytes([cplx[4], cplx[5], cplx[6], cplx[7]]) as usize + imag.len();
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
        let skipped: Vec<(&str, SkipReason)> = mat
            .skipped
            .iter()
            .map(|s| (s.name.as_str(), s.reason))
            .collect();
        assert_eq!(
            skipped,
            vec![
                ("label", SkipReason::UnsupportedClass(MatClass::Char)),
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
}
