//! Controller configuration: gains, sampling, delay and the effects (quantization,
//! saturation, integral action) in physical units, as designed on the host. The controller
//! crate validates and converts it once (`try_new`), the model blob carries it.

use serde::{Deserialize, Serialize};

/// How the loop is spatially discretized.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum QuantMode {
    /// What a device does: angles read as integer encoder counts `q = floor(angle / h_adc)`,
    /// derivatives are count differences over `dt`, the law runs on integers, the output is an
    /// integer DAC code and `u = h_dac * code`.
    Counts,
    /// The paper's formula read literally: `u = h * floor(-KP*floor(theta/h) - KD*floor(dtheta/h)
    /// + KphiD*floor(dphi/h))` with one step `h = h_adc` (the DAC step is ignored).
    Literal,
}

/// Spatial quantization of the loop.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Quantization {
    pub mode: QuantMode,
    /// ADC step of the primary angle (theta), rad per count.
    pub h_adc: f64,
    /// ADC step of the secondary angle (phi), rad per count.
    pub h_adc_phi: f64,
    /// DAC step, volts per code.
    pub h_dac: f64,
}

/// A sampled-data PD/PID controller with zero-order hold and a delay of `delay` samples:
///
/// `u_i = -kp*y_{i-r} - kd*(y_{i-r} - y_{i-r-1})/dt + kphi_d*(z_{i-r} - z_{i-r-1})/dt - ki*x_I`
///
/// with `y` the primary (stabilized) angle, `z` the secondary angle, `x_I` the running sum of
/// `y_{i-r}*dt`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ControllerConfig {
    /// Proportional gain on the primary angle, V/rad.
    pub kp: f64,
    /// Derivative gain on the primary angle, V s/rad.
    pub kd: f64,
    /// Derivative gain on the secondary angle (arm / cart), V s/rad.
    pub kphi_d: f64,
    /// Integral gain on the primary angle, V/(rad s); 0 disables integral action.
    pub ki: f64,
    /// Sampling period, s.
    pub dt: f64,
    /// Feedback delay in samples (r; the paper uses 1).
    pub delay: u32,
    /// Output saturation |u| <= u_max, V; `None` for no saturation.
    pub u_max: Option<f64>,
    /// Spatial quantization; `None` for exact floating-point control.
    pub quant: Option<Quantization>,
}

impl ControllerConfig {
    /// The paper's gains (KP = 15.5 V, KD = 5.45 V s, KphiD = 1.5 V s), r = 1, no effects.
    pub const fn paper(dt: f64) -> Self {
        Self { kp: 15.5, kd: 5.45, kphi_d: 1.5, ki: 0.0, dt, delay: 1, u_max: None, quant: None }
    }
}
