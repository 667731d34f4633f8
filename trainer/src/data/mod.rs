//! Measured data: file readers, the CWRU manifest, preprocessing to the model rate,
//! windowing and leakage-free train/test splits.
pub mod csv;
pub mod manifest;
pub mod mat;
pub mod preprocess;
pub mod record;
