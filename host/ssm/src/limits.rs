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
pub const MAX_DATA_FILE_BYTES: u64 = 512 * 1024 * 1024;
/// Largest saved-model (JSON) file read, bytes.
pub const MAX_MODEL_FILE_BYTES: u64 = 256 * 1024 * 1024;

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

/// Reads a whole file of at most `limit` bytes as UTF-8 text; a larger file (or a device
/// that never ends, such as `/dev/zero`) is an error naming the limit, read no further.
pub fn read_text_limited(path: &std::path::Path, limit: u64) -> std::io::Result<String> {
    let bytes = read_limited(path, limit)?;
    String::from_utf8(bytes)
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, format!("not UTF-8 text: {e}")))
}

/// Reads a whole file of at most `limit` bytes.
pub fn read_limited(path: &std::path::Path, limit: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let f = std::fs::File::open(path)?;
    let mut bytes = Vec::new();
    f.take(limit.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("file larger than the limit of {limit} bytes"),
        ));
    }
    Ok(bytes)
}
