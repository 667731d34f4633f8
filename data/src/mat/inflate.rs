//! Inflating `miCOMPRESSED` elements (zlib), with a size cap.

use std::io::Read;

use super::error::MatError;

/// Largest amount of data one `miCOMPRESSED` element may inflate to (1 GiB). Guards
/// against decompression bombs; a measured record is far smaller.
pub const MAX_DECOMPRESSED_BYTES: usize = 1 << 30;

/// Inflate the zlib stream of the compressed element at file offset `offset`.
pub(super) fn inflate(data: &[u8], offset: usize) -> Result<Vec<u8>, MatError> {
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
