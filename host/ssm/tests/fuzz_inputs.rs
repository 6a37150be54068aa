//! Fuzzing the learner's input boundaries (docs/decisions/0004): CSV data files and saved-model
//! JSON. Nothing may panic; an accepted series is valid; an accepted model can be used
//! (prediction, conversion to the device blob) without panicking.
//!
//! Bounded time: `FUZZ_CASES` cases per property (default 300); a fuzz campaign runs e.g.
//! `FUZZ_CASES=100000 cargo test -p ssm --test integration --release fuzz_inputs::`.

use proptest::prelude::*;
use serde_json::Value;
use ssm::data::parse_csv_column;
use ssm::{Dynamics, FitOptions, Ridge, SsmModel, TimeSeries, fit};
use std::sync::OnceLock;

fn cases() -> u32 {
    std::env::var("FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(300)
}

fn series(name: &str, a: f64, n: usize) -> TimeSeries {
    let t: Vec<f64> = (0..n).map(|i| i as f64 * 0.05).collect();
    let x = t
        .iter()
        .map(|&t| a * (-0.1 * t).exp() * (2.0 * t).cos() + 0.1 * a * a * (-0.2 * t).exp() * (4.0 * t).sin())
        .collect();
    TimeSeries::new(name, t, x).unwrap()
}

/// Saved models of each dynamics kind (fitted once), as JSON values to corrupt.
fn models() -> &'static Vec<Value> {
    static M: OnceLock<Vec<Value>> = OnceLock::new();
    M.get_or_init(|| {
        let train = [series("a", 1.0, 300), series("b", 0.7, 300)];
        [Dynamics::Rbf { centers: 12 }, Dynamics::Map, Dynamics::Flow]
            .into_iter()
            .map(|dynamics| {
                let o = FitOptions {
                    dim: 2,
                    embed: 5,
                    shift: 1,
                    manifold_order: 3,
                    dyn_order: 3,
                    dynamics,
                    ridge: Ridge::Fixed(1e-8),
                    linear_anchor: None,
                    anchor_joint: false,
                };
                serde_json::from_str(&fit(&train, &o).unwrap().to_json().unwrap()).unwrap()
            })
            .collect()
    })
}

/// Replacement values of every kind for a JSON node.
fn replacement() -> impl Strategy<Value = Value> {
    prop_oneof![
        Just(Value::Null),
        Just(serde_json::json!(0)),
        Just(serde_json::json!(1)),
        Just(serde_json::json!(-1)),
        Just(serde_json::json!(u32::MAX)),
        Just(serde_json::json!(u64::MAX)),
        Just(serde_json::json!(1e308)),
        Just(serde_json::json!(-1e308)),
        Just(serde_json::json!(5e-324)),
        Just(serde_json::json!([])),
        Just(serde_json::json!({})),
        Just(serde_json::json!("x")),
        (-1e6f64..1e6).prop_map(|v| serde_json::json!(v)),
        (0u32..50).prop_map(|v| serde_json::json!(v)),
        prop::collection::vec(0u32..40, 0..5).prop_map(|v| serde_json::json!(v)),
    ]
}

/// Walks `path` (indices taken modulo the children) into `v` and edits the node reached.
fn edit(node: &mut Value, path: &[prop::sample::Index], kind: u8, new: Value) {
    let has_child = match &*node {
        Value::Object(m) => !m.is_empty(),
        Value::Array(a) => !a.is_empty(),
        _ => false,
    };
    if let (true, Some((ix, rest))) = (has_child, path.split_first()) {
        let child = match node {
            Value::Object(m) => {
                let k = m.keys().nth(ix.index(m.len())).cloned().unwrap_or_default();
                m.get_mut(&k)
            }
            Value::Array(a) => {
                let i = ix.index(a.len());
                a.get_mut(i)
            }
            _ => None,
        };
        if let Some(c) = child {
            return edit(c, rest, kind, new);
        }
        return;
    }
    match (kind, &mut *node) {
        (0, Value::Array(a)) => {
            a.pop();
        }
        (1, Value::Array(a)) => {
            if let Some(x) = a.first().cloned() {
                a.push(x);
            }
        }
        (2, Value::Object(m)) => {
            if let Some(k) = m.keys().next().cloned() {
                m.remove(&k);
            }
        }
        _ => *node = new,
    }
}

/// An accepted model can be used: prediction and (RBF) device conversion return, no panic.
fn exercise(m: &SsmModel) {
    let test = series("test", 0.8, 200);
    if let Ok(p) = m.predict(&test) {
        let _ = p.nmte(&test);
        assert!(p.x.iter().all(|v| v.is_finite()) || p.stop.is_some());
    }
    let _ = m.dynamics.eigenvalues_ct();
    if let Ok(owned) = ssm::device::to_device_model(m, shared::ControllerConfig::paper(0.05)) {
        let _ = ssm::device::encode(&owned);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(), failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn corrupted_saved_models_never_panic(
        which in 0usize..3,
        edits in prop::collection::vec((prop::collection::vec(any::<prop::sample::Index>(), 1..6), 0u8..5, replacement()), 1..4),
    ) {
        let mut v = models()[which].clone();
        for (path, kind, new) in edits {
            edit(&mut v["model"], &path, kind, new);
        }
        if let Ok(m) = SsmModel::from_json(&v.to_string()) {
            exercise(&m);
        }
    }

    #[test]
    fn arbitrary_csv_text_never_panics(text in "[0-9a-z.,eE+\\- \n]{0,200}", column in prop::option::of("[a-z]{1,3}")) {
        if let Ok(ts) = parse_csv_column("fuzz.csv", "fuzz".into(), &text, column.as_deref()) {
            prop_assert!(ts.validate().is_ok());
        }
    }

    #[test]
    fn mutated_csv_files_never_panic(
        n in 2usize..40,
        edits in prop::collection::vec((any::<prop::sample::Index>(), "[0-9.,e\\-\nnaif ]{0,3}", 0u8..3), 1..6),
    ) {
        let mut text = String::from("t_s,theta_rad,phi\n");
        for i in 0..n {
            text.push_str(&format!("{},{},{}\n", i as f64 * 0.025, (i as f64).sin() * 0.01, i));
        }
        let mut chars: Vec<char> = text.chars().collect();
        for (at, s, kind) in edits {
            let i = at.index(chars.len() + 1);
            match kind {
                0 if i < chars.len() => { chars.remove(i); }
                _ => { for (k, c) in s.chars().enumerate() { chars.insert((i + k).min(chars.len()), c); } }
            }
        }
        let text: String = chars.into_iter().collect();
        for column in [None, Some("theta_rad"), Some("phi")] {
            if let Ok(ts) = parse_csv_column("fuzz.csv", "fuzz".into(), &text, column) {
                prop_assert!(ts.validate().is_ok());
            }
        }
    }
}
