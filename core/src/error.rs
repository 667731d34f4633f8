//! The core's one error type.

/// Everything that can go wrong in the core. Values, never panics.
#[non_exhaustive]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Error {
    /// A buffer handed in by the caller has the wrong length for the operation.
    BufferSize {
        /// Length the operation needs.
        expected: usize,
        /// Length it got.
        got: usize,
    },
    /// An input sample or parameter is NaN or infinite.
    NonFinite,
    /// A parameter is outside its physical or numerical domain (e.g. negative mass).
    InvalidParameter(&'static str),
    /// A transform length is not a power of two (or is too small).
    NotPowerOfTwo(usize),
    /// The signal is constant (zero variance) where a statistic needs variation.
    Degenerate,
    /// The numerical integration diverged (state became non-finite).
    Diverged {
        /// Index of the step at which the state stopped being finite.
        step: usize,
    },
    /// A masked reduction (softmax row, attention pooling) has no present entry:
    /// every node or neighbour is masked out.
    NothingPresent,
    /// A model file does not start with the magic bytes `PTWINMDL`.
    ModelMagic,
    /// A model file has a format version this core does not read.
    ModelVersion {
        /// Version in the file.
        found: u16,
        /// The version this core reads.
        supported: u16,
    },
    /// A model file is shorter than its header (or its header's payload length) says.
    ModelTruncated {
        /// Length the file needs.
        expected: usize,
        /// Length it has.
        got: usize,
    },
    /// A model file has bytes after its checksum.
    ModelTrailingBytes {
        /// Number of bytes after the end of the file its header declares.
        extra: usize,
    },
    /// A model file's CRC-32 over the payload does not match the stored one.
    ModelChecksum {
        /// CRC stored in the file.
        stored: u32,
        /// CRC computed over the payload.
        computed: u32,
    },
    /// A model file's payload is not a postcard encoding of the model (why).
    ModelDecode(&'static str),
    /// A model file's dimensions disagree with each other, with its buffers' lengths
    /// or with the core's compile-time maxima, or with the sizes asked for (which).
    ModelDimensions(&'static str),
    /// A value in a model file is outside its domain: a non-finite or non-positive
    /// scale, a feature std ≤ 0, an unphysical parameter (which).
    ModelValue(&'static str),
}

/// Result alias for the core.
pub type Result<T> = core::result::Result<T, Error>;

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::BufferSize { expected, got } => {
                write!(f, "buffer has length {got}, expected {expected}")
            }
            Error::NonFinite => f.write_str("input contains NaN or infinity"),
            Error::InvalidParameter(what) => write!(f, "invalid parameter: {what}"),
            Error::NotPowerOfTwo(n) => write!(f, "transform length {n} is not a power of two >= 2"),
            Error::Degenerate => f.write_str("signal has zero variance"),
            Error::Diverged { step } => write!(f, "integration diverged at step {step}"),
            Error::NothingPresent => f.write_str("every entry of a masked reduction is absent"),
            Error::ModelMagic => f.write_str("not a model file (magic bytes are not PTWINMDL)"),
            Error::ModelVersion { found, supported } => write!(
                f,
                "model file format version {found}, this core reads version {supported}"
            ),
            Error::ModelTruncated { expected, got } => {
                write!(f, "model file truncated: {got} bytes, expected {expected}")
            }
            Error::ModelTrailingBytes { extra } => {
                write!(f, "model file has {extra} bytes after its checksum")
            }
            Error::ModelChecksum { stored, computed } => write!(
                f,
                "model file checksum mismatch: stored {stored:#010x}, computed {computed:#010x}"
            ),
            Error::ModelDecode(why) => write!(f, "model file payload does not decode: {why}"),
            Error::ModelDimensions(what) => write!(f, "model file dimensions: {what}"),
            Error::ModelValue(what) => write!(f, "model file value out of domain: {what}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for Error {}

/// Check a buffer length.
pub(crate) fn expect_len(got: usize, expected: usize) -> Result<()> {
    if got == expected {
        Ok(())
    } else {
        Err(Error::BufferSize { expected, got })
    }
}
