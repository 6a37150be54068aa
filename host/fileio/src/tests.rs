use super::*;

fn dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("fileio-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Every entry of `d`, hidden ones included.
fn names(d: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

/// A file appears only complete: a writer dropped before its commit (a failed run) leaves
/// neither a partial target nor its temporary file, and an existing target is kept as it was.
#[test]
fn atomic_file_appears_only_when_committed() {
    let d = dir("atomic");
    let target = d.join("theta.csv");
    {
        let mut f = AtomicFile::create(&target).unwrap();
        writeln!(f, "t_s,theta_meas_rad\n0,1").unwrap();
        assert!(!target.exists(), "visible before the commit");
    }
    assert_eq!(names(&d), Vec::<String>::new());
    write_atomic(&target, b"old\n").unwrap();
    {
        let mut f = AtomicFile::create(&target).unwrap();
        f.write_all(b"partial").unwrap();
    }
    assert_eq!(std::fs::read(&target).unwrap(), b"old\n");
    let mut f = AtomicFile::create(&target).unwrap();
    f.write_all(b"new\n").unwrap();
    f.commit().unwrap();
    assert_eq!(std::fs::read(&target).unwrap(), b"new\n");
    assert_eq!(names(&d), ["theta.csv"]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn an_input_is_not_an_output() {
    let d = dir("inputs");
    let model = d.join("m.json");
    std::fs::write(&model, "{}").unwrap();
    let e = check_not_input(&model, &[("--model", &model)]).unwrap_err().to_string();
    assert!(e.contains("--model") && e.contains("m.json"), "{e}");
    // Another spelling of the same file.
    let other = d.join(".").join("m.json");
    assert!(check_not_input(&other, &[("--model", &model)]).is_err());
    let link = d.join("link.json");
    std::fs::hard_link(&model, &link).unwrap();
    assert!(check_not_input(&link, &[("--model", &model)]).is_err());
    // A new file, or another existing one, is fine.
    assert!(check_not_input(&d.join("blob.bin"), &[("--model", &model)]).is_ok());
    // Inside a transaction the writer itself refuses it, and the input is untouched.
    let tx = Outputs::begin(&[&d], &[("--model", &model)]);
    let e = AtomicFile::create(&link).err().expect("an input was accepted as an output").to_string();
    assert!(e.contains("this command's input") && e.contains("--model"), "{e}");
    drop(tx);
    assert_eq!(std::fs::read_to_string(&model).unwrap(), "{}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// A symbolic link at the target is refused by name and neither it nor what it points to is
/// touched; so is a directory, and a FIFO.
#[test]
fn links_directories_and_fifos_are_refused() {
    let d = dir("special");
    let victim = d.join("victim.txt");
    std::fs::write(&victim, "keep").unwrap();
    let link = d.join("out.png");
    std::os::unix::fs::symlink(&victim, &link).unwrap();
    let e = write_atomic(&link, b"png").unwrap_err().to_string();
    assert!(e.contains("symbolic link") && e.contains("out.png"), "{e}");
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "keep");
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    // A dangling link too: following it would create a file elsewhere.
    let dangling = d.join("dangling.json");
    std::os::unix::fs::symlink(d.join("nowhere").join("x"), &dangling).unwrap();
    assert!(write_atomic(&dangling, b"{}").unwrap_err().to_string().contains("symbolic link"));

    let sub = d.join("fig");
    std::fs::create_dir(&sub).unwrap();
    let e = write_atomic(&sub, b"x").unwrap_err().to_string();
    assert!(e.contains("directory") && e.contains("fig"), "{e}");

    let fifo = d.join("pipe.csv");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: mkfifo on a NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o644) }, 0);
    let e = write_atomic(&fifo, b"x").unwrap_err().to_string();
    assert!(e.contains("FIFO") && e.contains("pipe.csv"), "{e}");
    let mut left = names(&d);
    left.retain(|n| n.starts_with('.'));
    assert!(left.is_empty(), "temporary files left: {left:?}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// A private device node (root only: `mknod` of a copy of /dev/null) is never replaced.
#[test]
fn a_device_node_is_never_replaced() {
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        eprintln!("skipped: mknod needs root");
        return;
    }
    let d = dir("device");
    let node = d.join("null");
    let c = std::ffi::CString::new(node.to_str().unwrap()).unwrap();
    // SAFETY: mknod on a NUL-terminated path; 1,3 is the null device.
    assert_eq!(unsafe { libc::mknod(c.as_ptr(), libc::S_IFCHR | 0o666, libc::makedev(1, 3)) }, 0);
    let tx = Outputs::begin(&[&node], &[]);
    let e = write_atomic(&node, b"\x89PNG").unwrap_err().to_string();
    assert!(e.contains("character device") && e.contains("null"), "{e}");
    drop(tx);
    use std::os::unix::fs::FileTypeExt;
    assert!(std::fs::symlink_metadata(&node).unwrap().file_type().is_char_device());
    std::fs::remove_dir_all(&d).unwrap();
}

/// Files of a transaction are invisible until its commit, appear together, and a dropped
/// transaction leaves nothing behind (no staging folder either).
#[test]
fn a_transaction_is_all_or_nothing() {
    let d = dir("txn");
    write_atomic(&d.join("a.csv"), b"old a").unwrap();
    {
        let tx = Outputs::begin(&[&d], &[]);
        write_atomic(&d.join("a.csv"), b"new a").unwrap();
        write_atomic(&d.join("b.json"), b"new b").unwrap();
        assert_eq!(std::fs::read(d.join("a.csv")).unwrap(), b"old a");
        assert!(!d.join("b.json").exists());
        assert_eq!(tx.staged().len(), 2);
        // The error path: the transaction is dropped.
    }
    assert_eq!(names(&d), ["a.csv"]);
    assert_eq!(std::fs::read(d.join("a.csv")).unwrap(), b"old a");

    let sub = d.join("fig");
    std::fs::create_dir(&sub).unwrap();
    let tx = Outputs::begin(&[&d], &[]);
    write_atomic(&d.join("a.csv"), b"new a").unwrap();
    write_atomic(&sub.join("p.png"), b"png").unwrap();
    let mut f = AtomicFile::create(&d.join("b.json")).unwrap();
    f.write_all(b"new b").unwrap();
    f.commit().unwrap();
    let done = tx.commit().unwrap();
    assert_eq!(done.len(), 3);
    assert_eq!(names(&d), ["a.csv", "b.json", "fig"]);
    assert_eq!(names(&sub), ["p.png"]);
    assert_eq!(std::fs::read(d.join("a.csv")).unwrap(), b"new a");
    std::fs::remove_dir_all(&d).unwrap();
}

/// Something planted at a target after it was staged is caught at the commit, before any
/// file of the set moves.
#[test]
fn a_target_planted_before_the_commit_stops_the_whole_set() {
    let d = dir("planted");
    let tx = Outputs::begin(&[&d], &[]);
    write_atomic(&d.join("a.csv"), b"a").unwrap();
    write_atomic(&d.join("b.json"), b"b").unwrap();
    std::os::unix::fs::symlink("/etc/passwd", d.join("b.json")).unwrap();
    let e = tx.commit().unwrap_err().to_string();
    assert!(e.contains("symbolic link") && e.contains("b.json"), "{e}");
    assert_eq!(names(&d), ["b.json"]);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Leftovers of a process that no longer exists (SIGKILL) are removed by the next write into
/// the folder; those of a live process are kept.
#[test]
fn leftovers_of_dead_processes_are_cleaned() {
    let d = dir("stale");
    let mut child = std::process::Command::new("true").spawn().unwrap();
    let dead = child.id();
    child.wait().unwrap();
    let stale_dir = d.join(format!("{STAGE_PREFIX}{dead}-abcdefgh"));
    std::fs::create_dir(&stale_dir).unwrap();
    std::fs::write(stale_dir.join("1-a.csv"), "half").unwrap();
    let stale_tmp = d.join(format!(".a.csv{TMP_INFIX}{dead}-abcdefgh"));
    std::fs::write(&stale_tmp, "half").unwrap();
    let live = d.join(format!("{STAGE_PREFIX}1-abcdefgh"));
    std::fs::create_dir(&live).unwrap();
    write_atomic(&d.join("a.csv"), b"a").unwrap();
    let mut expect = vec!["a.csv".to_string(), format!("{STAGE_PREFIX}1-abcdefgh")];
    expect.sort();
    assert_eq!(names(&d), expect);
    std::fs::remove_dir_all(&d).unwrap();
}

/// Several writers into one folder at once, many rounds: every file is always complete, and
/// at the end the set is one writer's whole set.
#[test]
fn concurrent_transactions_leave_a_consistent_set() {
    let d = dir("concurrent");
    let payload = |k: usize| format!("{k}\n{}\n{k}\n", "x".repeat(20_000 + k));
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let reader = {
        let (d, stop) = (d.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut reads = 0;
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                for n in ["a.txt", "b.txt"] {
                    if let Ok(s) = std::fs::read_to_string(d.join(n)) {
                        let lines: Vec<&str> = s.lines().collect();
                        assert_eq!(lines.len(), 3, "partial {n}");
                        assert_eq!(lines[0], lines[2], "torn {n}");
                        reads += 1;
                    }
                }
            }
            reads
        })
    };
    let writers: Vec<_> = (0..4)
        .map(|w| {
            let d = d.clone();
            std::thread::spawn(move || {
                for round in 0..25 {
                    let k = w * 1000 + round;
                    let tx = Outputs::begin(&[&d], &[]);
                    write_atomic(&d.join("a.txt"), payload(k).as_bytes()).unwrap();
                    write_atomic(&d.join("b.txt"), payload(k).as_bytes()).unwrap();
                    tx.commit().unwrap();
                }
            })
        })
        .collect();
    for w in writers {
        w.join().unwrap();
    }
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    assert!(reader.join().unwrap() > 0);
    assert_eq!(std::fs::read(d.join("a.txt")).unwrap(), std::fs::read(d.join("b.txt")).unwrap());
    assert_eq!(names(&d), ["a.txt", "b.txt"]);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn an_output_folder_must_be_a_folder() {
    let d = dir("folder");
    create_dir(&d.join("x").join("y")).unwrap();
    std::fs::write(d.join("file"), "f").unwrap();
    let e = create_dir(&d.join("file")).unwrap_err().to_string();
    assert!(e.contains("file") && e.contains("output folder"), "{e}");
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn io_errors_are_in_words() {
    let e = io::Error::from_raw_os_error(17);
    assert_eq!(words(&e), "File exists");
    // A single output file in a folder that does not exist, inside a transaction (the
    // staging folder's error came as "No such file or directory (os error 2) at path
    // DIR/.ssmctl-stage-...").
    let d = dir("missing");
    let target = d.join("no-such-folder").join("m.bin");
    let t = Outputs::begin(&[target.as_path()], &[]);
    let e = AtomicFile::create(&target).err().unwrap().to_string();
    assert!(e.contains("no-such-folder") && e.contains("No such file or directory"), "{e}");
    assert!(!e.contains("os error") && !e.contains("at path") && !e.contains(STAGE_PREFIX), "{e}");
    drop(t);
    std::fs::remove_dir_all(&d).unwrap();
}
