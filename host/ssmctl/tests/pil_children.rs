//! Processes: QEMU never outlives `ssmctl pil`, whatever ends ssmctl.
//!
//! `SSMCTL_QEMU` puts a stand-in in QEMU's place (a shell script that execs `sleep 30`: it
//! never connects, so ssmctl waits for it). The test finds the stand-in among ssmctl's
//! children in `/proc`, checks it is running, signals ssmctl and requires the stand-in to be
//! gone (or a zombie waiting for its new parent to reap it) within one second.
#![cfg(target_os = "linux")]

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use shared::model::OwnedModel;

fn tmp(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ssmctl-children-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A valid blob with the scene's controller configuration, sampled at its 25 ms period.
fn blob(scene: &str) -> Vec<u8> {
    let config = sim::scene::Scene::load(scene, &[]).unwrap().controller_config();
    OwnedModel {
        config,
        p: 3,
        shift: 1,
        sample_period: 0.025,
        offset: 0.0,
        scale: 1.0,
        d: 1,
        lift_order: 1,
        k: 1,
        v1: vec![0.5, 0.5, 0.5],
        lift: vec![],
        centres: vec![0.1],
        weights: vec![0.2],
        affine: vec![0.9, 0.0],
    }
    .encode()
    .unwrap()
}

/// `(parent pid, state, command name)` of a process, `None` once it is gone.
fn stat(pid: i32) -> Option<(i32, char, String)> {
    let text = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    // `pid (comm) state ppid ...`; comm may hold spaces and parentheses: split at the last ')'.
    let open = text.find('(')?;
    let close = text.rfind(')')?;
    let comm = text[open + 1..close].to_string();
    let mut rest = text[close + 1..].split_whitespace();
    let state = rest.next()?.chars().next()?;
    let ppid = rest.next()?.parse().ok()?;
    Some((ppid, state, comm))
}

/// The child of `parent` named `name`, waiting up to 20 s for it to appear.
fn child_named(parent: i32, name: &str) -> i32 {
    let t0 = Instant::now();
    while t0.elapsed() < Duration::from_secs(20) {
        for entry in std::fs::read_dir("/proc").unwrap().flatten() {
            let Some(pid) = entry.file_name().to_str().and_then(|s| s.parse::<i32>().ok()) else { continue };
            if stat(pid).is_some_and(|(ppid, _, comm)| ppid == parent && comm == name) {
                return pid;
            }
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    panic!("no child `{name}` of ssmctl (pid {parent}) within 20 s");
}

/// Whether `pid` has stopped running (no such process, or a zombie / dead entry).
fn gone(pid: i32) -> bool {
    stat(pid).is_none_or(|(_, state, _)| matches!(state, 'Z' | 'X'))
}

/// Starts `ssmctl pil` with the stand-in QEMU, signals ssmctl with `signal` once the stand-in
/// runs, and returns how long the stand-in took to die (panics after 1 s).
fn stand_in_dies_with_ssmctl(dir: &Path, signal: i32) -> Duration {
    let script = dir.join("fake-qemu.sh");
    std::fs::write(&script, "#!/bin/sh\nexec sleep 30\n").unwrap();
    std::fs::set_permissions(&script, std::os::unix::fs::PermissionsExt::from_mode(0o755)).unwrap();
    let model = dir.join("model.bin");
    std::fs::write(&model, blob("furuta-quant-dt25")).unwrap();
    // The stand-in boots nothing, but ssmctl checks that --elf is ARM firmware: an ELF
    // header (32-bit, little-endian, machine ARM) is enough.
    let elf = dir.join("fake.elf");
    let mut header = vec![0x7f, b'E', b'L', b'F', 1, 1, 1];
    header.resize(18, 0);
    header.extend_from_slice(&40u16.to_le_bytes());
    std::fs::write(&elf, header).unwrap();
    let out = dir.join(format!("out-{signal}"));
    let mut ssmctl = Command::new(env!("CARGO_BIN_EXE_ssmctl"))
        .args(["pil", "--scene", "furuta-quant-dt25", "--periods", "10", "--model"])
        .arg(&model)
        .arg("--elf")
        .arg(&elf)
        .arg("--out")
        .arg(&out)
        .env("SSMCTL_QEMU", &script)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let parent = i32::try_from(ssmctl.id()).unwrap();
    let child = child_named(parent, "sleep");
    let (_, state, _) = stat(child).expect("the stand-in runs");
    assert!(!gone(child), "the stand-in must run before the signal (state {state})");
    // SAFETY: kill(2) on the ssmctl process this test started and has not reaped yet.
    assert_eq!(unsafe { libc::kill(parent, signal) }, 0, "kill({parent}, {signal})");
    let t0 = Instant::now();
    let status = ssmctl.wait().unwrap();
    assert!(!status.success(), "ssmctl ended by signal {signal}: {status}");
    while !gone(child) {
        assert!(
            t0.elapsed() < Duration::from_secs(1),
            "the stand-in (pid {child}) still runs 1 s after signal {signal} to ssmctl: {:?}",
            stat(child)
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    t0.elapsed()
}

#[test]
fn qemu_dies_when_ssmctl_is_terminated() {
    let dir = tmp("term");
    let t = stand_in_dies_with_ssmctl(&dir, libc::SIGTERM);
    eprintln!("SIGTERM: stand-in gone after {t:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn qemu_dies_when_ssmctl_is_killed() {
    let dir = tmp("kill");
    let t = stand_in_dies_with_ssmctl(&dir, libc::SIGKILL);
    eprintln!("SIGKILL: stand-in gone after {t:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn qemu_dies_on_ctrl_c() {
    let dir = tmp("int");
    let t = stand_in_dies_with_ssmctl(&dir, libc::SIGINT);
    eprintln!("SIGINT: stand-in gone after {t:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}
