//! Errors of the MAT reader, and the [`Position`] they point at.

use std::fmt;
use std::path::PathBuf;

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
    /// A struct's field-name length, field names or field values are malformed.
    #[error("struct `{name}` at {at}: {reason}")]
    BadStruct {
        /// Where the struct's matrix element starts.
        at: Position,
        /// The struct's name (`outer.inner` when nested).
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// Structs nest deeper than [`MAX_STRUCT_DEPTH`](super::structs::MAX_STRUCT_DEPTH).
    #[error("struct `{name}` at {at} is nested deeper than {limit} structs")]
    TooDeep {
        /// Where the too-deep struct's matrix element starts.
        at: Position,
        /// Its name (`a.b.c…`).
        name: String,
        /// [`MAX_STRUCT_DEPTH`](super::structs::MAX_STRUCT_DEPTH).
        limit: usize,
    },
    /// A compressed element inflates to more than
    /// [`MAX_DECOMPRESSED_BYTES`](super::inflate::MAX_DECOMPRESSED_BYTES).
    #[error("the compressed element at byte {offset} inflates to more than {limit} bytes")]
    DecompressedTooLarge {
        /// File offset of the element.
        offset: usize,
        /// The limit.
        limit: usize,
    },
}
