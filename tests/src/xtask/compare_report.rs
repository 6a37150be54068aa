//! `cargo xtask compare-report BASE NEW`: do two report directories written by
//! `ssmctl reproduce [--quick] --out DIR` hold the same results?
//!
//! - `summary.json` and the scenes' metadata `scenes/*.json` are compared as JSON: the same
//!   keys, the same array lengths, strings, booleans and nulls equal, every number equal to
//!   1e-12 relative (`|a - b| <= 1e-12 * max(|a|, |b|)`). The values of the wall-clock
//!   timing keys in [`TIMING_KEYS`] are skipped (at any depth; the key itself must still be
//!   on both sides). The timing records in [`TIMING_RECORDS`] (the top-level `timings`
//!   object of `summary.json`) are skipped whole, even when only one side has them: a
//!   report that predates them compares equal. A string that is a path inside the report directory (e.g.
//!   `BASE/fig/stability_chart.png`) equals its counterpart when both are the same after
//!   stripping the `BASE` / `NEW` prefix.
//! - `index.html` holds timings: it is compared as text with every number masked (see
//!   [`mask_numbers`]), the report directories' absolute paths replaced and the timing
//!   section dropped (the text between [`TIMINGS_BEGIN`] and [`TIMINGS_END`]).
//! - Every other file (PNG figures, `.bin` model blobs, scene CSVs) must be byte-identical,
//!   except the timing figures in [`TIMING_FILES`], skipped on either side.
//! - A file present in only one tree is a mismatch.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use serde_json::Value;

/// Keys whose values are wall-clock timings (or ratios of timings): their values differ
/// from run to run and are not compared, wherever the key appears in a JSON file.
pub const TIMING_KEYS: &[&str] = &[
    "periods_per_s",
    "round_trips_per_s",
    "ratio_vs_baseline",
    "seconds",
    "wall_seconds",
    "fit_ms",
    "compute_seconds",
    "draw_seconds",
    "fit_seconds",
    "step_us",
    "fit_s",
    "fit_ratio",
    "step_ratio",
];

/// Top-level keys of `summary.json` that hold only run records (wall times per section, the
/// thread-pool size, the peak memory, what was reused from a cache): skipped whole, also
/// when only one side has them (reports written before they existed lack them).
pub const TIMING_RECORDS: &[&str] = &["timings"];

/// Figures of wall times (relative to the report folder): skipped, on either side.
pub const TIMING_FILES: &[&str] = &["fig/timings.png"];

/// The markers `ssmctl reproduce` puts around the timing section of `index.html` and its
/// contents-list entry (`ssmctl::report::TIMINGS_BEGIN` / `TIMINGS_END`).
pub const TIMINGS_BEGIN: &str = "<!-- timings -->";
pub const TIMINGS_END: &str = "<!-- /timings -->";

/// Relative tolerance of the numbers in the JSON files.
pub const REL_TOL: f64 = 1e-12;

/// What [`compare`] found.
#[derive(Debug, Default)]
pub struct Outcome {
    /// Numbers compared in the JSON files (timing values excluded).
    pub numbers: usize,
    /// Files compared byte for byte and found identical.
    pub identical_files: usize,
    /// One line per mismatch: the file, and for JSON the path of the value inside it.
    pub mismatches: Vec<String>,
}

impl Outcome {
    /// `N numbers compared, M files byte-identical, K mismatches`.
    pub fn summary(&self) -> String {
        format!(
            "{} numbers compared, {} files byte-identical, {} mismatches",
            self.numbers,
            self.identical_files,
            self.mismatches.len()
        )
    }
}

/// Compares the report directories `base` and `new`. `Err` only when they cannot be read
/// (or `base` is not a report directory); differences are in [`Outcome::mismatches`].
pub fn compare(base: &Path, new: &Path) -> Result<Outcome, String> {
    for dir in [base, new] {
        if !dir.is_dir() {
            return Err(format!("{}: not a directory", dir.display()));
        }
    }
    if !base.join("summary.json").is_file() {
        return Err(format!("{}: no summary.json, not a report directory", base.display()));
    }
    let base_files = files(base)?;
    let new_files = files(new)?;
    let mut c = Comparer { base_prefixes: prefixes(base), new_prefixes: prefixes(new), out: Outcome::default() };
    for rel in base_files.union(&new_files) {
        let name = rel.to_string_lossy().replace('\\', "/");
        if TIMING_FILES.contains(&name.as_str()) {
            continue;
        }
        match (base_files.contains(rel), new_files.contains(rel)) {
            (true, false) => c.mismatch(format!("{name}: only in BASE ({})", base.display())),
            (false, true) => c.mismatch(format!("{name}: only in NEW ({})", new.display())),
            _ => {
                let a = read(&base.join(rel))?;
                let b = read(&new.join(rel))?;
                match kind(rel) {
                    Kind::Json => c.json_file(&name, &a, &b),
                    Kind::Html => c.html_file(&name, &a, &b),
                    Kind::Bytes => c.bytes_file(&name, &a, &b),
                }
            }
        }
    }
    Ok(c.out)
}

/// `cargo xtask compare-report BASE NEW`: prints each mismatch and the summary line; `Err`
/// on any mismatch.
pub fn run(args: &[String]) -> Result<(), String> {
    let [base, new] = args else {
        return Err("usage: cargo xtask compare-report BASE NEW (two report directories of `ssmctl reproduce`)".into());
    };
    let o = compare(Path::new(base), Path::new(new))?;
    for m in &o.mismatches {
        println!("mismatch: {m}");
    }
    println!("compare-report: {}", o.summary());
    if o.mismatches.is_empty() {
        Ok(())
    } else {
        Err(format!("compare-report: {} mismatches between {base} and {new}", o.mismatches.len()))
    }
}

enum Kind {
    Json,
    Html,
    Bytes,
}

/// `summary.json` and `scenes/*.json` are JSON, `index.html` is masked text, the rest bytes.
fn kind(rel: &Path) -> Kind {
    let parts: Vec<_> = rel.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    match parts.as_slice() {
        [f] if f == "summary.json" => Kind::Json,
        [d, f] if d == "scenes" && f.ends_with(".json") => Kind::Json,
        [f] if f == "index.html" => Kind::Html,
        _ => Kind::Bytes,
    }
}

fn read(path: &Path) -> Result<Vec<u8>, String> {
    std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Every file under `root`, relative to it.
fn files(root: &Path) -> Result<BTreeSet<PathBuf>, String> {
    let mut out = BTreeSet::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(rel) = stack.pop() {
        let dir = root.join(&rel);
        let entries = std::fs::read_dir(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        for entry in entries {
            let entry = entry.map_err(|e| format!("{}: {e}", dir.display()))?;
            let path = rel.join(entry.file_name());
            // Follows symbolic links, like reading the file does.
            if root.join(&path).is_dir() {
                stack.push(path);
            } else {
                out.insert(path);
            }
        }
    }
    Ok(out)
}

/// The spellings of a report directory a path inside it may start with: as given and
/// absolute (canonical), without a trailing `/`.
fn prefixes(dir: &Path) -> Vec<String> {
    let mut p = vec![dir.to_string_lossy().trim_end_matches('/').to_string()];
    if let Ok(abs) = dir.canonicalize() {
        p.push(abs.to_string_lossy().trim_end_matches('/').to_string());
    }
    p.retain(|s| !s.is_empty());
    p.dedup();
    p
}

/// `s` without the directory prefix `dir` (`dir/x/y` gives `/x/y`), if it has it.
fn strip_dir<'a>(s: &'a str, dir: &str) -> Option<&'a str> {
    s.strip_prefix(dir).filter(|rest| rest.is_empty() || rest.starts_with('/'))
}

/// `key` alone if it is an identifier, else quoted in brackets.
fn json_key(key: &str) -> String {
    if !key.is_empty() && key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        format!(".{key}")
    } else {
        format!("[{}]", Value::String(key.into()))
    }
}

fn type_name(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "bool",
        Value::Number(_) => "number",
        Value::String(_) => "string",
        Value::Array(_) => "array",
        Value::Object(_) => "object",
    }
}

/// Every number in `text` replaced by `#`: digits with an optional fraction, exponent and
/// thousands groups (`1,234`), and a leading minus sign when it does not follow a word or
/// number character (so `a-1` keeps its hyphen). `12.5 ms` and `3.1e-7 ms` both give `# ms`.
pub fn mask_numbers(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let digit = |i: usize| c.get(i).is_some_and(char::is_ascii_digit);
    let digits_from = |mut i: usize| {
        while digit(i) {
            i += 1;
        }
        i
    };
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < c.len() {
        let after_word = i > 0 && (c[i - 1].is_alphanumeric() || c[i - 1] == '.' || c[i - 1] == '_');
        let start = if digit(i) {
            Some(i)
        } else if c[i] == '-' && digit(i + 1) && !after_word {
            Some(i + 1)
        } else {
            None
        };
        let Some(start) = start else {
            out.push(c[i]);
            i += 1;
            continue;
        };
        let mut j = digits_from(start);
        // Thousands groups: `,` and exactly three digits.
        while c.get(j) == Some(&',') && digits_from(j + 1) == j + 4 {
            j += 4;
        }
        if c.get(j) == Some(&'.') && digit(j + 1) {
            j = digits_from(j + 1);
        }
        if matches!(c.get(j), Some('e' | 'E')) {
            let k = if matches!(c.get(j + 1), Some('+' | '-')) { j + 2 } else { j + 1 };
            if digit(k) {
                j = digits_from(k);
            }
        }
        out.push('#');
        i = j;
    }
    out
}

/// `text` without every span from [`TIMINGS_BEGIN`] to the next [`TIMINGS_END`] (markers
/// included, and a line break right after the end marker, so a span on lines of its own
/// leaves no empty line; an unclosed span runs to the end).
pub fn drop_timings(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find(TIMINGS_BEGIN) {
        out.push_str(&rest[..i]);
        rest = &rest[i + TIMINGS_BEGIN.len()..];
        rest = rest.find(TIMINGS_END).map_or("", |j| &rest[j + TIMINGS_END.len()..]);
        rest = rest.strip_prefix('\n').unwrap_or(rest);
    }
    out.push_str(rest);
    out
}

/// Shortens a line of text for a message.
fn clip(s: &str) -> String {
    const MAX: usize = 120;
    if s.chars().count() <= MAX { s.to_string() } else { format!("{}...", s.chars().take(MAX).collect::<String>()) }
}

struct Comparer {
    base_prefixes: Vec<String>,
    new_prefixes: Vec<String>,
    out: Outcome,
}

impl Comparer {
    fn mismatch(&mut self, m: String) {
        self.out.mismatches.push(m);
    }

    fn bytes_file(&mut self, name: &str, a: &[u8], b: &[u8]) {
        if a == b {
            self.out.identical_files += 1;
        } else {
            let at = a.iter().zip(b).position(|(x, y)| x != y).unwrap_or(a.len().min(b.len()));
            self.mismatch(format!(
                "{name}: files differ ({} vs {} bytes, first difference at byte {at})",
                a.len(),
                b.len()
            ));
        }
    }

    fn json_file(&mut self, name: &str, a: &[u8], b: &[u8]) {
        let parse = |bytes: &[u8], side: &str| {
            serde_json::from_slice::<Value>(bytes).map_err(|e| format!("{name}: not JSON in {side}: {e}"))
        };
        match (parse(a, "BASE"), parse(b, "NEW")) {
            (Ok(mut x), Ok(mut y)) => {
                if name == "summary.json" {
                    for v in [&mut x, &mut y] {
                        if let Value::Object(m) = v {
                            TIMING_RECORDS.iter().for_each(|k| drop(m.remove(*k)));
                        }
                    }
                }
                self.json(name, "$", &x, &y)
            }
            (Err(e), _) | (_, Err(e)) => self.mismatch(e),
        }
    }

    /// Paths inside the report directories are equal when they are after their prefixes.
    fn same_string(&self, a: &str, b: &str) -> bool {
        a == b
            || self
                .base_prefixes
                .iter()
                .filter_map(|p| strip_dir(a, p))
                .any(|ra| self.new_prefixes.iter().filter_map(|p| strip_dir(b, p)).any(|rb| ra == rb))
    }

    fn json(&mut self, name: &str, path: &str, a: &Value, b: &Value) {
        match (a, b) {
            (Value::Object(x), Value::Object(y)) => {
                for (k, va) in x {
                    let p = format!("{path}{}", json_key(k));
                    match y.get(k) {
                        None => self.mismatch(format!("{name} {p}: key only in BASE")),
                        Some(_) if TIMING_KEYS.contains(&k.as_str()) => {}
                        Some(vb) => self.json(name, &p, va, vb),
                    }
                }
                for k in y.keys().filter(|k| !x.contains_key(*k)) {
                    self.mismatch(format!("{name} {path}{}: key only in NEW", json_key(k)));
                }
            }
            (Value::Array(x), Value::Array(y)) => {
                if x.len() != y.len() {
                    self.mismatch(format!("{name} {path}: array lengths {} vs {}", x.len(), y.len()));
                } else {
                    for (i, (va, vb)) in x.iter().zip(y).enumerate() {
                        self.json(name, &format!("{path}[{i}]"), va, vb);
                    }
                }
            }
            (Value::Number(x), Value::Number(y)) => {
                self.out.numbers += 1;
                let (Some(fx), Some(fy)) = (x.as_f64(), y.as_f64()) else {
                    return self.mismatch(format!("{name} {path}: {x} vs {y} (not comparable as f64)"));
                };
                let diff = (fx - fy).abs();
                let scale = fx.abs().max(fy.abs());
                if diff > REL_TOL * scale {
                    self.mismatch(format!("{name} {path}: {x} vs {y} (relative difference {:.3e})", diff / scale));
                }
            }
            (Value::String(x), Value::String(y)) => {
                if !self.same_string(x, y) {
                    self.mismatch(format!("{name} {path}: {a} vs {b}"));
                }
            }
            (Value::Bool(_), Value::Bool(_)) | (Value::Null, Value::Null) => {
                if a != b {
                    self.mismatch(format!("{name} {path}: {a} vs {b}"));
                }
            }
            _ => self.mismatch(format!(
                "{name} {path}: {} vs {} ({} vs {})",
                type_name(a),
                type_name(b),
                clip(&a.to_string()),
                clip(&b.to_string())
            )),
        }
    }

    /// The same text once the absolute report directories and every number are masked.
    fn html_file(&mut self, name: &str, a: &[u8], b: &[u8]) {
        let normalize = |bytes: &[u8], prefixes: &[String]| {
            let mut text = String::from_utf8_lossy(bytes).into_owned();
            let mut abs: Vec<&String> = prefixes.iter().filter(|p| p.starts_with('/')).collect();
            abs.sort_by_key(|p| std::cmp::Reverse(p.len()));
            for p in abs {
                text = text.replace(&format!("{p}/"), "<REPORT>/");
            }
            mask_numbers(&drop_timings(&text))
        };
        let x = normalize(a, &self.base_prefixes);
        let y = normalize(b, &self.new_prefixes);
        if x == y {
            return;
        }
        let (mut la, mut lb) = (x.lines(), y.lines());
        let mut line = 1;
        loop {
            match (la.next(), lb.next()) {
                (Some(p), Some(q)) if p == q => line += 1,
                (p, q) => {
                    // Where in the line: a window from a little before the first difference.
                    let col = match (p, q) {
                        (Some(p), Some(q)) => p.chars().zip(q.chars()).take_while(|(x, y)| x == y).count(),
                        _ => 0,
                    };
                    let from = col.saturating_sub(40);
                    let show = |l: Option<&str>| {
                        l.map_or("<end of file>".to_string(), |l| {
                            let w: String = l.chars().skip(from).collect();
                            format!("`{}{}`", if from > 0 { "..." } else { "" }, clip(&w))
                        })
                    };
                    return self.mismatch(format!(
                        "{name}: text differs with numbers masked, first at line {line}, column {}: {} vs {}",
                        col + 1,
                        show(p),
                        show(q)
                    ));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    /// A fresh empty directory for one test.
    fn temp_dir(tag: &str) -> PathBuf {
        static N: AtomicUsize = AtomicUsize::new(0);
        let n = N.fetch_add(1, Ordering::Relaxed);
        let d = std::env::temp_dir().join(format!("xtask-compare-{}-{tag}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn write(path: &Path, bytes: &[u8]) {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, bytes).unwrap();
    }

    fn summary(dir: &Path) -> Value {
        serde_json::json!({
            "bench_simulate": [
                {"method": "rk4", "max_err_rad": 1.2456892620851812e-4, "periods_per_s": 85622.4, "ratio_vs_baseline": 1.0},
                {"method": "rodas4", "max_err_rad": 4.456470095726139e-9, "periods_per_s": 15672.3, "ratio_vs_baseline": 0.183},
            ],
            "chaos": {"measured: flag": {"exponent": 8.93848637148233e-6, "spectrum": [8.9e-6, -0.384, -0.429], "ok": true, "note": null}},
            "stability_chart": {"png": format!("{}/fig/stability_chart.png", dir.display()), "wall_seconds": 1.5, "count": 42},
        })
    }

    /// A small report in `dir`: 8 numbers compared in its JSON files, 3 byte-compared files.
    fn report(dir: &Path) {
        write(&dir.join("summary.json"), serde_json::to_string_pretty(&summary(dir)).unwrap().as_bytes());
        write(
            &dir.join("scenes/a.json"),
            br#"{"scene": "a", "periods_simulated": 300, "wall_seconds": 0.0109, "csv": "a.csv"}"#,
        );
        write(&dir.join("scenes/a.csv"), b"t,theta\n0,0.1\n");
        write(&dir.join("fig/x.png"), b"\x89PNG\r\n\x1a\n0123");
        write(&dir.join("model.bin"), &[1, 2, 3, 4]);
        write(
            &dir.join("index.html"),
            b"<p>furuta-dt25: 300 periods, max 0.0279 rad, 27362 periods/s, fit 12.5 ms</p>\n",
        );
    }

    fn pair(tag: &str) -> (PathBuf, PathBuf) {
        let (a, b) = (temp_dir(&format!("{tag}-base")), temp_dir(&format!("{tag}-new")));
        report(&a);
        report(&b);
        (a, b)
    }

    fn edit_summary(dir: &Path, f: impl FnOnce(&mut Value)) {
        let mut v = summary(dir);
        f(&mut v);
        write(&dir.join("summary.json"), serde_json::to_string(&v).unwrap().as_bytes());
    }

    fn cleanup(dirs: &[&Path]) {
        for d in dirs {
            std::fs::remove_dir_all(d).unwrap();
        }
    }

    #[test]
    fn equal_trees_pass() {
        let (a, b) = pair("equal");
        let o = compare(&a, &b).unwrap();
        assert!(o.mismatches.is_empty(), "{:?}", o.mismatches);
        assert_eq!(o.summary(), "8 numbers compared, 3 files byte-identical, 0 mismatches");
        cleanup(&[&a, &b]);
    }

    #[test]
    fn number_off_by_1e9_relative_fails_with_its_path_and_1e13_passes() {
        let (a, b) = pair("number");
        edit_summary(&b, |v| v["chaos"]["measured: flag"]["spectrum"][1] = (-0.384 * (1.0 + 1e-13)).into());
        let o = compare(&a, &b).unwrap();
        assert!(o.mismatches.is_empty(), "{:?}", o.mismatches);
        edit_summary(&b, |v| v["chaos"]["measured: flag"]["spectrum"][1] = (-0.384 * (1.0 + 1e-9)).into());
        let o = compare(&a, &b).unwrap();
        assert_eq!(o.mismatches.len(), 1, "{:?}", o.mismatches);
        assert!(
            o.mismatches[0].starts_with(r#"summary.json $.chaos["measured: flag"].spectrum[1]: -0.384 vs"#),
            "{}",
            o.mismatches[0]
        );
        assert!(o.mismatches[0].contains("relative difference 1.000e-9"), "{}", o.mismatches[0]);
        assert!(o.summary().ends_with(", 1 mismatches"));
        cleanup(&[&a, &b]);
    }

    #[test]
    fn timing_keys_changed_pass() {
        let (a, b) = pair("timing");
        edit_summary(&b, |v| {
            v["bench_simulate"][0]["periods_per_s"] = 1.0.into();
            v["bench_simulate"][1]["ratio_vs_baseline"] = 7.0.into();
            v["stability_chart"]["wall_seconds"] = 99.0.into();
        });
        write(
            &b.join("scenes/a.json"),
            br#"{"scene": "a", "periods_simulated": 300, "wall_seconds": 0.5, "csv": "a.csv"}"#,
        );
        write(
            &b.join("index.html"),
            b"<p>furuta-dt25: 300 periods, max 0.0279 rad, 9,361 periods/s, fit 1.1e-3 ms</p>\n",
        );
        let o = compare(&a, &b).unwrap();
        assert!(o.mismatches.is_empty(), "{:?}", o.mismatches);
        assert_eq!(o.numbers, 8);
        cleanup(&[&a, &b]);
    }

    /// A report with the timing records (summary key, figure, marked page section and
    /// contents entry) against one without, and two with different timings: equal.
    #[test]
    fn timing_records_are_skipped_even_when_base_lacks_them() {
        let (a, b) = pair("records");
        let timings = |total: f64| {
            serde_json::json!({"total_seconds": total, "jobs": 2, "cached": [], "peak_rss_mb": 512.0,
                               "sections": [{"name": "scenes", "seconds": total / 2.0}]})
        };
        edit_summary(&b, |v| v["timings"] = timings(40.0));
        write(&b.join("fig/timings.png"), b"\x89PNG\r\n\x1a\nbars");
        let page = |extra: &str| {
            format!(
                "<ul><li><a href=\"#a\">A</a></li><!-- timings --><li><a href=\"#timings\">Where the time goes</a></li><!-- /timings --></ul>\n\
                 <p>furuta-dt25: 300 periods, max 0.0279 rad, 27362 periods/s, fit 12.5 ms</p>\n\
                 <!-- timings -->\n<h2 id=\"timings\">Where the time goes</h2>\n<table><tr><td>{extra}</td></tr></table>\n<!-- /timings -->\n"
            )
        };
        write(&a.join("index.html"), b"<ul><li><a href=\"#a\">A</a></li></ul>\n<p>furuta-dt25: 300 periods, max 0.0279 rad, 27362 periods/s, fit 12.5 ms</p>\n");
        write(&b.join("index.html"), page("scenes").as_bytes());
        let o = compare(&a, &b).unwrap();
        assert!(o.mismatches.is_empty(), "{:?}", o.mismatches);
        assert_eq!(o.numbers, 8, "the timing record's numbers are not counted");
        // Both with timings, different ones (and different section names in the page).
        edit_summary(&a, |v| v["timings"] = timings(75.0));
        write(&a.join("fig/timings.png"), b"\x89PNG\r\n\x1a\nother bars");
        write(&a.join("index.html"), page("chart").as_bytes());
        let o = compare(&a, &b).unwrap();
        assert!(o.mismatches.is_empty(), "{:?}", o.mismatches);
        // Only the marked span is dropped: a change outside it still counts.
        write(&b.join("index.html"), page("scenes").replace("max", "min").as_bytes());
        let o = compare(&a, &b).unwrap();
        assert_eq!(o.mismatches.len(), 1, "{:?}", o.mismatches);
        // `timings` is skipped only at the top level of summary.json.
        edit_summary(&b, |v| v["chaos"]["timings"] = 1.into());
        write(&b.join("index.html"), page("scenes").as_bytes());
        let o = compare(&a, &b).unwrap();
        assert_eq!(o.mismatches.len(), 1, "{:?}", o.mismatches);
        assert!(o.mismatches[0].starts_with("summary.json $.chaos.timings: key only in NEW"), "{:?}", o.mismatches);
        cleanup(&[&a, &b]);
    }

    #[test]
    fn drop_timings_removes_marked_spans() {
        assert_eq!(drop_timings("a<!-- timings -->b<!-- /timings -->c<!-- timings -->d<!-- /timings -->e"), "ace");
        assert_eq!(drop_timings("a<!-- timings -->b"), "a");
        assert_eq!(drop_timings("a\n<!-- timings -->\nb\n<!-- /timings -->\nc\n"), "a\nc\n");
        assert_eq!(drop_timings("no markers"), "no markers");
    }

    #[test]
    fn changed_structure_fails() {
        let (a, b) = pair("structure");
        edit_summary(&b, |v| {
            v["chaos"]["measured: flag"]["ok"] = false.into();
            v["chaos"]["measured: flag"]["extra"] = 1.into();
            v["bench_simulate"][1]["method"] = "rodas5".into();
            v["stability_chart"]["count"] = "42".into();
            v["chaos"]["measured: flag"]["spectrum"].as_array_mut().unwrap().pop();
            v["stability_chart"]["png"] = format!("{}/fig/other.png", b.display()).into();
        });
        write(&b.join("scenes/a.json"), br#"{"scene": "a", "periods_simulated": 300, "csv": "a.csv"}"#);
        write(&b.join("index.html"), b"<p>furuta-dt25: 300 periods, max 0.0279 rad, 27362 periods/s</p>\n");
        let o = compare(&a, &b).unwrap();
        let expect = [
            r#"summary.json $.chaos["measured: flag"].ok: true vs false"#,
            r#"summary.json $.chaos["measured: flag"].extra: key only in NEW"#,
            r#"summary.json $.bench_simulate[1].method: "rodas4" vs "rodas5""#,
            "summary.json $.stability_chart.count: number vs string",
            r#"summary.json $.chaos["measured: flag"].spectrum: array lengths 3 vs 2"#,
            "summary.json $.stability_chart.png:",
            "scenes/a.json $.wall_seconds: key only in BASE",
            "index.html: text differs with numbers masked, first at line 1, column 49: `...a-dt#: # periods, max # rad, # periods/s, fit # ms</p>` vs `...a-dt#: # periods, max # rad, # periods/s</p>`",
        ];
        for e in expect {
            assert!(o.mismatches.iter().any(|m| m.starts_with(e)), "no `{e}` in {:#?}", o.mismatches);
        }
        assert_eq!(o.mismatches.len(), expect.len(), "{:#?}", o.mismatches);
        cleanup(&[&a, &b]);
    }

    #[test]
    fn changed_png_byte_fails_naming_the_file() {
        let (a, b) = pair("png");
        write(&b.join("fig/x.png"), b"\x89PNG\r\n\x1a\n0124");
        let o = compare(&a, &b).unwrap();
        assert_eq!(o.mismatches, ["fig/x.png: files differ (12 vs 12 bytes, first difference at byte 11)"]);
        assert_eq!(o.identical_files, 2);
        cleanup(&[&a, &b]);
    }

    #[test]
    fn file_in_one_tree_only_fails() {
        let (a, b) = pair("missing");
        std::fs::remove_file(b.join("scenes/a.csv")).unwrap();
        write(&b.join("fig/new.png"), b"\x89PNG");
        let o = compare(&a, &b).unwrap();
        assert_eq!(o.mismatches.len(), 2, "{:?}", o.mismatches);
        assert!(o.mismatches[0].starts_with("fig/new.png: only in NEW"), "{:?}", o.mismatches);
        assert!(o.mismatches[1].starts_with("scenes/a.csv: only in BASE"), "{:?}", o.mismatches);
        std::fs::remove_file(b.join("summary.json")).unwrap();
        let o = compare(&a, &b).unwrap();
        assert!(o.mismatches.iter().any(|m| m.starts_with("summary.json: only in BASE")), "{:?}", o.mismatches);
        assert!(compare(&b, &a).unwrap_err().contains("no summary.json"));
        assert!(compare(&a, &a.join("nope")).unwrap_err().contains("not a directory"));
        cleanup(&[&a, &b]);
    }

    #[test]
    fn run_fails_on_mismatch_and_bad_arguments() {
        let (a, b) = pair("run");
        let args = |v: &[&Path]| v.iter().map(|p| p.display().to_string()).collect::<Vec<_>>();
        assert!(run(&args(&[&a, &b])).is_ok());
        write(&b.join("model.bin"), &[1, 2, 3]);
        assert!(run(&args(&[&a, &b])).unwrap_err().contains("1 mismatches"));
        assert!(run(&args(&[&a])).unwrap_err().contains("usage"));
        cleanup(&[&a, &b]);
    }

    #[test]
    fn numbers_are_masked() {
        assert_eq!(
            mask_numbers("dt30.5: 27362 periods/s, 1.5e-7 s, -0.25, x-1, 5,000-9,000/s, rk4"),
            "dt#: # periods/s, # s, #, x-#, #-#/s, rk#"
        );
        assert_eq!(mask_numbers("3 edges, 2e, v1.2.3, 1E+5"), "# edges, #e, v#.#, #");
    }
}
