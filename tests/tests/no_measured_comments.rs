//! No measured results in code comments: a comment line (`//`, `///`, `//!`, `/* */` in Rust,
//! `#` in Python) that carries the numbers of a run fails here with its file and line.
//! Comments say what the code does and why; a run's values are printed by the test that
//! measures them or kept in `docs/`, generated or checked by code that runs.
//!
//! The patterns are narrow on purpose (no false positives on the cleaned tree): `measured`
//! followed by a number, a note opening with `Measured` (or holding `measured:`) with a
//! decimal number, `N x faster/slower/fewer/more/...`, `N % fewer/less/...`,
//! `N vs M` with a decimal number on either side, `N s wall/CPU/in the test profile` and
//! `N instructions`. Numbers that define the code (constants, tolerances, parameters,
//! targets, known answers) match none of them.
//!
//! Skipped: `host/lab/` (research programs, which print what they measure).

use std::path::{Path, PathBuf};

/// Research and profiling programs: they print their measurements, and their notes may
/// quote them.
const RESEARCH: &[&str] = &["host/lab"];

/// Every `.rs` and `.py` file under `dir`, except build output, hidden folders and the
/// skipped paths.
fn source_files(root: &Path, dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("folder is listed") {
        let p = entry.expect("folder entry").path();
        let rel = p.strip_prefix(root).unwrap_or(&p).to_string_lossy().replace('\\', "/");
        let name = p.file_name().and_then(|n| n.to_str()).unwrap_or_default();
        if name.starts_with('.') || name == "target" || RESEARCH.contains(&rel.as_str()) {
            continue;
        }
        if p.is_dir() {
            source_files(root, &p, out);
        } else if name.ends_with(".rs") || name.ends_with(".py") {
            out.push(p);
        }
    }
}

/// The comments of Rust source `src`: (1-based line, text of the comment on that line).
/// String, raw-string and char literals are skipped, so `"// x"` is not a comment.
fn rust_comments(src: &str) -> Vec<(usize, String)> {
    let c: Vec<char> = src.chars().collect();
    let (mut out, mut i, mut line) = (Vec::new(), 0, 1);
    let mut cur = String::new();
    while i < c.len() {
        match c[i] {
            '\n' => {
                line += 1;
                i += 1;
            }
            '/' if c.get(i + 1) == Some(&'/') => {
                let start = i;
                while i < c.len() && c[i] != '\n' {
                    i += 1;
                }
                out.push((line, c[start..i].iter().collect()));
            }
            '/' if c.get(i + 1) == Some(&'*') => {
                let mut depth = 0usize;
                cur.clear();
                while i < c.len() {
                    if c[i] == '/' && c.get(i + 1) == Some(&'*') {
                        depth += 1;
                        cur.push_str("/*");
                        i += 2;
                    } else if c[i] == '*' && c.get(i + 1) == Some(&'/') {
                        depth -= 1;
                        cur.push_str("*/");
                        i += 2;
                        if depth == 0 {
                            break;
                        }
                    } else if c[i] == '\n' {
                        out.push((line, std::mem::take(&mut cur)));
                        line += 1;
                        i += 1;
                    } else {
                        cur.push(c[i]);
                        i += 1;
                    }
                }
                out.push((line, std::mem::take(&mut cur)));
            }
            // Raw strings: r"..", r#".."#, br"..", cr"..".
            'r' if (i == 0 || !(c[i - 1].is_alphanumeric() || c[i - 1] == '_') || matches!(c[i - 1], 'b' | 'c'))
                && matches!(c.get(i + 1), Some('"') | Some('#')) =>
            {
                let mut j = i + 1;
                let mut hashes = 0;
                while c.get(j) == Some(&'#') {
                    hashes += 1;
                    j += 1;
                }
                if c.get(j) != Some(&'"') {
                    i += 1;
                    continue;
                }
                j += 1;
                while j < c.len() {
                    if c[j] == '\n' {
                        line += 1;
                    }
                    if c[j] == '"' && (1..=hashes).all(|k| c.get(j + k) == Some(&'#')) {
                        j += 1 + hashes;
                        break;
                    }
                    j += 1;
                }
                i = j;
            }
            '"' => {
                i += 1;
                while i < c.len() && c[i] != '"' {
                    if c[i] == '\\' {
                        i += 1;
                    }
                    if c.get(i) == Some(&'\n') {
                        line += 1;
                    }
                    i += 1;
                }
                i += 1;
            }
            // A char literal ('x', '\n', '\u{..}'); otherwise a lifetime or label.
            '\'' => {
                if c.get(i + 1) == Some(&'\\') {
                    i += 3;
                    while i < c.len() && c[i] != '\'' {
                        i += 1;
                    }
                    i += 1;
                } else if c.get(i + 2) == Some(&'\'') {
                    i += 3;
                } else {
                    i += 1;
                }
            }
            _ => i += 1,
        }
    }
    out
}

/// The `#` comments of Python source `src`: (1-based line, text). Strings (quoted and
/// triple-quoted) are skipped.
fn python_comments(src: &str) -> Vec<(usize, String)> {
    let c: Vec<char> = src.chars().collect();
    let (mut out, mut i, mut line) = (Vec::new(), 0, 1);
    while i < c.len() {
        match c[i] {
            '\n' => {
                line += 1;
                i += 1;
            }
            '#' => {
                let start = i;
                while i < c.len() && c[i] != '\n' {
                    i += 1;
                }
                out.push((line, c[start..i].iter().collect()));
            }
            q @ ('"' | '\'') => {
                let triple = c.get(i + 1) == Some(&q) && c.get(i + 2) == Some(&q);
                i += if triple { 3 } else { 1 };
                while i < c.len() {
                    if c[i] == '\\' {
                        i += 2;
                        continue;
                    }
                    if c[i] == '\n' {
                        if !triple {
                            break;
                        }
                        line += 1;
                    }
                    if c[i] == q && (!triple || (c.get(i + 1) == Some(&q) && c.get(i + 2) == Some(&q))) {
                        i += if triple { 3 } else { 1 };
                        break;
                    }
                    i += 1;
                }
            }
            _ => i += 1,
        }
    }
    out
}

/// The end of the number starting at `i` of `s` (digits with `.`, `,` thousands separators,
/// an exponent, an optional sign or `~` before, and a range `N-M` or `N..M` after), if one
/// starts there and is not the tail of an identifier (`rho_1`, `x10`).
fn number_at(s: &[u8], i: usize) -> Option<usize> {
    if i > 0 && (s[i - 1].is_ascii_alphanumeric() || s[i - 1] == b'_') {
        return None;
    }
    let mut j = i;
    while j < s.len() && matches!(s[j], b'~' | b'+' | b'-') {
        j += 1;
    }
    if !s.get(j).is_some_and(u8::is_ascii_digit) {
        return None;
    }
    let digits = |mut j: usize| {
        while j < s.len() {
            match s[j] {
                b'0'..=b'9' => j += 1,
                b'.' | b',' if s.get(j + 1).is_some_and(u8::is_ascii_digit) => j += 1,
                b'e' | b'E'
                    if s.get(j + 1).is_some_and(u8::is_ascii_digit)
                        || (s.get(j + 1) == Some(&b'-') && s.get(j + 2).is_some_and(u8::is_ascii_digit)) =>
                {
                    j += 2
                }
                _ => break,
            }
        }
        j
    };
    j = digits(j);
    // A range: `12-25`, `1e-4..1e-3`.
    for sep in [&b"-"[..], &b".."[..]] {
        if s[j..].starts_with(sep) && s.get(j + sep.len()).is_some_and(u8::is_ascii_digit) {
            j = digits(j + sep.len());
        }
    }
    Some(j)
}

/// Whether the number `n` looks measured rather than counted: a decimal point, an exponent
/// or a thousands separator.
fn decimal(n: &[u8]) -> bool {
    n.iter().any(|c| matches!(c, b'.' | b',' | b'e' | b'E'))
}

/// `s` from `i` on after spaces.
fn skip_spaces(s: &[u8], mut i: usize) -> usize {
    while s.get(i) == Some(&b' ') {
        i += 1;
    }
    i
}

/// Whether `s[i..]` starts with one of `words` (lowercase), as a whole word.
fn word_at(s: &[u8], i: usize, words: &[&str]) -> bool {
    words.iter().any(|w| {
        s.len() >= i + w.len()
            && s[i..i + w.len()].eq_ignore_ascii_case(w.as_bytes())
            && !s.get(i + w.len()).is_some_and(|c| c.is_ascii_alphanumeric())
    })
}

/// Comparatives that state a measured ratio after `N x` or `N %`.
const COMPARATIVES: &[&str] =
    &["faster", "slower", "fewer", "more", "less", "cheaper", "smaller", "larger", "the cpu", "the time"];

/// The rule a comment breaks, if it carries a measurement.
fn measurement(comment: &str) -> Option<&'static str> {
    let s = comment.as_bytes();
    // `measured` followed by a number (`Measured: N`, `measured N`, `measured at most N`,
    // `measured: <= N`).
    let lower = comment.to_ascii_lowercase();
    let mut from = 0;
    while let Some(at) = lower[from..].find("measured") {
        let mut j = from + at + "measured".len();
        from = j;
        while s.get(j).is_some_and(|c| matches!(c, b' ' | b':' | b'(' | b'<' | b'=')) {
            j += 1;
        }
        for lead in ["at most ", "about ", "up to "] {
            if lower[j..].starts_with(lead) {
                j += lead.len();
            }
        }
        if number_at(s, j).is_some() {
            return Some("`measured` followed by a number");
        }
    }
    // A comment that opens with `Measured` or holds `measured:`, with a decimal number after it
    // (`// Measured (N runs): N.n ...`, `(measured: RBF N.n)`).
    let body = comment.trim_start_matches(['/', '!', '#', '*', ' ']);
    let opens = body.starts_with("Measured");
    if let Some(at) = if opens { Some(comment.len() - body.len()) } else { lower.find("measured:") } {
        let rest = &s[at..];
        if (0..rest.len()).any(|k| number_at(rest, k).is_some_and(|e| decimal(&rest[k..e]))) {
            return Some("a `Measured` note with decimal numbers");
        }
    }
    for i in 0..s.len() {
        let Some(end) = number_at(s, i) else { continue };
        let num = &s[i..end];
        let j = skip_spaces(s, end);
        // `Nx fewer`, `N x faster`, `Nx the CPU`.
        if matches!(s.get(j), Some(b'x')) || s[j..].starts_with("×".as_bytes()) {
            let k = skip_spaces(s, j + if s[j] == b'x' { 1 } else { "×".len() });
            if k > j + 1 && word_at(s, k, COMPARATIVES) {
                return Some("a ratio `N x faster/slower/fewer/...`");
            }
        }
        // `N% fewer instructions`, `N-M % less CPU`.
        if s.get(j) == Some(&b'%') && word_at(s, skip_spaces(s, j + 1), COMPARATIVES) {
            return Some("a ratio `N % fewer/less/...`");
        }
        // `N vs M` with a decimal number on either side, or a time after M (`N.n vs M`,
        // `N vs M s`); a short unit may follow N (`N rad vs M.m`).
        let unit = s[j..].iter().take_while(|c| c.is_ascii_alphabetic()).count();
        let vs = if word_at(s, j, &["vs"]) { Some(j) } else { Some(skip_spaces(s, j + unit)).filter(|_| unit <= 3) };
        if let Some(vs) = vs.filter(|&v| word_at(s, v, &["vs"])) {
            let mut k = skip_spaces(s, vs + 2);
            if s.get(k) == Some(&b'.') {
                k = skip_spaces(s, k + 1);
            }
            if let Some(e2) = number_at(s, k)
                && (decimal(num) || decimal(&s[k..e2]) || word_at(s, skip_spaces(s, e2), &["s", "ms", "min"]))
            {
                return Some("a comparison `N vs M` of measured values");
            }
        }
        // `N s wall`, `N s CPU`, `~N-M s in the test profile`.
        if word_at(s, j, &["s", "ms", "min", "us", "µs"]) {
            let k = skip_spaces(s, j + s[j..].iter().take_while(|c| !c.is_ascii_whitespace()).count());
            if word_at(s, k, &["wall", "cpu", "user", "in the test profile", "in release", "of cpu"]) {
                return Some("a timing `N s wall/CPU/in the test profile`");
            }
        }
        // `N instructions a step`, `N Ir`.
        if word_at(s, j, &["instructions", "ir"]) {
            return Some("an instruction count");
        }
    }
    None
}

/// Every comment line of `path` that carries a measurement: (line, rule, text).
fn offending(path: &Path) -> Vec<(usize, &'static str, String)> {
    let src = std::fs::read_to_string(path).expect("source file reads");
    let comments =
        if path.extension().is_some_and(|e| e == "py") { python_comments(&src) } else { rust_comments(&src) };
    comments.into_iter().filter_map(|(line, text)| measurement(&text).map(|rule| (line, rule, text))).collect()
}

#[test]
fn no_comment_carries_a_measurement() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf();
    let mut files = Vec::new();
    source_files(&root, &root, &mut files);
    files.sort();
    assert!(files.len() > 100, "only {} source files found under {}", files.len(), root.display());
    let mut found = Vec::new();
    for f in &files {
        for (line, rule, text) in offending(f) {
            found.push(format!("{}:{line}: {rule}: {}", f.strip_prefix(&root).unwrap_or(f).display(), text.trim()));
        }
    }
    assert!(
        found.is_empty(),
        "comments carrying measurements (say what and why in words; print the value from the test that \
         measures it, or keep it in docs/ generated by code that runs):\n{}",
        found.join("\n")
    );
}

/// The pattern on known lines: measurements of a run match, numbers that define the code do
/// not.
#[test]
fn the_pattern_tells_measurements_from_definitions() {
    for line in [
        "// Measured: 3.1e-4 (slow) and 5.0e-4 (fast) at training",
        "/// tolerance 1e-7 rad (measured 4.5e-16)",
        "// every period must do better (measured: at most 0.17).",
        "//! the same loop (130 vs 140 s wall)",
        "// gain: ordinary 0.831 vs 0.787",
        "/// 1.24x fewer instructions than RK4",
        "/// at 0.49x the CPU",
        "// indexed: 3% fewer instructions than the zips",
        "/// 25-30 % less CPU per product",
        "// ~12-25 s in the test profile",
        "/// (1.6 s CPU per circle)",
        "/// 220 instructions a step",
        "# measured: <= 1.6e-4",
        "//! exprb54-filtered at 1e-10: 6.7e-7 rad vs 1.0e-6",
        "/// (173,571 Ir a period)",
        "// Measured (30,000 periods per run): powers 0.44 / 0.45",
        "// Rosenstein value (measured: RBF 0.47 / JS 0.0086)",
    ] {
        assert!(measurement(line).is_some(), "not caught: {line}");
    }
    for line in [
        "/// A = 0.95 x rotation by 0.3",
        "/// Measured steps (a multiple of `renorm_every * blocks`)",
        "/// error is measured on: a fifth and a half of the 2-torus amplitude at 30.8 ms.",
        "/// The held-out data the rows were measured against (scale 1, 4,000 s of Benettin).",
        "/// the measured angle the controller saw",
        "/// auto's held-out NMTE within 1.2x of the grid's smallest",
        "// at most 0.6x exprb-lean's steps for at most 4x its error",
        "// refine 1 vs 4",
        "/// ~16 times smaller at the next halving",
        "// tolerance 1e-7 rad; 100 s in periods of 30.8 ms",
        "/// Largest `--timeout` accepted, seconds.",
        "/// 25 % and 75 % quantiles",
        "// rho_1 vs rho_2",
    ] {
        assert_eq!(measurement(line), None, "false positive: {line}");
    }
}

/// Comments are found where they are, and only there: not in strings, raw strings or char
/// literals; block comments line by line; Python `#` outside strings.
#[test]
fn the_scanners_find_comments_only() {
    let rs = "let a = \"// measured 1.0\"; // one\nlet b = r#\"// x \"# ; let c = '/'; /* two\nthree */ // four\nfn f<'a>() { let q = ('\\'', '\"'); } // five\n";
    let got: Vec<(usize, String)> = rust_comments(rs);
    assert_eq!(
        got,
        vec![
            (1, "// one".to_string()),
            (2, "/* two".to_string()),
            (3, "three */".to_string()),
            (3, "// four".to_string()),
            (4, "// five".to_string()),
        ]
    );
    let py = "x = '# not'  # one\ns = \"\"\"\n# not either\n\"\"\"  # two\n";
    assert_eq!(python_comments(py), vec![(1, "# one".to_string()), (4, "# two".to_string())]);
}
