//! The spatially quantized control paths: [`IntPd`] (integer counts in, integer DAC code out,
//! `QuantMode::Counts`, what a device runs) and [`LiteralPd`] (the paper's formula read
//! literally, `QuantMode::Literal`), plus the sensor conversion [`adc`].
//!
//! Fixed-point format of [`IntPd`]: each gain is converted once to codes per count and
//! rounded to nearest (ties away from zero) in Q16 ([`GAIN_FRAC_BITS`] fractional bits),
//! stored in an `i64`; `|gain| <= GAIN_MAX_Q` (`2^29 - 1`, about 8192 codes per count).
//! The step sums `gain * count` products exactly in an `i64` and floors with an arithmetic
//! right shift by 16, then clamps to the DAC range. Each gain is off by at most
//! `2^-17` codes per count (plus the `f64` rounding of the conversion, a few `1e-16` relative),
//! so the code differs from the exact `floor(u / h_dac)` only when `u / h_dac` lies within
//! `2^-17 * (|q_y| + |dq_y| + |dq_z| + |S|)` codes of an integer (`S` only with integral action),
//! and then by at most the ceiling of that bound.
//!
//! This module does not own the float law ([`crate::pd`]) or the predictor.

use shared::{ControllerConfig, QuantMode};

use crate::history::Delay;
use crate::pd::{Output, saturate};
use crate::{ConfigError, Field, InputError, Signal, validate_common, validate_quant};

/// Fractional bits of the fixed-point gains (Q16: one unit is `2^-16` codes per count).
pub const GAIN_FRAC_BITS: u32 = 16;
/// Largest magnitude of a fixed-point gain, in Q16 units. With inputs in `i32`, the
/// proportional and both derivative products stay below `2^60, 2^61, 2^61`, so their sum is
/// exact in `i64`; only the integral product can saturate, and then the sum still has the
/// right sign and a magnitude far beyond any DAC code, so the clamp gives the exact result.
pub const GAIN_MAX_Q: i64 = (1 << 29) - 1;
/// [`GAIN_MAX_Q`] in codes per count (about 8192).
pub const GAIN_MAX_CODES_PER_COUNT: f64 = GAIN_MAX_Q as f64 / (1u64 << GAIN_FRAC_BITS) as f64;
/// Worst-case rounding of one fixed-point gain, codes per count (half a Q16 unit).
pub const GAIN_ROUNDING: f64 = 0.5 / (1u64 << GAIN_FRAC_BITS) as f64;
/// DAC range when no `u_max` is configured: `|code| <= CODE_MAX`.
pub const CODE_MAX: i32 = i32::MAX;

/// Why [`adc`] could not convert an angle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdcError {
    /// The angle is NaN or infinite.
    NonFiniteAngle,
    /// The step `h` is not finite or not positive.
    BadStep,
    /// `floor(angle / h)` is outside `i32`.
    OutOfRange,
}

impl core::fmt::Display for AdcError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            AdcError::NonFiniteAngle => "adc: angle is not finite",
            AdcError::BadStep => "adc: step h must be finite and > 0",
            AdcError::OutOfRange => "adc: floor(angle / h) is outside the i32 range",
        })
    }
}

impl core::error::Error for AdcError {}

/// `floor(x)` as `i32`, or `None` if it is outside `i32` (or NaN).
fn floor_to_i32(x: f64) -> Option<i32> {
    let q = libm::floor(x);
    if (-2_147_483_648.0..=2_147_483_647.0).contains(&q) {
        // In range and integral: the conversion is exact.
        Some(q as i32)
    } else {
        None
    }
}

/// The encoder: `floor(angle / h)` counts, the sensor model of `QuantMode::Counts`.
pub fn adc(angle: f64, h: f64) -> Result<i32, AdcError> {
    if !(h.is_finite() && h > 0.0) {
        return Err(AdcError::BadStep);
    }
    if !angle.is_finite() {
        return Err(AdcError::NonFiniteAngle);
    }
    floor_to_i32(angle / h).ok_or(AdcError::OutOfRange)
}

/// Like [`adc`] with a step already validated, errors naming the signal.
pub(crate) fn count(angle: f64, h: f64, signal: Signal) -> Result<i32, InputError> {
    if !angle.is_finite() {
        return Err(InputError::NonFinite(signal));
    }
    floor_to_i32(angle / h).ok_or(InputError::AdcOutOfRange(signal))
}

/// The fixed-point gains of an [`IntPd`], Q16 codes per count.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntGains {
    /// `round(2^16 * kp * h_adc / h_dac)`, on `q_y`.
    pub p: i64,
    /// `round(2^16 * kd * h_adc / (dt * h_dac))`, on `q_y - q_y_prev`.
    pub d: i64,
    /// `round(2^16 * kphi_d * h_adc_phi / (dt * h_dac))`, on `q_z - q_z_prev`.
    pub z: i64,
    /// `round(2^16 * ki * dt * h_adc / h_dac)`, on the count sum `S`.
    pub i: i64,
}

/// One integer control value: the DAC `code` to hold, and whether the DAC range clamp
/// changed it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntOutput {
    pub code: i32,
    pub saturated: bool,
}

/// The integer control law of `QuantMode::Counts`, with delay `r = cfg.delay`:
///
/// `code_i = clamp(floor((-P*q_y[i-r] - D*(q_y[i-r] - q_y[i-r-1]) + Z*(q_z[i-r] - q_z[i-r-1])
/// - I*S_i) / 2^16), -C, C)`, `S_i = S_{i-1} + q_y[i-r]` (saturating `i64`, `S_{-1} = 0`)
///
/// with the Q16 gains of [`IntGains`] and `C = floor(u_max / h_dac)` (or [`CODE_MAX`]).
/// Only integer arithmetic with `i64` accumulators; never panics, never overflows (see
/// [`GAIN_MAX_Q`]); `saturated` is set exactly when the clamp changed the code.
#[derive(Clone, Copy, Debug)]
pub struct IntPd<const H: usize> {
    gains: IntGains,
    /// The gains as `i32` for the step's 32x32 -> 64-bit products: `z`, `d`, and `p + d`
    /// (all below `2^30` in magnitude by [`GAIN_MAX_Q`]).
    g32: [i32; 3],
    code_max: i64,
    h_dac: f64,
    delay: usize,
    hist: Delay<(i32, i32), H>,
    sum: i64,
}

fn to_q16(codes_per_count: f64, source: f64, field: Field) -> Result<i64, ConfigError> {
    let scaled = libm::round(codes_per_count * (1u64 << GAIN_FRAC_BITS) as f64);
    if !scaled.is_finite() || libm::fabs(scaled) > GAIN_MAX_Q as f64 {
        return Err(ConfigError::OutOfRange(field));
    }
    if scaled == 0.0 && source != 0.0 {
        // A non-zero gain would silently vanish.
        return Err(ConfigError::OutOfRange(field));
    }
    // |scaled| <= 2^29 - 1 and integral: the conversion is exact.
    Ok(scaled as i64)
}

impl<const H: usize> IntPd<H> {
    /// Validate `cfg` once (quantization present with mode `Counts`; every step finite and
    /// positive; gains finite; `dt` positive; `delay + 2 <= H`; every Q16 gain within
    /// [`GAIN_MAX_Q`] and non-zero when its field is; `1 <= u_max / h_dac <= i32::MAX`) and
    /// convert the gains to Q16 codes per count.
    pub fn try_new(cfg: &ControllerConfig) -> Result<Self, ConfigError> {
        let delay = validate_common(cfg, H)?;
        let q = validate_quant(cfg, QuantMode::Counts)?;
        let per_volt = 1.0 / q.h_dac;
        let gains = IntGains {
            p: to_q16(cfg.kp * q.h_adc * per_volt, cfg.kp, Field::Kp)?,
            d: to_q16(cfg.kd * q.h_adc / cfg.dt * per_volt, cfg.kd, Field::Kd)?,
            z: to_q16(cfg.kphi_d * q.h_adc_phi / cfg.dt * per_volt, cfg.kphi_d, Field::KphiD)?,
            i: to_q16(cfg.ki * cfg.dt * q.h_adc * per_volt, cfg.ki, Field::Ki)?,
        };
        let code_max = match cfg.u_max {
            Some(u_max) => {
                let c = libm::floor(u_max / q.h_dac);
                if !(1.0..=f64::from(CODE_MAX)).contains(&c) {
                    return Err(ConfigError::OutOfRange(Field::UMax));
                }
                c as i64
            }
            None => i64::from(CODE_MAX),
        };
        // |p|, |d| <= GAIN_MAX_Q = 2^29 - 1, so p + d fits in i32; the conversion cannot fail.
        let narrow = |v: i64| i32::try_from(v).map_err(|_| ConfigError::OutOfRange(Field::Kd));
        let g32 = [narrow(gains.z)?, narrow(gains.d)?, narrow(gains.p + gains.d)?];
        Ok(Self { gains, g32, code_max, h_dac: q.h_dac, delay, hist: Delay::new((0, 0)), sum: 0 })
    }

    /// The Q16 gains in use.
    pub fn gains(&self) -> IntGains {
        self.gains
    }

    /// The DAC range: `|code| <= code_max()`.
    pub fn code_max(&self) -> i32 {
        i32::try_from(self.code_max).unwrap_or(CODE_MAX)
    }

    /// The delay `r` in samples.
    pub fn delay(&self) -> usize {
        self.delay
    }

    /// The integral state `S`, the saturating sum of the delayed counts `q_y[j-r]`.
    pub fn integral_counts(&self) -> i64 {
        self.sum
    }

    /// The actuator: the voltage of a DAC code, `h_dac * code`.
    pub fn volts(&self, code: i32) -> f64 {
        self.h_dac * f64::from(code)
    }

    /// Zero pre-history and zero integral, as after `try_new`.
    pub fn reset(&mut self) {
        self.hist.fill((0, 0));
        self.sum = 0;
    }

    /// Start a run: load the `r + 1` count pairs `(q_y, q_z)` before `t_0`, oldest first,
    /// and clear the integral. On error nothing changes.
    pub fn prime(&mut self, history: &[(i32, i32)]) -> Result<(), InputError> {
        let expected = self.delay.saturating_add(1);
        if history.len() != expected {
            return Err(InputError::HistoryLength { expected, found: history.len() });
        }
        for &s in history {
            self.hist.push(s);
        }
        self.sum = 0;
        Ok(())
    }

    /// Start a run from rest at `(q_y, q_z)`: every pre-history sample equal, integral cleared.
    pub fn prime_constant(&mut self, q_y: i32, q_z: i32) {
        self.hist.fill((q_y, q_z));
        self.sum = 0;
    }

    pub(crate) fn push_history(&mut self, s: (i32, i32)) {
        self.hist.push(s);
    }

    pub(crate) fn clear_integral(&mut self) {
        self.sum = 0;
    }

    /// Push the counts read at `t_i` and return the DAC code to hold over `[t_i, t_i + dt)`.
    pub fn step(&mut self, q_y: i32, q_z: i32) -> IntOutput {
        let (y0, z0) = self.hist.back_after_push((q_y, q_z), self.delay);
        let (y1, z1) = self.hist.back_after_push((q_y, q_z), self.delay.saturating_add(1));
        self.hist.push((q_y, q_z));
        let g = self.gains;
        self.sum = self.sum.saturating_add(i64::from(y0));
        // The law `z (z0 - z1) - p y0 - d (y0 - y1)` expanded into four 32 x 32 -> 64-bit
        // products (one SMULL each on the M4): `z z0 - z z1 - (p + d) y0 + d y1`. Each factor
        // is below 2^31 (counts) and 2^30 (gains), so each product is below 2^61 and the sum
        // below 2^63: exact, no wrap, no saturation needed.
        let [gz, gd, gpd] = self.g32;
        let m = |a: i32, b: i32| i64::from(a) * i64::from(b);
        let pdz = m(gz, z0) - m(gz, z1) - m(gpd, y0) + m(gd, y1);
        // The integral product is exact below |S| < 2^33 (then < 2^62); beyond, saturate.
        let integral = if g.i == 0 {
            0
        } else if self.sum.unsigned_abs() < 1 << 33 {
            g.i.wrapping_mul(self.sum)
        } else {
            g.i.saturating_mul(self.sum)
        };
        let acc = pdz.saturating_sub(integral);
        // Arithmetic shift: floor division by 2^16.
        let raw = acc >> GAIN_FRAC_BITS;
        let code = raw.clamp(self.code_max.saturating_neg(), self.code_max);
        IntOutput {
            // |code| <= code_max <= i32::MAX.
            code: i32::try_from(code).unwrap_or(0),
            saturated: code != raw,
        }
    }
}

/// The paper's quantized formula read literally (`QuantMode::Literal`), in `f64`, with one
/// step `h = h_adc`:
///
/// `u = h * floor(-kp*floor(y/h) - kd*floor(ydot/h) + kphi_d*floor(zdot/h) - ki*floor(x_I/h))`
///
/// with `y = y_{i-r}`, `ydot = (y_{i-r} - y_{i-r-1})/dt`, `zdot` likewise and `x_I` the running
/// sum of `y_{i-r}*dt` (the `ki` term only when `ki != 0`). The formula is dimensionally loose
/// (volts per radian times radians per step); it is the paper's reading, kept for comparison.
/// `h_adc_phi` and `h_dac` are validated but not used. With `u_max`, the integer in the outer
/// floor is clamped to `|n| <= floor(u_max / h)` so `u` stays on the grid, flagged.
/// Non-finite inputs are rejected as in [`crate::FloatPd`] (state unchanged).
#[derive(Clone, Copy, Debug)]
pub struct LiteralPd<const H: usize> {
    kp: f64,
    kd: f64,
    kphi_d: f64,
    ki: f64,
    dt: f64,
    h: f64,
    n_max: Option<f64>,
    delay: usize,
    hist: Delay<(f64, f64), H>,
    integral: f64,
}

impl<const H: usize> LiteralPd<H> {
    /// Validate `cfg` (quantization present with mode `Literal`, every step finite and > 0,
    /// gains finite, `dt` > 0, `delay + 2 <= H`, `u_max / h_adc >= 1`).
    pub fn try_new(cfg: &ControllerConfig) -> Result<Self, ConfigError> {
        let delay = validate_common(cfg, H)?;
        let q = validate_quant(cfg, QuantMode::Literal)?;
        let n_max = match cfg.u_max {
            Some(u_max) => {
                let n = libm::floor(u_max / q.h_adc);
                if !(n.is_finite() && n >= 1.0) {
                    return Err(ConfigError::OutOfRange(Field::UMax));
                }
                Some(n)
            }
            None => None,
        };
        Ok(Self {
            kp: cfg.kp,
            kd: cfg.kd,
            kphi_d: cfg.kphi_d,
            ki: cfg.ki,
            dt: cfg.dt,
            h: q.h_adc,
            n_max,
            delay,
            hist: Delay::new((0.0, 0.0)),
            integral: 0.0,
        })
    }

    /// The delay `r` in samples.
    pub fn delay(&self) -> usize {
        self.delay
    }

    /// The integral state `x_I`.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// Zero pre-history and zero integral, as after `try_new`.
    pub fn reset(&mut self) {
        self.hist.fill((0.0, 0.0));
        self.integral = 0.0;
    }

    /// Start a run: load the `r + 1` samples before `t_0`, oldest first; clear the integral.
    pub fn prime(&mut self, history: &[(f64, f64)]) -> Result<(), InputError> {
        let expected = self.delay.saturating_add(1);
        if history.len() != expected {
            return Err(InputError::HistoryLength { expected, found: history.len() });
        }
        for &(y, z) in history {
            check(y, z)?;
        }
        for &s in history {
            self.hist.push(s);
        }
        self.integral = 0.0;
        Ok(())
    }

    /// Start a run from rest at `(y, z)`.
    pub fn prime_constant(&mut self, y: f64, z: f64) -> Result<(), InputError> {
        check(y, z)?;
        self.hist.fill((y, z));
        self.integral = 0.0;
        Ok(())
    }

    /// Push the sample taken at `t_i` and return the `u_i` to hold over `[t_i, t_i + dt)`.
    pub fn step(&mut self, y: f64, z: f64) -> Result<Output<f64>, InputError> {
        check(y, z)?;
        let (y0, z0) = self.hist.back_after_push((y, z), self.delay);
        let (y1, z1) = self.hist.back_after_push((y, z), self.delay.saturating_add(1));
        let integral = if self.ki == 0.0 { self.integral } else { self.integral + y0 * self.dt };
        if !integral.is_finite() {
            return Err(InputError::NonFiniteOutput);
        }
        let h = self.h;
        let ydot = (y0 - y1) / self.dt;
        let zdot = (z0 - z1) / self.dt;
        let mut s =
            -self.kp * libm::floor(y0 / h) - self.kd * libm::floor(ydot / h) + self.kphi_d * libm::floor(zdot / h);
        if self.ki != 0.0 {
            s -= self.ki * libm::floor(integral / h);
        }
        let n = saturate(libm::floor(s), self.n_max)?;
        let u = h * n.u;
        if !u.is_finite() {
            return Err(InputError::NonFiniteOutput);
        }
        self.hist.push((y, z));
        self.integral = integral;
        Ok(Output { u, saturated: n.saturated })
    }
}

fn check(y: f64, z: f64) -> Result<(), InputError> {
    if !y.is_finite() {
        return Err(InputError::NonFinite(Signal::Y));
    }
    if !z.is_finite() {
        return Err(InputError::NonFinite(Signal::Z));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::Quantization;

    fn extreme_cfg(u_max: Option<f64>) -> ControllerConfig {
        let g = GAIN_MAX_CODES_PER_COUNT;
        ControllerConfig {
            kp: -g,
            kd: g,
            kphi_d: -g,
            ki: g,
            dt: 1.0,
            delay: 0,
            u_max,
            quant: Some(Quantization { mode: QuantMode::Counts, h_adc: 1.0, h_adc_phi: 1.0, h_dac: 1.0 }),
        }
    }

    /// The integral sum saturating at `i64::MAX` (unreachable in a test run: 2^32 full-scale
    /// samples) still gives the clamp of the exact i128 sum with that saturated state.
    #[test]
    fn saturated_integral_state_clamps_like_the_exact_sum() {
        for u_max in [None, Some(1000.0)] {
            let mut pd = IntPd::<4>::try_new(&extreme_cfg(u_max)).expect("valid");
            let g = pd.gains();
            assert_eq!(g.i, GAIN_MAX_Q);
            assert_eq!(g.p, -GAIN_MAX_Q);
            for (s0, y, z) in [
                (i64::MAX - 5, i32::MAX, i32::MIN),
                (i64::MAX, i32::MIN, i32::MAX),
                (i64::MIN + 3, i32::MIN, i32::MIN),
                (i64::MIN, i32::MAX, i32::MAX),
                (-1, 0, 0),
            ] {
                pd.prime_constant(0, 0);
                pd.sum = s0;
                let out = pd.step(y, z);
                let s = s0.saturating_add(i64::from(y));
                assert_eq!(pd.sum, s);
                let (y, z) = (i128::from(y), i128::from(z));
                let exact =
                    -i128::from(g.p) * y - i128::from(g.d) * y + i128::from(g.z) * z - i128::from(g.i) * i128::from(s);
                let raw = exact >> 16;
                let c = i128::from(pd.code_max());
                let code = raw.clamp(-c, c);
                assert_eq!(i128::from(out.code), code, "s0 = {s0}");
                assert_eq!(out.saturated, code != raw);
            }
        }
    }
}
