//! Every library `Err` that reaches `main` becomes exit code 1 (or clap's 2)
//! with a message naming the input, never 101 (panic) or 134 (abort). One property over
//! generated bad inputs of each boundary kind, run through the test-built `ssmctl`: a scene
//! file, a CSV data file, a saved model (JSON), a device blob, a numeric option, a
//! `.mat` file, a sweep spec and a sweep shard file. A run that
//! succeeds is allowed (a mutation may leave the input valid); then what it wrote must be
//! accepted downstream (an exported blob passes `inspect`).
//!
//! Bounded: `EXIT_CASES` cases (default 64), each one process.

use proptest::prelude::*;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

fn cases() -> u32 {
    std::env::var("EXIT_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(64)
}

fn ssmctl(args: &[&str]) -> (Option<i32>, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_ssmctl")).arg("--quiet").args(args).output().unwrap();
    (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// A simulated data set, a model fitted to it and its exported blob (made once).
struct Fixture {
    dir: PathBuf,
    csv: String,
    model: String,
    blob: Vec<u8>,
    scene: String,
    /// The shard file of [`SPEC`], one shard (pretty JSON: one value per line).
    shard: String,
}

fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("ssmctl-exit-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let sim = dir.join("sim");
        let (code, err) =
            ssmctl(&["simulate", "--scene", "furuta-quant-dt25", "--out", s(&sim), "--set", "run.periods=400"]);
        assert_eq!(code, Some(0), "{err}");
        let csv_path = sim.join("furuta-quant-dt25.csv");
        let model_path = dir.join("model.json");
        let (code, err) = ssmctl(&[
            "fit",
            "--data",
            s(&csv_path),
            "--column",
            "theta",
            "--dim",
            "2",
            "--embed",
            "5",
            "--dynamics",
            "rbf",
            "--centers",
            "20",
            "--save",
            s(&model_path),
        ]);
        assert_eq!(code, Some(0), "{err}");
        let blob_path = dir.join("model.bin");
        let (code, err) = ssmctl(&["export", "--model", s(&model_path), "--out", s(&blob_path)]);
        assert_eq!(code, Some(0), "{err}");
        let spec = dir.join("tiny.toml");
        std::fs::write(&spec, SPEC).unwrap();
        let (code, err) = ssmctl(&["sweep", s(&spec), "--out", s(&dir.join("shards"))]);
        assert_eq!(code, Some(0), "{err}");
        let shard: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(dir.join("shards/shard-000000-of-000001.json")).unwrap())
                .unwrap();
        Fixture {
            shard: serde_json::to_string_pretty(&shard).unwrap(),
            csv: std::fs::read_to_string(&csv_path).unwrap(),
            model: std::fs::read_to_string(&model_path).unwrap(),
            blob: std::fs::read(&blob_path).unwrap(),
            scene: sim::scene::BUNDLED.iter().find(|(n, _)| *n == "furuta-quant-dt25").unwrap().1.to_string(),
            dir,
        }
    })
}

/// Bad numbers of every kind, as text.
fn bad_number() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("0".to_string()),
        Just("-1".to_string()),
        Just("1e300".to_string()),
        Just("1e-300".to_string()),
        Just("18446744073709551615".to_string()),
        Just("1e12".to_string()),
        Just("x".to_string()),
        Just("".to_string()),
        any::<i64>().prop_map(|v| v.to_string()),
        any::<f64>().prop_map(|v| format!("{v:e}")),
    ]
}

/// One bad input and the command that reads it.
#[derive(Debug, Clone)]
enum Case {
    /// A scene file with the numeric value of one `key = value` line replaced.
    Scene { line: usize, value: String },
    /// The data CSV with one edit: a line dropped, a field replaced, the header dropped.
    Csv { line: usize, field: usize, value: String, drop: bool },
    /// The saved model with one number or array (by position in the text) replaced.
    Model { at: usize, value: String },
    /// The device blob with bytes changed (and the CRC fixed or not).
    Blob { edits: Vec<(usize, u8)>, fix_crc: bool, cut: Option<usize> },
    /// A numeric option of a command with a bad value.
    Option { which: usize, value: String },
    /// A `.mat` file (SSMLearn's duffing data) with bytes changed, or a header-size field
    /// (a dimension or a byte count) set to a huge value.
    Mat { edits: Vec<(usize, u8)>, huge: Option<usize> },
    /// A small chart sweep spec with the numeric value of one line replaced.
    Spec { line: usize, value: String },
    /// A shard file of that sweep with one number or array (by position) replaced.
    Shard { at: usize, value: String },
}

fn case() -> impl Strategy<Value = Case> {
    let json_value = prop_oneof![
        bad_number(),
        Just("[]".to_string()),
        Just("[1e300]".to_string()),
        Just("null".to_string()),
        Just("\"x\"".to_string()),
        Just("[[0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,64]]".to_string()),
    ];
    prop_oneof![
        (any::<usize>(), bad_number()).prop_map(|(line, value)| Case::Scene { line, value }),
        (any::<usize>(), 0usize..4, bad_number(), any::<bool>()).prop_map(|(line, field, value, drop)| Case::Csv {
            line,
            field,
            value,
            drop
        }),
        (any::<usize>(), json_value).prop_map(|(at, value)| Case::Model { at, value }),
        (prop::collection::vec((any::<usize>(), any::<u8>()), 1..6), any::<bool>(), prop::option::of(any::<usize>()))
            .prop_map(|(edits, fix_crc, cut)| Case::Blob { edits, fix_crc, cut }),
        (0usize..OPTIONS.len(), bad_number()).prop_map(|(which, value)| Case::Option { which, value }),
        (prop::collection::vec((any::<usize>(), any::<u8>()), 0..6), prop::option::of(any::<usize>()))
            .prop_map(|(edits, huge)| Case::Mat { edits, huge }),
        (any::<usize>(), bad_number()).prop_map(|(line, value)| Case::Spec { line, value }),
        (any::<usize>(), json_value2()).prop_map(|(at, value)| Case::Shard { at, value }),
    ]
}

/// Bad JSON values for the shard file (the model's list, without its long vector).
fn json_value2() -> impl Strategy<Value = String> {
    prop_oneof![bad_number(), Just("[]".to_string()), Just("null".to_string()), Just("\"../x\"".to_string())]
}

/// The sweep spec of [`Case::Spec`] and [`Case::Shard`]: 6 chart cells.
const SPEC: &str = "name = \"tiny\"\nkind = \"chart\"\nscene = \"furuta-dt25\"\n[[axes]]\nname = \"kd\"\nlo = 0.0\nhi = 8.0\nn = 2\n[[axes]]\nname = \"kp\"\nlo = 0.0\nhi = 40.0\nn = 3\n";

/// Commands with one numeric option (the last argument's value is the case's); what the
/// message must name.
const OPTIONS: &[(&[&str], &str)] = &[
    (
        &[
            "pil",
            "--scene",
            "furuta-quant-dt25",
            "--model",
            "/nonexistent.bin",
            "--out",
            "/nonexistent",
            "--elf",
            "/nonexistent",
            "--periods",
        ],
        "periods",
    ),
    (
        &[
            "pil",
            "--scene",
            "furuta-quant-dt25",
            "--model",
            "/nonexistent.bin",
            "--out",
            "/nonexistent",
            "--elf",
            "/nonexistent",
            "--timeout",
        ],
        "timeout",
    ),
    (&["fit", "--data", "CSV", "--column", "theta", "--embed", "9", "--dim"], "dim"),
    (&["fit", "--data", "CSV", "--column", "theta", "--dim", "2", "--embed"], "embed"),
    (&["fit", "--data", "CSV", "--column", "theta", "--dim", "2", "--embed", "5", "--order"], "order"),
    (&["fit", "--data", "CSV", "--column", "theta", "--dim", "2", "--embed", "5", "--ridge"], "ridge"),
    (
        &["fit", "--data", "CSV", "--column", "theta", "--dim", "2", "--embed", "5", "--dynamics", "rbf", "--centers"],
        "centers",
    ),
    (&["chaos", "--data", "CSV", "--column", "theta", "--ssm-dim"], "ssm"),
    (&["chaos", "--data", "CSV", "--column", "theta", "--poly-order"], "poly"),
    (&["stability-chart", "--scene", "furuta-dt25", "--out", "/nonexistent/x.png", "--kp"], "kp"),
    (&["stability", "--scene", "furuta-dt25", "--set"], "kp"),
    (&["bench", "simulate", "--periods"], "periods"),
];

fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 { (c >> 1) ^ 0xEDB8_8320 } else { c >> 1 };
        }
    }
    !c
}

/// Replaces the JSON value (number or array) starting at the `at`-th `: ` or `:` of `t`.
fn replace_json_value(t: &str, at: usize, value: &str) -> String {
    let starts: Vec<usize> = t
        .match_indices(':')
        .map(|(i, _)| if t[i + 1..].starts_with(' ') { i + 2 } else { i + 1 })
        .filter(|&i| t[i..].starts_with(['-', '0', '1', '2', '3', '4', '5', '6', '7', '8', '9', '[']))
        .collect();
    let i = starts[at % starts.len()];
    let end = if t[i..].starts_with('[') {
        let mut depth = 0;
        i + t[i..]
            .char_indices()
            .find(|&(_, ch)| {
                depth += match ch {
                    '[' => 1,
                    ']' => -1,
                    _ => 0,
                };
                depth == 0
            })
            .unwrap()
            .0
            + 1
    } else {
        i + t[i..].find([',', '\n', '}', ']']).unwrap()
    };
    format!("{}{}{}", &t[..i], value, &t[end..])
}

/// Writes the case's input, runs its command; returns (args, exit code, stderr, what the
/// message must name).
fn run_case(c: &Case, n: usize) -> (Vec<String>, Option<i32>, String, Vec<String>) {
    let f = fixture();
    let path = |ext: &str| f.dir.join(format!("case{n}.{ext}"));
    let csv_path = f.dir.join("sim/furuta-quant-dt25.csv");
    let (args, names): (Vec<String>, Vec<String>) = match c {
        Case::Scene { line, value } => {
            let lines: Vec<&str> = f.scene.lines().collect();
            let numeric: Vec<usize> = (0..lines.len())
                .filter(|&i| lines[i].split_once('=').is_some_and(|(_, v)| v.trim().parse::<f64>().is_ok()))
                .collect();
            let i = numeric[line % numeric.len()];
            let key = lines[i].split_once('=').unwrap().0.trim().to_string();
            let text: Vec<String> = lines
                .iter()
                .enumerate()
                .map(|(j, l)| if j == i { format!("{key} = {value}") } else { l.to_string() })
                .collect();
            let p = path("toml");
            std::fs::write(&p, text.join("\n")).unwrap();
            // The message names the file (TOML syntax) or the scene and the key of the value
            // refused (a configuration error names the key of the field it is about, e.g. a
            // fixed-point gain from kp and h_adc names kp).
            (
                vec!["stability".into(), "--scene".into(), s(&p).into()],
                vec![s(&p).into(), key, "scene furuta-quant-dt25: `".into()],
            )
        }
        Case::Csv { line, field, value, drop } => {
            let mut lines: Vec<String> = f.csv.lines().map(String::from).collect();
            let i = line % lines.len();
            if *drop {
                lines.remove(i);
            } else {
                let mut fields: Vec<String> = lines[i].split(',').map(String::from).collect();
                let k = field % fields.len();
                fields[k] = value.clone();
                lines[i] = fields.join(",");
            }
            let p = path("csv");
            std::fs::write(&p, lines.join("\n")).unwrap();
            (
                ["fit", "--data", s(&p), "--column", "theta", "--dim", "2", "--embed", "5"].map(String::from).to_vec(),
                vec![s(&p).into(), "--dim".into(), "--embed".into()],
            )
        }
        Case::Model { at, value } => {
            // Replace the JSON value (number or array) starting at the at-th `: ` of the text.
            let t = &f.model;
            let starts: Vec<usize> = t
                .match_indices(": ")
                .map(|(i, _)| i + 2)
                .filter(|&i| t[i..].starts_with(['-', '0', '1', '2', '3', '4', '5', '6', '7', '8', '9', '[']))
                .collect();
            let i = starts[at % starts.len()];
            let end = if t[i..].starts_with('[') {
                let mut depth = 0;
                i + t[i..]
                    .char_indices()
                    .find(|&(_, ch)| {
                        depth += match ch {
                            '[' => 1,
                            ']' => -1,
                            _ => 0,
                        };
                        depth == 0
                    })
                    .unwrap()
                    .0
                    + 1
            } else {
                i + t[i..].find([',', '\n', '}']).unwrap()
            };
            let text = format!("{}{}{}", &t[..i], value, &t[end..]);
            let p = path("json");
            std::fs::write(&p, text).unwrap();
            (
                vec!["export".into(), "--model".into(), s(&p).into(), "--out".into(), s(&path("out.bin")).into()],
                vec![s(&p).into()],
            )
        }
        Case::Blob { edits, fix_crc, cut } => {
            let mut b = f.blob.clone();
            for &(at, v) in edits {
                let i = at % b.len();
                b[i] = v;
            }
            if let Some(c) = cut {
                b.truncate(c % (b.len() + 1));
            }
            if *fix_crc && b.len() >= 22 {
                let crc = crc32(&b[22..]);
                b[18..22].copy_from_slice(&crc.to_le_bytes());
            }
            let p = path("bin");
            std::fs::write(&p, b).unwrap();
            (vec!["inspect".into(), s(&p).into()], vec![s(&p).into()])
        }
        Case::Mat { edits, huge } => {
            let mut b =
                std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../ssm/tests/data/duffing_plain.mat"))
                    .unwrap();
            for &(at, v) in edits {
                let i = 128 + at % (b.len() - 128);
                b[i] = v;
            }
            if let Some(at) = huge {
                // A u32 field at an 8-byte boundary after the header: a tag's byte count or
                // a dimension, set to 2^31 - 1.
                let i = 128 + 4 + 8 * (at % ((b.len() - 136) / 8));
                b[i..i + 4].copy_from_slice(&i32::MAX.to_le_bytes());
            }
            let p = path("mat");
            std::fs::write(&p, b).unwrap();
            (["fit", "--mat", s(&p), "--dim", "2", "--embed", "2"].map(String::from).to_vec(), vec![s(&p).into()])
        }
        Case::Spec { line, value } => {
            let lines: Vec<&str> = SPEC.lines().collect();
            let numeric: Vec<usize> = (0..lines.len())
                .filter(|&i| lines[i].split_once('=').is_some_and(|(_, v)| v.trim().parse::<f64>().is_ok()))
                .collect();
            let i = numeric[line % numeric.len()];
            let key = lines[i].split_once('=').unwrap().0.trim().to_string();
            let text: Vec<String> = lines
                .iter()
                .enumerate()
                .map(|(j, l)| if j == i { format!("{key} = {value}") } else { l.to_string() })
                .collect();
            let p = path("spec.toml");
            std::fs::write(&p, text.join("\n")).unwrap();
            let out = f.dir.join(format!("case{n}-sweep"));
            (vec!["sweep".into(), s(&p).into(), "--out".into(), s(&out).into()], vec![s(&p).into()])
        }
        Case::Shard { at, value } => {
            let text = replace_json_value(&f.shard, *at, value);
            let dir = f.dir.join(format!("case{n}-shards"));
            std::fs::create_dir_all(&dir).unwrap();
            let p = dir.join("shard-000000-of-000001.json");
            std::fs::write(&p, text).unwrap();
            let out = f.dir.join(format!("case{n}-merged"));
            (vec!["sweep-merge".into(), s(&dir).into(), "--out".into(), s(&out).into()], vec![s(&p).into()])
        }
        Case::Option { which, value } => {
            let (cmd, name) = OPTIONS[*which];
            let mut a: Vec<String> =
                cmd.iter().map(|x| if *x == "CSV" { s(&csv_path).to_string() } else { x.to_string() }).collect();
            match *a.last().unwrap() {
                ref l if l == "--set" => a.push(format!("controller.kp={value}")),
                ref l if l == "--kp" => a.push(format!("0:{value}:3")),
                _ => a.push(value.clone()),
            }
            // The option, or (clap's usage error for a value that looks like a flag, `-1`)
            // the value.
            let mut names = vec![name.to_string()];
            if !value.is_empty() {
                names.push(format!("'{value}'"));
            }
            // A value that is valid lets the command go on to its files: then those.
            names.extend(a.iter().filter(|x| x.starts_with('/')).cloned());
            (a, names)
        }
    };
    let refs: Vec<&str> = args.iter().map(String::as_str).collect();
    let (code, err) = ssmctl(&refs);
    (args, code, err, names)
}

#[test]
fn every_refusal_exits_1_or_2_naming_the_input_never_a_panic() {
    let f = fixture();
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: cases(),
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    let counter = std::sync::atomic::AtomicUsize::new(0);
    runner
        .run(&case(), |c| {
            let n = counter.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let (args, code, err, names) = run_case(&c, n);
            prop_assert!(
                matches!(code, Some(0..=2)),
                "{c:?} {args:?}: exit {code:?} (101 is a panic, 134 an abort, None a signal)\n{err}"
            );
            if code != Some(0) {
                prop_assert!(!err.trim().is_empty(), "{args:?}: failed without a message");
                // clap's usage error (2) for a value that reads as flags (`-inf` as `-i`) names
                // the flag and shows the usage.
                let usage = code == Some(2) && err.contains("Usage: ssmctl");
                prop_assert!(
                    usage || names.iter().any(|x| err.contains(x.as_str())),
                    "{c:?} {args:?}: exit {code:?}, the message names none of {names:?}:\n{err}"
                );
            } else if let Case::Model { .. } = c {
                // An export that succeeds wrote a blob that inspect accepts.
                let out = f.dir.join(format!("case{n}.out.bin"));
                let (code, err) = ssmctl(&["inspect", s(&out)]);
                prop_assert_eq!(code, Some(0), "{:?}: exported, then refused by inspect: {}", args, err);
            }
            Ok(())
        })
        .unwrap();
    let _ = std::fs::remove_dir_all(&f.dir);
}
