//! Helpers shared by the controller's integration tests.
#![allow(dead_code)]

use controller::{ControllerConfig, Gains, QuantMode, Quantization};

/// 1024-line encoder read x4: one count is 2 pi / 4096 rad.
pub const H_ADC: f64 = 2.0 * core::f64::consts::PI / 4096.0;
/// 11 bits per side at 10 V: one code is 10/2048 V.
pub const H_DAC: f64 = 10.0 / 2048.0;

/// The paper's gains at dt = 25 ms, counts path, u_max = 10 V.
pub fn paper_counts(ki: f64, delay: u32) -> ControllerConfig {
    ControllerConfig { ki, delay, u_max: Some(10.0), ..ControllerConfig::paper(0.025).with_counts(H_ADC, H_ADC, H_DAC) }
}

/// The shorthand law's configuration with every field given (no resolutions).
#[allow(clippy::too_many_arguments)]
pub fn shorthand(
    kp: f64,
    kd: f64,
    kphi_d: f64,
    ki: f64,
    dt: f64,
    delay: u32,
    u_max: Option<f64>,
    quant: Option<Quantization>,
) -> ControllerConfig {
    ControllerConfig { gains: Gains::shorthand(kp, kd, kphi_d, 0.0, 0.0), ki, dt, delay, u_max, quant }
}

/// A counts-mode quantization with DAC step `h_dac`.
pub fn counts(h_dac: f64) -> Option<Quantization> {
    Some(Quantization { mode: QuantMode::Counts, h_dac })
}

/// `|a - b| <= atol + rtol * scale`, with a message naming the case.
pub fn assert_close(a: f64, b: f64, rtol: f64, scale: f64, what: &str) {
    let tol = rtol * scale.abs() + f64::MIN_POSITIVE;
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b}, |diff| = {} > {tol}", (a - b).abs());
}
