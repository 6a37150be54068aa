//! A reader of the subset of MATLAB's Level 5 MAT-file format (the `-v6`/`-v7` files MATLAB
//! writes by default, and scipy's `savemat`) that trajectory data needs: real 2D double
//! arrays and cell arrays of them, compressed (`miCOMPRESSED`, zlib) or not,
//! little-endian. This module knows the format only; SSMLearn's trajectory layout is read
//! by [`crate::data::load_mat`].
//!
//! # Format (MathWorks, "MAT-File Format", Level 5)
//!
//! * A 128-byte header: 116 bytes of descriptive text (`MATLAB 5.0 MAT-file, ...`; not
//!   checked, writers word it differently), 8 bytes of subsystem offset, the version
//!   `0x0100` (`0x0200` is v7.3) and the endian indicator `IM` (little-endian writer; `MI`
//!   is big-endian, refused here).
//! * Then data elements, one per variable: an 8-byte tag (type `u32`, byte count `u32`) and
//!   the data padded to 8 bytes; or the *small* form, a 4-byte tag (count in the high 16
//!   bits, type in the low 16) with up to 4 bytes of data. A top-level `miCOMPRESSED`
//!   element holds a zlib stream of one whole element (no padding after it).
//! * An `miMATRIX` element holds sub-elements: array flags (`miUINT32`: class in the low
//!   byte, the complex flag `0x0800`), dimensions (`miINT32`), the name (`miINT8`), then for
//!   numeric classes the real part (any numeric storage type: MATLAB stores integral values
//!   of a double array in the smallest integer type that holds them), for cells one
//!   `miMATRIX` per element, column-major. An `miMATRIX` of 0 bytes is an empty array.
//!
//! Anything else (other classes, complex, sparse, more than 2 dimensions, big-endian, v4,
//! v7.3) is an error naming the variable, and the cell within it, where it was met. A v7.3
//! file is HDF5: the error says so and how to convert it.
// Parses untrusted input: no indexing that can panic (CI runs clippy).
#![cfg_attr(not(test), deny(clippy::indexing_slicing))]

use std::path::Path;

use thiserror::Error;

/// Upper bound on what the compressed variables of one file inflate to, together: a corrupt
/// or hostile stream cannot make the reader allocate without bound.
pub const MAX_INFLATED_BYTES: usize = infile::MAX_MAT_BYTES as usize;

/// A zlib failure in words.
fn inflate_why(status: miniz_oxide::inflate::TINFLStatus) -> String {
    use miniz_oxide::inflate::TINFLStatus as S;
    match status {
        S::HasMoreOutput => {
            format!("the variables inflate to more than {MAX_INFLATED_BYTES} bytes together, the limit for a .mat file")
        }
        S::FailedCannotMakeProgress | S::NeedsMoreInput => "the compressed stream ends early (truncated)".into(),
        S::Adler32Mismatch => "checksum mismatch (corrupt data)".into(),
        _ => "corrupt compressed data".into(),
    }
}

/// A value this reader understands.
#[derive(Clone, Debug, PartialEq)]
pub enum MatValue {
    /// A real double array, `dims = [rows, cols]`, `data` column-major.
    Double { dims: [usize; 2], data: Vec<f64> },
    /// A cell array, `dims = [rows, cols]`, elements column-major.
    Cell { dims: [usize; 2], cells: Vec<MatValue> },
}

impl MatValue {
    /// `[rows, cols]`.
    pub fn dims(&self) -> [usize; 2] {
        match self {
            MatValue::Double { dims, .. } | MatValue::Cell { dims, .. } => *dims,
        }
    }
}

/// Errors of [`MatFile`]. `var` is a MATLAB-style path: `xData` or `xData{2,1}`.
#[derive(Debug, Error)]
pub enum MatError {
    #[error("{file}: cannot read: {source}")]
    Io {
        file: String,
        #[source]
        source: std::io::Error,
    },
    #[error(
        "{file}: a MATLAB v7.3 (HDF5) .mat file; this reader reads v5-v7 files: in MATLAB, `load` it and `save(FILE, 'xData', '-v7')` (or use scipy.io.savemat)"
    )]
    V73 { file: String },
    #[error("{file}: not a MATLAB v5 .mat file ({why})")]
    NotMat { file: String, why: String },
    #[error("{file}: big-endian .mat file; save it on a little-endian machine (`save(..., '-v7')`)")]
    BigEndian { file: String },
    #[error("{file}: {var}: truncated or malformed ({why})")]
    Malformed { file: String, var: String, why: String },
    #[error("{file}: {var}: zlib decompression failed ({why})")]
    Inflate { file: String, var: String, why: String },
    #[error("{file}: {var}: {what} is not supported (this reader takes real 2D double arrays and cell arrays of them)")]
    Unsupported { file: String, var: String, what: String },
    #[error("{file}: {var}: {why}")]
    Limit { file: String, var: String, why: String },
    #[error("{file}: no variable `{var}` (variables: {available})")]
    NoVariable { file: String, var: String, available: String },
}

// Data types (miTYPE) and array classes (mxCLASS) used here.
const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
const MX_CELL: u8 = 1;
const MX_DOUBLE: u8 = 6;
const FLAG_COMPLEX: u32 = 0x0800;

fn class_name(c: u8) -> String {
    match c {
        1 => "cell".into(),
        2 => "struct".into(),
        3 => "object".into(),
        4 => "char".into(),
        5 => "sparse".into(),
        6 => "double".into(),
        7 => "single".into(),
        8 => "int8".into(),
        9 => "uint8".into(),
        10 => "int16".into(),
        11 => "uint16".into(),
        12 => "int32".into(),
        13 => "uint32".into(),
        14 => "int64".into(),
        15 => "uint64".into(),
        16 => "function handle".into(),
        17 => "opaque (e.g. string, table, datetime)".into(),
        c => format!("unknown class {c}"),
    }
}

/// One top-level variable: its name and the `miMATRIX` payload (inflated).
struct Var {
    name: String,
    body: Vec<u8>,
}

/// The variables of a v5 MAT-file, parsed on demand by [`MatFile::get`].
pub struct MatFile {
    file: String,
    vars: Vec<Var>,
}

/// Reads sub-elements from a byte slice.
struct Cursor<'a> {
    buf: &'a [u8],
    pos: usize,
}

/// The little-endian `u32` at the start of `b` (`None` when fewer than 4 bytes).
fn u32_le(b: &[u8]) -> Option<u32> {
    b.first_chunk::<4>().map(|c| u32::from_le_bytes(*c))
}

impl<'a> Cursor<'a> {
    fn new(buf: &'a [u8]) -> Self {
        Cursor { buf, pos: 0 }
    }

    fn at_end(&self) -> bool {
        self.pos >= self.buf.len()
    }

    /// The next element `(type, data)`; `padded`: skip to the next 8-byte boundary after
    /// a full-form element (always, except after a top-level `miCOMPRESSED`).
    fn element(&mut self) -> Result<(u32, &'a [u8]), String> {
        let rest = self.buf.get(self.pos..).unwrap_or_default();
        let short = || format!("{} bytes left at offset {}, need an 8-byte tag", rest.len(), self.pos);
        let (Some(first), Some(second)) = (u32_le(rest), rest.get(4..).and_then(u32_le)) else {
            return Err(short());
        };
        if first >> 16 != 0 {
            // Small data element: 2-byte count, 2-byte type, 4 data bytes.
            let (ty, n) = (first & 0xffff, (first >> 16) as usize);
            let data = rest.get(4..4 + n).filter(|_| n <= 4);
            let Some(data) = data else {
                return Err(format!("small element of {n} bytes at offset {}", self.pos));
            };
            self.pos += 8;
            return Ok((ty, data));
        }
        let n = second as usize;
        let Some(data) = rest.get(8..).and_then(|r| r.get(..n)) else {
            return Err(format!(
                "element of {n} bytes at offset {} but only {} left",
                self.pos,
                rest.len().saturating_sub(8)
            ));
        };
        let ty = first;
        let advance = if ty == MI_COMPRESSED { 8 + n } else { 8 + n.div_ceil(8) * 8 };
        self.pos = (self.pos + advance).min(self.buf.len());
        Ok((ty, data))
    }
}

/// Little-endian values of `N` bytes each, converted by `f`.
fn convert<const N: usize>(data: &[u8], f: fn([u8; N]) -> f64) -> Result<Vec<f64>, String> {
    let chunks = data.chunks_exact(N);
    if !chunks.remainder().is_empty() {
        return Err(format!("{} bytes is not a multiple of {N}", data.len()));
    }
    Ok(chunks.map(|c| f(c.try_into().unwrap_or([0; N]))).collect())
}

/// Bytes per value of numeric storage type `ty` (`None` when not numeric).
fn type_size(ty: u32) -> Option<usize> {
    match ty {
        MI_INT8 | MI_UINT8 => Some(1),
        MI_INT16 | MI_UINT16 => Some(2),
        MI_INT32 | MI_UINT32 | MI_SINGLE => Some(4),
        MI_DOUBLE | MI_INT64 | MI_UINT64 => Some(8),
        _ => None,
    }
}

/// Numbers of storage type `ty` as f64 (little-endian).
fn numbers(ty: u32, data: &[u8]) -> Result<Vec<f64>, String> {
    match ty {
        MI_INT8 => convert::<1>(data, |b| i8::from_le_bytes(b) as f64),
        MI_UINT8 => convert::<1>(data, |b| u8::from_le_bytes(b) as f64),
        MI_INT16 => convert::<2>(data, |b| i16::from_le_bytes(b) as f64),
        MI_UINT16 => convert::<2>(data, |b| u16::from_le_bytes(b) as f64),
        MI_INT32 => convert::<4>(data, |b| i32::from_le_bytes(b) as f64),
        MI_UINT32 => convert::<4>(data, |b| u32::from_le_bytes(b) as f64),
        MI_SINGLE => convert::<4>(data, |b| f32::from_le_bytes(b) as f64),
        MI_DOUBLE => convert::<8>(data, f64::from_le_bytes),
        MI_INT64 => convert::<8>(data, |b| i64::from_le_bytes(b) as f64),
        MI_UINT64 => convert::<8>(data, |b| u64::from_le_bytes(b) as f64),
        t => Err(format!("data type {t} is not numeric")),
    }
}

/// Array flags, dimensions and name at the start of an `miMATRIX` payload.
struct Header {
    class: u8,
    flags: u32,
    dims: Vec<usize>,
    name: String,
}

fn header(c: &mut Cursor<'_>) -> Result<Header, String> {
    let (ty, flags) = c.element()?;
    if ty != MI_UINT32 || flags.len() != 8 {
        return Err(format!("array flags: expected 8 bytes of miUINT32, found type {ty} with {} bytes", flags.len()));
    }
    let Some(f) = u32_le(flags) else {
        return Err(format!("array flags: {} bytes", flags.len()));
    };
    let (ty, dims) = c.element()?;
    if ty != MI_INT32 || dims.len() % 4 != 0 || dims.len() < 8 {
        return Err(format!("dimensions: expected at least 2 miINT32, found type {ty} with {} bytes", dims.len()));
    }
    let dims: Vec<usize> = dims
        .chunks_exact(4)
        .filter_map(|b| b.first_chunk::<4>().map(|c| i32::from_le_bytes(*c)))
        .map(|d| usize::try_from(d).map_err(|_| format!("negative dimension {d}")))
        .collect::<Result<_, _>>()?;
    let (ty, name) = c.element()?;
    if ty != MI_INT8 && ty != MI_UINT8 {
        return Err(format!("array name: expected miINT8, found type {ty}"));
    }
    Ok(Header { class: (f & 0xff) as u8, flags: f, dims, name: String::from_utf8_lossy(name).into_owned() })
}

impl MatFile {
    /// Reads and indexes a file (see [`MatFile::parse`]).
    pub fn open(path: impl AsRef<Path>) -> Result<Self, MatError> {
        let path = path.as_ref();
        let file = path.display().to_string();
        let bytes = infile::read_bytes(path, infile::MAX_MAT_BYTES)
            .map_err(|source| MatError::Io { file: file.clone(), source })?;
        Self::parse(&file, &bytes)
    }

    /// Checks the header and inflates every variable; `file` names the input in errors.
    pub fn parse(file: &str, bytes: &[u8]) -> Result<Self, MatError> {
        let not = |why: &str| MatError::NotMat { file: file.to_string(), why: why.to_string() };
        let v73 = || MatError::V73 { file: file.to_string() };
        if bytes.starts_with(b"MATLAB 7.3")
            || bytes.get(512..520) == Some(b"\x89HDF\r\n\x1a\n")
            || bytes.starts_with(b"\x89HDF")
        {
            return Err(v73());
        }
        // The text is descriptive (MATLAB, Octave, scipy and matio word it differently): the
        // version and the endian indicator identify the format.
        let (Some(version), Some(endian), Some(rest)) =
            (bytes.get(124..126).and_then(|b| b.first_chunk::<2>()), bytes.get(126..128), bytes.get(128..))
        else {
            return Err(not(&format!("{} bytes, shorter than the 128-byte header", bytes.len())));
        };
        let version = u16::from_le_bytes(*version);
        match (endian, version) {
            (b"IM", 0x0100) => {}
            (b"IM", 0x0200) => return Err(v73()),
            (b"MI", _) => return Err(MatError::BigEndian { file: file.to_string() }),
            (b"IM", v) => return Err(not(&format!("version {v:#06x}, expected 0x0100"))),
            (other, _) => {
                return Err(not(&format!(
                    "endian indicator {other:?} at byte 126, expected \"IM\"; a v4 file or not a .mat file"
                )));
            }
        }
        let mut vars = Vec::new();
        let mut top = Cursor::new(rest);
        let mut inflated_total = 0usize;
        while !top.at_end() {
            let index = vars.len() + 1;
            let where_ = || format!("variable #{index}");
            let malformed = |why: String| MatError::Malformed { file: file.to_string(), var: where_(), why };
            let (ty, data) = top.element().map_err(malformed)?;
            let body = match ty {
                MI_COMPRESSED => {
                    let budget = MAX_INFLATED_BYTES.saturating_sub(inflated_total);
                    let inflated =
                        miniz_oxide::inflate::decompress_to_vec_zlib_with_limit(data, budget).map_err(|e| {
                            MatError::Inflate { file: file.to_string(), var: where_(), why: inflate_why(e.status) }
                        })?;
                    inflated_total = inflated_total.saturating_add(inflated.len());
                    let mut inner = Cursor::new(&inflated);
                    let (ty, payload) = inner.element().map_err(malformed)?;
                    if ty != MI_MATRIX {
                        return Err(malformed(format!(
                            "compressed element holds data type {ty}, expected miMATRIX (14)"
                        )));
                    }
                    payload.to_vec()
                }
                MI_MATRIX => data.to_vec(),
                t => {
                    return Err(malformed(format!(
                        "top-level data type {t}, expected miMATRIX (14) or miCOMPRESSED (15)"
                    )));
                }
            };
            if body.is_empty() {
                continue;
            }
            let h = header(&mut Cursor::new(&body)).map_err(malformed)?;
            vars.push(Var { name: h.name, body });
        }
        Ok(MatFile { file: file.to_string(), vars })
    }

    /// Names of the variables, in file order.
    pub fn names(&self) -> Vec<&str> {
        self.vars.iter().map(|v| v.name.as_str()).collect()
    }

    /// Variable `name`, fully parsed.
    pub fn get(&self, name: &str) -> Result<MatValue, MatError> {
        let v = self.vars.iter().find(|v| v.name == name).ok_or_else(|| MatError::NoVariable {
            file: self.file.clone(),
            var: name.to_string(),
            available: if self.vars.is_empty() { "none".into() } else { self.names().join(", ") },
        })?;
        let mut entries = 0usize;
        self.value(&v.body, name, 0, &mut entries)
    }

    /// Parses one `miMATRIX` payload; `path` names it in errors, `depth` counts the cells
    /// around it ([`crate::limits::MAX_MAT_DEPTH`]), `entries` the doubles and cells read so
    /// far ([`crate::limits::MAX_MATRIX_ENTRIES`] for the whole variable).
    fn value(&self, body: &[u8], path: &str, depth: usize, entries: &mut usize) -> Result<MatValue, MatError> {
        let malformed = |why: String| MatError::Malformed { file: self.file.clone(), var: path.to_string(), why };
        let unsupported = |what: String| MatError::Unsupported { file: self.file.clone(), var: path.to_string(), what };
        let limit = |why: String| MatError::Limit { file: self.file.clone(), var: path.to_string(), why };
        if body.is_empty() {
            // `[]` inside a cell.
            return Ok(MatValue::Double { dims: [0, 0], data: Vec::new() });
        }
        let mut c = Cursor::new(body);
        let h = header(&mut c).map_err(malformed)?;
        let class = class_name(h.class);
        let &[rows, cols] = h.dims.as_slice() else {
            return Err(unsupported(format!("a {}-dimensional {class} array ({:?})", h.dims.len(), h.dims)));
        };
        let dims = [rows, cols];
        let n = rows.checked_mul(cols).ok_or_else(|| malformed(format!("dimensions {rows}x{cols} overflow")))?;
        // Checked against the limit before anything of that size is allocated.
        *entries = entries.saturating_add(n);
        if *entries > crate::limits::MAX_MATRIX_ENTRIES {
            return Err(limit(format!(
                "a {rows}x{cols} {class} array: {} entries with those before it, over the limit of {}",
                *entries,
                crate::limits::MAX_MATRIX_ENTRIES
            )));
        }
        match h.class {
            MX_DOUBLE => {
                if h.flags & FLAG_COMPLEX != 0 {
                    return Err(unsupported("a complex double array".into()));
                }
                let (ty, re) = c.element().map_err(malformed)?;
                // The count is checked before the conversion allocates (a byte per value
                // would become eight).
                if let Some(size) = type_size(ty) {
                    if re.len() / size != n {
                        return Err(malformed(format!("{} values for dimensions {rows}x{cols}", re.len() / size)));
                    }
                }
                let data = numbers(ty, re).map_err(|w| malformed(format!("real part: {w}")))?;
                if data.len() != n {
                    return Err(malformed(format!("{} values for dimensions {rows}x{cols}", data.len())));
                }
                Ok(MatValue::Double { dims, data })
            }
            MX_CELL => {
                if depth >= crate::limits::MAX_MAT_DEPTH {
                    return Err(limit(format!("cell arrays nested more than {} deep", crate::limits::MAX_MAT_DEPTH)));
                }
                // Every element takes at least an 8-byte tag: a count the bytes cannot hold is
                // refused before the list is allocated.
                let left = body.len().saturating_sub(c.pos);
                if n > left / 8 {
                    return Err(malformed(format!(
                        "a {rows}x{cols} cell array claims {n} elements but only {left} bytes follow"
                    )));
                }
                let mut cells = Vec::with_capacity(n);
                for k in 0..n {
                    let sub = format!("{path}{{{},{}}}", k % dims[0].max(1) + 1, k / dims[0].max(1) + 1);
                    let (ty, payload) = c.element().map_err(|w| MatError::Malformed {
                        file: self.file.clone(),
                        var: sub.clone(),
                        why: w,
                    })?;
                    if ty != MI_MATRIX {
                        return Err(MatError::Malformed {
                            file: self.file.clone(),
                            var: sub,
                            why: format!("data type {ty}, expected miMATRIX"),
                        });
                    }
                    cells.push(self.value(payload, &sub, depth + 1, entries)?);
                }
                Ok(MatValue::Cell { dims, cells })
            }
            other => Err(unsupported(format!("class {}", class_name(other)))),
        }
    }
}
