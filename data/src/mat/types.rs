//! What the MAT reader returns: [`MatFile`] and its variables, texts and skipped
//! entries, and the [`ByteOrder`] and [`MatClass`] they are described by.

use std::fmt;

use super::error::Position;

/// Byte order of a MAT file, from its endian indicator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ByteOrder {
    /// Indicator bytes `IM`.
    Little,
    /// Indicator bytes `MI`.
    Big,
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
    pub(super) fn from_flags(flags: u32) -> Self {
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

    /// Whether this class is a plain numeric array that
    /// [`read_mat`](super::read::read_mat) returns as a
    /// [`MatVariable`] (structs and char arrays are read too, but not as numbers).
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

/// One char array, as text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct MatText {
    /// Variable name as stored, or `struct.field` for a field of a struct.
    pub name: String,
    /// Dimensions of the char array (in UTF-16 code units, as MATLAB counts them).
    pub dims: Vec<usize>,
    /// The characters; the rows of a multi-row array are joined by `'\n'`. Code units
    /// that are not valid UTF-16 become U+FFFD.
    pub text: String,
}

/// Why a variable was skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SkipReason {
    /// A class this reader does not convert (cell, object, sparse, …).
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
    /// Real numeric variables, in file order (fields of structs flattened to
    /// `struct.field`).
    pub variables: Vec<MatVariable>,
    /// Char arrays, in file order (fields of structs named `struct.field`).
    pub texts: Vec<MatText>,
    /// Variables and elements that were skipped, in file order.
    pub skipped: Vec<SkippedVariable>,
}

impl MatFile {
    /// The variable called `name`, if present.
    pub fn variable(&self, name: &str) -> Option<&MatVariable> {
        self.variables.iter().find(|v| v.name == name)
    }

    /// The text of the char array called `name` (e.g. `bearing.load`), if present.
    pub fn text(&self, name: &str) -> Option<&str> {
        self.texts
            .iter()
            .find(|t| t.name == name)
            .map(|t| t.text.as_str())
    }
}
