//! Stated size limits of the learner, checked before anything of that size is allocated.
//!
//! Every option, saved model and data file is checked against these before a matrix, a
//! monomial list or a file buffer of the corresponding size exists, so a mistyped option
//! (`--dim 100`, `--poly-order 30`) is an error naming the limit, not gigabytes of
//! allocation. The limits are far above what the study uses (d <= 6, p <= 41, orders <= 7,
//! 500 centres, about 10^5 samples).

use super::error::FitError;

/// Largest SSM dimension d (the host decoder's capacity for device models is the same).
pub const MAX_DIM: usize = 32;
/// Largest delay-embedding dimension p.
pub const MAX_EMBED: usize = 4096;
/// Largest delay-embedding shift, samples.
pub const MAX_SHIFT: usize = 1_000_000;
/// Largest polynomial order (manifold, flow, map) and largest exponent in a saved model.
pub const MAX_ORDER: u32 = 32;
/// Largest number of monomials of one polynomial.
pub const MAX_TERMS: usize = 20_000;
/// Largest number of RBF centres.
pub const MAX_CENTERS: usize = 100_000;
/// Largest number of entries (rows x columns) of any regression design matrix or data
/// matrix (10^8 f64 = 800 MB).
pub const MAX_MATRIX_ENTRIES: usize = 100_000_000;
/// Largest data (CSV) file read, bytes.
pub const MAX_DATA_FILE_BYTES: u64 = infile::MAX_DATA_BYTES;
/// Largest saved-model (JSON) file read, bytes.
pub const MAX_MODEL_FILE_BYTES: u64 = infile::MAX_MODEL_BYTES;
/// Deepest nesting of cell arrays in a `.mat` file (SSMLearn's `xData` is one level).
pub const MAX_MAT_DEPTH: usize = 16;

/// `Err(TooLarge)` naming `what` and the limit when `value > limit`.
pub fn check(what: &'static str, value: usize, limit: usize) -> Result<(), FitError> {
    if value > limit {
        return Err(FitError::TooLarge { what, value: value.to_string(), limit: limit.to_string() });
    }
    Ok(())
}

/// Checks a `rows x cols` matrix before it is allocated: at most [`MAX_MATRIX_ENTRIES`]
/// entries, and (for a regression, `need_rows`) at least as many rows as columns.
pub fn check_matrix(what: &'static str, rows: usize, cols: usize, need_rows: bool) -> Result<(), FitError> {
    if need_rows && rows < cols {
        return Err(FitError::Underdetermined { what, rows, cols });
    }
    match rows.checked_mul(cols) {
        Some(n) if n <= MAX_MATRIX_ENTRIES => Ok(()),
        _ => Err(FitError::TooLarge {
            what,
            value: format!("a {rows} x {cols} matrix ({} entries)", rows as u128 * cols as u128),
            limit: format!("{MAX_MATRIX_ENTRIES} entries"),
        }),
    }
}

/// Reads a whole regular file of at most `limit` bytes as UTF-8 text ([`infile::read_text`]:
/// a device, FIFO or directory, or a larger file, is an error in words, read no further).
pub fn read_text_limited(path: &std::path::Path, limit: u64) -> std::io::Result<String> {
    infile::read_text(path, limit)
}

/// Reads a whole regular file of at most `limit` bytes ([`infile::read_bytes`]).
pub fn read_limited(path: &std::path::Path, limit: u64) -> std::io::Result<Vec<u8>> {
    infile::read_bytes(path, limit)
}
