//! Models shared by the format tests (the module `common` of `tests/integration.rs`).
#![allow(dead_code)]

use shared::ControllerConfig;
use shared::model::ModelRef;

pub const TINY_V1: [f32; 2] = [0.6, 0.8];
pub const TINY_LIFT: [f32; 2] = [0.25, -0.5];
pub const TINY_CENTRES: [f32; 1] = [0.125];
pub const TINY_WEIGHTS: [f32; 1] = [0.2];
pub const TINY_AFFINE: [f32; 2] = [0.9, 0.0];

/// p = 2, d = 1, lift order 2 (one monomial), one centre.
pub fn tiny() -> ModelRef<'static> {
    ModelRef {
        config: ControllerConfig::paper(0.01),
        p: 2,
        shift: 1,
        sample_period: 0.01,
        offset: 0.5,
        scale: 2.0,
        d: 1,
        lift_order: 2,
        k: 1,
        v1: &TINY_V1,
        lift: &TINY_LIFT,
        centres: &TINY_CENTRES,
        weights: &TINY_WEIGHTS,
        affine: &TINY_AFFINE,
    }
}

/// The pinned model of `data/model_v2.bin` (`data/model_v1.bin` is the same model in the
/// format before the gain vector): p = 4, shift 2, d = 2, lift order 3 (7 terms),
/// k = 3, with quantization and saturation in its config.
pub mod pinned {
    use shared::{ControllerConfig, Gains, QuantMode, Quantization};
    pub const CONFIG: ControllerConfig = ControllerConfig {
        gains: Gains::shorthand(15.5, 5.45, 1.5, 0.0015339807878856412, 0.0015339807878856412),
        ki: 0.25,
        dt: 0.002,
        delay: 1,
        u_max: Some(10.0),
        quant: Some(Quantization { mode: QuantMode::Counts, h_dac: 0.0048828125 }),
    };
    pub const V1: [f32; 8] = [0.5, 0.5, 0.5, -0.5, 0.5, 0.5, 0.5, -0.5];
    pub const LIFT: [f32; 28] = [
        0.01, -0.02, 0.03, -0.04, 0.05, -0.06, 0.07, //
        0.11, -0.12, 0.13, -0.14, 0.15, -0.16, 0.17, //
        0.21, -0.22, 0.23, -0.24, 0.25, -0.26, 0.27, //
        0.31, -0.32, 0.33, -0.34, 0.35, -0.36, 0.37,
    ];
    pub const CENTRES: [f32; 6] = [0.0, 0.0, 1.0, -1.0, -0.5, 0.25];
    pub const WEIGHTS: [f32; 6] = [0.001, -0.002, 0.003, 0.004, -0.005, 0.006];
    pub const AFFINE: [f32; 6] = [0.95, -0.2, 0.001, 0.2, 0.95, -0.002];
}

pub fn pinned() -> ModelRef<'static> {
    ModelRef {
        config: pinned::CONFIG,
        p: 4,
        shift: 2,
        sample_period: 0.002,
        offset: -0.0125,
        scale: 0.5,
        d: 2,
        lift_order: 3,
        k: 3,
        v1: &pinned::V1,
        lift: &pinned::LIFT,
        centres: &pinned::CENTRES,
        weights: &pinned::WEIGHTS,
        affine: &pinned::AFFINE,
    }
}

pub fn encode(m: &ModelRef<'_>) -> Vec<u8> {
    let mut buf = vec![0u8; m.encoded_len_bound()];
    let n = m.encode_into(&mut buf).expect("test model encodes");
    buf.truncate(n);
    buf
}
