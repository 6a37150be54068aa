//! Fuzzing the app's boundaries (docs/decisions/0004): device blobs through `inspect` (the
//! host decoder plus the controller-configuration check), and the CLI's numeric options:
//! every run exits 0, 1 (an error naming the input) or 2 (clap's usage error), never 101
//! (panic) or 134 (abort), and within a bounded time.
//!
//! Bounded time: `FUZZ_CASES` cases per in-process property (default 300; the CLI property
//! runs a fifth of that, each case is a process); a fuzz campaign runs e.g.
//! `FUZZ_CASES=100000 cargo test -p ssmctl --test commands --release fuzz_boundaries::`.

use proptest::prelude::*;
use shared::model::OwnedModel;
use shared::{ControllerConfig, Gain, Gains, QuantMode, Quantization};
use ssmctl::fit_command::{BlobError, inspect};
use std::process::Command;
use std::time::{Duration, Instant};

fn cases() -> u32 {
    std::env::var("FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(300)
}

fn model(config: ControllerConfig) -> OwnedModel {
    OwnedModel {
        config,
        p: 5,
        shift: 1,
        sample_period: 0.025,
        offset: 0.0,
        scale: 1.0,
        d: 2,
        lift_order: 2,
        k: 2,
        v1: vec![0.1; 10],
        lift: vec![0.01; 15],
        centres: vec![0.1, 0.2, -0.3, 0.4],
        weights: vec![0.5, -0.5, 0.25, 0.125],
        affine: vec![0.9, 0.1, 0.0, -0.1, 0.9, 0.0],
    }
}

fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(f64::NAN),
        Just(f64::INFINITY),
        Just(0.0),
        Just(-0.0),
        Just(5e-324),
        Just(1e300),
        Just(-1.0),
        0.0f64..50.0,
        any::<f64>(),
    ]
}

fn any_config() -> impl Strategy<Value = ControllerConfig> {
    let quant = prop::option::of((prop::bool::ANY, any_f64()).prop_map(|(counts, h_dac)| Quantization {
        mode: if counts { QuantMode::Counts } else { QuantMode::Literal },
        h_dac,
    }));
    // Zero to four gains (zero and duplicate indices are invalid configurations too).
    let gain = (0u8..5, any_f64(), any_f64(), any_f64()).prop_map(|(index, p, d, h_adc)| Gain { index, p, d, h_adc });
    (
        prop::collection::vec(gain, 0..=4),
        any_f64(),
        any_f64(),
        prop_oneof![0u32..10, any::<u32>()],
        prop::option::of(any_f64()),
        quant,
    )
        .prop_map(|(g, ki, dt, delay, u_max, quant)| {
            let mut gains = Gains::new();
            for x in g {
                let _ = gains.push(x);
            }
            ControllerConfig { gains, ki, dt, delay, u_max, quant }
        })
}

/// The CRC-32 the blob header carries (ISO-HDLC, as `shared::model`).
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

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() })]

    /// A blob with any controller configuration passes `inspect` exactly when the
    /// controller's validation accepts the configuration, with the controller's message.
    #[test]
    fn blob_configuration_is_judged_by_the_controller_check(cfg in any_config()) {
        let blob = model(cfg).encode().unwrap();
        let expected = controller::validate_config::<{ controller::HISTORY }>(&cfg);
        match (inspect(&blob), expected) {
            (Ok(_), Ok(())) => {}
            (Err(BlobError::Config(e)), Err(x)) => prop_assert_eq!(e, x),
            (got, want) => prop_assert!(false, "{cfg:?}: inspect {got:?}, controller {want:?}"),
        }
    }

    /// Mutated payloads with a correct CRC reach every check of the decoder; none panics.
    #[test]
    fn mutated_blobs_with_valid_crc_never_panic(
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>(), 0u8..4), 1..8),
        truncate in prop::option::of(any::<prop::sample::Index>()),
    ) {
        let mut blob = model(ControllerConfig::paper(0.025)).encode().unwrap();
        let header = shared::model::HEADER_LEN;
        for (at, b, kind) in edits {
            let i = at.index(blob.len());
            match kind {
                0 | 1 => blob[i] = b,
                2 => blob[i] ^= 1 << (b % 8),
                _ => blob.insert(i.max(header), b),
            }
        }
        if let Some(t) = truncate {
            let n = t.index(blob.len() + 1);
            blob.truncate(n);
        }
        if blob.len() >= header {
            let payload_len = (blob.len() - header) as u32;
            blob[14..18].copy_from_slice(&payload_len.to_le_bytes());
            let crc = crc32(&blob[header..]);
            blob[18..22].copy_from_slice(&crc.to_le_bytes());
        }
        let _ = inspect(&blob);
    }
}

/// Numeric option values of every kind.
fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("0".to_string()),
        Just("-1".to_string()),
        Just("1e30".to_string()),
        Just("NaN".to_string()),
        Just("inf".to_string()),
        Just("18446744073709551615".to_string()),
        Just("18446744073709551616".to_string()),
        Just("1e-300".to_string()),
        Just("x".to_string()),
        (0u64..100).prop_map(|v| v.to_string()),
        any::<u64>().prop_map(|v| v.to_string()),
        any::<f64>().prop_map(|v| format!("{v:e}")),
    ]
}

/// Commands with one numeric option replaced; inputs that exist (a small simulated CSV).
fn command(which: usize, v: &str, csv: &str, dir: &str) -> Vec<String> {
    let args: Vec<&str> = match which {
        0 => vec!["stability", "--scene", "furuta-dt25", "--set"],
        1 => vec!["fit", "--data", csv, "--column", "theta", "--embed", "9", "--dim"],
        2 => vec!["fit", "--data", csv, "--column", "theta", "--dim", "2", "--embed"],
        3 => vec!["fit", "--data", csv, "--column", "theta", "--dim", "2", "--embed", "5", "--order"],
        4 => vec![
            "fit",
            "--data",
            csv,
            "--column",
            "theta",
            "--dim",
            "2",
            "--embed",
            "5",
            "--dynamics",
            "rbf",
            "--centers",
        ],
        5 => vec!["chaos", "--data", csv, "--column", "theta", "--ssm-dim", "2", "--centers", "20", "--poly-order"],
        6 => vec!["chaos", "--data", csv, "--column", "theta", "--ssm-dim"],
        7 => vec![
            "pil",
            "--scene",
            "furuta-quant-dt25",
            "--model",
            "/nonexistent.bin",
            "--out",
            dir,
            "--elf",
            "/nonexistent",
            "--timeout",
        ],
        8 => vec![
            "pil",
            "--scene",
            "furuta-quant-dt25",
            "--model",
            "/nonexistent.bin",
            "--out",
            dir,
            "--elf",
            "/nonexistent",
            "--periods",
        ],
        _ => vec!["simulate", "--scene", "furuta-dt25", "--out", dir, "--set"],
    };
    let mut a: Vec<String> = args.into_iter().map(String::from).collect();
    let key = ["controller.kp", "run.periods", "controller.dt_ms", "controller.delay"];
    match which {
        0 => a.push(format!("{}={v}", key[v.len() % key.len()])),
        9 => a.push(format!("run.periods={v}")),
        _ => a.push(v.to_string()),
    }
    a
}

#[test]
fn cli_numeric_options_exit_0_1_or_2_never_a_panic() {
    let dir = std::env::temp_dir().join(format!("ssmctl-fuzz-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let sim = dir.join("sim");
    let bin = env!("CARGO_BIN_EXE_ssmctl");
    let o = Command::new(bin)
        .args([
            "--quiet",
            "simulate",
            "--scene",
            "furuta-quant-dt25",
            "--out",
            sim.to_str().unwrap(),
            "--set",
            "run.periods=300",
        ])
        .output()
        .unwrap();
    assert!(o.status.success());
    let csv = sim.join("furuta-quant-dt25.csv");
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig {
        cases: (cases() / 5).max(10),
        failure_persistence: None,
        ..ProptestConfig::default()
    });
    runner
        .run(&(0usize..10, number()), |(which, v)| {
            let args = command(which, &v, csv.to_str().unwrap(), dir.join("out").to_str().unwrap());
            let t0 = Instant::now();
            let o = Command::new(bin).arg("--quiet").args(&args).output().unwrap();
            let code = o.status.code();
            let err = String::from_utf8_lossy(&o.stderr);
            prop_assert!(matches!(code, Some(0..=2)), "{args:?}: exit {code:?}\n{err}");
            prop_assert!(code == Some(0) || !err.trim().is_empty(), "{args:?}: failed silently");
            prop_assert!(t0.elapsed() < Duration::from_secs(60), "{args:?}: {:?}", t0.elapsed());
            Ok(())
        })
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
}
