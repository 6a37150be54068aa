//! The one reader of input files: every file the tool reads (scene and sweep-spec TOML,
//! model JSON, CSV data, `.mat` files, sweep shard files, model blobs) goes through
//! [`read_bytes`] / [`read_text`] with the limit of its kind, so no input can make a reader
//! allocate without bound, block on a FIFO or read a device. It sits below every crate that
//! reads files (`sim`, `ssm`, `furuta`, `ssmctl`, the Python module).
//!
//! Errors are `std::io::Error`s whose message is words (what the path is, the limit), never
//! a bare `os error N`, so each caller's "FILE: cannot read: ..." reads as a sentence.
//!
//! Sizes declared inside files are checked by their parsers against their own limits
//! (`ssm::limits`, the sweep's cell limit, ...); [`check_nesting`] bounds the bracket
//! nesting of TOML text before a recursive parser sees it.
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing)]

use std::io::{self, Read};
use std::path::Path;

/// Largest scene file (TOML), bytes.
pub const MAX_SCENE_BYTES: u64 = 1 << 20;
/// Largest sweep spec (TOML), bytes.
pub const MAX_SPEC_BYTES: u64 = 1 << 20;
/// Largest sweep shard file (JSON), bytes.
pub const MAX_SHARD_BYTES: u64 = 256 << 20;
/// Largest saved model (JSON), bytes.
pub const MAX_MODEL_BYTES: u64 = 256 << 20;
/// Largest data file (CSV), bytes.
pub const MAX_DATA_BYTES: u64 = 512 << 20;
/// Largest `.mat` file, bytes; also the bound on everything its compressed variables
/// inflate to, together.
pub const MAX_MAT_BYTES: u64 = 512 << 20;
/// Largest model blob, bytes.
pub const MAX_BLOB_BYTES: u64 = 16 << 20;
/// Largest side file the report reads (device table, PIL summary, the xtask's timings).
pub const MAX_REPORT_INPUT_BYTES: u64 = 16 << 20;
/// Deepest bracket nesting (`[`, `{`) of TOML or JSON text, and deepest dotted key.
pub const MAX_NESTING: usize = 64;

/// A message-only `io::Error` of `kind`.
fn err(kind: io::ErrorKind, msg: String) -> io::Error {
    io::Error::new(kind, msg)
}

/// An OS error in words: the system's description without its `(os error N)` suffix.
pub fn describe(e: &io::Error) -> String {
    match e.kind() {
        io::ErrorKind::NotFound => "no such file".into(),
        io::ErrorKind::PermissionDenied => "permission denied".into(),
        io::ErrorKind::IsADirectory => "a directory, not a file".into(),
        io::ErrorKind::NotADirectory => "a component of the path is not a directory".into(),
        io::ErrorKind::AlreadyExists => "already exists".into(),
        _ => {
            let s = e.to_string();
            let s = s.split(" (os error").next().unwrap_or_default();
            let mut c = s.chars();
            match c.next() {
                Some(f) => f.to_lowercase().chain(c).collect(),
                None => format!("{:?}", e.kind()).to_lowercase(),
            }
        }
    }
}

/// What a non-regular file is, in words.
fn kind_of(ft: &std::fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if ft.is_char_device() {
            return "a character device";
        }
        if ft.is_block_device() {
            return "a block device";
        }
        if ft.is_socket() {
            return "a socket";
        }
    }
    if ft.is_dir() {
        return "a directory";
    }
    if ft.is_symlink() {
        return "a symbolic link";
    }
    "not a regular file"
}

/// Opens `path` for reading without blocking (a FIFO with no writer would hang a plain
/// open) and without becoming a controlling terminal.
fn open(path: &Path) -> io::Result<std::fs::File> {
    let mut o = std::fs::OpenOptions::new();
    o.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        o.custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY);
    }
    o.open(path)
}

/// The whole of the regular file `path`, at most `limit` bytes. A device, FIFO, socket or
/// directory, a file over the limit (by its size, or by what it yields if it grows) and an
/// OS error are errors whose message says which, in words.
pub fn read_bytes(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    let f = open(path).map_err(|e| err(e.kind(), describe(&e)))?;
    let meta = f.metadata().map_err(|e| err(e.kind(), describe(&e)))?;
    let ft = meta.file_type();
    if !ft.is_file() {
        return Err(err(io::ErrorKind::InvalidInput, format!("{}, not a regular file", kind_of(&ft))));
    }
    let too_large = |n: String| {
        err(io::ErrorKind::InvalidData, format!("{n} bytes, over the limit of {limit} bytes for this kind of file"))
    };
    if meta.len() > limit {
        return Err(too_large(meta.len().to_string()));
    }
    let mut bytes = Vec::with_capacity(usize::try_from(meta.len()).unwrap_or(0));
    f.take(limit.saturating_add(1)).read_to_end(&mut bytes).map_err(|e| err(e.kind(), describe(&e)))?;
    if bytes.len() as u64 > limit {
        return Err(too_large(format!("more than {limit}")));
    }
    Ok(bytes)
}

/// The first `n` bytes (fewer if the file is shorter) of the regular file `path`, refused
/// like [`read_bytes`] when it is not one: for checking what a file is (a magic number).
pub fn read_prefix(path: &Path, n: usize) -> io::Result<Vec<u8>> {
    let f = open(path).map_err(|e| err(e.kind(), describe(&e)))?;
    let ft = f.metadata().map_err(|e| err(e.kind(), describe(&e)))?.file_type();
    if !ft.is_file() {
        return Err(err(io::ErrorKind::InvalidInput, format!("{}, not a regular file", kind_of(&ft))));
    }
    let mut bytes = Vec::with_capacity(n);
    f.take(n as u64).read_to_end(&mut bytes).map_err(|e| err(e.kind(), describe(&e)))?;
    Ok(bytes)
}

/// [`read_bytes`] as UTF-8 text; other bytes are an error giving the offset.
pub fn read_text(path: &Path, limit: u64) -> io::Result<String> {
    String::from_utf8(read_bytes(path, limit)?).map_err(|e| {
        err(
            io::ErrorKind::InvalidData,
            format!("not UTF-8 text (invalid byte at offset {})", e.utf8_error().valid_up_to()),
        )
    })
}

/// Checks that the brackets (`[`, `{`) of TOML or JSON `text` nest at most `max` deep, so
/// a recursive parser (and the drop of what it builds) cannot overflow the stack. Strings
/// (basic, literal, multi-line) and `#` comments are skipped; text the scan misreads is
/// text the parser refuses. `Err` gives the 1-based line where the limit is passed.
pub fn check_nesting(text: &str, max: usize) -> Result<(), String> {
    let b = text.as_bytes();
    let (mut i, mut depth, mut line) = (0usize, 0usize, 1usize);
    let at = |i: usize| b.get(i).copied();
    let starts = |i: usize, s: &[u8]| b.get(i..).is_some_and(|r| r.starts_with(s));
    while let Some(c) = at(i) {
        match c {
            b'\n' => line += 1,
            b'#' => {
                while at(i).is_some_and(|c| c != b'\n') {
                    i += 1;
                }
                continue;
            }
            b'"' | b'\'' => {
                let triple: &[u8] = if c == b'"' { b"\"\"\"" } else { b"'''" };
                let multi = starts(i, triple);
                i += if multi { 3 } else { 1 };
                loop {
                    match at(i) {
                        None => return Ok(()),
                        Some(b'\\') if c == b'"' => i += 2,
                        Some(b'\n') if !multi => break,
                        Some(b'\n') => {
                            line += 1;
                            i += 1;
                        }
                        Some(q) if q == c && (!multi || starts(i, triple)) => {
                            i += if multi { 3 } else { 1 };
                            break;
                        }
                        Some(_) => i += 1,
                    }
                }
                continue;
            }
            b'[' | b'{' => {
                depth += 1;
                if depth > max {
                    return Err(format!("line {line}: brackets nested more than {max} deep"));
                }
            }
            b']' | b'}' => depth = depth.saturating_sub(1),
            _ => {}
        }
        i += 1;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("infile-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn reads_regular_files_within_the_limit() {
        let d = tmp("ok");
        let p = d.join("a.txt");
        std::fs::write(&p, "hello").unwrap();
        assert_eq!(read_text(&p, 5).unwrap(), "hello");
        let e = read_text(&p, 4).unwrap_err().to_string();
        assert!(e.contains("5 bytes, over the limit of 4 bytes"), "{e}");
        std::fs::write(&p, [0xff, 0xfe]).unwrap();
        let e = read_text(&p, 10).unwrap_err().to_string();
        assert!(e.contains("not UTF-8 text (invalid byte at offset 0)"), "{e}");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn refuses_devices_fifos_and_directories_by_name() {
        let e = read_bytes(Path::new("/dev/zero"), 1 << 20).unwrap_err().to_string();
        assert_eq!(e, "a character device, not a regular file");
        let d = tmp("kinds");
        let e = read_bytes(&d, 1 << 20).unwrap_err().to_string();
        assert_eq!(e, "a directory, not a regular file");
        let fifo = d.join("fifo");
        let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
        // SAFETY: a valid NUL-terminated path; mkfifo only creates the node.
        assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
        // No writer: a blocking open would hang here.
        let e = read_bytes(&fifo, 1 << 20).unwrap_err().to_string();
        assert_eq!(e, "a FIFO (named pipe), not a regular file");
        let e = read_bytes(&d.join("missing"), 10).unwrap_err().to_string();
        assert_eq!(e, "no such file");
        let _ = std::fs::remove_dir_all(&d);
    }

    #[test]
    fn nesting_is_bounded_outside_strings_and_comments() {
        assert!(check_nesting("a = [[1], {b = [2]}]\n[t]\n[[u]]\n", 3).is_ok());
        assert!(check_nesting(&format!("a = {}", "[".repeat(5)), 4).unwrap_err().contains("nested more than 4"));
        let quoted =
            format!("a = \"{0}\"\nb = '{0}'\nc = \"\"\"\n{0}\n\"\"\"\n# {0}\nd = '''{0}'''\n", "[".repeat(100));
        assert!(check_nesting(&quoted, 2).is_ok(), "brackets in strings and comments are text");
        assert!(check_nesting("a = \"x\\\"[[[\"", 1).is_ok(), "escaped quotes stay inside the string");
        let e = check_nesting(&format!("x = 1\n\ny = {}", "{a=".repeat(10)), 9).unwrap_err();
        assert!(e.starts_with("line 3:"), "{e}");
    }
}
