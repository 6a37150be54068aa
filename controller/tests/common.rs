//! Helpers shared by the controller's integration tests.
#![allow(dead_code)]

use controller::{ControllerConfig, QuantMode, Quantization};

/// 1024-line encoder read x4: one count is 2 pi / 4096 rad.
pub const H_ADC: f64 = 2.0 * core::f64::consts::PI / 4096.0;
/// 11 bits per side at 10 V: one code is 10/2048 V.
pub const H_DAC: f64 = 10.0 / 2048.0;

/// The paper's gains at dt = 25 ms, counts path, u_max = 10 V.
pub fn paper_counts(ki: f64, delay: u32) -> ControllerConfig {
    ControllerConfig {
        ki,
        delay,
        u_max: Some(10.0),
        quant: Some(Quantization { mode: QuantMode::Counts, h_adc: H_ADC, h_adc_phi: H_ADC, h_dac: H_DAC }),
        ..ControllerConfig::paper(0.025)
    }
}

/// `|a - b| <= atol + rtol * scale`, with a message naming the case.
pub fn assert_close(a: f64, b: f64, rtol: f64, scale: f64, what: &str) {
    let tol = rtol * scale.abs() + f64::MIN_POSITIVE;
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b}, |diff| = {} > {tol}", (a - b).abs());
}
