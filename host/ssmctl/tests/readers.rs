//! Every reader is bounded and refuses what is not a regular file by
//! name, sizes declared inside a file or an option are checked before allocating, nesting is
//! bounded, numbers that mean nothing are refused naming their key, shard files are checked
//! against the spec they embed, and errors are words naming the file, option or key. Each
//! case runs the test-built `ssmctl` and expects exit 1 within seconds (never a panic, an
//! abort, a hang or gigabytes).

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Runs `ssmctl --quiet ARGS` with a 60 s deadline (killed after it): (exit code, stderr).
fn ssmctl(args: &[&str]) -> (Option<i32>, String) {
    let t0 = Instant::now();
    let mut child = Command::new(env!("CARGO_BIN_EXE_ssmctl"))
        .arg("--quiet")
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run ssmctl");
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if t0.elapsed() > Duration::from_secs(60) {
            child.kill().unwrap();
            child.wait().unwrap();
            panic!("{args:?}: still running after 60 s (a hang)");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let o = child.wait_with_output().unwrap();
    (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// Exit 1 with every `parts` in the message, which is words: no `Debug` text, no bare OS
/// error number.
fn refused(args: &[&str], parts: &[&str]) -> String {
    let (code, err) = ssmctl(args);
    assert_eq!(code, Some(1), "{args:?}: expected exit 1, stderr: {err}");
    for p in parts {
        assert!(err.contains(p), "{args:?}: stderr does not contain {p:?}:\n{err}");
    }
    for debug in ["os error", "Invalid {", "Some(", "Err(", "Status"] {
        assert!(!err.contains(debug), "{args:?}: Rust debug text `{debug}` in:\n{err}");
    }
    err
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ssmctl-readers-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn mkfifo(p: &Path) {
    let c = std::ffi::CString::new(s(p)).unwrap();
    // SAFETY: a valid NUL-terminated path; mkfifo only creates the node.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0, "mkfifo {}", p.display());
}

/// A v5 `.mat` header followed by `elements`.
fn mat(elements: &[u8]) -> Vec<u8> {
    let mut b = b"MATLAB 5.0 MAT-file, readers test".to_vec();
    b.resize(124, b' ');
    b.extend_from_slice(&0x0100u16.to_le_bytes());
    b.extend_from_slice(b"IM");
    b.extend_from_slice(elements);
    b
}

fn element(ty: u32, data: &[u8]) -> Vec<u8> {
    let mut b = ty.to_le_bytes().to_vec();
    b.extend_from_slice(&(data.len() as u32).to_le_bytes());
    b.extend_from_slice(data);
    b.resize(8 + data.len().div_ceil(8) * 8, 0);
    b
}

/// An `miMATRIX` of `class` with `dims` and `name`, then `rest`.
fn matrix(class: u32, dims: &[i32], name: &str, rest: &[u8]) -> Vec<u8> {
    let mut body = element(6, &[class.to_le_bytes(), [0; 4]].concat());
    body.extend(element(5, &dims.iter().flat_map(|d| d.to_le_bytes()).collect::<Vec<_>>()));
    body.extend(element(1, name.as_bytes()));
    body.extend_from_slice(rest);
    element(14, &body)
}

#[test]
fn mat_sizes_and_nesting_are_checked_before_allocating() {
    let d = tmp("mat");
    // The issue's 184-byte file: a cell claiming 2147483647 x 2147483647 elements.
    let bomb = mat(&matrix(1, &[i32::MAX, i32::MAX], "xData", &[]));
    assert_eq!(bomb.len(), 184);
    let p = d.join("bomb.mat");
    std::fs::write(&p, &bomb).unwrap();
    refused(
        &["fit", "--mat", s(&p), "--dim", "2", "--embed", "2"],
        &[
            s(&p),
            "xData: a 2147483647x2147483647 cell array: 4611686014132420609 entries",
            "over the limit of 100000000",
        ],
    );
    // Cells nested 5000 deep (a stack overflow before): refused at the depth limit.
    let mut inner = matrix(6, &[0, 0], "", &[]);
    for _ in 0..5000 {
        inner = matrix(1, &[1, 1], "", &inner);
    }
    let p = d.join("deep.mat");
    std::fs::write(&p, mat(&matrix(1, &[1, 1], "xData", &inner))).unwrap();
    refused(&["fit", "--mat", s(&p), "--dim", "2", "--embed", "2"], &[s(&p), "cell arrays nested more than 16 deep"]);
    // A cell whose element count is within the limit but not within the bytes that follow.
    let p = d.join("short.mat");
    std::fs::write(&p, mat(&matrix(1, &[1000, 1000], "xData", &[]))).unwrap();
    refused(
        &["fit", "--mat", s(&p), "--dim", "2", "--embed", "2"],
        &[s(&p), "a 1000x1000 cell array claims 1000000 elements but only 0 bytes follow"],
    );
    // A 1x1 double whose real part holds 2^24 one-byte values: refused before conversion.
    let p = d.join("mismatch.mat");
    std::fs::write(&p, mat(&matrix(6, &[1, 1], "xData", &element(2, &vec![0u8; 1 << 24])))).unwrap();
    refused(&["fit", "--mat", s(&p), "--dim", "2", "--embed", "2"], &[s(&p), "16777216 values for dimensions 1x1"]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn non_regular_files_are_refused_by_name_without_blocking() {
    let d = tmp("kinds");
    let fifo = d.join("fifo");
    mkfifo(&fifo);
    let out = d.join("out");
    let fifo_s = s(&fifo);
    let fifo_toml = d.join("fifo.toml");
    mkfifo(&fifo_toml);
    let cases: Vec<Vec<&str>> = vec![
        vec!["fit", "--data", fifo_s, "--column", "theta", "--dim", "2", "--embed", "5"],
        vec!["fit", "--data", fifo_s, "--observables", "all", "--dim", "2", "--embed", "5"],
        vec!["fit", "--mat", fifo_s, "--dim", "2", "--embed", "5"],
        vec!["export", "--model", fifo_s, "--out", "/nonexistent/x.bin"],
        vec!["backbone", "--model", fifo_s, "--out", s(&out), "--amplitude", "0.1"],
        vec!["inspect", fifo_s],
        vec!["stability", "--scene", s(&fifo_toml)],
        vec!["sweep", fifo_s, "--out", s(&out)],
        vec!["chaos", "--data", fifo_s],
    ];
    for a in &cases {
        refused(a, &["FIFO (named pipe), not a regular file"]);
    }
    refused(&["inspect", "/dev/zero"], &["/dev/zero", "a character device, not a regular file"]);
    refused(
        &["export", "--model", "/dev/zero", "--out", "/nonexistent/x.bin"],
        &["--model /dev/zero", "a character device"],
    );
    let dir_toml = d.join("dir.toml");
    std::fs::create_dir_all(&dir_toml).unwrap();
    refused(&["stability", "--scene", s(&dir_toml)], &[s(&dir_toml), "a directory, not a regular file"]);
    refused(
        &["fit", "--data", "/nonexistent/a.csv", "--dim", "2", "--embed", "5"],
        &["/nonexistent/a.csv", "no such file"],
    );
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn the_issue_commands_are_refused_quickly() {
    let d = tmp("issue");
    // A sweep axis of n = 1e9: refused before its values are allocated.
    let spec = d.join("huge.toml");
    std::fs::write(
        &spec,
        "name = \"huge\"\nkind = \"chart\"\nscene = \"furuta-dt25\"\n[[axes]]\nname = \"kp\"\nlo = 0.0\nhi = 40.0\nn = 1000000000\n[[axes]]\nname = \"kd\"\nlo = 0.0\nhi = 8.0\nn = 2\n",
    )
    .unwrap();
    let t0 = Instant::now();
    refused(&["sweep", s(&spec), "--out", s(&d.join("o"))], &["`axes[0]` (kp)", "n = 1000000000", "100000000 cells"]);
    assert!(t0.elapsed() < Duration::from_secs(20), "took {:?}", t0.elapsed());
    // A chart sweep of 1000 sampling periods: 1000 figure panels, past the chart's limit
    // (it was computed and accepted); refused naming the axis, like `stability-chart --dt-ms`.
    let panels = d.join("panels.toml");
    let dts: Vec<String> = (0..1000).map(|i| format!("{}", 20.0 + 0.01 * f64::from(i))).collect();
    std::fs::write(
        &panels,
        format!(
            "name = \"panels\"\nkind = \"chart\"\nscene = \"furuta-dt25\"\n[[axes]]\nname = \"dt_ms\"\nvalues = [{}]\n[[axes]]\nname = \"kp\"\nlo = 0.0\nhi = 40.0\nn = 3\n[[axes]]\nname = \"kd\"\nlo = 0.0\nhi = 8.0\nn = 2\n",
            dts.join(", ")
        ),
    )
    .unwrap();
    refused(&["sweep", s(&panels), "--out", s(&d.join("p"))], &["`axes[0]`", "`dt_ms` has 1000 values", "at most 64"]);
    // backbone --model out/backbone.json: a backbone result is not a model, said with its name.
    let out = d.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let bb = out.join("backbone.json");
    std::fs::write(&bb, "{\"observable\": \"1\", \"curves\": []}").unwrap();
    refused(&["backbone", "--model", s(&bb), "--out", s(&out), "--amplitude", "0.1"], &[s(&bb), "model"]);
    assert_eq!(std::fs::read_to_string(&bb).unwrap(), "{\"observable\": \"1\", \"curves\": []}");
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn nesting_of_scenes_specs_and_set_keys_is_bounded() {
    let d = tmp("nest");
    let p = d.join("deep.toml");
    std::fs::write(&p, format!("name = \"deep\"\ndescription = {}{}\n", "[".repeat(100_000), "]".repeat(100_000)))
        .unwrap();
    refused(&["stability", "--scene", s(&p)], &[s(&p), "nested more than 64 deep"]);
    // (One argument is at most 128 KiB on Linux.)
    let key = vec!["a"; 30_000].join(".");
    refused(
        &["stability", "--scene", "furuta-dt25", "--set", &format!("{key}=1")],
        &["30000 dotted keys", "at most 8"],
    );
    refused(
        &["stability", "--scene", "furuta-dt25", "--set", &format!("controller.kp={}", "[".repeat(100_000))],
        &["controller.kp", "nested more than 64 deep"],
    );
    let spec = d.join("spec.toml");
    std::fs::write(&spec, format!("name = \"x\"\nkind = \"chart\"\nscene = {}\n", "{a=".repeat(100_000))).unwrap();
    refused(&["sweep", s(&spec), "--out", s(&d.join("o"))], &[s(&spec), "nested more than 64 deep"]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn meaningless_numbers_are_refused_naming_their_key() {
    fn set(kv: &str) -> Vec<&str> {
        vec!["stability", "--scene", "furuta-dt25", "--set", kv]
    }
    refused(&set("integrator.rtol=1e-300"), &["`integrator.rtol`", "outside 1e-14 ..= 1e-1"]);
    refused(&set("integrator.rtol=0.5"), &["`integrator.rtol`"]);
    refused(&set("integrator.atol=1e-300"), &["`integrator.atol`"]);
    refused(
        &["stability", "--scene", "furuta-dt25", "--set", "integrator={method=\"rk4\", steps=4000000000}"],
        &["`integrator.steps`", "limit of 1000000 steps per period"],
    );
    refused(&set("controller.dt_ms=1e-310"), &["`controller.dt_ms`", "too small a sampling period"]);
    // A bad quantization step is the step's error, not the gain's.
    refused(
        &["stability", "--scene", "furuta-quant-dt25", "--set", "effects.quantization.h_adc=1e-310"],
        &["`effects.quantization.h_adc`"],
    );
    let (_, err) = ssmctl(&["stability", "--scene", "furuta-quant-dt25", "--set", "effects.quantization.h_adc=1e-310"]);
    assert!(!err.contains("`controller.kp`"), "{err}");
    // ssm-equations at a sampling period whose expansion needs unbounded work: refused by
    // the loop's linear analysis, before the expansion, under the key.
    let t0 = Instant::now();
    refused(
        &["ssm-equations", "--scene", "furuta-dt25", "--set", "controller.dt_ms=100000", "--order", "3"],
        &["`controller.dt_ms`", "dt = 100 s", "cannot be trusted"],
    );
    assert!(t0.elapsed() < Duration::from_secs(30), "took {:?}", t0.elapsed());
    // CSV times whose step the time axis cannot resolve.
    let d = tmp("num");
    let p = d.join("tiny.csv");
    let rows: Vec<String> = (0..50).map(|i| format!("{:e},{}", i as f64 * 5e-324, (i as f64 * 0.3).sin())).collect();
    std::fs::write(&p, format!("t,x\n{}\n", rows.join("\n"))).unwrap();
    refused(&["fit", "--data", s(&p), "--dim", "2", "--embed", "5"], &[s(&p), "cannot be resolved on the time axis"]);
    // Chart panels and forced-response points from options.
    let many: Vec<String> = (1..=65).map(|i| format!("{}", 20.0 + i as f64 * 0.1)).collect();
    refused(
        &["stability-chart", "--scene", "furuta-dt25", "--out", s(&d.join("c.png")), "--dt-ms", &many.join(",")],
        &["--dt-ms", "65 sampling periods", "at most 64 panels"],
    );
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn pil_elf_that_is_not_firmware_says_so() {
    let d = tmp("elf");
    let elf = d.join("notes.txt");
    std::fs::write(&elf, "hello").unwrap();
    let out = d.join("out");
    let args = |elf: &Path| {
        [
            "pil",
            "--scene",
            "furuta-quant-dt25",
            "--model",
            "/nonexistent.bin",
            "--periods",
            "5",
            "--out",
            s(&out),
            "--elf",
        ]
        .iter()
        .map(|a| a.to_string())
        .chain([s(elf).to_string()])
        .collect::<Vec<_>>()
    };
    let a = args(&elf);
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    refused(&a, &["--elf", s(&elf), "not an ELF file, not the firmware", "qemu.log"]);
    // A host program is an ELF file, but not 32-bit ARM.
    let a = args(Path::new(env!("CARGO_BIN_EXE_ssmctl")));
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    refused(&a, &["--elf", "a 64-bit ELF file", "not the firmware"]);
    let a = args(&d.join("missing.elf"));
    let a: Vec<&str> = a.iter().map(String::as_str).collect();
    refused(&a, &["--elf", "no such file", "cargo xtask pil"]);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Shard files are data: `sweep-merge` rebuilds the spec each one embeds, recomputes its
/// grid and checks every cell against it, even when the file's hash was made to match.
#[test]
fn shard_files_edited_by_hand_are_refused() {
    let d = tmp("shard");
    let spec = d.join("tiny.toml");
    std::fs::write(
        &spec,
        "name = \"tiny\"\nkind = \"chart\"\nscene = \"furuta-dt25\"\n[[axes]]\nname = \"kd\"\nlo = 0.0\nhi = 8.0\nn = 2\n[[axes]]\nname = \"kp\"\nlo = 0.0\nhi = 40.0\nn = 3\n",
    )
    .unwrap();
    let shards = d.join("shards");
    let (code, err) = ssmctl(&["sweep", s(&spec), "--out", s(&shards)]);
    assert_eq!(code, Some(0), "{err}");
    let file = shards.join("shard-000000-of-000001.json");
    let good: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&file).unwrap()).unwrap();
    // Each edit, with the spec hash recomputed so only the content checks can catch it.
    let edits: Vec<(&str, Box<dyn Fn(&mut serde_json::Value)>, &[&str])> = vec![
        ("name-with-path", Box::new(|v| v["spec"]["name"] = "../../evil".into()), &["`name`", "../../evil"]),
        (
            "grid-value-off-range",
            Box::new(|v| v["spec"]["axes"][1]["values"][1] = 21.0.into()),
            &["`axes[1]`", "not the grid of its range"],
        ),
        ("kind-swapped", Box::new(|v| v["spec"]["kind"] = "basin".into()), &["basin sweep without its basin settings"]),
        (
            "cell-of-another-kind",
            Box::new(|v| {
                v["cells"][0].as_object_mut().unwrap().remove("kind");
                v["cells"][0]["bounded"] = true.into();
            }),
            &["cell 0", "`bounded`", "does not record"],
        ),
        (
            "range-n-huge",
            Box::new(|v| v["spec"]["axes"][0]["range"]["n"] = 1_000_000_000u64.into()),
            &["`axes[0]`", "n = 1000000000"],
        ),
    ];
    for (name, edit, parts) in &edits {
        let mut v = good.clone();
        edit(&mut v);
        v["spec_hash"] = furuta::sweep::hash_value(&v["spec"]).into();
        let dir = d.join(name);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("shard-000000-of-000001.json"), v.to_string()).unwrap();
        let out = d.join(format!("{name}-out"));
        let mut want = vec!["shard-000000-of-000001.json"];
        want.extend_from_slice(parts);
        refused(&["sweep-merge", s(&dir), "--out", s(&out)], &want);
        assert!(!d.join("evil.json").exists() && !out.exists() || std::fs::read_dir(&out).unwrap().count() == 0);
    }
    std::fs::remove_dir_all(&d).unwrap();
}
