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
//! Structs (`mxSTRUCT_CLASS`) are flattened: after the name come the field-name length
//! (miINT32, one value), the field names (miINT8, each padded with NULs to that length)
//! and then one `miMATRIX` per field for every element of the struct array (elements
//! in column-major order, fields in name order). A numeric field of a 1×1 struct `s`
//! becomes the variable `s.field`; of a larger struct array, `s(k).field` (k counted
//! from 1 in MATLAB's linear order). Structs nest up to [`MAX_STRUCT_DEPTH`] deep.
//!
//! Char arrays (`mxCHAR_CLASS`, stored as miUINT16 / miUTF16 code units, miUTF8, or
//! 8-bit text) are read into [`MatFile::texts`] ([`MatFile::text`]); a multi-row char
//! array becomes its rows joined by `'\n'`. A char field of a struct is named as a
//! numeric field is.
//!
//! Cells, objects, sparse and complex arrays are not needed for measured signals; they
//! are skipped and listed in [`MatFile::skipped`] rather than failing the whole file,
//! because real files often carry such extras.
//!
//! Robustness: every size field is checked against the bytes that actually remain in
//! its parent before anything is sliced or allocated, so a corrupt or truncated file
//! gives a [`MatError`] with a byte offset, never a panic and never an allocation
//! sized by an untrusted field. Decompressed output grows only with the data actually
//! inflated and is capped at [`MAX_DECOMPRESSED_BYTES`].

mod error;
mod inflate;
mod matrix;
mod numeric;
mod read;
mod stream;
mod structs;
mod types;

pub use error::{MatError, Position};
pub use inflate::MAX_DECOMPRESSED_BYTES;
pub use read::{read_mat, read_mat_file, HEADER_LEN};
pub use structs::MAX_STRUCT_DEPTH;
pub use types::{ByteOrder, MatClass, MatFile, MatText, MatVariable, SkipReason, SkippedVariable};

#[cfg(test)]
pub(crate) mod writer;

#[cfg(test)]
mod struct_tests;

#[cfg(test)]
mod tests;
