//! The host tests of `cargo xtask test` with the wall time of each test binary, and what each
//! crate of the host build cost.
//!
//! [`run_parallel`] runs the test executables of the host build two at a time (each in its
//! package folder, as `cargo test` does), its output printed whole when it ends, then the doc
//! tests through cargo, whose `Doc-tests ...` lines on stderr and results on stdout go through
//! one pipe so that they arrive in order ([`binaries`] times each crate's doc tests from its
//! line to the next). [`timing_units`] reads the unit data of the `--timings` report of the
//! host build.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use crate::Result;

/// One test binary (or a crate's doc tests) of a `cargo test` run.
#[derive(Debug, Clone, PartialEq)]
pub struct Binary {
    /// `package target`, e.g. `ssmctl tests/cli.rs`, `ssm src/lib.rs`, `ssm doc tests`.
    pub name: String,
    /// Seconds after the command started.
    pub start_s: f64,
    pub seconds: f64,
    /// Tests passed, from the harness's `test result:` line(s).
    pub passed: u32,
    /// `false` when the harness reported a failure or printed no result (a crash).
    pub ok: bool,
    /// Each test's seconds, when the harness printed them (`--report-time`).
    pub tests: Vec<(String, f64)>,
    /// What the binary's passing tests said they skipped (lines starting `SKIPPED` or
    /// `skipped:`, e.g. for want of `../shared/data`), shown by `--show-output`.
    pub skipped: Vec<String>,
}

impl Binary {
    /// A binary named `name` that started `start_s` seconds after the command, before any of
    /// its output is read: no tests counted yet, not failed.
    pub fn new(name: impl Into<String>, start_s: f64) -> Self {
        Self { name: name.into(), start_s, seconds: 0.0, passed: 0, ok: true, tests: Vec::new(), skipped: Vec::new() }
    }
}

/// libtest's summary line (`test result: ok. 5 passed; 0 failed; ...`) as (ok, passed).
fn test_result(line: &str) -> Option<(bool, u32)> {
    let r = line.trim().strip_prefix("test result: ")?;
    Some((r.starts_with("ok."), count_before(r, " passed")))
}

/// A line in which a test says it skipped its work (and why), if `line` is one.
pub fn skip_line(line: &str) -> Option<&str> {
    let t = line.trim();
    (t.starts_with("SKIPPED") || t.get(..8).is_some_and(|p| p.eq_ignore_ascii_case("skipped:"))).then_some(t)
}

/// Runs `c` with stdout and stderr through one pipe: its lines with their arrival time
/// (seconds after the start, printed as they come when `forward`), its duration and result.
fn run_lines(c: &mut Command, forward: bool) -> (Vec<(f64, String)>, f64, Result<()>) {
    let pipes = pipe().and_then(|(r, w)| Ok((r, w.try_clone()?, w)));
    let (reader, writer, writer2) = match pipes {
        Ok(p) => p,
        Err(e) => return (Vec::new(), 0.0, Err(format!("cannot make a pipe for {c:?}: {e}"))),
    };
    c.stdin(Stdio::null()).stdout(writer).stderr(writer2);
    let t0 = Instant::now();
    let child = c.spawn();
    // The child holds the pipe's write ends; drop ours (inside `c`) so the reader sees EOF.
    c.stdout(Stdio::null()).stderr(Stdio::null());
    let mut child = match child {
        Ok(ch) => crate::child::Tied(ch),
        Err(e) => return (Vec::new(), 0.0, Err(format!("cannot start {c:?}: {e}"))),
    };
    let mut lines = Vec::new();
    for line in BufReader::new(reader).lines() {
        let Ok(line) = line else { break };
        if forward {
            // println! (not a handle to stdout): the test harness captures it.
            println!("{line}");
        }
        lines.push((t0.elapsed().as_secs_f64(), line));
    }
    let status = child.0.wait();
    let end = t0.elapsed().as_secs_f64();
    let result = match status {
        Ok(s) if s.success() => Ok(()),
        Ok(s) => Err(format!("{c:?} failed with {s}")),
        Err(e) => Err(format!("{c:?}: {e}")),
    };
    (lines, end, result)
}

/// A test executable of the host build: its label (as [`binaries`] names it) and the
/// package folder cargo runs it in.
#[derive(Debug, Clone, PartialEq)]
pub struct Executable {
    pub name: String,
    pub path: PathBuf,
    pub package_dir: PathBuf,
    pub package: String,
}

/// The test executables of `cargo test --no-run --message-format=json` output (one JSON
/// message a line): every artifact of a test target (libraries' unit tests, integration
/// tests, binaries' unit tests) with an executable.
pub fn executables(json_lines: &str) -> Result<Vec<Executable>> {
    let mut out = Vec::new();
    for line in json_lines.lines().filter(|l| l.starts_with('{')) {
        let m: serde_json::Value = serde_json::from_str(line).map_err(|e| format!("cargo's JSON message: {e}"))?;
        let (Some(exe), true) = (m["executable"].as_str(), m["profile"]["test"].as_bool() == Some(true)) else {
            continue;
        };
        if m["reason"] != "compiler-artifact" {
            continue;
        }
        let manifest = PathBuf::from(m["manifest_path"].as_str().ok_or("an artifact without manifest_path")?);
        let package_dir = manifest.parent().ok_or("a manifest path without a folder")?.to_path_buf();
        let src = PathBuf::from(m["target"]["src_path"].as_str().ok_or("an artifact without src_path")?);
        let src = src.strip_prefix(&package_dir).unwrap_or(&src).display().to_string();
        // `path+file:///work/ws/host/ssm#0.1.0` or `...#name@0.1.0` (name unlike the folder).
        let id = m["package_id"].as_str().unwrap_or("");
        let tail = id.rsplit('#').next().unwrap_or("");
        let package = match tail.split_once('@') {
            Some((name, _)) => name.to_string(),
            None => package_dir.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        };
        out.push(Executable { name: format!("{package} {src}"), path: PathBuf::from(exe), package_dir, package });
    }
    Ok(out)
}

impl Executable {
    /// The binary as the host tests run it: in its package folder, with the package's variables.
    pub fn command(&self) -> Command {
        let mut c = crate::cmd(&self.path);
        c.current_dir(&self.package_dir)
            .env("CARGO_MANIFEST_DIR", &self.package_dir)
            .env("CARGO_PKG_NAME", &self.package);
        c
    }
}

/// Asks libtest for each test's time: an unstable option; RUSTC_BOOTSTRAP reaches only the
/// test process, so nothing is compiled again.
pub fn report_time(c: &mut Command) -> &mut Command {
    c.env("RUSTC_BOOTSTRAP", "1").args(["-Z", "unstable-options", "--report-time"])
}

/// Runs the test executables `jobs` at a time, longest first by `previous` (seconds by name
/// from the last run or the stored estimates; the ones without a time after them, in their
/// order: the estimates hold every long binary), each in its package folder as `cargo test` runs it,
/// its whole output printed when it ends (with `test_times`, libtest's time of each test);
/// then `doc` (the doc tests, through cargo). Returns every binary's timing (start relative to
/// this call) and the failed ones' names.
pub fn run_parallel(
    exes: &[Executable],
    previous: &std::collections::BTreeMap<String, f64>,
    jobs: usize,
    test_times: bool,
    log_dir: &Path,
    doc: &mut Command,
) -> (Vec<Binary>, Vec<String>) {
    let made = std::fs::create_dir_all(log_dir);
    let mut order: Vec<&Executable> = exes.iter().collect();
    order.sort_by(|a, b| {
        let t = |e: &Executable| previous.get(&e.name).copied().unwrap_or(f64::NEG_INFINITY);
        t(b).total_cmp(&t(a))
    });
    let queue = std::sync::Mutex::new(order.into_iter());
    let results = std::sync::Mutex::new(Vec::<Binary>::new());
    let t0 = Instant::now();
    std::thread::scope(|s| {
        for _ in 0..jobs.max(1) {
            s.spawn(|| {
                loop {
                    let next = queue.lock().unwrap_or_else(|p| p.into_inner()).next();
                    let Some(e) = next else { break };
                    let mut c = e.command();
                    if test_times {
                        report_time(&mut c);
                    }
                    // The passing tests' output too, where a test that lacks its data says so.
                    c.arg("--show-output");
                    let start = t0.elapsed().as_secs_f64();
                    let (lines, seconds, r) = run_lines(&mut c, false);
                    let mut b = Binary { seconds, ok: r.is_ok(), ..Binary::new(e.name.clone(), start) };
                    let head = format!("     Running {} ({})\n", e.name, e.path.display());
                    read_output(lines.iter().map(|(_, l)| l.as_str()), &mut b);
                    let tail = r.as_ref().err().map(|err| format!("{err}\n")).unwrap_or_default();
                    let all: String = lines.iter().map(|(_, l)| format!("{l}\n")).collect();
                    // The whole output into the binary's log; the command's own shows it without
                    // the passing tests' captured output (their skip lines are in the summary).
                    let log = log_dir.join(log_name(&e.name));
                    let saved = match &made {
                        Ok(()) => std::fs::write(&log, format!("{head}{all}{tail}")).map_err(|err| err.to_string()),
                        Err(err) => Err(err.to_string()),
                    };
                    let mut text = head;
                    for l in shown_lines(lines.iter().map(|(_, l)| l.as_str())) {
                        text.push_str(l);
                        text.push('\n');
                    }
                    match saved {
                        Ok(()) => text
                            .push_str(&format!("(the whole output, with the passing tests' own: {})\n", log.display())),
                        Err(err) => text.push_str(&format!("(writing {}: {err})\n", log.display())),
                    }
                    text.push_str(&tail);
                    print!("{text}");
                    results.lock().unwrap_or_else(|p| p.into_inner()).push(b);
                }
            });
        }
    });
    let mut all = results.into_inner().unwrap_or_else(|p| p.into_inner());
    let start = t0.elapsed().as_secs_f64();
    let (lines, end, r) = run_lines(doc, true);
    let doc_ok = r.is_ok();
    let mut docs = binaries(&lines, end);
    for d in &mut docs {
        d.start_s += start;
        d.ok &= doc_ok;
    }
    if docs.is_empty() && !doc_ok {
        docs.push(Binary { seconds: end, ok: false, ..Binary::new("doc tests", start) });
    }
    all.extend(docs);
    all.sort_by(|a, b| a.start_s.total_cmp(&b.start_s));
    let failed = all.iter().filter(|b| !b.ok).map(|b| b.name.clone()).collect();
    (all, failed)
}

/// A binary's log file name in the log folder: its label with every character but letters,
/// digits, `.`, `_` and `-` made `-`.
fn log_name(label: &str) -> String {
    let name: String = label
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-') { c } else { '-' })
        .collect();
    format!("{name}.log")
}

/// The lines of a libtest binary's output (run with `--show-output`) worth showing in the
/// command's output: all but the passing tests' captured output and their names' list
/// (libtest's two `successes:` blocks), so that what a passing test prints (an expected
/// failure of a tool it drives, a `FAILED` of a fixture) cannot be read as a failure.
/// The failing tests' output (`failures:`) stays.
pub fn shown_lines<'a>(lines: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    // 0: before, 1: in the captured output, 2: in the names' list, 3: after.
    let mut state = 0;
    let mut out = Vec::new();
    for l in lines {
        state = match (state, l) {
            (0, "successes:") | (1, "successes:") => state + 1,
            (0, _) | (3, _) => {
                out.push(l);
                state
            }
            (1, _) => 1,
            (2, l) if l.starts_with("    ") => 2,
            (2, "") => 3,
            (_, l) => {
                out.push(l);
                3
            }
        };
    }
    out
}

/// Reads a libtest binary's output (run with `--show-output`) into `b`: the `test result:`
/// counts and `--report-time` lines outside the tests' captured output, and the skip lines
/// ([`skip_line`]) inside it, so that what a test prints cannot count as a result.
pub fn read_output<'a>(lines: impl Iterator<Item = &'a str>, b: &mut Binary) {
    let mut captured = false;
    for l in lines {
        if l.starts_with("---- ") && l.ends_with(" stdout ----") {
            captured = true;
        } else if captured && (l == "successes:" || l == "failures:") {
            captured = false;
        } else if captured {
            if let Some(t) = skip_line(l) {
                b.skipped.push(t.to_string());
            }
        } else if let Some((_, passed)) = test_result(l) {
            b.passed += passed;
        } else if let Some(t) = test_time(l) {
            b.tests.push(t);
        }
    }
}

/// A pipe as two files (read end, write end), close-on-exec.
fn pipe() -> std::io::Result<(std::fs::File, std::fs::File)> {
    use std::os::fd::FromRawFd;
    let mut fds = [0 as libc::c_int; 2];
    // SAFETY: pipe2 writes two descriptors into the array it is given.
    if unsafe { libc::pipe2(fds.as_mut_ptr(), libc::O_CLOEXEC) } != 0 {
        return Err(std::io::Error::last_os_error());
    }
    // SAFETY: both descriptors were just opened and are owned by nothing else.
    Ok(unsafe { (std::fs::File::from_raw_fd(fds[0]), std::fs::File::from_raw_fd(fds[1])) })
}

/// The binaries of a `cargo test` output: `lines` with their arrival time (seconds), `end` the
/// time the command ended.
pub fn binaries(lines: &[(f64, String)], end: f64) -> Vec<Binary> {
    let mut out: Vec<Binary> = Vec::new();
    let mut package = String::new();
    let mut results = 0u32;
    let close = |out: &mut Vec<Binary>, at: f64, results: u32| {
        if let Some(b) = out.last_mut() {
            b.seconds = at - b.start_s;
            b.ok &= results > 0;
        }
    };
    for (at, line) in lines {
        let l = line.trim();
        let started = if let Some(rest) = l.strip_prefix("Running ") {
            // `Running unittests src/lib.rs (target/debug/deps/ssm-5a38897a8b496259)` or
            // `Running tests/cli.rs (target/debug/deps/cli-534d1c05b88c48fe)`.
            let (src, bin) = rest.split_once(" (").unwrap_or((rest, ""));
            let src = src.strip_prefix("unittests ").unwrap_or(src);
            let stem = bin.trim_end_matches(')').rsplit('/').next().unwrap_or("");
            let crate_name = stem.rsplit_once('-').map_or(stem, |(n, _)| n);
            // cargo runs a package's library unit tests first, then its other targets.
            if src == "src/lib.rs" || package.is_empty() {
                package = crate_name.to_string();
            }
            Some(format!("{package} {src}"))
        } else {
            l.strip_prefix("Doc-tests ").map(|krate| format!("{krate} doc tests"))
        };
        if let Some(name) = started {
            close(&mut out, *at, results);
            results = 0;
            out.push(Binary::new(name, *at));
        } else if let Some((ok, passed)) = test_result(l) {
            results += 1;
            if let Some(b) = out.last_mut() {
                b.ok &= ok;
                b.passed += passed;
            }
        }
    }
    close(&mut out, end, results);
    out
}

/// A test's name and seconds from libtest's `--report-time` line
/// (`test a::b ... ok <1.234s>`).
pub fn test_time(line: &str) -> Option<(String, f64)> {
    let rest = line.trim().strip_prefix("test ")?;
    let (name, result) = rest.split_once(" ... ")?;
    let secs = result.rsplit_once('<')?.1.strip_suffix("s>")?.parse().ok()?;
    Some((name.to_string(), secs))
}

/// The `n` slowest tests of `binaries` (with `--report-time`) as Markdown rows.
pub fn slowest_tests(binaries: &[Binary], n: usize) -> String {
    let mut all: Vec<(&str, &str, f64)> =
        binaries.iter().flat_map(|b| b.tests.iter().map(|(t, s)| (b.name.as_str(), t.as_str(), *s))).collect();
    all.sort_by(|a, b| b.2.total_cmp(&a.2));
    let mut md = String::from("| binary | test | s |\n|---|---|---:|\n");
    for (b, t, s) in all.iter().take(n) {
        md.push_str(&format!("| {b} | `{t}` | {s:.1} |\n"));
    }
    md
}

/// The number just before `word` in `s` (`"ok. 34 passed; 0 failed"`, `" passed"` -> 34).
fn count_before(s: &str, word: &str) -> u32 {
    s.split_once(word)
        .and_then(|(head, _)| head.rsplit(|c: char| !c.is_ascii_digit()).next())
        .and_then(|n| n.parse().ok())
        .unwrap_or(0)
}

/// One compilation unit of a `cargo --timings` report: package, target (`lib`, `lib (test)`,
/// `test cli`, ...) and its duration in seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct Unit {
    pub package: String,
    pub target: String,
    pub seconds: f64,
}

/// The units of a `cargo --timings` HTML report (its `UNIT_DATA` array).
pub fn timing_units(html: &str) -> Result<Vec<Unit>> {
    let start = html.find("const UNIT_DATA = ").ok_or("no UNIT_DATA in the timings report")? + 18;
    let value = serde_json::Deserializer::from_str(&html[start..])
        .into_iter::<serde_json::Value>()
        .next()
        .ok_or("UNIT_DATA is empty")?
        .map_err(|e| format!("UNIT_DATA: {e}"))?;
    let units = value.as_array().ok_or("UNIT_DATA is not an array")?;
    units
        .iter()
        .map(|u| {
            let package = u["name"].as_str().ok_or("a unit without a name")?.to_string();
            let seconds = u["duration"].as_f64().ok_or_else(|| format!("unit {package}: no duration"))?;
            // ` ssm "lib" (test)` -> `lib (test)`; ` cli "test" (test)` -> `test cli`;
            // ` ssmctl "bin"` -> `bin ssmctl`; `` -> `lib`.
            let raw = u["target"].as_str().unwrap_or("").trim();
            let target = match raw.split_once(" \"") {
                None if raw.is_empty() => "lib".to_string(),
                None => raw.to_string(),
                Some((name, kind)) => {
                    let kind = kind.replacen('"', "", 1);
                    match kind.as_str() {
                        "lib (test)" | "lib" => kind,
                        "test (test)" => format!("test {name}"),
                        _ => format!("{kind} {name}"),
                    }
                }
            };
            Ok(Unit { package, target, seconds })
        })
        .collect()
}

/// Unit-seconds of a build by kind (the workspace's libraries, their unit-test builds, the
/// integration-test binaries, other workspace targets, dependencies) and the costliest units.
pub fn timing_summary(units: &[Unit], workspace: &[&str], top: usize) -> serde_json::Value {
    let mut sums = [0.0f64; 5];
    // A dependency's unit in a check, clippy or doc build that only checks it (its proc
    // macros and build scripts are compiled in every kind of build).
    let mut dependency_checks = 0.0;
    for u in units {
        if !workspace.contains(&u.package.as_str()) && u.target.contains("(check)") {
            dependency_checks += u.seconds;
        }
        let kind = if !workspace.contains(&u.package.as_str()) {
            4
        } else if u.target == "lib" {
            0
        } else if u.target == "lib (test)" {
            1
        } else if u.target.starts_with("test ") {
            2
        } else {
            3
        };
        sums[kind] += u.seconds;
    }
    // A warm build lists its fresh units too, at 0 s.
    let mut sorted: Vec<&Unit> = units.iter().filter(|u| u.seconds > 0.0).collect();
    sorted.sort_by(|a, b| b.seconds.total_cmp(&a.seconds));
    let top: Vec<serde_json::Value> = sorted
        .iter()
        .take(top)
        .map(|u| serde_json::json!({"package": u.package, "target": u.target, "seconds": u.seconds}))
        .collect();
    serde_json::json!({
        "units": units.len(),
        "compiled_units": sorted.len(),
        "unit_seconds": sums.iter().sum::<f64>(),
        "workspace_lib_unit_seconds": sums[0],
        "workspace_lib_test_unit_seconds": sums[1],
        "workspace_integration_test_unit_seconds": sums[2],
        "integration_test_binaries": units.iter().filter(|u| workspace.contains(&u.package.as_str()) && u.target.starts_with("test ")).count(),
        "workspace_other_unit_seconds": sums[3],
        "dependency_unit_seconds": sums[4],
        "dependency_check_unit_seconds": dependency_checks,
        "costliest": top,
    })
}

/// `cargo xtask build-times [--steps FILE] [--save-estimates] [LABEL=TIMINGS.html ...]`:
/// Markdown tables of the step table and host test binaries of `cargo xtask test` (from its
/// JSON, default `target/xtask-test-steps.json`; with `--save-estimates` its binaries'
/// seconds also go to `estimates`, see [`estimates_json`]) and, for each `--timings` report given, its unit-seconds by
/// kind, side by side (the measurements of `docs/build-time.md`).
pub fn build_times(
    args: &[String],
    default_steps: &std::path::Path,
    estimates: &std::path::Path,
    workspace: &[&str],
) -> Result<String> {
    let mut steps_path = None;
    let mut reports = Vec::new();
    let mut save = false;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        if a == "--steps" {
            steps_path = Some(it.next().ok_or("build-times: --steps needs a file")?.clone());
        } else if a == "--save-estimates" {
            save = true;
        } else if let Some((label, path)) = a.split_once('=') {
            let html = std::fs::read_to_string(path).map_err(|e| format!("build-times: {path}: {e}"))?;
            let units = timing_units(&html).map_err(|e| format!("build-times: {path}: {e}"))?;
            reports.push((label.to_string(), units));
        } else {
            return Err(format!("build-times: `{a}` is neither --steps FILE, --save-estimates nor LABEL=TIMINGS.html"));
        }
    }
    let mut md = String::new();
    let path = steps_path.map(std::path::PathBuf::from).unwrap_or_else(|| default_steps.to_path_buf());
    if path.exists() || !reports.is_empty() {
        if path.exists() {
            let text = std::fs::read_to_string(&path).map_err(|e| format!("build-times: {}: {e}", path.display()))?;
            let v: serde_json::Value =
                serde_json::from_str(&text).map_err(|e| format!("build-times: {}: {e}", path.display()))?;
            md.push_str(&steps_markdown(&v));
            if save {
                let e = estimates_json(&v).ok_or_else(|| {
                    format!("build-times: {} has no host test binaries to save as estimates", path.display())
                })?;
                let text = serde_json::to_string_pretty(&e).map_err(|err| format!("build-times: {err}"))? + "\n";
                std::fs::write(estimates, text)
                    .map_err(|err| format!("build-times: {}: {err}", estimates.display()))?;
                md.push_str(&format!("\nSaved the binaries' seconds to {}.\n", estimates.display()));
            }
        } else if save {
            return Err(format!("build-times: --save-estimates needs {}", path.display()));
        }
    } else {
        return Err(format!("build-times: {} is missing (run `cargo xtask test` first)", path.display()));
    }
    if !reports.is_empty() {
        md.push_str(&compare_markdown(&reports, workspace));
    }
    Ok(md)
}

/// The stored estimates of the host test binaries' seconds, from a steps JSON: the order in
/// which a clean clone (no last run in `target/`) starts them. `None` when it has none.
pub fn estimates_json(steps: &serde_json::Value) -> Option<serde_json::Value> {
    let mut seconds = std::collections::BTreeMap::new();
    for b in steps["host_test_binaries"].as_array()? {
        let (Some(name), Some(s)) = (b["name"].as_str(), b["seconds"].as_f64()) else { continue };
        // The doc tests run after the binaries, through cargo: not scheduled.
        if !name.ends_with(" doc tests") {
            seconds.insert(name.to_string(), s);
        }
    }
    (!seconds.is_empty()).then(|| estimates_of(&seconds, &steps["load_average_1_5_15_min"]))
}

/// The estimates file's JSON for `seconds` by binary (rounded to 0.1 s).
pub fn estimates_of(seconds: &std::collections::BTreeMap<String, f64>, load: &serde_json::Value) -> serde_json::Value {
    let rounded: serde_json::Map<String, serde_json::Value> =
        seconds.iter().map(|(k, s)| (k.clone(), ((s * 10.0).round() / 10.0).into())).collect();
    serde_json::json!({
        "about": "Wall seconds of host test binaries (`cargo xtask build-times --save-estimates`: every binary of a run of `cargo xtask test`; `cargo xtask test-cpu --save-estimates`: the binaries it measured, each alone, merged in): the xtask starts them longest first, the ones not listed after them, when target/ holds no run of its own.",
        "load_average_1_5_15_min": load,
        "seconds": rounded,
    })
}

/// Seconds by binary of an estimates JSON ([`estimates_json`]); empty when it has none.
pub fn read_estimates(v: &serde_json::Value) -> std::collections::BTreeMap<String, f64> {
    v["seconds"]
        .as_object()
        .map(|m| m.iter().filter_map(|(k, s)| Some((k.clone(), s.as_f64()?))).collect())
        .unwrap_or_default()
}

/// The step table and the host test binaries, slowest first, of a steps JSON.
fn steps_markdown(v: &serde_json::Value) -> String {
    let mut md = String::from("| step | start s | wall s | result |\n|---|---:|---:|---|\n");
    let empty = Vec::new();
    for s in v["steps"].as_array().unwrap_or(&empty) {
        let ok = if s["ok"].as_bool() == Some(true) { "ok" } else { "FAILED" };
        md.push_str(&format!(
            "| {} | {:.1} | {:.1} | {ok} |\n",
            s["name"].as_str().unwrap_or("?").trim(),
            s["start_seconds"].as_f64().unwrap_or(f64::NAN),
            s["seconds"].as_f64().unwrap_or(f64::NAN)
        ));
    }
    md.push_str(&format!("| whole command | | {:.1} | |\n", v["total_seconds"].as_f64().unwrap_or(f64::NAN)));
    md.push_str(&format!(
        "\nCPU of the children: user {:.0} s, system {:.0} s; load average at the end {}.\n",
        v["children_cpu_user_seconds"].as_f64().unwrap_or(f64::NAN),
        v["children_cpu_system_seconds"].as_f64().unwrap_or(f64::NAN),
        v["load_average_1_5_15_min"].as_str().unwrap_or("?")
    ));
    let mut bins: Vec<&serde_json::Value> = v["host_test_binaries"].as_array().unwrap_or(&empty).iter().collect();
    if !bins.is_empty() {
        bins.sort_by(|a, b| b["seconds"].as_f64().unwrap_or(0.0).total_cmp(&a["seconds"].as_f64().unwrap_or(0.0)));
        let total: f64 = bins.iter().filter_map(|b| b["seconds"].as_f64()).sum();
        md.push_str(&format!(
            "\nHost test binaries ({}, {total:.1} s in all), slowest first:\n\n| binary | wall s | tests passed |\n|---|---:|---:|\n",
            bins.len()
        ));
        for b in bins {
            md.push_str(&format!(
                "| {} | {:.1} | {} |\n",
                b["name"].as_str().unwrap_or("?"),
                b["seconds"].as_f64().unwrap_or(f64::NAN),
                b["passed"]
            ));
        }
    }
    md
}

/// A Markdown table's header: `first`, then one right-aligned column per report's label.
fn report_columns(first: &str, reports: &[(String, Vec<Unit>)]) -> String {
    let mut md = format!("\n| {first} |");
    for (label, _) in reports {
        md.push_str(&format!(" {label} |"));
    }
    md.push_str("\n|---|");
    md.push_str(&"---:|".repeat(reports.len()));
    md.push('\n');
    md
}

/// Unit-seconds by kind of several `--timings` reports, one column each.
fn compare_markdown(reports: &[(String, Vec<Unit>)], workspace: &[&str]) -> String {
    let sums: Vec<serde_json::Value> = reports.iter().map(|(_, u)| timing_summary(u, workspace, 0)).collect();
    let mut md = report_columns("unit-seconds", reports);
    for (key, name) in [
        ("workspace_lib_unit_seconds", "workspace libraries"),
        ("workspace_lib_test_unit_seconds", "workspace libraries' unit-test builds"),
        ("workspace_integration_test_unit_seconds", "integration-test binaries"),
        ("workspace_other_unit_seconds", "other workspace targets (bins, examples)"),
        ("dependency_unit_seconds", "dependencies"),
        ("dependency_check_unit_seconds", "of which checks only (not compiled)"),
        ("unit_seconds", "all units"),
    ] {
        md.push_str(&format!("| {name} |"));
        for s in &sums {
            md.push_str(&format!(" {:.0} |", s[key].as_f64().unwrap_or(f64::NAN)));
        }
        md.push('\n');
    }
    md.push_str("| integration-test binaries (count) |");
    for s in &sums {
        md.push_str(&format!(" {} |", s["integration_test_binaries"]));
    }
    md.push('\n');
    md.push_str(&package_markdown(reports, COMPARE_TOP_PACKAGES));
    md
}

/// Packages [`package_markdown`] lists when comparing reports.
const COMPARE_TOP_PACKAGES: usize = 25;

/// Unit-seconds per package (all its units and versions) in each report, for the `top`
/// packages by their largest value in any report, largest first; `-` where a report compiled
/// none of the package's units.
fn package_markdown(reports: &[(String, Vec<Unit>)], top: usize) -> String {
    use std::collections::BTreeMap;
    let per: Vec<BTreeMap<&str, f64>> = reports
        .iter()
        .map(|(_, units)| {
            let mut m = BTreeMap::new();
            for u in units {
                *m.entry(u.package.as_str()).or_insert(0.0) += u.seconds;
            }
            m
        })
        .collect();
    let mut largest: BTreeMap<&str, f64> = BTreeMap::new();
    for (k, v) in per.iter().flatten() {
        let e = largest.entry(k).or_insert(0.0);
        *e = e.max(*v);
    }
    let mut names: Vec<(&str, f64)> = largest.into_iter().collect();
    names.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(b.0)));
    let mut md = report_columns("package (unit-seconds, all its units)", reports);
    for (name, _) in names.into_iter().take(top) {
        md.push_str(&format!("| {name} |"));
        for m in &per {
            match m.get(name) {
                Some(v) => md.push_str(&format!(" {v:.1} |")),
                None => md.push_str(" - |"),
            }
        }
        md.push('\n');
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(v: &[(f64, &str)]) -> Vec<(f64, String)> {
        v.iter().map(|(t, s)| (*t, s.to_string())).collect()
    }

    #[test]
    fn binaries_take_their_package_and_last_until_the_next() {
        let out = lines(&[
            (0.5, "   Compiling ssm v0.1.0"),
            (1.0, "     Running unittests src/lib.rs (target/debug/deps/ssm-5a38897a8b496259)"),
            (1.1, "running 2 tests"),
            (3.0, "test result: ok. 2 passed; 0 failed; 0 ignored; 0 measured; 0 filtered out; finished in 1.9s"),
            (3.5, "     Running tests/cli.rs (target/debug/deps/cli-534d1c05b88c48fe)"),
            (9.0, "test result: FAILED. 12 passed; 1 failed; 0 ignored; 0 measured; 0 filtered out"),
            (9.5, "     Running unittests src/lib.rs (target/debug/deps/chaos_study-07ec3bf5dcc0f1f2)"),
            (10.0, "     Running tests/crash.rs (target/debug/deps/crash-0123)"),
            (11.0, "   Doc-tests ssm"),
            (11.5, "test result: ok. 1 passed; 0 failed; 0 ignored; 0 measured; 0 filtered out; finished in 0.1s"),
        ]);
        let b = binaries(&out, 12.0);
        let names: Vec<&str> = b.iter().map(|b| b.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "ssm src/lib.rs",
                "ssm tests/cli.rs",
                "chaos_study src/lib.rs",
                "chaos_study tests/crash.rs",
                "ssm doc tests"
            ]
        );
        let secs: Vec<f64> = b.iter().map(|b| b.seconds).collect();
        assert_eq!(secs, [2.5, 6.0, 0.5, 1.0, 1.0]);
        assert_eq!(b.iter().map(|b| b.passed).collect::<Vec<_>>(), [2, 12, 0, 0, 1]);
        // A failed harness and binaries without a result line (crashed) are not ok.
        assert_eq!(b.iter().map(|b| b.ok).collect::<Vec<_>>(), [true, false, false, false, true]);
    }

    #[test]
    fn packages_are_compared_largest_first_across_reports() {
        let u = |package: &str, target: &str, seconds: f64| Unit {
            package: package.to_string(),
            target: target.to_string(),
            seconds,
        };
        let before =
            vec![u("syn", "lib", 40.0), u("syn", "lib", 30.0), u("ssm", "lib", 20.0), u("ssm", "lib (test)", 5.0)];
        let after = vec![u("syn", "lib", 12.0), u("ssm", "lib", 26.0), u("png", "lib", 1.0)];
        let md = package_markdown(&[("before".into(), before), ("after".into(), after)], 2);
        let rows: Vec<&str> = md.lines().filter(|l| l.starts_with("| ") && !l.starts_with("| package")).collect();
        assert_eq!(rows, ["| syn | 70.0 | 12.0 |", "| ssm | 25.0 | 26.0 |"]);
        let md = package_markdown(&[("a".into(), vec![u("png", "lib", 1.0)]), ("b".into(), vec![])], 5);
        assert!(md.contains("| png | 1.0 | - |"), "{md}");
    }

    #[test]
    fn timing_units_are_read_and_summed_by_kind() {
        let html = r#"<script>
const UNIT_DATA = [{"i":0,"name":"faer","version":"0.24.4","target":"","duration":52.5},
 {"i":1,"name":"ssm","version":"0.1.0","target":"","duration":10.0},
 {"i":2,"name":"ssm","version":"0.1.0","target":" ssm \"lib\" (test)","duration":7.0},
 {"i":3,"name":"ssm","version":"0.1.0","target":" mat_files \"test\" (test)","duration":2.0},
 {"i":4,"name":"ssmctl","version":"0.1.0","target":" ssmctl \"bin\"","duration":1.5},
 {"i":5,"name":"gemm","version":"0.19.0","target":" gemm \"lib\" (check)","duration":3.0}];
const CONCURRENCY_DATA = [];
</script>"#;
        let units = timing_units(html).unwrap();
        let targets: Vec<&str> = units.iter().map(|u| u.target.as_str()).collect();
        assert_eq!(targets, ["lib", "lib", "lib (test)", "test mat_files", "bin ssmctl", "lib (check) gemm"]);
        let s = timing_summary(&units, &["ssm", "ssmctl"], 2);
        assert_eq!(s["unit_seconds"], 76.0);
        assert_eq!(s["workspace_lib_unit_seconds"], 10.0);
        assert_eq!(s["workspace_lib_test_unit_seconds"], 7.0);
        assert_eq!(s["workspace_integration_test_unit_seconds"], 2.0);
        assert_eq!(s["integration_test_binaries"], 1);
        assert_eq!(s["workspace_other_unit_seconds"], 1.5);
        assert_eq!(s["dependency_unit_seconds"], 55.5);
        assert_eq!(s["dependency_check_unit_seconds"], 3.0);
        assert_eq!(s["costliest"][0]["package"], "faer");
        assert_eq!(s["costliest"].as_array().map(Vec::len), Some(2));
        let fresh =
            [units.clone(), vec![Unit { package: "ssm".into(), target: "test x".into(), seconds: 0.0 }]].concat();
        let s = timing_summary(&fresh, &["ssm", "ssmctl"], 10);
        assert_eq!((s["units"].as_u64(), s["compiled_units"].as_u64()), (Some(7), Some(6)));
        assert_eq!(s["costliest"].as_array().map(Vec::len), Some(6));
        assert!(timing_units("<html>no data</html>").unwrap_err().contains("UNIT_DATA"));
    }

    #[test]
    fn executables_are_the_test_artifacts_with_their_package() {
        let json = r#"{"reason":"compiler-artifact","package_id":"path+file:///w/host/ssm#0.1.0","manifest_path":"/w/host/ssm/Cargo.toml","target":{"name":"ssm","kind":["lib"],"src_path":"/w/host/ssm/src/lib.rs"},"profile":{"test":true},"executable":"/w/target/debug/deps/ssm-1"}
{"reason":"compiler-artifact","package_id":"path+file:///w/host/ssm#0.1.0","manifest_path":"/w/host/ssm/Cargo.toml","target":{"name":"ssm","kind":["lib"],"src_path":"/w/host/ssm/src/lib.rs"},"profile":{"test":false},"executable":null}
{"reason":"compiler-artifact","package_id":"path+file:///w/tests/fuzz-targets#fuzz-targets@0.1.0","manifest_path":"/w/tests/fuzz-targets/Cargo.toml","target":{"name":"replay","kind":["test"],"src_path":"/w/tests/fuzz-targets/tests/replay.rs"},"profile":{"test":true},"executable":"/w/target/debug/deps/replay-2"}
{"reason":"build-finished","success":true}"#;
        let e = executables(json).unwrap();
        assert_eq!(e.len(), 2);
        assert_eq!((e[0].name.as_str(), e[0].package.as_str()), ("ssm src/lib.rs", "ssm"));
        assert_eq!(e[0].package_dir, PathBuf::from("/w/host/ssm"));
        assert_eq!(e[1].name, "fuzz-targets tests/replay.rs");
        assert_eq!(e[1].path, PathBuf::from("/w/target/debug/deps/replay-2"));
        assert!(executables("{not json").is_err());
    }

    #[test]
    fn binaries_run_side_by_side_longest_first_and_failures_are_named() {
        let dir = std::env::temp_dir().join(format!("xtask-host-tests-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let script = |name: &str, body: &str| {
            let p = dir.join(name);
            std::fs::write(&p, format!("#!/bin/sh\n{body}\n")).unwrap();
            std::fs::set_permissions(&p, std::os::unix::fs::PermissionsExt::from_mode(0o755)).unwrap();
            Executable { name: format!("p {name}"), path: p, package_dir: dir.clone(), package: "p".into() }
        };
        let exes = [
            // Asked for the passing tests' output.
            script("short", "[ \"$1\" = --show-output ] || exit 4; echo 'test result: ok. 1 passed; 0 failed'"),
            // Runs in its package folder, with the package's CARGO_MANIFEST_DIR.
            script(
                "long",
                "[ \"$CARGO_MANIFEST_DIR\" = \"$(pwd)\" ] || exit 3; echo 'test result: ok. 5 passed; 0 failed'",
            ),
            script("bad", "echo 'test result: FAILED. 0 passed; 1 failed'; exit 101"),
        ];
        // `short` has no time: it runs after the others.
        let previous = [("p long".to_string(), 9.0), ("p bad".to_string(), 2.0)].into();
        let mut doc = Command::new("sh");
        doc.args(["-c", "echo '   Doc-tests p' >&2; echo 'test result: ok. 2 passed; 0 failed'"]);
        let logs = dir.join("logs");
        let (b, failed) = run_parallel(&exes, &previous, 1, false, &logs, &mut doc);
        let names: Vec<&str> = b.iter().map(|b| b.name.as_str()).collect();
        assert_eq!(names, ["p long", "p bad", "p short", "p doc tests"]);
        assert_eq!(b.iter().map(|b| b.passed).collect::<Vec<_>>(), [5, 0, 1, 2]);
        assert_eq!(failed, ["p bad"]);
        // Each binary's whole output in its log.
        let bad = std::fs::read_to_string(logs.join("p-bad.log")).unwrap();
        assert!(bad.contains("test result: FAILED. 0 passed; 1 failed") && bad.contains("exit status: 101"), "{bad}");
        let (b, failed) = run_parallel(&exes[..2], &previous, 2, false, &logs, &mut doc);
        assert_eq!(b.len(), 3);
        assert!(failed.is_empty(), "{failed:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Skip lines count inside a test's captured output only, results outside it only.
    #[test]
    fn output_is_read_by_where_its_lines_stand() {
        let text = [
            "running 2 tests",
            "test a ... ok",
            "test b ... ok",
            "",
            "successes:",
            "",
            "---- a stdout ----",
            "SKIPPED: no data at ../shared/data",
            "test result: ok. 9 passed; 0 failed",
            "",
            "---- b stdout ----",
            "skipped: x not found",
            "",
            "successes:",
            "    a",
            "    b",
            "",
            "SKIPPED outside captured output",
            "test result: ok. 2 passed; 0 failed; 0 ignored",
        ];
        let mut b = Binary::new("p", 0.0);
        read_output(text.into_iter(), &mut b);
        assert_eq!(b.passed, 2);
        assert_eq!(b.skipped, ["SKIPPED: no data at ../shared/data", "skipped: x not found"]);
    }

    /// The passing tests' output is left out of what is shown, the failing tests' stays.
    #[test]
    fn passing_tests_output_is_not_shown_and_failures_are() {
        let text = [
            "running 3 tests",
            "test a ... ok",
            "test b ... ok",
            "test c ... FAILED",
            "",
            "successes:",
            "",
            "---- a stdout ----",
            "step: second: FAILED in 0.0 s: broke",
            "",
            "successes:",
            "    a",
            "    b",
            "",
            "failures:",
            "",
            "---- c stdout ----",
            "thread 'c' panicked",
            "",
            "failures:",
            "    c",
            "",
            "test result: FAILED. 2 passed; 1 failed; 0 ignored",
        ];
        let shown = shown_lines(text.into_iter());
        assert_eq!(shown[..5], text[..5]);
        assert_eq!(shown[5..], text[14..]);
        assert!(!shown.iter().any(|l| l.contains("broke")));
        // Without a successes block (no passing test printed anything), everything is shown.
        let plain = ["running 1 test", "test a ... ok", "", "test result: ok. 1 passed; 0 failed"];
        assert_eq!(shown_lines(plain.into_iter()), plain);
        assert_eq!(log_name("ssmctl tests/commands.rs"), "ssmctl-tests-commands.rs.log");
    }

    #[test]
    fn skip_lines_are_recognised() {
        assert_eq!(skip_line("  SKIPPED: sloshing data not found"), Some("SKIPPED: sloshing data not found"));
        assert!(skip_line("skipped: x not found (the shared data folder is absent)").is_some());
        assert_eq!(skip_line("Skipped: x"), Some("Skipped: x"));
        assert_eq!(skip_line("test a ... ok"), None);
        assert_eq!(skip_line("2 rows skipped"), None);
    }

    #[test]
    fn estimates_are_saved_from_a_run_and_read_back() {
        let steps = serde_json::json!({
            "load_average_1_5_15_min": "1.0 2.0 3.0",
            "host_test_binaries": [
                {"name": "furuta src/lib.rs", "seconds": 136.14},
                {"name": "ssm doc tests", "seconds": 9.0},
                {"name": "ssmctl tests/commands.rs", "seconds": 144.36},
            ],
        });
        let e = estimates_json(&steps).unwrap();
        let t = read_estimates(&e);
        assert_eq!(t.len(), 2, "{t:?}");
        assert_eq!((t["furuta src/lib.rs"], t["ssmctl tests/commands.rs"]), (136.1, 144.4));
        assert!(estimates_json(&serde_json::json!({"host_test_binaries": []})).is_none());
        assert!(read_estimates(&serde_json::Value::Null).is_empty());
        // Saved through build-times from a steps file.
        let dir = std::env::temp_dir().join(format!("xtask-estimates-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (steps_file, out) = (dir.join("steps.json"), dir.join("estimates.json"));
        std::fs::write(&steps_file, steps.to_string()).unwrap();
        let args = ["--steps".to_string(), steps_file.display().to_string(), "--save-estimates".to_string()];
        let md = build_times(&args, &steps_file, &out, &[]).unwrap();
        assert!(md.contains("Saved the binaries' seconds"), "{md}");
        let back: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
        assert_eq!(read_estimates(&back), t);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn test_times_are_read_and_ranked() {
        assert_eq!(test_time("test a::b ... ok <1.250s>"), Some(("a::b".to_string(), 1.25)));
        assert_eq!(test_time("test a::b ... ok"), None);
        assert_eq!(test_time("test result: ok. 1 passed"), None);
        let b = |name: &str, tests: &[(&str, f64)]| Binary {
            tests: tests.iter().map(|(t, s)| (t.to_string(), *s)).collect(),
            ..Binary::new(name, 0.0)
        };
        let md =
            slowest_tests(&[b("x src/lib.rs", &[("fast", 0.1), ("slow", 9.0)]), b("y tests/t.rs", &[("mid", 2.0)])], 2);
        assert_eq!(
            md.lines().skip(2).collect::<Vec<_>>(),
            ["| x src/lib.rs | `slow` | 9.0 |", "| y tests/t.rs | `mid` | 2.0 |"]
        );
    }

    #[test]
    fn a_command_s_two_streams_arrive_in_order() {
        let (lines, end, r) = run_lines(
            Command::new("sh").args([
                "-c",
                "echo '     Running tests/a.rs (target/debug/deps/a-1)' >&2; \
             echo 'test result: ok. 3 passed; 0 failed'; \
             echo '   Doc-tests a' >&2; echo 'test result: ok. 0 passed; 0 failed'; exit 2",
            ]),
            false,
        );
        let b = binaries(&lines, end);
        assert!(r.unwrap_err().contains("failed"));
        assert_eq!(b.len(), 2, "{b:?}");
        assert_eq!((b[0].name.as_str(), b[0].passed, b[0].ok), ("a tests/a.rs", 3, true));
        assert_eq!(b[1].name, "a doc tests");
    }
}
