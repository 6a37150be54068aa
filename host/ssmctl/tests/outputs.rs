//! Output safety of every command that writes: a symbolic link, a folder, a device node or the
//! command's own input at an output path is refused by name and left untouched; a failed or
//! interrupted command leaves nothing half-written; concurrent runs into one folder leave one
//! consistent set.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

fn ssmctl(args: &[&str]) -> (bool, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_ssmctl")).arg("--quiet").args(args).output().expect("run ssmctl");
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ssmctl-outputs-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The entries of `d` that a run may have left: hidden staging folders and temporary files.
fn leftovers(d: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(d)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    v.sort();
    v
}

/// A saved polynomial model of the bundled Duffing data (for backbone, frc).
fn duffing_model(dir: &Path) -> PathBuf {
    let mat = Path::new(env!("CARGO_MANIFEST_DIR")).join("../ssm/tests/data/duffing.mat");
    let model = dir.join("duffing.json");
    let (ok, _, err) = ssmctl(&[
        "fit",
        "--mat",
        s(&mat),
        "--test-rows",
        "2",
        "--from",
        "0.5",
        "--dim",
        "2",
        "--embed",
        "2",
        "--order",
        "3",
        "--dyn-order",
        "5",
        "--save",
        s(&model),
    ]);
    assert!(ok, "{err}");
    model
}

/// Plants `what` at `path`: a symbolic link to a victim file, or a folder.
enum Plant {
    Link,
    Folder,
}

fn plant(path: &Path, how: &Plant, victim: &Path) {
    if let Some(p) = path.parent() {
        std::fs::create_dir_all(p).unwrap();
    }
    match how {
        Plant::Link => std::os::unix::fs::symlink(victim, path).unwrap(),
        Plant::Folder => std::fs::create_dir_all(path.join("inside")).unwrap(),
    }
}

#[test]
fn every_output_path_refuses_links_and_folders() {
    let root = tmp("planted");
    let model = duffing_model(&root);
    let victim = root.join("victim.txt");
    // Each case: the command's arguments (OUT replaced by the case's folder) and one of the
    // files it writes, relative to OUT.
    let cases: Vec<(Vec<String>, &str)> = vec![
        (
            vec!["simulate".into(), "--scene".into(), "furuta-dt31".into(), "--set".into(), "run.periods=5".into()],
            "furuta-dt31.csv",
        ),
        (
            vec!["simulate".into(), "--scene".into(), "furuta-dt31".into(), "--set".into(), "run.periods=5".into()],
            "furuta-dt31.json",
        ),
        (
            vec!["backbone".into(), "--model".into(), s(&model).into(), "--amplitude".into(), "0.3".into()],
            "backbone.json",
        ),
        (
            vec!["backbone".into(), "--model".into(), s(&model).into(), "--amplitude".into(), "0.3".into()],
            "backbone.png",
        ),
        (
            vec![
                "frc".into(),
                "--model".into(),
                s(&model).into(),
                "--freq-range".into(),
                "5.8:6.9:50".into(),
                "--calibrate".into(),
                "6.25,0.32".into(),
            ],
            "frc.png",
        ),
    ];
    for (k, (args, file)) in cases.iter().enumerate() {
        for how in [Plant::Link, Plant::Folder] {
            std::fs::write(&victim, "keep").unwrap();
            let out = root.join(format!("case{k}-{}", matches!(how, Plant::Link)));
            plant(&out.join(file), &how, &victim);
            let mut a: Vec<&str> = args.iter().map(String::as_str).collect();
            a.extend(["--out", s(&out)]);
            let (ok, _, err) = ssmctl(&a);
            assert!(!ok, "{a:?} wrote through {file}");
            let word = if matches!(how, Plant::Link) { "symbolic link" } else { "directory" };
            assert!(err.contains(word) && err.contains(file), "{a:?}: {err}");
            assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
            // Nothing else of the set appeared, and nothing was left staged.
            let names: Vec<String> = std::fs::read_dir(&out)
                .unwrap()
                .flatten()
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect();
            assert_eq!(names, [file.to_string()], "{a:?}");
        }
    }
    // Single-file outputs: export and fit --save.
    let blob = root.join("m.bin");
    plant(&blob, &Plant::Link, &victim);
    let rbf = root.join("rbf.json");
    let (ok, _, err) = ssmctl(&["export", "--model", s(&rbf), "--out", s(&blob)]);
    assert!(!ok && err.contains("symbolic link") && err.contains("m.bin"), "{err}");
    std::fs::remove_dir_all(&root).unwrap();
}

#[test]
fn a_command_never_overwrites_its_input() {
    let root = tmp("inputs");
    let model = duffing_model(&root);
    let before = std::fs::read(&model).unwrap();
    // The model named as its own output folder's file: `backbone --model out/backbone.json --out out`.
    let out = root.join("bb");
    std::fs::create_dir_all(&out).unwrap();
    let inside = out.join("backbone.json");
    std::fs::copy(&model, &inside).unwrap();
    let (ok, _, err) = ssmctl(&["backbone", "--model", s(&inside), "--out", s(&out), "--amplitude", "0.3"]);
    assert!(!ok && err.contains("this command's input") && err.contains("--model"), "{err}");
    assert_eq!(std::fs::read(&inside).unwrap(), before);
    assert!(!out.join("backbone.png").exists(), "half of the set appeared");
    // export onto its own model, fit --save onto its data.
    let (ok, _, err) = ssmctl(&["export", "--model", s(&model), "--out", s(&model)]);
    assert!(!ok && err.contains("--model"), "{err}");
    let mat = Path::new(env!("CARGO_MANIFEST_DIR")).join("../ssm/tests/data/duffing.mat");
    let copy = root.join("d.mat");
    std::fs::copy(&mat, &copy).unwrap();
    let (ok, _, err) = ssmctl(&["fit", "--mat", s(&copy), "--dim", "2", "--embed", "2", "--save", s(&copy)]);
    assert!(!ok && err.contains("--mat"), "{err}");
    assert_eq!(std::fs::read(&copy).unwrap(), std::fs::read(&mat).unwrap());
    assert_eq!(std::fs::read(&model).unwrap(), before);
    // simulate's scene file at either of the run's two output paths: the command's
    // transaction refuses it (there is no second check in the writer), and the other file
    // of the pair does not appear.
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/furuta-dt31.toml");
    let text = std::fs::read(&scene).unwrap();
    for (own, other) in [("furuta-dt31.csv", "furuta-dt31.json"), ("furuta-dt31.json", "furuta-dt31.csv")] {
        let out = root.join(format!("sim-{own}"));
        std::fs::create_dir_all(&out).unwrap();
        let input = out.join(own);
        std::fs::write(&input, &text).unwrap();
        let (ok, _, err) = ssmctl(&["simulate", "--scene", s(&input), "--set", "run.periods=5", "--out", s(&out)]);
        assert!(!ok && err.contains("this command's input") && err.contains("--scene") && err.contains(own), "{err}");
        assert_eq!(std::fs::read(&input).unwrap(), text, "{own} overwritten");
        assert!(!out.join(other).exists(), "{other} appeared without {own}");
        assert_eq!(leftovers(&out), Vec::<String>::new());
    }
    std::fs::remove_dir_all(&root).unwrap();
}

/// `stability-chart --out` onto a device node (a private `mknod` copy of /dev/null; root only).
#[test]
fn a_device_node_is_never_replaced() {
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        eprintln!("skipped: mknod needs root");
        return;
    }
    let root = tmp("device");
    let node = root.join("null");
    let c = std::ffi::CString::new(s(&node)).unwrap();
    // SAFETY: mknod on a NUL-terminated path; 1,3 is the null device.
    assert_eq!(unsafe { libc::mknod(c.as_ptr(), libc::S_IFCHR | 0o666, libc::makedev(1, 3)) }, 0);
    let (ok, _, err) = ssmctl(&[
        "stability-chart",
        "--scene",
        "furuta-dt31",
        "--out",
        s(&node),
        "--dt-ms",
        "25",
        "--kp",
        "0:40:5",
        "--kd",
        "0:8:5",
    ]);
    assert!(!ok && err.contains("character device") && err.contains("null"), "{err}");
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::symlink_metadata(&node).unwrap().file_type().is_char_device());
    assert_eq!(leftovers(&root), Vec::<String>::new());
    std::fs::remove_dir_all(&root).unwrap();
}

/// Four `simulate` runs at once into one folder, several rounds: every file parses, and the
/// CSV and JSON always come from the same run.
#[test]
fn concurrent_runs_leave_one_consistent_set() {
    let root = tmp("concurrent");
    let out = root.join("out");
    for round in 0..4 {
        let children: Vec<_> = (0..4)
            .map(|k| {
                let periods = format!("run.periods={}", 20 + 7 * k + round);
                Command::new(env!("CARGO_BIN_EXE_ssmctl"))
                    .args(["--quiet", "simulate", "--scene", "furuta-dt31", "--set", &periods, "--out", s(&out)])
                    .stdout(Stdio::null())
                    .stderr(Stdio::piped())
                    .spawn()
                    .unwrap()
            })
            .collect();
        for c in children {
            let o = c.wait_with_output().unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        }
        let csv = std::fs::read_to_string(out.join("furuta-dt31.csv")).unwrap();
        let meta: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("furuta-dt31.json")).unwrap()).unwrap();
        let rows = csv.lines().count() - 2;
        assert_eq!(meta["periods_simulated"].as_u64(), Some(rows as u64), "CSV and JSON of different runs");
        assert_eq!(leftovers(&out), Vec::<String>::new());
    }
    std::fs::remove_dir_all(&root).unwrap();
}

/// SIGTERM while a finished command's files are staged: nothing appears, nothing is left.
#[test]
fn sigterm_leaves_nothing_half_written() {
    let root = tmp("sigterm");
    let out = root.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_ssmctl"))
        .args(["--quiet", "simulate", "--scene", "furuta-dt31", "--set", "run.periods=5", "--out", s(&out)])
        .env("SSMCTL_HOLD_BEFORE_COMMIT_MS", "20000")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until the files are staged (the hidden staging folder holds both).
    let t0 = std::time::Instant::now();
    loop {
        let staged = std::fs::read_dir(&out)
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().starts_with(".ssmctl-stage-"))
            .any(|e| std::fs::read_dir(e.path()).map(|d| d.count() >= 2).unwrap_or(false));
        if staged {
            break;
        }
        assert!(t0.elapsed().as_secs() < 60, "the run never staged its files");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // SAFETY: kill on our own child's pid.
    assert_eq!(unsafe { libc::kill(child.id() as libc::pid_t, libc::SIGTERM) }, 0);
    let status = child.wait().unwrap();
    assert_eq!(std::os::unix::process::ExitStatusExt::signal(&status), None, "killed before the cleanup ran");
    assert_eq!(status.code(), Some(128 + libc::SIGTERM));
    let names: Vec<_> = std::fs::read_dir(&out).unwrap().flatten().map(|e| e.file_name()).collect();
    assert!(names.is_empty(), "left behind: {names:?}");
    std::fs::remove_dir_all(&root).unwrap();
}
