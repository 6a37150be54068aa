//! No measured results in library source: a `const` or `static` table of more than
//! [`MAX_ROWS`] rows with numbers in them, outside `#[cfg(test)]`, fails here with its file
//! and name. Tables of results belong in data files (`studies/results/`), written by the
//! program that computes them and read at run time (`chaos_study::study_results`).

use std::path::{Path, PathBuf};

/// Most numeric rows a table in library source may have.
const MAX_ROWS: usize = 20;

/// The library and app source folders of the workspace (`*/src` of its crates).
fn source_dirs(root: &Path) -> Vec<PathBuf> {
    let mut dirs = vec![root.join("shared/src"), root.join("controller/src")];
    for entry in std::fs::read_dir(root.join("host")).expect("host/ is listed") {
        let src = entry.expect("host/ entry").path().join("src");
        if src.is_dir() {
            dirs.push(src);
        }
    }
    dirs
}

/// Every `.rs` file under `dir`, except test modules in their own files (`tests.rs`, `tests/`).
fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("source folder is listed") {
        let p = entry.expect("source entry").path();
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or_default().to_string();
        if p.is_dir() {
            if name != "tests" {
                rust_files(&p, out);
            }
        } else if name.ends_with(".rs") && name != "tests.rs" {
            out.push(p);
        }
    }
}

/// `src` with comments and the contents of string and char literals blanked (so brackets in
/// them do not count), lengths kept.
fn blank_comments_and_strings(src: &str) -> Vec<u8> {
    let b = src.as_bytes();
    let mut out = b.to_vec();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                out[i] = b' ';
                i += 1;
            }
        } else if b[i] == b'"' {
            i += 1;
            while i < b.len() && b[i] != b'"' {
                let esc = b[i] == b'\\';
                out[i] = b' ';
                if esc && i + 1 < b.len() {
                    out[i + 1] = b' ';
                    i += 1;
                }
                i += 1;
            }
            i += 1;
        } else if b[i] == b'\'' && b.get(i + 2) == Some(&b'\'') {
            out[i + 1] = b' ';
            i += 3;
        } else {
            i += 1;
        }
    }
    out
}

/// `s` with every `#[cfg(test)]` item removed (a `mod x;` line, or the braced block after it).
fn strip_cfg_test(s: &[u8]) -> Vec<u8> {
    let pat = b"#[cfg(test)]";
    let mut out = Vec::with_capacity(s.len());
    let mut i = 0;
    while i < s.len() {
        if s[i..].starts_with(pat) {
            let rest = &s[i..];
            let brace = rest.iter().position(|&c| c == b'{');
            let semi = rest.iter().position(|&c| c == b';');
            match (brace, semi) {
                (_, Some(sc)) if brace.is_none_or(|b| sc < b) => i += sc + 1,
                (Some(bc), _) => {
                    let mut depth = 0usize;
                    let mut j = i + bc;
                    while j < s.len() {
                        match s[j] {
                            b'{' => depth += 1,
                            b'}' => {
                                depth -= 1;
                                if depth == 0 {
                                    break;
                                }
                            }
                            _ => {}
                        }
                        j += 1;
                    }
                    i = j + 1;
                }
                _ => i = s.len(),
            }
        } else {
            out.push(s[i]);
            i += 1;
        }
    }
    out
}

/// Whether `cell` holds a numeric literal (a digit not inside an identifier).
fn has_number(cell: &[u8]) -> bool {
    cell.iter()
        .enumerate()
        .any(|(k, c)| c.is_ascii_digit() && (k == 0 || !(cell[k - 1].is_ascii_alphanumeric() || cell[k - 1] == b'_')))
}

/// The `const`/`static` array tables of `src` (comments, strings and test code already
/// blanked): (name, top-level rows, rows with a number).
fn tables(src: &[u8]) -> Vec<(String, usize, usize)> {
    let text = String::from_utf8_lossy(src);
    let mut out = Vec::new();
    for kw in ["const ", "static "] {
        let mut from = 0;
        while let Some(at) = text[from..].find(kw) {
            let start = from + at;
            from = start + kw.len();
            if start > 0 && (src[start - 1].is_ascii_alphanumeric() || matches!(src[start - 1], b'_' | b'*')) {
                continue;
            }
            let rest = &text[from..];
            let name: String = rest.chars().take_while(|c| c.is_alphanumeric() || *c == '_').collect();
            // The `=` of the item: the first outside brackets, unless a `;` ends the item first.
            let mut depth = 0i32;
            let Some(eq) = rest.char_indices().find_map(|(k, c)| {
                match c {
                    '[' | '(' | '<' => depth += 1,
                    ']' | ')' | '>' => depth -= 1,
                    '=' | ';' if depth == 0 => return Some((k, c)),
                    _ => {}
                }
                None
            }) else {
                continue;
            };
            // Only items whose initializer opens with an array (`= [` or `= &[`).
            let (eq, c) = eq;
            if c == ';' || name.is_empty() || name == "fn" {
                continue;
            }
            let init = rest[eq + 1..].trim_start();
            let init = init.strip_prefix('&').unwrap_or(init).trim_start();
            if !init.starts_with('[') {
                continue;
            }
            let open = from + eq + 1 + (rest[eq + 1..].len() - init.len());
            let (mut depth, mut rows, mut numeric, mut cell_start) = (0usize, 0, 0, open + 1);
            let mut j = open;
            while j < src.len() {
                match src[j] {
                    b'(' | b'[' | b'{' => depth += 1,
                    b')' | b']' | b'}' => {
                        depth -= 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    b',' if depth == 1 => {
                        rows += 1;
                        numeric += has_number(&src[cell_start..j]) as usize;
                        cell_start = j + 1;
                    }
                    _ => {}
                }
                j += 1;
            }
            let last = &src[cell_start..j.min(src.len())];
            if last.iter().any(|c| !c.is_ascii_whitespace()) {
                rows += 1;
                numeric += has_number(last) as usize;
            }
            out.push((name, rows, numeric));
        }
    }
    out
}

fn numeric_tables(src: &str) -> Vec<(String, usize)> {
    tables(&strip_cfg_test(&blank_comments_and_strings(src)))
        .into_iter()
        .filter(|(_, _, n)| *n > MAX_ROWS)
        .map(|(name, _, n)| (name, n))
        .collect()
}

#[test]
fn no_numeric_table_over_twenty_rows_in_library_source() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf();
    let mut files = Vec::new();
    for d in source_dirs(&root) {
        rust_files(&d, &mut files);
    }
    assert!(files.len() > 50, "only {} source files found under {}", files.len(), root.display());
    let mut found = Vec::new();
    for f in &files {
        let src = std::fs::read_to_string(f).expect("source file reads");
        for (name, rows) in numeric_tables(&src) {
            found.push(format!("{}: `{name}` has {rows} numeric rows", f.strip_prefix(&root).unwrap_or(f).display()));
        }
    }
    assert!(
        found.is_empty(),
        "measured-result tables in library source (more than {MAX_ROWS} numeric rows; move them to a data file \
         under studies/results/ written by the program that computes them):\n{}",
        found.join("\n")
    );
}

/// The scanner on known sources: a 21-row table fails, 20 rows pass, rows of names only and
/// tables in `#[cfg(test)]` code do not count, brackets in strings and comments are ignored.
#[test]
fn the_scanner_counts_what_it_should() {
    let table = |n: usize, row: &str| format!("pub const T: &[(&str, f64)] = &[\n{}];\n", row.repeat(n));
    assert_eq!(numeric_tables(&table(21, "    (\"a(\", 0.5), // ]\n")), vec![("T".to_string(), 21)]);
    assert!(numeric_tables(&table(20, "    (\"a\", 0.5),\n")).is_empty());
    assert!(numeric_tables(&table(30, "    (\"x1\", NAN),\n")).is_empty());
    let hidden = format!("#[cfg(test)]\nmod tests {{\n{}}}\n", table(30, "    (\"a\", 1.0),\n"));
    assert!(numeric_tables(&hidden).is_empty());
    let after = format!("#[cfg(test)]\nmod tests;\n{}", table(25, "    (\"a\", 1.0),\n"));
    assert_eq!(numeric_tables(&after), vec![("T".to_string(), 25)]);
    let flat = format!("static S: [f64; 22] = [{}];\n", "1.0, ".repeat(22));
    assert_eq!(numeric_tables(&flat), vec![("S".to_string(), 22)]);
}
