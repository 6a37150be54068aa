//! `ssmctl sweep` / `sweep-merge` as separate processes: N shards (flag, Slurm array and
//! Kubernetes Indexed Job environments) merge to the single-process run bit for bit; re-runs
//! are idempotent; every bad input is an error naming it.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn cmd(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_ssmctl"));
    c.arg("--quiet").args(args);
    for k in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_COUNT",
        "SLURM_ARRAY_TASK_MIN",
        "SLURM_ARRAY_TASK_STEP",
        "JOB_COMPLETION_INDEX",
    ] {
        c.env_remove(k);
    }
    c
}

fn ok(o: Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).to_string();
    assert!(o.status.success(), "{err}");
    err
}

fn fails(o: Output) -> String {
    assert!(!o.status.success(), "expected a failure");
    String::from_utf8_lossy(&o.stderr).to_string()
}

fn tmp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ssmctl-sweep-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const BASIN: &str = r#"
name = "basin"
kind = "basin"
scene = "furuta-dt30.5"
[[axes]]
name = "dt_ms"
values = [30.5, 31.8]
[[axes]]
name = "theta0"
lo = 0.02
hi = 0.3
n = 3
[basin]
periods = 300
"#;

const CHART: &str = r#"
name = "chart"
kind = "chart"
scene = "furuta-dt25"
shards = 2
[[axes]]
name = "dt_ms"
values = [25.0, 30.8]
[[axes]]
name = "kd"
lo = 0.0
hi = 8.0
n = 6
[[axes]]
name = "kp"
lo = 0.0
hi = 40.0
n = 7
"#;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn merge(dir: &Path, out: &Path) -> String {
    ok(cmd(&["sweep-merge", s(dir), "--out", s(out)]).output().unwrap());
    String::new()
}

fn same_files(a: &Path, b: &Path, name: &str) {
    for ext in ["json", "csv", "png"] {
        let (x, y) = (
            std::fs::read(a.join(format!("{name}.{ext}"))).unwrap(),
            std::fs::read(b.join(format!("{name}.{ext}"))).unwrap(),
        );
        assert!(x == y, "{name}.{ext} differs between {} and {}", a.display(), b.display());
    }
}

#[test]
fn shards_as_separate_processes_merge_to_the_single_process_run() {
    let d = tmp("merge");
    for (name, text) in [("basin", BASIN), ("chart", CHART)] {
        let spec = d.join(format!("{name}.toml"));
        std::fs::write(&spec, text).unwrap();
        // One process, the whole grid.
        let (one, one_out) = (d.join(format!("{name}-one")), d.join(format!("{name}-one-merged")));
        let err = ok(cmd(&["sweep", s(&spec), "--out", s(&one)]).output().unwrap());
        assert!(err.contains("shard 0/1 (Whole)"), "{err}");
        merge(&one, &one_out);
        // Three processes at once, one thread each.
        let three = d.join(format!("{name}-three"));
        let kids: Vec<_> = (0..3)
            .map(|i| {
                cmd(&["sweep", s(&spec), "--out", s(&three), "--shard", &format!("{i}/3"), "--jobs", "1"])
                    .spawn()
                    .unwrap()
            })
            .collect();
        for k in kids {
            ok(k.wait_with_output().unwrap());
        }
        let three_out = d.join(format!("{name}-three-merged"));
        merge(&three, &three_out);
        same_files(&one_out, &three_out, name);
        // A Slurm array numbered from 1 (--array=1-2).
        let slurm = d.join(format!("{name}-slurm"));
        for id in ["1", "2"] {
            let err = ok(cmd(&["sweep", s(&spec), "--out", s(&slurm)])
                .env("SLURM_ARRAY_TASK_ID", id)
                .env("SLURM_ARRAY_TASK_COUNT", "2")
                .env("SLURM_ARRAY_TASK_MIN", "1")
                .output()
                .unwrap());
            assert!(err.contains("(Slurm)"), "{err}");
        }
        let slurm_out = d.join(format!("{name}-slurm-merged"));
        merge(&slurm, &slurm_out);
        same_files(&one_out, &slurm_out, name);
    }
    // A Kubernetes Indexed Job: the count from the spec (`shards = 2`) or --shards.
    let spec = d.join("chart.toml");
    let k8s = d.join("chart-k8s");
    ok(cmd(&["sweep", s(&spec), "--out", s(&k8s)]).env("JOB_COMPLETION_INDEX", "0").output().unwrap());
    let err = ok(cmd(&["sweep", s(&spec), "--out", s(&k8s), "--shards", "2"])
        .env("JOB_COMPLETION_INDEX", "1")
        .output()
        .unwrap());
    assert!(err.contains("shard 1/2 (Kubernetes)"), "{err}");
    let k8s_out = d.join("chart-k8s-merged");
    merge(&k8s, &k8s_out);
    same_files(&d.join("chart-one-merged"), &k8s_out, "chart");
    // The merged chart: 84 cells, some stable, and its figure is a PNG of two panels.
    let v: serde_json::Value = serde_json::from_slice(&std::fs::read(k8s_out.join("chart.json")).unwrap()).unwrap();
    assert_eq!(v["cells"].as_array().unwrap().len(), 2 * 6 * 7);
    let png = std::fs::read(k8s_out.join("chart.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    assert_eq!(u32::from_be_bytes(png[16..20].try_into().unwrap()), 2 * 620);
    // Re-running a complete shard keeps it, byte for byte.
    let file = k8s.join("shard-000001-of-000002.json");
    let before = std::fs::read(&file).unwrap();
    let err = ok(cmd(&["sweep", s(&spec), "--out", s(&k8s), "--shard", "1/2"]).output().unwrap());
    assert!(err.contains("already complete, kept"), "{err}");
    assert_eq!(std::fs::read(&file).unwrap(), before);
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn bad_inputs_are_errors_naming_them() {
    let d = tmp("bad");
    let spec = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let run = |p: &Path, extra: &[&str]| {
        let out = d.join("out");
        let mut a = vec!["sweep", s(p), "--out", s(&out)];
        a.extend_from_slice(extra);
        fails(cmd(&a).output().unwrap())
    };
    let e = run(&spec("axis.toml", &CHART.replace("name = \"kd\"", "name = \"kdd\"")), &[]);
    assert!(e.contains("axes[1]") && e.contains("unknown axis `kdd`"), "{e}");
    let e = run(&spec("empty.toml", &BASIN.replace("values = [30.5, 31.8]", "values = []")), &[]);
    assert!(e.contains("`axes[0]` (dt_ms)") && e.contains("empty range"), "{e}");
    let chart = spec("chart.toml", CHART);
    let e = run(&chart, &["--shard", "3/3"]);
    assert!(e.contains("shard index 3 outside 0..3"), "{e}");
    let e = fails(
        cmd(&["sweep", s(&chart), "--out", s(&d.join("o"))])
            .env("SLURM_ARRAY_TASK_ID", "4")
            .env("SLURM_ARRAY_TASK_COUNT", "4")
            .output()
            .unwrap(),
    );
    assert!(e.contains("Slurm array task 4") && e.contains("outside 0..4"), "{e}");
    let basin = spec("basin.toml", BASIN);
    let e =
        fails(cmd(&["sweep", s(&basin), "--out", s(&d.join("o"))]).env("JOB_COMPLETION_INDEX", "1").output().unwrap());
    assert!(e.contains("JOB_COMPLETION_INDEX=1 is set but no shard count"), "{e}");
    // Merges: a missing shard, a duplicated one, shards of two specs.
    let m = d.join("m");
    ok(cmd(&["sweep", s(&chart), "--out", s(&m), "--shard", "0/3"]).output().unwrap());
    ok(cmd(&["sweep", s(&chart), "--out", s(&m), "--shard", "2/3"]).output().unwrap());
    let e = fails(cmd(&["sweep-merge", s(&m), "--out", s(&d.join("r"))]).output().unwrap());
    assert!(e.contains("missing shard 1/3 of spec `chart`"), "{e}");
    ok(cmd(&["sweep", s(&chart), "--out", s(&m), "--shard", "1/3"]).output().unwrap());
    std::fs::copy(m.join("shard-000002-of-000003.json"), m.join("shard-copy.json")).unwrap();
    let e = fails(cmd(&["sweep-merge", s(&m), "--out", s(&d.join("r"))]).output().unwrap());
    assert!(e.contains("shard 2/3 appears twice") && e.contains("shard-copy.json"), "{e}");
    std::fs::remove_file(m.join("shard-copy.json")).unwrap();
    let other = spec("other.toml", &CHART.replace("n = 7", "n = 8"));
    let e = fails(cmd(&["sweep", s(&other), "--out", s(&m), "--shard", "1/3"]).output().unwrap());
    assert!(e.contains("holds shard 1/3 of spec `chart`") && e.contains("--force"), "{e}");
    ok(cmd(&["sweep", s(&other), "--out", s(&m), "--shard", "1/3", "--force"]).output().unwrap());
    let e = fails(cmd(&["sweep-merge", s(&m), "--out", s(&d.join("r"))]).output().unwrap());
    assert!(e.contains("shards of two specs") && e.contains("shard-000001-of-000003.json"), "{e}");
    let e = fails(cmd(&["sweep-merge", s(&d.join("nothing")), "--out", s(&d.join("r"))]).output().unwrap());
    assert!(e.contains("cannot read shard folder"), "{e}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// The bundled cart-pole chart sweep over named gains (`gains.x.p`, `gains.x.d`): two shards
/// run as separate processes merge to the one-process result (JSON, CSV, figure), and the
/// figure names its axes.
#[test]
fn cartpole_gain_chart_sweep_merges_shards_to_the_whole() {
    let d = tmp("cartpole");
    let spec = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/sweeps/chart-cartpole-x.toml");
    let (whole, parts) = (d.join("whole"), d.join("parts"));
    ok(cmd(&["sweep", s(&spec), "--out", s(&whole), "--shard", "0/1"]).output().unwrap());
    for i in 0..2 {
        ok(cmd(&["sweep", s(&spec), "--out", s(&parts), "--shard", &format!("{i}/2")]).output().unwrap());
    }
    let (a, b) = (d.join("a"), d.join("b"));
    ok(cmd(&["sweep-merge", s(&whole), "--out", s(&a)]).output().unwrap());
    let out = cmd(&["sweep-merge", s(&parts), "--out", s(&b)]).output().unwrap();
    let summary: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(summary["figure_note"].is_null(), "{summary}");
    for f in ["chart-cartpole-x.json", "chart-cartpole-x.csv", "chart-cartpole-x.png"] {
        assert_eq!(std::fs::read(a.join(f)).unwrap(), std::fs::read(b.join(f)).unwrap(), "{f}");
    }
    let v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("chart-cartpole-x.json")).unwrap()).unwrap();
    let cells = v["cells"].as_array().unwrap();
    assert_eq!(cells.len(), 16 * 21);
    let stable = cells.iter().filter(|c| c["radius"].as_f64().unwrap() < 1.0).count();
    assert!(stable > 0 && stable < cells.len(), "{stable} stable cells of {}", cells.len());
    std::fs::remove_dir_all(&d).unwrap();
}
