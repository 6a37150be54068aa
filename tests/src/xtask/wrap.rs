//! The host build's compiler wrapper: cargo runs the xtask binary itself as
//! `RUSTC_WORKSPACE_WRAPPER` (`xtask /path/to/rustc ARGS`), so that one compile of each
//! workspace crate serves the test build, the lint policy, the API docs and the lab check.
//!
//! `cargo clippy`, `cargo doc` and `cargo check` would each need the dependencies' metadata
//! from check units of their own (cargo never reads a build unit's metadata for a check), a
//! second front-end pass over the whole dependency graph. Here, beside the build's `rustc` of a
//! library under the lint policy `clippy-driver` checks the same arguments (its metadata into a
//! folder of its own), and beside that of a documented library `rustdoc` documents them, both
//! against the dependencies' metadata the build already made; the lab's library and examples are compiled to metadata only (checked, not
//! linked: nothing runs them in the suite), with empty files where cargo expects the rlib and
//! the executables. What is asked comes in environment variables ([`Plan::from_env`]); without
//! them, and for every other crate, the wrapper runs `rustc` unchanged.

use std::ffi::{OsStr, OsString};
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};

/// Packages whose library is linted (comma-separated).
pub const ENV_LINT: &str = "XTASK_WRAP_LINT";
/// Packages whose library is documented (comma-separated).
pub const ENV_DOC: &str = "XTASK_WRAP_DOC";
/// Packages compiled to metadata only (comma-separated).
pub const ENV_CHECK_ONLY: &str = "XTASK_WRAP_CHECK_ONLY";
/// The `clippy-driver` that lints.
pub const ENV_CLIPPY: &str = "XTASK_WRAP_CLIPPY";
/// Where the API docs go (cargo doc's `target/doc`).
pub const ENV_DOC_DIR: &str = "XTASK_WRAP_DOC_DIR";
/// Where clippy's metadata goes (never the build's `deps/`).
pub const ENV_LINT_DIR: &str = "XTASK_WRAP_LINT_DIR";

/// The arguments clippy-driver gets (as `cargo clippy -- -A clippy::all` gives them): only the
/// lints the crates deny themselves.
pub const CLIPPY_ARGS: &str = "-A__CLIPPY_HACKERY__clippy::all__CLIPPY_HACKERY__";

/// Is this process cargo's call of the wrapper: the first argument is a `rustc`?
pub fn is_wrapper_call(args: &[OsString]) -> bool {
    args.get(1).and_then(|a| Path::new(a).file_stem()).is_some_and(|s| s == "rustc")
}

/// What the host build asks of the wrapper.
#[derive(Debug)]
pub struct Plan {
    pub lint: Vec<String>,
    pub doc: Vec<String>,
    pub check_only: Vec<String>,
    pub clippy: PathBuf,
    pub doc_dir: PathBuf,
    pub lint_dir: PathBuf,
}

impl Plan {
    /// The plan in the environment, `None` when the build asks for nothing but compiles.
    pub fn from_env() -> Result<Option<Plan>, String> {
        let list = |k: &str| -> Vec<String> {
            std::env::var(k).unwrap_or_default().split(',').filter(|s| !s.is_empty()).map(str::to_string).collect()
        };
        let (lint, doc, check_only) = (list(ENV_LINT), list(ENV_DOC), list(ENV_CHECK_ONLY));
        if lint.is_empty() && doc.is_empty() && check_only.is_empty() {
            return Ok(None);
        }
        let path =
            |k: &str| std::env::var_os(k).map(PathBuf::from).ok_or_else(|| format!("xtask wrapper: {k} is not set"));
        let (clippy, lint_dir) =
            if lint.is_empty() { Default::default() } else { (path(ENV_CLIPPY)?, path(ENV_LINT_DIR)?) };
        let doc_dir = if doc.is_empty() { PathBuf::new() } else { path(ENV_DOC_DIR)? };
        Ok(Some(Plan { lint, doc, check_only, clippy, doc_dir, lint_dir }))
    }

    /// The environment that asks for this plan.
    pub fn env(&self) -> Vec<(&'static str, OsString)> {
        vec![
            (ENV_LINT, self.lint.join(",").into()),
            (ENV_DOC, self.doc.join(",").into()),
            (ENV_CHECK_ONLY, self.check_only.join(",").into()),
            (ENV_CLIPPY, self.clippy.clone().into()),
            (ENV_DOC_DIR, self.doc_dir.clone().into()),
            (ENV_LINT_DIR, self.lint_dir.clone().into()),
        ]
    }
}

/// What a `rustc` command line compiles, read from cargo's arguments.
#[derive(Debug, PartialEq)]
struct Unit {
    crate_name: String,
    crate_types: Vec<String>,
    is_test: bool,
    out_dir: PathBuf,
    extra_filename: String,
}

/// Options of rustc that take their value as the next argument.
const WITH_VALUE: &[&str] = &[
    "--crate-name",
    "--crate-type",
    "--edition",
    "--cfg",
    "--check-cfg",
    "-L",
    "-l",
    "--extern",
    "-C",
    "--codegen",
    "--out-dir",
    "-o",
    "--emit",
    "--error-format",
    "--json",
    "--target",
    "--cap-lints",
    "-A",
    "-W",
    "-D",
    "-F",
    "--print",
    "--sysroot",
    "--explain",
    "--diagnostic-width",
    "--color",
    "--env-set",
];

/// One option of a command line: its name (`""` for a lone argument such as the source
/// file), its value, and the arguments it was written as (`--opt=value` or `--opt value`).
struct Opt {
    key: String,
    value: String,
    written: Vec<String>,
}

/// Splits a command line into options.
fn options(args: &[String]) -> Vec<Opt> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < args.len() {
        let a = &args[i];
        let (key, value, n) = if let Some((k, v)) = a.split_once('=').filter(|(k, _)| k.starts_with("--")) {
            (k.to_string(), v.to_string(), 1)
        } else if WITH_VALUE.contains(&a.as_str()) && i + 1 < args.len() {
            (a.clone(), args[i + 1].clone(), 2)
        } else if a.starts_with('-') {
            (a.clone(), String::new(), 1)
        } else {
            (String::new(), a.clone(), 1)
        };
        out.push(Opt { key, value, written: args[i..i + n].to_vec() });
        i += n;
    }
    out
}

fn unit(args: &[String]) -> Option<Unit> {
    let opts = options(args);
    let get = |k: &str| opts.iter().find(|o| o.key == k).map(|o| o.value.clone());
    let codegen = |k: &str| {
        opts.iter()
            .filter(|o| o.key == "-C" || o.key == "--codegen")
            .find_map(|o| o.value.strip_prefix(k).and_then(|r| r.strip_prefix('=')).map(str::to_string))
    };
    Some(Unit {
        crate_name: get("--crate-name")?,
        crate_types: opts.iter().filter(|o| o.key == "--crate-type").map(|o| o.value.clone()).collect(),
        is_test: opts.iter().any(|o| o.key == "--test"),
        out_dir: PathBuf::from(get("--out-dir")?),
        extra_filename: codegen("extra-filename").unwrap_or_default(),
    })
}

/// Rebuilds a command line: each option as written, replaced (`Some(args)`) or dropped
/// (`Some(vec![])`) where `change` says.
fn rebuild(args: &[String], mut change: impl FnMut(&str, &str) -> Option<Vec<String>>) -> Vec<String> {
    let mut out = Vec::new();
    for o in options(args) {
        match change(&o.key, &o.value) {
            Some(args) => out.extend(args),
            None => out.extend(o.written),
        }
    }
    out
}

/// clippy-driver's arguments: the build's, emitting metadata into `lint_dir`, diagnostics
/// rendered for people (they are shown only when a lint fails), and without the build's
/// incremental session folder, which the build's `rustc` is using at the same time.
fn clippy_args(args: &[String], lint_dir: &Path) -> Vec<String> {
    rebuild(args, |k, v| match k {
        "--emit" => Some(vec!["--emit=metadata".into()]),
        "--out-dir" => Some(vec!["--out-dir".into(), lint_dir.display().to_string()]),
        "--error-format" | "--json" => Some(Vec::new()),
        "-C" | "--codegen" if v.starts_with("incremental=") => Some(Vec::new()),
        _ => None,
    })
}

/// rustdoc's arguments: what names the crate, its features and cfgs, its dependencies and its
/// source, as cargo doc passes them, into `doc_dir` with warnings denied.
fn rustdoc_args(args: &[String], doc_dir: &Path, version: &str) -> Vec<String> {
    let mut out = rebuild(args, |k, _| match k {
        "" | "--crate-name" | "--crate-type" | "--edition" | "--cfg" | "--check-cfg" | "-L" | "--extern" => None,
        _ => Some(Vec::new()),
    });
    out.extend(["-o".into(), doc_dir.display().to_string(), "-D".into(), "warnings".into()]);
    if !version.is_empty() {
        out.extend(["--crate-version".into(), version.to_string()]);
    }
    out
}

/// A metadata-only compile's arguments: no linking, and the check-only libraries it depends on
/// read from their metadata (their rlib is an empty stand-in).
fn check_args(args: &[String]) -> Vec<String> {
    rebuild(args, |k, v| match k {
        "--emit" => Some(vec!["--emit=dep-info,metadata".into()]),
        "--extern" => {
            let (name, path) = v.split_once('=').unwrap_or((v, ""));
            let rlib = Path::new(path);
            let stand_in = rlib.extension() == Some(OsStr::new("rlib"))
                && std::fs::metadata(rlib).is_ok_and(|m| m.len() == 0)
                && rlib.with_extension("rmeta").exists();
            stand_in.then(|| vec!["--extern".into(), format!("{name}={}", rlib.with_extension("rmeta").display())])
        }
        _ => None,
    })
}

/// The files cargo expects from a linking compile, which a metadata-only compile leaves out.
fn stand_ins(u: &Unit) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for t in &u.crate_types {
        match t.as_str() {
            "lib" | "rlib" => out.push(u.out_dir.join(format!("lib{}{}.rlib", u.crate_name, u.extra_filename))),
            "bin" => out.push(u.out_dir.join(format!("{}{}", u.crate_name, u.extra_filename))),
            _ => {}
        }
    }
    out
}

/// The wrapper's entry: `args` are the xtask's own (`xtask RUSTC ARGS...`).
pub fn main(args: Vec<OsString>) -> ExitCode {
    match run(args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("xtask wrapper: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Vec<OsString>) -> Result<ExitCode, String> {
    let rustc = PathBuf::from(&args[1]);
    let plan = Plan::from_env()?;
    let package = std::env::var("CARGO_PKG_NAME").unwrap_or_default();
    let version = std::env::var("CARGO_PKG_VERSION").unwrap_or_default();
    compile(&rustc, &args[2..], plan.as_ref(), &package, &version)
}

/// Runs `rustc ARGS` for cargo's unit of `package` and what `plan` asks beside it.
fn compile(
    rustc: &Path,
    rest: &[OsString],
    plan: Option<&Plan>,
    package: &str,
    version: &str,
) -> Result<ExitCode, String> {
    let text: Option<Vec<String>> = rest.iter().map(|a| a.to_str().map(str::to_string)).collect();
    let (Some(plan), Some(text)) = (plan, text) else { return status(Command::new(rustc).args(rest)) };
    let Some(u) = unit(&text) else { return status(Command::new(rustc).args(rest)) };
    if plan.check_only.iter().any(|p| p == package) {
        let code = status(Command::new(rustc).args(check_args(&text)))?;
        if code == ExitCode::SUCCESS {
            for f in stand_ins(&u) {
                std::fs::write(&f, b"").map_err(|e| format!("writing the stand-in {}: {e}", f.display()))?;
            }
        }
        return Ok(code);
    }
    let is_lib = u.crate_types.iter().any(|t| t == "lib" || t == "rlib");
    let lint = plan.lint.iter().any(|p| p == package) && is_lib && !u.is_test;
    let doc = plan.doc.iter().any(|p| p == package) && is_lib && !u.is_test;
    if !lint && !doc {
        return status(Command::new(rustc).args(rest));
    }
    let spawn = |c: &mut Command, what: &str| c.spawn().map_err(|e| format!("cannot start {what}: {e}"));
    let mut build = spawn(Command::new(rustc).args(rest), "rustc")?;
    let mut checks = Vec::new();
    if lint {
        std::fs::create_dir_all(&plan.lint_dir).map_err(|e| format!("{}: {e}", plan.lint_dir.display()))?;
        let mut c = Command::new(&plan.clippy);
        c.arg(rustc).args(clippy_args(&text, &plan.lint_dir)).env("CLIPPY_ARGS", CLIPPY_ARGS);
        checks.push((
            "clippy (the crate's lint policy)",
            spawn(c.stdout(Stdio::piped()).stderr(Stdio::piped()), "clippy-driver")?,
        ));
    }
    if doc {
        let rustdoc = rustc.with_file_name(match rustc.extension() {
            Some(ext) => format!("rustdoc.{}", ext.to_string_lossy()),
            None => "rustdoc".into(),
        });
        let mut c = Command::new(&rustdoc);
        c.args(rustdoc_args(&text, &plan.doc_dir, version));
        checks.push(("rustdoc (warnings denied)", spawn(c.stdout(Stdio::piped()).stderr(Stdio::piped()), "rustdoc")?));
    }
    let built = build.wait().map_err(|e| format!("rustc: {e}"))?;
    let mut failed = false;
    for (what, child) in checks {
        let o = child.wait_with_output().map_err(|e| format!("{what}: {e}"))?;
        if built.success() && !o.status.success() {
            failed = true;
            eprintln!("xtask wrapper: {what} failed for package `{package}` ({}):", o.status);
            eprint!("{}{}", String::from_utf8_lossy(&o.stdout), String::from_utf8_lossy(&o.stderr));
        }
    }
    if !built.success() {
        return Ok(exit_code(built));
    }
    Ok(if failed { ExitCode::FAILURE } else { ExitCode::SUCCESS })
}

fn status(c: &mut Command) -> Result<ExitCode, String> {
    let s = c.status().map_err(|e| format!("cannot start {c:?}: {e}"))?;
    Ok(exit_code(s))
}

fn exit_code(s: std::process::ExitStatus) -> ExitCode {
    match s.code() {
        Some(0) => ExitCode::SUCCESS,
        Some(c) => ExitCode::from(u8::try_from(c).unwrap_or(1)),
        None => ExitCode::FAILURE,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|x| x.to_string()).collect()
    }

    const LIB: &[&str] = &[
        "--crate-name",
        "sim",
        "--edition=2024",
        "host/sim/src/lib.rs",
        "--error-format=json",
        "--json=diagnostic-rendered-ansi,artifacts,future-incompat",
        "--crate-type",
        "lib",
        "--emit=dep-info,metadata,link",
        "-C",
        "opt-level=2",
        "--cfg",
        "feature=\"std\"",
        "--check-cfg",
        "cfg(feature, values(\"std\"))",
        "-C",
        "metadata=ab",
        "-C",
        "extra-filename=-cd",
        "--out-dir",
        "/t/debug/deps",
        "-L",
        "dependency=/t/debug/deps",
        "--extern",
        "faer=/t/debug/deps/libfaer-12.rmeta",
    ];

    #[test]
    fn reads_what_a_command_line_compiles() {
        let u = unit(&s(LIB)).unwrap();
        assert_eq!(
            u,
            Unit {
                crate_name: "sim".into(),
                crate_types: vec!["lib".into()],
                is_test: false,
                out_dir: "/t/debug/deps".into(),
                extra_filename: "-cd".into()
            }
        );
        assert_eq!(stand_ins(&u), [PathBuf::from("/t/debug/deps/libsim-cd.rlib")]);
        let bin = s(&[
            "--crate-name",
            "plant_forms",
            "x.rs",
            "--crate-type",
            "bin",
            "--out-dir",
            "/o",
            "-C",
            "extra-filename=-9",
        ]);
        assert_eq!(stand_ins(&unit(&bin).unwrap()), [PathBuf::from("/o/plant_forms-9")]);
        assert!(unit(&s(&["-vV"])).is_none());
        assert!(unit(&s(&["--crate-name", "t", "--test", "--out-dir", "/o"])).unwrap().is_test);
    }

    #[test]
    fn clippy_checks_the_same_crate_into_its_own_folder() {
        let a = clippy_args(&s(LIB), Path::new("/t/lint"));
        assert!(a.contains(&"--emit=metadata".to_string()));
        assert!(a.windows(2).any(|w| w == ["--out-dir", "/t/lint"]));
        assert!(!a.iter().any(|x| x.starts_with("--error-format") || x.starts_with("--json") || x == "/t/debug/deps"));
        assert!(a.windows(2).any(|w| w == ["--extern", "faer=/t/debug/deps/libfaer-12.rmeta"]));
        assert!(a.windows(2).any(|w| w == ["-C", "opt-level=2"]));
        // The build's incremental session folder stays the build's own.
        let mut incremental = s(LIB);
        incremental.extend(s(&["-C", "incremental=/t/debug/incremental", "--codegen=incremental=/t/i2"]));
        let a = clippy_args(&incremental, Path::new("/t/lint"));
        assert!(!a.iter().any(|x| x.contains("incremental")), "{a:?}");
        assert_eq!(a.len(), clippy_args(&s(LIB), Path::new("/t/lint")).len());
    }

    #[test]
    fn rustdoc_gets_the_crate_its_cfgs_and_its_dependencies_only() {
        let a = rustdoc_args(&s(LIB), Path::new("/t/doc"), "0.1.0");
        assert_eq!(
            a,
            s(&[
                "--crate-name",
                "sim",
                "--edition=2024",
                "host/sim/src/lib.rs",
                "--crate-type",
                "lib",
                "--cfg",
                "feature=\"std\"",
                "--check-cfg",
                "cfg(feature, values(\"std\"))",
                "-L",
                "dependency=/t/debug/deps",
                "--extern",
                "faer=/t/debug/deps/libfaer-12.rmeta",
                "-o",
                "/t/doc",
                "-D",
                "warnings",
                "--crate-version",
                "0.1.0",
            ])
        );
    }

    #[test]
    fn a_check_reads_stand_in_libraries_from_their_metadata() {
        let dir = std::env::temp_dir().join(format!("xtask-wrap-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (rlib, rmeta, real) = (dir.join("liblab-1.rlib"), dir.join("liblab-1.rmeta"), dir.join("libsim-2.rlib"));
        std::fs::write(&rlib, b"").unwrap();
        std::fs::write(&rmeta, b"meta").unwrap();
        std::fs::write(&real, b"code").unwrap();
        let args = s(&[
            "--crate-name",
            "plant_forms",
            "--emit=dep-info,link",
            "--extern",
            &format!("lab={}", rlib.display()),
            "--extern",
            &format!("sim={}", real.display()),
        ]);
        let a = check_args(&args);
        assert!(a.contains(&"--emit=dep-info,metadata".to_string()));
        assert!(a.contains(&format!("lab={}", rmeta.display())));
        assert!(a.contains(&format!("sim={}", real.display())));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A library of `body` compiled as cargo would, with the plan's lints and docs beside it.
    fn compile_lib(dir: &Path, body: &str) -> ExitCode {
        let sysroot = std::process::Command::new("rustc").args(["--print", "sysroot"]).output().unwrap();
        let bin = PathBuf::from(String::from_utf8(sysroot.stdout).unwrap().trim()).join("bin");
        std::fs::create_dir_all(dir.join("out")).unwrap();
        let src = dir.join("lib.rs");
        std::fs::write(&src, body).unwrap();
        let plan = Plan {
            lint: vec!["probe".into()],
            doc: vec!["probe".into()],
            check_only: Vec::new(),
            clippy: bin.join("clippy-driver"),
            doc_dir: dir.join("doc"),
            lint_dir: dir.join("lint"),
        };
        std::fs::create_dir_all(&plan.lint_dir).unwrap();
        let args: Vec<OsString> = [
            "--crate-name",
            "probe",
            "--edition=2021",
            src.to_str().unwrap(),
            "--error-format=json",
            "--crate-type",
            "lib",
            "--emit=dep-info,metadata,link",
            "-C",
            "extra-filename=-0",
            "--out-dir",
            dir.join("out").to_str().unwrap(),
        ]
        .iter()
        .map(OsString::from)
        .collect();
        compile(&bin.join("rustc"), &args, Some(&plan), "probe", "0.1.0").unwrap()
    }

    #[test]
    fn a_lint_or_a_broken_doc_link_fails_the_compile_and_a_clean_crate_passes() {
        let dir = std::env::temp_dir().join(format!("xtask-wrap-probe-{}", std::process::id()));
        let policy = "#![deny(clippy::unwrap_used)]\n";
        let clean = format!("{policy}/// Doubles [`u8`]s.\npub fn f(v: Option<u8>) -> u8 {{ v.unwrap_or(0) * 2 }}\n");
        assert_eq!(compile_lib(&dir.join("clean"), &clean), ExitCode::SUCCESS);
        assert!(dir.join("clean/doc/probe/index.html").exists(), "rustdoc wrote no docs");
        assert!(dir.join("clean/out/libprobe-0.rlib").exists(), "rustc wrote no rlib");
        let lint = format!("{policy}/// Unwraps.\npub fn f(v: Option<u8>) -> u8 {{ v.unwrap() }}\n");
        assert_eq!(compile_lib(&dir.join("lint"), &lint), ExitCode::FAILURE);
        let link = format!("{policy}/// See [`Missing`].\npub fn f() {{}}\n");
        assert_eq!(compile_lib(&dir.join("link"), &link), ExitCode::FAILURE);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn only_a_rustc_as_first_argument_is_a_wrapper_call() {
        let os = |v: &[&str]| v.iter().map(OsString::from).collect::<Vec<_>>();
        assert!(is_wrapper_call(&os(&["xtask", "/r/bin/rustc", "-vV"])));
        assert!(!is_wrapper_call(&os(&["xtask", "test"])));
        assert!(!is_wrapper_call(&os(&["xtask"])));
    }
}
