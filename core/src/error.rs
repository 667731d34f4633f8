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
