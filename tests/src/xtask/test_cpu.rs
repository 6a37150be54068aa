//! `cargo xtask test-cpu`: where a test binary's CPU goes, test by test.
//!
//! For each binary asked for (`PACKAGE` its library's unit tests, `PACKAGE:TEST` an
//! integration test), built in the test profile by one `cargo test -p ... --no-run`: the whole
//! binary as the host tests run it (libtest's default threads), its user + system CPU, wall
//! time and cores used (CPU / wall), with libtest's wall time of each test (`--report-time`);
//! then the longest tests of that run each alone (`--exact NAME --test-threads=1`, one
//! process each), their CPU from `wait4`'s resource usage. A fixture shared through a
//! `OnceLock` is paid by every test that runs alone, so tests alone can sum to more than the
//! whole binary. The measurements go to `target/xtask-test-cpu.json` (merged by binary with
//! what is there); the Markdown tables of `docs/build-time.md` are printed, with a `before`
//! column from `--baseline FILE` (an earlier copy of that JSON).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

use crate::Result;
use crate::host_tests::Executable;

/// What one process cost: user and system CPU seconds (its children included) and wall
/// seconds, and whether it exited with success.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cost {
    pub user_s: f64,
    pub sys_s: f64,
    pub wall_s: f64,
    pub ok: bool,
}

impl Cost {
    pub fn cpu_s(&self) -> f64 {
        self.user_s + self.sys_s
    }

    fn json(&self) -> serde_json::Value {
        serde_json::json!({"user_s": self.user_s, "sys_s": self.sys_s, "wall_s": self.wall_s, "ok": self.ok})
    }

    fn from_json(v: &serde_json::Value) -> Option<Self> {
        Some(Cost {
            user_s: v["user_s"].as_f64()?,
            sys_s: v["sys_s"].as_f64()?,
            wall_s: v["wall_s"].as_f64()?,
            ok: v["ok"].as_bool()?,
        })
    }
}

/// Runs `c` (stderr discarded) and measures it with `wait4`; returns its stdout too.
pub fn measure(c: &mut Command) -> Result<(Cost, String)> {
    use std::io::Read;
    c.stdin(Stdio::null()).stdout(Stdio::piped()).stderr(Stdio::null());
    let t0 = Instant::now();
    let mut child = c.spawn().map_err(|e| format!("cannot start {c:?}: {e}"))?;
    let mut out = Vec::new();
    // Read to the end (the child closes its stdout when it exits), then reap it.
    let read = child.stdout.take().map(|mut o| o.read_to_end(&mut out));
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: wait4 writes the status and the zeroed rusage it is given; the child is ours
    // and not waited for elsewhere (std's `Child` is dropped unwaited, which does nothing).
    let (r, usage) = unsafe {
        let mut u: libc::rusage = std::mem::zeroed();
        let r = libc::wait4(pid, &mut status, 0, &mut u);
        (r, u)
    };
    let wall_s = t0.elapsed().as_secs_f64();
    drop(child);
    if r != pid {
        return Err(format!("wait4 for {c:?}: {}", std::io::Error::last_os_error()));
    }
    if let Some(Err(e)) = read {
        return Err(format!("{c:?}: reading its output: {e}"));
    }
    let s = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    let ok = libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0;
    let cost = Cost { user_s: s(usage.ru_utime), sys_s: s(usage.ru_stime), wall_s, ok };
    Ok((cost, String::from_utf8_lossy(&out).into_owned()))
}

/// One binary's measurements.
#[derive(Debug, Clone, PartialEq)]
pub struct BinaryCpu {
    /// As the host tests name it, e.g. `furuta src/lib.rs`.
    pub name: String,
    pub whole: Cost,
    /// The longest tests of the whole run, each alone, longest first.
    pub tests: Vec<(String, Cost)>,
}

impl BinaryCpu {
    fn json(&self) -> serde_json::Value {
        let tests: Vec<serde_json::Value> = self
            .tests
            .iter()
            .map(|(n, c)| {
                let mut v = c.json();
                v["name"] = n.clone().into();
                v
            })
            .collect();
        serde_json::json!({"name": self.name, "whole": self.whole.json(), "tests": tests})
    }

    fn from_json(v: &serde_json::Value) -> Option<Self> {
        let tests = v["tests"]
            .as_array()?
            .iter()
            .map(|t| Some((t["name"].as_str()?.to_string(), Cost::from_json(t)?)))
            .collect::<Option<Vec<_>>>()?;
        Some(BinaryCpu { name: v["name"].as_str()?.to_string(), whole: Cost::from_json(&v["whole"])?, tests })
    }
}

/// The binaries of a `test-cpu` JSON (empty when it has none).
pub fn read_binaries(v: &serde_json::Value) -> Vec<BinaryCpu> {
    v["binaries"].as_array().map(|a| a.iter().filter_map(BinaryCpu::from_json).collect()).unwrap_or_default()
}

/// `new` over `old`, by binary name, in `old`'s order then the new ones.
pub fn merge(old: Vec<BinaryCpu>, new: &[BinaryCpu]) -> Vec<BinaryCpu> {
    let mut out: Vec<BinaryCpu> =
        old.into_iter().map(|o| new.iter().find(|n| n.name == o.name).cloned().unwrap_or(o)).collect();
    for n in new {
        if !out.iter().any(|o| o.name == n.name) {
            out.push(n.clone());
        }
    }
    out
}

/// Markdown: a table of the binaries (whole run, CPU and cores used; `before` beside when
/// given), then each binary's `top` costliest tests alone.
pub fn markdown(binaries: &[BinaryCpu], before: &[BinaryCpu], top: usize) -> String {
    let prior = |name: &str| before.iter().find(|b| b.name == name);
    let with_before = binaries.iter().any(|b| prior(&b.name).is_some());
    let mut md = String::from(if with_before {
        "| binary | tests alone | CPU s before | CPU s (user + sys) | wall s | cores used |\n|---|---:|---:|---:|---:|---:|\n"
    } else {
        "| binary | tests alone | CPU s (user + sys) | wall s | cores used |\n|---|---:|---:|---:|---:|\n"
    });
    for b in binaries {
        let w = &b.whole;
        let mut row = format!("| {} | {} |", b.name, b.tests.len());
        if with_before {
            match prior(&b.name) {
                Some(p) => row.push_str(&format!(" {:.1} |", p.whole.cpu_s())),
                None => row.push_str(" |"),
            }
        }
        let failed = if w.ok { "" } else { " (FAILED)" };
        row.push_str(&format!(" {:.1}{failed} | {:.1} | {:.2} |\n", w.cpu_s(), w.wall_s, w.cpu_s() / w.wall_s));
        md.push_str(&row);
    }
    for b in binaries {
        let mut tests: Vec<&(String, Cost)> = b.tests.iter().collect();
        tests.sort_by(|x, y| y.1.cpu_s().total_cmp(&x.1.cpu_s()));
        let sum: f64 = b.tests.iter().map(|t| t.1.cpu_s()).sum();
        md.push_str(&format!(
            "\n`{}`: the {} costliest of its longest tests, each alone ({sum:.1} CPU-s for the {} measured):\n\n",
            b.name,
            top.min(tests.len()),
            tests.len()
        ));
        let old = prior(&b.name);
        md.push_str(if old.is_some() {
            "| test | CPU s before | CPU s | wall s |\n|---|---:|---:|---:|\n"
        } else {
            "| test | CPU s | wall s |\n|---|---:|---:|\n"
        });
        for (name, c) in tests.into_iter().take(top) {
            let failed = if c.ok { "" } else { " (FAILED)" };
            let mut row = format!("| `{name}`{failed} |");
            if let Some(o) = old {
                match o.tests.iter().find(|t| &t.0 == name) {
                    Some(t) => row.push_str(&format!(" {:.1} |", t.1.cpu_s())),
                    None => row.push_str(" new |"),
                }
            }
            row.push_str(&format!(" {:.1} | {:.1} |\n", c.cpu_s(), c.wall_s));
            md.push_str(&row);
        }
    }
    md
}

/// A target as asked for, `PACKAGE` (library unit tests) or `PACKAGE:TEST`: its package,
/// cargo's target flag and its name as the host tests label it.
fn parse_target(target: &str) -> (String, Vec<String>, String) {
    match target.split_once(':') {
        Some((p, t)) => (p.into(), vec!["--test".into(), t.into()], format!("{p} tests/{t}.rs")),
        None => (target.into(), vec!["--lib".into()], format!("{target} src/lib.rs")),
    }
}

/// The test executables of `targets`, built in the test profile by one cargo run (the
/// packages' features unified as one build, so a dependency is compiled once for all).
fn build(root: &Path, targets: &[String]) -> Result<Vec<Executable>> {
    let mut c = crate::host_cargo()?;
    c.current_dir(root).args(["test", "--no-run", "--message-format=json"]);
    let parsed: Vec<(String, Vec<String>, String)> = targets.iter().map(|t| parse_target(t)).collect();
    // Cargo takes each target flag once for all the packages.
    let mut flags: Vec<&Vec<String>> = Vec::new();
    for (p, f, _) in &parsed {
        c.args(["-p", p]);
        if !flags.contains(&f) {
            flags.push(f);
        }
    }
    c.args(flags.into_iter().flatten());
    c.stderr(Stdio::inherit());
    let o = c.output().map_err(|e| format!("cannot start {c:?}: {e}"))?;
    if !o.status.success() {
        return Err(format!("{c:?} failed with {}", o.status));
    }
    let exes = crate::host_tests::executables(&String::from_utf8_lossy(&o.stdout))?;
    parsed
        .iter()
        .zip(targets)
        .map(|((_, _, label), t)| {
            exes.iter().find(|e| &e.name == label).cloned().ok_or_else(|| format!("test-cpu: `{t}` built no `{label}`"))
        })
        .collect()
}

/// `TARGET=PATH`: the executable at PATH as `TARGET`'s, run in its package's folder (from
/// `cargo metadata`).
fn prebuilt_executable(root: &Path, target: &str) -> Result<Executable> {
    let (t, path) = target.split_once('=').ok_or_else(|| format!("test-cpu: `{target}` is not TARGET=PATH"))?;
    let (package, _, name) = parse_target(t);
    if !Path::new(path).is_file() {
        return Err(format!("test-cpu: `{target}`: {path} is not a file"));
    }
    let mut c = crate::cmd("cargo");
    c.current_dir(root).args(["metadata", "--no-deps", "--format-version", "1"]);
    let o = c.output().map_err(|e| format!("cannot start {c:?}: {e}"))?;
    let m: serde_json::Value =
        serde_json::from_slice(&o.stdout).map_err(|e| format!("test-cpu: cargo metadata: {e}"))?;
    let manifest = m["packages"]
        .as_array()
        .into_iter()
        .flatten()
        .find(|p| p["name"] == package.as_str())
        .and_then(|p| p["manifest_path"].as_str())
        .ok_or_else(|| format!("test-cpu: `{target}`: no package `{package}` in the workspace"))?;
    let package_dir = Path::new(manifest).parent().ok_or("test-cpu: a manifest path without a folder")?.to_path_buf();
    Ok(Executable { name, path: PathBuf::from(path), package_dir, package })
}

/// Measures one binary: whole (libtest's `--report-time` giving each test's wall time in
/// that run), then its `alone` longest tests of that run each alone (printed as they end).
fn measure_binary(e: &Executable, alone: usize) -> Result<BinaryCpu> {
    println!("test-cpu: {}: the whole binary", e.name);
    let (whole, out) = measure(crate::host_tests::report_time(&mut e.command()))?;
    println!("test-cpu: {}: {:.1} CPU-s in {:.1} s", e.name, whole.cpu_s(), whole.wall_s);
    let mut in_run: Vec<(String, f64)> = out.lines().filter_map(crate::host_tests::test_time).collect();
    in_run.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut tests = Vec::with_capacity(alone);
    for (n, _) in in_run.into_iter().take(alone) {
        let (c, _) = measure(e.command().args(["--exact", &n, "--test-threads=1"]))?;
        println!("test-cpu: {:7.1} CPU-s {:7.1} s  {n}{}", c.cpu_s(), c.wall_s, if c.ok { "" } else { "  FAILED" });
        tests.push((n, c));
    }
    Ok(BinaryCpu { name: e.name.clone(), whole, tests })
}

/// `cargo xtask test-cpu [--top N] [--alone N] [--baseline FILE] [--save-estimates] TARGET
/// ...` (`--json FILE` instead of `json_path`; a target `TARGET=PATH` measures the executable at PATH, built before, as TARGET's); `estimates` is the stored estimates file (`--save-estimates` merges the measured
/// binaries' wall times into it).
pub fn run(args: &[String], root: &Path, json_path: &Path, estimates: &Path) -> Result<()> {
    let mut top = 20;
    let mut save = false;
    let mut json_file: Option<PathBuf> = None;
    let mut alone = 20;
    let mut baseline: Option<PathBuf> = None;
    let mut targets = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--top" => {
                let v = it.next().ok_or("test-cpu: --top needs a number")?;
                top = v.parse().map_err(|_| format!("test-cpu: --top `{v}` is not a count"))?;
            }
            "--alone" => {
                let v = it.next().ok_or("test-cpu: --alone needs a number")?;
                alone = v.parse().map_err(|_| format!("test-cpu: --alone `{v}` is not a count"))?;
            }
            "--save-estimates" => save = true,
            "--json" => json_file = Some(PathBuf::from(it.next().ok_or("test-cpu: --json needs a file")?)),
            "--baseline" => baseline = Some(PathBuf::from(it.next().ok_or("test-cpu: --baseline needs a file")?)),
            t if t.starts_with('-') => return Err(format!("test-cpu: unknown option `{t}`")),
            t => targets.push(t.to_string()),
        }
    }
    let json_path = json_file.as_deref().unwrap_or(json_path);
    let read = |p: &Path| -> Result<serde_json::Value> {
        let text = std::fs::read_to_string(p).map_err(|e| format!("test-cpu: {}: {e}", p.display()))?;
        serde_json::from_str(&text).map_err(|e| format!("test-cpu: {}: {e}", p.display()))
    };
    let before = match &baseline {
        Some(p) => read_binaries(&read(p)?),
        None => Vec::new(),
    };
    // Every binary built before any runs: an edit made while they run changes nothing.
    // `TARGET=PATH`: an executable built before (e.g. the binary before a change), not built.
    let (prebuilt, to_build): (Vec<String>, Vec<String>) = targets.iter().cloned().partition(|t| t.contains('='));
    let mut exes = if to_build.is_empty() { Vec::new() } else { build(root, &to_build)? };
    for t in &prebuilt {
        exes.push(prebuilt_executable(root, t)?);
    }
    let mut measured = Vec::new();
    for e in &exes {
        measured.push(measure_binary(e, alone)?);
    }
    let old = if json_path.exists() { read_binaries(&read(json_path)?) } else { Vec::new() };
    let all = merge(old, &measured);
    let mut v = crate::steps::cpu_and_load();
    v["binaries"] = all.iter().map(BinaryCpu::json).collect::<Vec<_>>().into();
    let text = serde_json::to_string_pretty(&v).map_err(|e| format!("test-cpu: JSON: {e}"))?;
    std::fs::write(json_path, text + "\n").map_err(|e| format!("test-cpu: {}: {e}", json_path.display()))?;
    if save {
        // Merged into the stored estimates: each measured binary's wall time alone.
        let text = std::fs::read_to_string(estimates).unwrap_or_default();
        let old: serde_json::Value = serde_json::from_str(&text).unwrap_or(serde_json::Value::Null);
        let mut seconds = crate::host_tests::read_estimates(&old);
        // Without targets: every binary of the JSON.
        let from = if measured.is_empty() { &all } else { &measured };
        seconds.extend(from.iter().map(|b| (b.name.clone(), b.whole.wall_s)));
        let e = crate::host_tests::estimates_of(&seconds, &v["load_average_1_5_15_min"]);
        let text = serde_json::to_string_pretty(&e).map_err(|err| format!("test-cpu: JSON: {err}"))? + "\n";
        std::fs::write(estimates, text).map_err(|err| format!("test-cpu: {}: {err}", estimates.display()))?;
        println!("test-cpu: saved the binaries' wall seconds to {}", estimates.display());
    }
    let shown: Vec<BinaryCpu> = if measured.is_empty() { all } else { measured };
    print!("{}", markdown(&shown, &before, top));
    println!("\nLoad average at the end: {}.", v["load_average_1_5_15_min"].as_str().unwrap_or("?"));
    let failed: Vec<String> = shown
        .iter()
        .flat_map(|b| {
            let whole = (!b.whole.ok).then(|| b.name.clone());
            whole.into_iter().chain(b.tests.iter().filter(|t| !t.1.ok).map(|t| format!("{} {}", b.name, t.0)))
        })
        .collect();
    if failed.is_empty() { Ok(()) } else { Err(format!("test-cpu: failed: {}", failed.join(", "))) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_child_s_cpu_and_exit_are_measured() {
        // A busy loop of the shell: some user CPU, and the exit code read.
        let (c, out) =
            measure(Command::new("sh").args(["-c", "i=0; while [ $i -lt 20000 ]; do i=$((i+1)); done; echo $i"]))
                .unwrap();
        assert!(c.ok && c.cpu_s() > 0.0 && c.wall_s >= c.cpu_s() * 0.5, "{c:?}");
        assert_eq!(out, "20000\n");
        let (c, _) = measure(Command::new("sh").args(["-c", "exit 3"])).unwrap();
        assert!(!c.ok);
        assert!(measure(&mut Command::new("/nonexistent/program")).is_err());
    }

    #[test]
    fn targets_name_their_package_flag_and_label() {
        assert_eq!(parse_target("furuta"), ("furuta".into(), vec!["--lib".into()], "furuta src/lib.rs".into()));
        assert_eq!(
            parse_target("ssmctl:commands"),
            ("ssmctl".into(), vec!["--test".into(), "commands".into()], "ssmctl tests/commands.rs".into())
        );
    }

    #[test]
    fn runs_merge_by_binary_and_read_back() {
        let cost = |cpu: f64| Cost { user_s: cpu, sys_s: 0.5, wall_s: cpu, ok: true };
        let b = |name: &str, cpu: f64| BinaryCpu {
            name: name.into(),
            whole: cost(cpu),
            tests: vec![("t1".into(), cost(cpu / 2.0)), ("t2".into(), cost(1.0))],
        };
        let old = vec![b("x src/lib.rs", 10.0), b("y tests/a.rs", 4.0)];
        let all = merge(old.clone(), &[b("y tests/a.rs", 2.0), b("z src/lib.rs", 1.0)]);
        let names: Vec<&str> = all.iter().map(|b| b.name.as_str()).collect();
        assert_eq!(names, ["x src/lib.rs", "y tests/a.rs", "z src/lib.rs"]);
        assert_eq!(all[1].whole.user_s, 2.0);
        let v = serde_json::json!({"binaries": all.iter().map(BinaryCpu::json).collect::<Vec<_>>()});
        assert_eq!(read_binaries(&v), all);
        let md = markdown(&all[..2], &old, 1);
        // The binaries with their before, then each one's costliest test only.
        assert!(md.contains("| x src/lib.rs | 2 | 10.5 | 10.5 | 10.0 | 1.05 |"), "{md}");
        assert!(md.contains("| y tests/a.rs | 2 | 4.5 | 2.5 | 2.0 | 1.25 |"), "{md}");
        assert!(md.contains("| `t1` | 5.5 | 5.5 | 5.0 |") && md.contains("| `t1` | 2.5 | 1.5 | 1.0 |"), "{md}");
        assert!(!md.contains("`t2`"), "{md}");
    }
}
