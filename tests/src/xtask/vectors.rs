//! The on-target test data: a synthetic reduced model (deterministic), its blob, the input
//! samples and the predictor outputs the device must reproduce bit for bit, computed here
//! with the same `controller::predictor` code.

use controller::predictor::{Predictor, SqrtFlavour};
use shared::ControllerConfig;
use shared::model::{Model, OwnedModel};
use std::fmt::Write as _;

/// Capacities of the firmware's predictor (`qemu/src/model_tests.rs` uses the same).
pub type Pred = Predictor<16, 6, 64, 64, 64>;

pub const P: usize = 8;
pub const SHIFT: usize = 2;
pub const D: usize = 4;
pub const ORDER: usize = 3;
pub const K: usize = 32;
pub const INPUTS: usize = 60;
pub const HORIZON: u32 = 12;
pub const FREE_RUN: usize = 100;
pub const CORRUPT_CASES: u32 = 2000;

/// SplitMix64, for reproducible pseudo-random coefficients.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [-1, 1).
    fn sym(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// A stable synthetic model: `V1` with orthonormal columns, a contracting rotation pair as
/// the affine part, small RBF weights and lift coefficients.
pub fn model() -> OwnedModel {
    let mut rng = Rng(0x0053_534d_5200_0001);
    // Gram-Schmidt on random columns (f64), stored row-major p x d.
    let mut cols: Vec<Vec<f64>> = Vec::new();
    while cols.len() < D {
        let mut v: Vec<f64> = (0..P).map(|_| rng.sym()).collect();
        for c in &cols {
            let dot: f64 = v.iter().zip(c).map(|(a, b)| a * b).sum();
            v.iter_mut().zip(c).for_each(|(a, b)| *a -= dot * b);
        }
        let norm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
        if norm > 1e-3 {
            cols.push(v.into_iter().map(|a| a / norm).collect());
        }
    }
    let v1 = (0..P).flat_map(|i| cols.iter().map(move |c| c[i] as f32)).collect();
    let n_terms = shared::model::lift_terms(D, ORDER).expect("small");
    let lift = (0..P * n_terms).map(|_| (0.05 * rng.sym()) as f32).collect();
    let centres = (0..K * D).map(|_| rng.sym() as f32).collect();
    let weights = (0..K * D).map(|_| (0.01 * rng.sym()) as f32).collect();
    // Two damped rotations: radius 0.96 at 0.2 rad/step, radius 0.9 at 0.5 rad/step.
    let mut affine = vec![0.0f32; D * (D + 1)];
    for (block, (r, th)) in [(0.96f64, 0.2f64), (0.9, 0.5)].into_iter().enumerate() {
        let (c, s) = ((r * th.cos()) as f32, (r * th.sin()) as f32);
        let (i, j) = (2 * block, 2 * block + 1);
        affine[i * (D + 1) + i] = c;
        affine[i * (D + 1) + j] = -s;
        affine[j * (D + 1) + i] = s;
        affine[j * (D + 1) + j] = c;
        affine[i * (D + 1) + D] = (0.002 * rng.sym()) as f32;
        affine[j * (D + 1) + D] = (0.002 * rng.sym()) as f32;
    }
    OwnedModel {
        config: ControllerConfig::paper(0.002),
        p: P,
        shift: SHIFT,
        sample_period: 0.002,
        offset: 0.02,
        scale: 0.3,
        d: D,
        lift_order: ORDER,
        k: K,
        v1,
        lift,
        centres,
        weights,
        affine,
    }
}

/// The observable fed to the device: two incommensurate oscillations.
pub fn inputs() -> Vec<f32> {
    (0..INPUTS)
        .map(|i| {
            let t = i as f64;
            (0.02 + 0.3 * (0.5 * (0.15 * t).sin() + 0.3 * (0.37 * t + 1.0).sin())) as f32
        })
        .collect()
}

pub struct Vectors {
    pub blob: Vec<u8>,
    pub source: String,
    pub rolling_len: usize,
}

fn bits_list(xs: &[f32]) -> String {
    xs.iter().map(|x| format!("{:#010x}", x.to_bits())).collect::<Vec<_>>().join(", ")
}

/// Blob plus `vectors.rs` for `qemu/target-data/`.
pub fn generate() -> Result<Vectors, String> {
    let owned = model();
    let blob = owned.encode().map_err(|e| format!("encoding the test model: {e}"))?;
    let decoded = Model::<16, 6, 64, 64>::decode(&blob).map_err(|e| format!("decoding the test model: {e}"))?;
    let input = inputs();
    let mut rolling: Vec<Vec<f32>> = Vec::new();
    let mut free: Vec<Vec<f32>> = Vec::new();
    for sqrt in SqrtFlavour::ALL {
        let mut p = Pred::from_model(decoded.clone(), sqrt).map_err(|e| e.to_string())?;
        let mut r = Vec::new();
        for &x in &input {
            p.push(x).map_err(|e| format!("{e:?}"))?;
            if p.is_ready() {
                r.push(p.predict(HORIZON).map_err(|e| format!("{e:?}"))?);
            }
        }
        let mut eta = p.reduce().map_err(|e| format!("{e:?}"))?;
        let mut f = Vec::new();
        for _ in 0..FREE_RUN {
            eta = p.step(&eta);
            f.push(p.lift(&eta));
        }
        if r.iter().chain(&f).any(|x| !x.is_finite()) {
            return Err("the test model diverges: non-finite expected outputs".into());
        }
        rolling.push(r);
        free.push(f);
    }
    let rolling_len = rolling[0].len();
    let mut s = String::new();
    let _ = writeln!(s, "// Generated by `cargo xtask qemu-test` (tests/src/xtask/vectors.rs). Do not edit.");
    let _ = writeln!(s, "/// [p, d, k, lift terms, shift] of the model blob.");
    let _ = writeln!(
        s,
        "pub const DIMS: [usize; 5] = [{}, {}, {}, {}, {}];",
        decoded.p(),
        decoded.d(),
        decoded.k(),
        decoded.lift_terms(),
        decoded.shift()
    );
    let _ = writeln!(s, "pub const SCALE_BITS: u32 = {:#010x};", decoded.scale().to_bits());
    let _ = writeln!(s, "pub const OFFSET_BITS: u32 = {:#010x};", decoded.offset().to_bits());
    let _ = writeln!(s, "pub const HORIZON: u32 = {HORIZON};");
    let _ = writeln!(s, "pub const CORRUPT_CASES: u32 = {CORRUPT_CASES};");
    let _ = writeln!(s, "pub static INPUTS: [u32; {}] = [{}];", input.len(), bits_list(&input));
    let _ = writeln!(s, "/// predict(HORIZON) after each push once the window is full; per flavour Libm, Fast, Hardware.");
    let _ = writeln!(s, "pub static ROLLING: [[u32; {rolling_len}]; 3] = [");
    for r in &rolling {
        let _ = writeln!(s, "    [{}],", bits_list(r));
    }
    let _ = writeln!(s, "];");
    let _ = writeln!(s, "/// lift after each of {FREE_RUN} map steps from the final window; per flavour.");
    let _ = writeln!(s, "pub static FREE_RUN: [[u32; {FREE_RUN}]; 3] = [");
    for f in &free {
        let _ = writeln!(s, "    [{}],", bits_list(f));
    }
    let _ = writeln!(s, "];");
    Ok(Vectors { blob, source: s, rolling_len })
}
