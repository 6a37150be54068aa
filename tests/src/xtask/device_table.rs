//! The device cost table: test models with K = 50 ... 1000 centres at d = 6, the input
//! windows, an independent `f64` evaluation of every model's prediction, and the parser of
//! the firmware's `dt ...` lines (`qemu/src/bin/device_table.rs`).

use crate::rng::{Rng, orthonormal_v1};
use shared::ControllerConfig;
use shared::model::OwnedModel;
use std::collections::BTreeMap;
use std::fmt::Write as _;

pub const P: usize = 13;
pub const SHIFT: usize = 2;
pub const D: usize = 6;
pub const ORDER: usize = 3;
pub const CENTRES: [usize; 5] = [50, 100, 200, 500, 1000];
/// Samples a window spans, `(p-1)*shift + 1`.
pub const WINDOW: usize = (P - 1) * SHIFT + 1;
pub const WINDOWS: usize = 4;
pub const HORIZON: u32 = 12;
pub const FLAVOURS: [&str; 3] = ["libm", "fast", "hardware"];
/// Centre counts and scalars of the generic-kernel rows (f32 on the FPU, f64 in software).
pub const GENERIC_CENTRES: [usize; 2] = [50, 200];
pub const SCALARS: [&str; 2] = ["f32", "f64"];
/// SysTick ticks (40 ns) per instruction (2^7 ns) under `-icount shift=7`.
pub const TICKS_PER_INSTRUCTION: f64 = 128.0 / 40.0;

/// A random but valid model with `k` centres: `V1` with orthonormal columns, three damped
/// rotations as the affine part, centres uniform in `[-1, 1]^d`, RBF weights of size
/// `0.05 / sqrt(k)` (the RBF sum stays O(0.1) and the map contracting for every `k`), small lift coefficients.
pub fn model(k: usize) -> OwnedModel {
    let mut rng = Rng(0x4445_5654_4142_0000 ^ k as u64);
    let v1 = orthonormal_v1(&mut rng, P, D);
    let n_terms = shared::model::lift_terms(D, ORDER).expect("small");
    let lift = (0..P * n_terms).map(|_| (0.05 * rng.sym()) as f32).collect();
    let centres = (0..k * D).map(|_| rng.sym() as f32).collect();
    let w = 0.05 / (k as f64).sqrt();
    let weights = (0..k * D).map(|_| (w * rng.sym()) as f32).collect();
    let mut affine = vec![0.0f32; D * (D + 1)];
    for (block, (r, th)) in [(0.95f64, 0.15f64), (0.9, 0.4), (0.85, 0.9)].into_iter().enumerate() {
        let (c, s) = ((r * th.cos()) as f32, (r * th.sin()) as f32);
        let (i, j) = (2 * block, 2 * block + 1);
        affine[i * (D + 1) + i] = c;
        affine[i * (D + 1) + j] = -s;
        affine[j * (D + 1) + i] = s;
        affine[j * (D + 1) + j] = c;
        affine[i * (D + 1) + D] = (0.01 * rng.sym()) as f32;
        affine[j * (D + 1) + D] = (0.01 * rng.sym()) as f32;
    }
    OwnedModel {
        config: ControllerConfig::paper(0.002),
        p: P,
        shift: SHIFT,
        sample_period: 0.002,
        offset: 0.0,
        scale: 0.5,
        d: D,
        lift_order: ORDER,
        k,
        v1,
        lift,
        centres,
        weights,
        affine,
    }
}

/// Input windows: sums of two oscillations with different phases per window.
pub fn windows() -> Vec<Vec<f32>> {
    (0..WINDOWS)
        .map(|w| {
            (0..WINDOW)
                .map(|i| {
                    let t = i as f64;
                    let ph = 1.3 * w as f64;
                    (0.4 * (0.11 * t + ph).sin() + 0.2 * (0.29 * t + 2.0 * ph).cos()) as f32
                })
                .collect()
        })
        .collect()
}

/// Independent `f64` evaluation of the model formula of `shared::model`, written from the
/// documentation: monomials enumerated as non-decreasing index tuples in lexicographic order.
pub mod reference {
    use shared::model::OwnedModel;

    fn tuples(d: usize, k: usize, start: usize, prefix: &mut Vec<usize>, out: &mut Vec<Vec<usize>>) {
        if prefix.len() == k {
            out.push(prefix.clone());
            return;
        }
        for i in start..d {
            prefix.push(i);
            tuples(d, k, i, prefix, out);
            prefix.pop();
        }
    }

    /// The lift monomials as index tuples, degree 2..=order.
    pub fn monomials(d: usize, order: usize) -> Vec<Vec<usize>> {
        let mut out = Vec::new();
        for k in 2..=order {
            tuples(d, k, 0, &mut Vec::new(), &mut out);
        }
        out
    }

    /// `V1^T (y - offset) / scale` with `y_j = window[j * shift]`.
    pub fn reduce(m: &OwnedModel, window: &[f32]) -> Vec<f64> {
        (0..m.d)
            .map(|j| {
                (0..m.p)
                    .map(|i| {
                        let y = f64::from(window[i * m.shift]);
                        f64::from(m.v1[i * m.d + j]) * (y - f64::from(m.offset)) / f64::from(m.scale)
                    })
                    .sum()
            })
            .collect()
    }

    pub fn step(m: &OwnedModel, eta: &[f64]) -> Vec<f64> {
        let d = m.d;
        (0..d)
            .map(|j| {
                let mut acc = f64::from(m.affine[j * (d + 1) + d]);
                for (l, &e) in eta.iter().enumerate() {
                    acc += f64::from(m.affine[j * (d + 1) + l]) * e;
                }
                for i in 0..m.k {
                    let r = (0..d).map(|l| (eta[l] - f64::from(m.centres[i * d + l])).powi(2)).sum::<f64>().sqrt();
                    acc += f64::from(m.weights[i * d + j]) * r;
                }
                acc
            })
            .collect()
    }

    /// Component 0 of the lifted embedding, unnormalized.
    pub fn lift0(m: &OwnedModel, eta: &[f64]) -> f64 {
        let mono = monomials(m.d, m.lift_order);
        let lin: f64 = (0..m.d).map(|j| f64::from(m.v1[j]) * eta[j]).sum();
        let nl: f64 = mono
            .iter()
            .enumerate()
            .map(|(t, idx)| f64::from(m.lift[t]) * idx.iter().map(|&i| eta[i]).product::<f64>())
            .sum();
        (lin + nl) * f64::from(m.scale) + f64::from(m.offset)
    }

    /// `lift0(step^n(reduce(window)))`.
    pub fn predict(m: &OwnedModel, window: &[f32], n: u32) -> f64 {
        let mut eta = reduce(m, window);
        for _ in 0..n {
            eta = step(m, &eta);
        }
        lift0(m, &eta)
    }
}

/// The generated data: blobs per `k`, `device_table.rs` and the f64 references
/// (`[k index][window]`).
pub struct Data {
    pub blobs: Vec<(usize, Vec<u8>)>,
    pub source: String,
    pub reference: Vec<Vec<f64>>,
}

pub fn generate() -> Result<Data, String> {
    let wins = windows();
    let mut blobs = Vec::new();
    let mut reference = Vec::new();
    for k in CENTRES {
        let m = model(k);
        let blob = m.encode().map_err(|e| format!("encoding the K = {k} table model: {e}"))?;
        let r: Vec<f64> = wins.iter().map(|w| reference::predict(&m, w, HORIZON)).collect();
        if r.iter().any(|x| !x.is_finite() || x.abs() > 10.0) || r.iter().all(|x| x.abs() < 1e-3) {
            return Err(format!("the K = {k} table model is degenerate: references {r:?}"));
        }
        blobs.push((k, blob));
        reference.push(r);
    }
    let mut s = String::new();
    let _ = writeln!(s, "// Generated by `cargo xtask device-table` (tests/src/xtask/device_table.rs). Do not edit.");
    let _ = writeln!(s, "pub const HORIZON: u32 = {HORIZON};");
    let _ = writeln!(s, "/// (K, blob) of the table models, d = {D}, p = {P}, lift order {ORDER}.");
    let _ = writeln!(s, "pub static MODELS: [(usize, &[u8]); {}] = [", CENTRES.len());
    for k in CENTRES {
        let _ = writeln!(
            s,
            "    ({k}, include_bytes!(concat!(env!(\"CARGO_MANIFEST_DIR\"), \"/target-data/dt_k{k}.bin\")) as &[u8]),"
        );
    }
    let _ = writeln!(s, "];");
    let _ = writeln!(s, "pub static WINDOWS: [[u32; {WINDOW}]; {WINDOWS}] = [");
    for w in &wins {
        let bits: Vec<String> = w.iter().map(|x| format!("{:#010x}", x.to_bits())).collect();
        let _ = writeln!(s, "    [{}],", bits.join(", "));
    }
    let _ = writeln!(s, "];");
    Ok(Data { blobs, source: s, reference })
}

/// One `dt KEY reps=R ticks=T base=B` measurement.
#[derive(Clone, Debug, PartialEq)]
pub struct Measure {
    pub reps: u64,
    pub ticks: u64,
    pub base: u64,
}

impl Measure {
    /// Instructions per call: `(ticks - base) * 40 / 128 / reps`.
    pub fn per_call(&self) -> f64 {
        (self.ticks as f64 - self.base as f64) / TICKS_PER_INSTRUCTION / self.reps as f64
    }
}

/// Everything the firmware printed.
#[derive(Debug, Default)]
pub struct Parsed {
    /// `calib_nops1000`, `ctrl_int`, `ctrl_f32`, `ctrl_f64`, `project`, `lift`, `pred:K:SQRT`.
    pub measures: BTreeMap<String, Measure>,
    /// `(K, sqrt, window)` -> prediction.
    pub predictions: BTreeMap<(usize, String, usize), f32>,
    /// `(K, scalar, window)` -> prediction of the generic kernel (`gstep:K:SCALAR` measures).
    pub generic: BTreeMap<(usize, String, usize), f64>,
    pub done: bool,
}

fn field<'a>(tokens: &[&'a str], name: &str) -> Result<&'a str, String> {
    tokens
        .iter()
        .find_map(|t| t.strip_prefix(name).and_then(|r| r.strip_prefix('=')))
        .ok_or_else(|| format!("device-table line lacks `{name}=`: {}", tokens.join(" ")))
}

fn num<T: std::str::FromStr>(tokens: &[&str], name: &str) -> Result<T, String> {
    let v = field(tokens, name)?;
    v.parse().map_err(|_| format!("device-table line: `{name}={v}` is not a number"))
}

/// Parses the firmware's output; a `dt error` line or a malformed `dt` line is an error.
pub fn parse(text: &str) -> Result<Parsed, String> {
    let mut out = Parsed::default();
    for line in text.lines() {
        let Some(rest) = line.strip_prefix("dt ") else { continue };
        let tokens: Vec<&str> = rest.split_whitespace().collect();
        match tokens.first().copied() {
            Some("error") => return Err(format!("firmware reported: {rest}")),
            Some("done") => out.done = true,
            Some("predval") => {
                let k = num(&tokens, "k")?;
                let sqrt = field(&tokens, "sqrt")?.to_string();
                let w = num(&tokens, "w")?;
                let bits = field(&tokens, "bits")?;
                let bits = u32::from_str_radix(bits.trim_start_matches("0x"), 16)
                    .map_err(|_| format!("device-table line: bad bits `{bits}`"))?;
                out.predictions.insert((k, sqrt, w), f32::from_bits(bits));
            }
            Some("gpredval") => {
                let k = num(&tokens, "k")?;
                let scalar = field(&tokens, "scalar")?.to_string();
                let w = num(&tokens, "w")?;
                let bits = field(&tokens, "bits")?;
                let bits = u64::from_str_radix(bits.trim_start_matches("0x"), 16)
                    .map_err(|_| format!("device-table line: bad bits `{bits}`"))?;
                out.generic.insert((k, scalar, w), f64::from_bits(bits));
            }
            Some(key) => {
                let name = if key == "pred" {
                    format!("pred:{}:{}", num::<usize>(&tokens, "k")?, field(&tokens, "sqrt")?)
                } else if key == "gstep" {
                    format!("gstep:{}:{}", num::<usize>(&tokens, "k")?, field(&tokens, "scalar")?)
                } else {
                    key.to_string()
                };
                let m =
                    Measure { reps: num(&tokens, "reps")?, ticks: num(&tokens, "ticks")?, base: num(&tokens, "base")? };
                if m.reps == 0 || m.ticks < m.base {
                    return Err(format!("device-table line: implausible measurement {line}"));
                }
                out.measures.insert(name, m);
            }
            None => return Err("empty `dt` line".into()),
        }
    }
    if !out.done {
        return Err("the device-table firmware did not finish (no `dt done` line)".into());
    }
    Ok(out)
}

/// One predictor row of the table.
#[derive(Debug, Clone)]
pub struct PredRow {
    pub centers: usize,
    pub sqrt: &'static str,
    pub instructions: f64,
    pub per_center: f64,
    pub rel_error: f64,
}

/// One row of the f32-vs-f64 comparison (the firmware's generic kernel).
#[derive(Debug, Clone)]
pub struct ScalarRow {
    pub centers: usize,
    pub scalar: &'static str,
    pub instructions: f64,
    pub per_center: f64,
    pub rel_error: f64,
}

/// The table: controller steps, predictor rows, projection and lift.
#[derive(Debug, Clone)]
pub struct Table {
    pub calib_nops1000: f64,
    /// The Furuta's configuration (two coordinates).
    pub ctrl_int: f64,
    /// The same gains on one and on four coordinates.
    pub ctrl_int_n1: f64,
    pub ctrl_int_n3: f64,
    pub ctrl_int_n4: f64,
    /// The same four with a configuration the compiler cannot fold in (decoded at run time,
    /// as in the PIL firmware): 1, 2, 3, 4 coordinates.
    pub ctrl_int_rt: [f64; 4],
    /// The Furuta's two coordinates without integral action (PD, the bundled scenes' law),
    /// configuration decoded at run time.
    pub ctrl_int_rt_pd: f64,
    pub ctrl_f32: f64,
    pub ctrl_f64: f64,
    pub project: f64,
    pub lift: f64,
    pub predictor: Vec<PredRow>,
    /// The generic kernel as f32 and as f64 (software double) for [`GENERIC_CENTRES`].
    pub scalar: Vec<ScalarRow>,
}

/// `rel_error = max_w |device_w - ref_w| / max_w |ref_w|` over the input windows, the
/// device's `predict(HORIZON)` against the host's f64 evaluation of the same model.
pub fn table(parsed: &Parsed, reference: &[Vec<f64>]) -> Result<Table, String> {
    let get = |key: &str| {
        parsed.measures.get(key).map(Measure::per_call).ok_or_else(|| format!("device table: no `{key}` measurement"))
    };
    let calib = get("calib_nops1000")?;
    if (calib - 1000.0).abs() > 2.0 {
        return Err(format!(
            "1,000 nops measured as {calib:.1} instructions: QEMU is not running with `-icount shift=7` (or SysTick is not the 25 MHz core clock)"
        ));
    }
    let mut rows = Vec::new();
    for (ki, k) in CENTRES.into_iter().enumerate() {
        let refs = reference.get(ki).ok_or("missing reference")?;
        for sqrt in FLAVOURS {
            let instructions = get(&format!("pred:{k}:{sqrt}"))?;
            let mut err: f64 = 0.0;
            let mut norm: f64 = 0.0;
            for (w, &r) in refs.iter().enumerate() {
                let got = parsed
                    .predictions
                    .get(&(k, sqrt.to_string(), w))
                    .ok_or_else(|| format!("device table: no prediction for K = {k}, {sqrt}, window {w}"))?;
                err = err.max((f64::from(*got) - r).abs());
                norm = norm.max(r.abs());
            }
            rows.push(PredRow {
                centers: k,
                sqrt,
                instructions,
                per_center: instructions / k as f64,
                rel_error: err / norm,
            });
        }
    }
    let mut scalar = Vec::new();
    for k in GENERIC_CENTRES {
        let ki = CENTRES.iter().position(|&c| c == k).ok_or("generic K not among the table's")?;
        let refs = reference.get(ki).ok_or("missing reference")?;
        for s in SCALARS {
            let instructions = get(&format!("gstep:{k}:{s}"))?;
            let (mut err, mut norm) = (0.0f64, 0.0f64);
            for (w, &r) in refs.iter().enumerate() {
                let got = parsed
                    .generic
                    .get(&(k, s.to_string(), w))
                    .ok_or_else(|| format!("device table: no {s} prediction for K = {k}, window {w}"))?;
                err = err.max((got - r).abs());
                norm = norm.max(r.abs());
            }
            scalar.push(ScalarRow {
                centers: k,
                scalar: s,
                instructions,
                per_center: instructions / k as f64,
                rel_error: err / norm,
            });
        }
    }
    Ok(Table {
        calib_nops1000: calib,
        ctrl_int: get("ctrl_int")?,
        ctrl_int_n1: get("ctrl_int_n1")?,
        ctrl_int_n3: get("ctrl_int_n3")?,
        ctrl_int_n4: get("ctrl_int_n4")?,
        ctrl_int_rt: [get("ctrl_int_rt_n1")?, get("ctrl_int_rt")?, get("ctrl_int_rt_n3")?, get("ctrl_int_rt_n4")?],
        ctrl_int_rt_pd: get("ctrl_int_rt_pd")?,
        ctrl_f32: get("ctrl_f32")?,
        ctrl_f64: get("ctrl_f64")?,
        project: get("project")?,
        lift: get("lift")?,
        predictor: rows,
        scalar,
    })
}

/// Accuracy bounds of the table's predictions (`predict(HORIZON)` against the host's f64):
/// correctly rounded sqrt flavours to f32 accuracy, micromath's fast sqrt (~5 % per root)
/// within 10 %. A table that violates them (or has a non-finite entry) fails `xtask test`.
pub const REL_ERROR_EXACT: f64 = 1e-4;
pub const REL_ERROR_FAST: f64 = 0.1;
/// The f64 kernel against the host's f64 evaluation of the same model: only summation order
/// and libm's `sqrt` against std's may differ (both correctly rounded), so near f64 epsilon.
pub const REL_ERROR_F64: f64 = 1e-12;

pub fn check(t: &Table) -> Result<(), String> {
    for r in &t.predictor {
        let bound = if r.sqrt == "fast" { REL_ERROR_FAST } else { REL_ERROR_EXACT };
        if !(r.rel_error <= bound && r.instructions.is_finite() && r.instructions > 0.0) {
            return Err(format!(
                "K = {} {}: rel_error {:e} (bound {bound:e}), {} instructions",
                r.centers, r.sqrt, r.rel_error, r.instructions
            ));
        }
    }
    for r in &t.scalar {
        let bound = if r.scalar == "f64" { REL_ERROR_F64 } else { REL_ERROR_EXACT };
        if !(r.rel_error <= bound && r.instructions.is_finite() && r.instructions > 0.0) {
            return Err(format!(
                "generic kernel K = {} {}: rel_error {:e} (bound {bound:e}), {} instructions",
                r.centers, r.scalar, r.rel_error, r.instructions
            ));
        }
    }
    if t.scalar.len() != GENERIC_CENTRES.len() * SCALARS.len() {
        return Err(format!("{} f32/f64 rows, expected {}", t.scalar.len(), GENERIC_CENTRES.len() * SCALARS.len()));
    }
    for (what, v) in [
        ("IntPd", t.ctrl_int),
        ("IntPd (1 coordinate)", t.ctrl_int_n1),
        ("IntPd (3 coordinates)", t.ctrl_int_n3),
        ("IntPd (4 coordinates)", t.ctrl_int_n4),
        ("IntPd (run-time configuration, 1 coordinate)", t.ctrl_int_rt[0]),
        ("IntPd (run-time configuration, 2 coordinates)", t.ctrl_int_rt[1]),
        ("IntPd (run-time configuration, 3 coordinates)", t.ctrl_int_rt[2]),
        ("IntPd (run-time configuration, 4 coordinates)", t.ctrl_int_rt[3]),
        ("IntPd (run-time configuration, PD on 2 coordinates)", t.ctrl_int_rt_pd),
        ("FloatPd<f32>", t.ctrl_f32),
        ("FloatPd<f64>", t.ctrl_f64),
    ] {
        if !(v.is_finite() && v > 0.0) {
            return Err(format!("{what} step measured as {v} instructions"));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller::predictor::{Predictor, SqrtFlavour};
    use shared::model::Model;

    type Pred = Predictor<16, 6, 1000, 80, 64>;

    #[test]
    fn monomial_enumeration_matches_documented_order() {
        // d = 2, order 3: eta0^2, eta0 eta1, eta1^2, eta0^3, eta0^2 eta1, eta0 eta1^2, eta1^3.
        let m = reference::monomials(2, 3);
        let want: Vec<Vec<usize>> =
            vec![vec![0, 0], vec![0, 1], vec![1, 1], vec![0, 0, 0], vec![0, 0, 1], vec![0, 1, 1], vec![1, 1, 1]];
        assert_eq!(m, want);
        assert_eq!(reference::monomials(D, ORDER).len(), shared::model::lift_terms(D, ORDER).unwrap());
    }

    /// The f64 reference and the f32 predictor (libm, correctly rounded) agree to f32
    /// accuracy on every table model; the fast sqrt is visibly less accurate.
    #[test]
    fn reference_agrees_with_f32_predictor() {
        let data = generate().unwrap();
        for ((k, blob), refs) in data.blobs.iter().zip(&data.reference) {
            let model = Model::<16, 6, 1000, 80>::decode(blob).unwrap();
            for (sqrt, tol) in [(SqrtFlavour::Libm, 1e-4), (SqrtFlavour::Fast, 0.5)] {
                let mut p = Pred::from_model(model.clone(), sqrt).unwrap();
                for (w, &r) in windows().iter().zip(refs) {
                    p.reset();
                    for &x in w {
                        p.push(x).unwrap();
                    }
                    let got = f64::from(p.predict(HORIZON).unwrap());
                    assert!((got - r).abs() <= tol * r.abs().max(0.05), "K = {k} {sqrt:?}: {got} vs {r}");
                }
            }
        }
    }

    #[test]
    fn parser_reads_lines_and_rejects_errors() {
        let text = "noise\ndt ctrl_int reps=1000 ticks=320000 base=32000\ndt predval k=50 sqrt=fast w=1 bits=0x3f800000\ndt pred k=50 sqrt=libm reps=4 ticks=12800 base=0\ndt gstep k=200 scalar=f64 reps=10 ticks=64000 base=0\ndt gpredval k=200 scalar=f64 w=3 bits=0xbff8000000000000\ndt done\n";
        let p = parse(text).unwrap();
        assert_eq!(p.measures["gstep:200:f64"].per_call(), 2000.0);
        assert_eq!(p.generic[&(200, "f64".to_string(), 3)], -1.5);
        assert!(parse("dt gpredval k=1 scalar=f64 w=0 bits=0xzz\ndt done\n").unwrap_err().contains("bad bits"));
        assert_eq!(p.measures["ctrl_int"].per_call(), 90.0);
        assert_eq!(p.measures["pred:50:libm"].per_call(), 1000.0);
        assert_eq!(p.predictions[&(50, "fast".to_string(), 1)], 1.0);
        assert!(parse("dt ctrl_int reps=1 ticks=1 base=0\n").unwrap_err().contains("did not finish"));
        assert!(parse("dt error HardFault\ndt done\n").unwrap_err().contains("HardFault"));
        assert!(parse("dt ctrl_int reps=x ticks=1 base=0\ndt done\n").unwrap_err().contains("reps=x"));
        assert!(parse("dt ctrl_int reps=1 ticks=1 base=5\ndt done\n").unwrap_err().contains("implausible"));
    }
}
