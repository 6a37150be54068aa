//! The spatially quantized control paths: [`IntPd`] (integer counts in, integer DAC code out,
//! `QuantMode::Counts`, what a device runs) and [`LiteralPd`] (the paper's formula read
//! literally, `QuantMode::Literal`), plus the sensor conversion [`adc`].
//!
//! Fixed-point format of [`IntPd`]: each gain is converted once to codes per count and
//! rounded to nearest (ties away from zero) in Q16 ([`GAIN_FRAC_BITS`] fractional bits),
//! stored in an `i64`; `|gain| <= GAIN_MAX_Q` (`2^29 - 1`, about 8192 codes per count), and
//! over the coordinates `sum_i |P_i + D_i| + |D_i| <= GAIN_SUM_MAX_Q` (`2^32 - 1`).
//! The step sums `gain * count` products exactly in an `i64` and floors with an arithmetic
//! right shift by 16, then clamps to the DAC range. Each gain is off by at most
//! `2^-17` codes per count (plus the `f64` rounding of the conversion, a few `1e-16` relative),
//! so the code differs from the exact `floor(u / h_dac)` only when `u / h_dac` lies within
//! `2^-17 * (sum_i |c_i| [P_i != 0] + |dc_i| + |S|)` codes of an integer (`S` only with
//! integral action), and then by at most the ceiling of that bound.
//!
//! This module does not own the float law ([`crate::pd`]) or the predictor.

use shared::{ControllerConfig, QuantMode};

use crate::history::Delay;
use crate::pd::{Output, check_history, sample, saturate};
use crate::{ConfigError, Field, InputError, MAX_GAINS, Signal, validate_common, validate_quant};

/// Fractional bits of the fixed-point gains (Q16: one unit is `2^-16` codes per count).
pub const GAIN_FRAC_BITS: u32 = 16;
/// Largest magnitude of a fixed-point gain, in Q16 units. With inputs in `i32`, the
/// proportional and both derivative products stay below `2^60, 2^61, 2^61`, so their sum is
/// exact in `i64`; only the integral product can saturate, and then the sum still has the
/// right sign and a magnitude far beyond any DAC code, so the clamp gives the exact result.
pub const GAIN_MAX_Q: i64 = (1 << 29) - 1;
/// Largest sum over the coordinates of `|P_i + D_i| + |D_i|` (Q16 units), the magnitudes of
/// the two gains each coordinate's counts are multiplied by: with every count at most `2^31`
/// in magnitude, the step's sum of products stays below `(2^32 - 1) * 2^31 < 2^63`, exact in
/// `i64`. The shorthand (two coordinates, no P on the second) stays below it for any gains
/// within [`GAIN_MAX_Q`]: `(2^30 + 2^29 + 2 * 2^29) < 2^32`.
pub const GAIN_SUM_MAX_Q: i64 = (1 << 32) - 1;
/// [`GAIN_SUM_MAX_Q`] in codes per count (about 65536).
pub const GAIN_SUM_MAX_CODES_PER_COUNT: f64 = GAIN_SUM_MAX_Q as f64 / (1u64 << GAIN_FRAC_BITS) as f64;
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
    /// `round(2^16 * p_i * h_i / h_dac)` per measured coordinate, on its count `c_i`
    /// (entries past the gain vector's length are zero).
    pub p: [i64; MAX_GAINS],
    /// `round(2^16 * d_i * h_i / (dt * h_dac))`, on `c_i - c_i_prev`.
    pub d: [i64; MAX_GAINS],
    /// `round(2^16 * ki * dt * h_0 / h_dac)`, on the count sum `S` of the first coordinate.
    pub i: i64,
}

/// One integer control value: the DAC `code` to hold, and whether the DAC range clamp
/// changed it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct IntOutput {
    pub code: i32,
    pub saturated: bool,
}

/// The integer control law of `QuantMode::Counts`, with delay `r = cfg.delay`, on the counts
/// `c_i` of the measured coordinates:
///
/// `code_k = clamp(floor((-sum_i [P_i*c_i[k-r] + D_i*(c_i[k-r] - c_i[k-r-1])] - I*S_k) / 2^16),
/// -C, C)`, `S_k = S_{k-1} + c_0[k-r]` (saturating `i64`, `S_{-1} = 0`)
///
/// with the Q16 gains of [`IntGains`] and `C = floor(u_max / h_dac)` (or [`CODE_MAX`]).
/// Only integer arithmetic with `i64` accumulators; never panics, never overflows (see
/// [`GAIN_MAX_Q`] and [`GAIN_SUM_MAX_Q`]); `saturated` is set exactly when the clamp changed
/// the code.
#[derive(Clone, Copy, Debug)]
pub struct IntPd<const H: usize> {
    gains: IntGains,
    /// Per coordinate the gains as `i32` for the step's 32x32 -> 64-bit products:
    /// `-(P_i + D_i)` on the delayed count and `D_i` on the one before (both below `2^30`
    /// in magnitude by [`GAIN_MAX_Q`]).
    g32: [[i32; 2]; MAX_GAINS],
    /// The integral gain `I` as `i32` (`|I| <= GAIN_MAX_Q < 2^29`).
    gi: i32,
    n: usize,
    /// Which straight-line step runs: `n - 1`, plus 4 with integral action (`I != 0`),
    /// decided once here rather than tested every step.
    shape: u8,
    /// The DAC range `C` (`1 <= C <= i32::MAX`) and `-C`.
    code_max: i32,
    code_min: i32,
    h_dac: f64,
    delay: usize,
    hist: Delay<[i32; MAX_GAINS], H>,
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

/// The `n` counts of `q` as one history sample (the rest zero).
fn counts(q: &[i32], n: usize) -> Result<[i32; MAX_GAINS], InputError> {
    if q.len() != n {
        return Err(InputError::Measurements { expected: n, found: q.len() });
    }
    let mut s = [0; MAX_GAINS];
    for (d, &v) in s.iter_mut().zip(q) {
        *d = v;
    }
    Ok(s)
}

impl<const H: usize> IntPd<H> {
    /// Validate `cfg` once (quantization present with mode `Counts`; one to [`MAX_GAINS`]
    /// gains on distinct indices; every step finite and positive; gains finite; `dt`
    /// positive; `delay + 2 <= H`; every Q16 gain within [`GAIN_MAX_Q`] and non-zero when its
    /// field is; their magnitudes' sum within [`GAIN_SUM_MAX_Q`]; `1 <= u_max / h_dac <=
    /// i32::MAX`) and convert the gains to Q16 codes per count.
    pub fn try_new(cfg: &ControllerConfig) -> Result<Self, ConfigError> {
        let delay = validate_common(cfg, H)?;
        let q = validate_quant(cfg, QuantMode::Counts)?;
        let per_volt = 1.0 / q.h_dac;
        let mut gains = IntGains { p: [0; MAX_GAINS], d: [0; MAX_GAINS], i: 0 };
        let mut g32 = [[0i32; 2]; MAX_GAINS];
        let mut total: i64 = 0;
        for (k, (g, ((p, d), w))) in
            cfg.gains.iter().zip(gains.p.iter_mut().zip(gains.d.iter_mut()).zip(g32.iter_mut())).enumerate()
        {
            let at = k as u8;
            *p = to_q16(g.p * g.h_adc * per_volt, g.p, Field::P(at))?;
            *d = to_q16(g.d * g.h_adc / cfg.dt * per_volt, g.d, Field::D(at))?;
            // |p|, |d| <= GAIN_MAX_Q = 2^29 - 1, so p + d fits in i32; the conversion cannot fail.
            let narrow = |v: i64| i32::try_from(v).map_err(|_| ConfigError::OutOfRange(Field::D(at)));
            *w = [narrow(-(*p + *d))?, narrow(*d)?];
            total = total.saturating_add((*p + *d).abs()).saturating_add(d.abs());
        }
        if total > GAIN_SUM_MAX_Q {
            return Err(ConfigError::GainSum);
        }
        let h0 = cfg.gains.first().map_or(0.0, |g| g.h_adc);
        gains.i = to_q16(cfg.ki * cfg.dt * h0 * per_volt, cfg.ki, Field::Ki)?;
        let code_max = match cfg.u_max {
            Some(u_max) => {
                let c = libm::floor(u_max / q.h_dac);
                if !(1.0..=f64::from(CODE_MAX)).contains(&c) {
                    return Err(ConfigError::OutOfRange(Field::UMax));
                }
                // 1 <= c <= i32::MAX and integral: the conversion is exact.
                c as i32
            }
            None => CODE_MAX,
        };
        // |I| <= GAIN_MAX_Q < 2^29: fits i32.
        let gi = i32::try_from(gains.i).map_err(|_| ConfigError::OutOfRange(Field::Ki))?;
        let n = cfg.gains.len();
        // 1 <= n <= MAX_GAINS = 4 (validate_common): n - 1 is 0..=3.
        let shape = (n.saturating_sub(1) as u8 & 3) | if gi != 0 { 4 } else { 0 };
        Ok(Self {
            gains,
            g32,
            gi,
            n,
            shape,
            code_max,
            code_min: -code_max,
            h_dac: q.h_dac,
            delay,
            hist: Delay::new([0; MAX_GAINS]),
            sum: 0,
        })
    }

    /// The Q16 gains in use.
    pub fn gains(&self) -> IntGains {
        self.gains
    }

    /// The number of measured coordinates (counts per sample).
    pub fn coordinates(&self) -> usize {
        self.n
    }

    /// The DAC range: `|code| <= code_max()`.
    pub fn code_max(&self) -> i32 {
        self.code_max
    }

    /// The delay `r` in samples.
    pub fn delay(&self) -> usize {
        self.delay
    }

    /// The integral state `S`, the saturating sum of the delayed counts `c_0[j-r]`.
    pub fn integral_counts(&self) -> i64 {
        self.sum
    }

    /// The actuator: the voltage of a DAC code, `h_dac * code`.
    pub fn volts(&self, code: i32) -> f64 {
        self.h_dac * f64::from(code)
    }

    /// Zero pre-history and zero integral, as after `try_new`.
    pub fn reset(&mut self) {
        self.hist.fill([0; MAX_GAINS]);
        self.sum = 0;
    }

    /// Start a run: load the `r + 1` samples of counts before `t_0`, oldest first, each one
    /// count per measured coordinate (flattened: `(r + 1) * n` values), and clear the
    /// integral. On error nothing changes.
    pub fn prime(&mut self, history: &[i32]) -> Result<(), InputError> {
        let expected = self.delay.saturating_add(1).saturating_mul(self.n);
        if history.len() != expected || self.n == 0 {
            return Err(InputError::HistoryLength { expected, found: history.len() });
        }
        for s in history.chunks_exact(self.n) {
            self.hist.push(counts(s, self.n)?);
        }
        self.sum = 0;
        Ok(())
    }

    /// Start a run from rest at the counts `q`: every pre-history sample equal, integral
    /// cleared. On error nothing changes.
    pub fn prime_constant(&mut self, q: &[i32]) -> Result<(), InputError> {
        self.hist.fill(counts(q, self.n)?);
        self.sum = 0;
        Ok(())
    }

    pub(crate) fn push_history(&mut self, s: [i32; MAX_GAINS]) {
        self.hist.push(s);
    }

    pub(crate) fn clear_integral(&mut self) {
        self.sum = 0;
    }

    /// Push the counts `q` (one per measured coordinate) read at `t_k` and return the DAC
    /// code to hold over `[t_k, t_k + dt)`. On error nothing changes.
    pub fn step(&mut self, q: &[i32]) -> Result<IntOutput, InputError> {
        let new = counts(q, self.n)?;
        Ok(self.step_counts(&new))
    }

    /// [`step`](Self::step) on a whole sample of [`MAX_GAINS`] slots, of which the first
    /// [`coordinates`](Self::coordinates) are the counts (the others are padding, never read):
    /// what a device calls once it has checked the number of counts it received.
    pub fn step_counts(&mut self, new: &[i32; MAX_GAINS]) -> IntOutput {
        // One straight-line step per number of coordinates and presence of integral action
        // (both fixed for a controller): a jump table, no per-step test of the gains.
        match self.shape {
            5 => self.step_n::<2, true>(new),
            1 => self.step_n::<2, false>(new),
            0 => self.step_n::<1, false>(new),
            4 => self.step_n::<1, true>(new),
            2 => self.step_n::<3, false>(new),
            6 => self.step_n::<3, true>(new),
            3 => self.step_n::<4, false>(new),
            _ => self.step_n::<4, true>(new),
        }
    }

    #[inline(always)]
    fn step_n<const N: usize, const INTEGRAL: bool>(&mut self, new: &[i32; MAX_GAINS]) -> IntOutput {
        let (c0, c1) = self.hist.push_first_and_back::<N>(new, self.delay);
        // Per coordinate `-(P + D) c0 + D c1`: two 32 x 32 -> 64-bit products (one SMLAL
        // each on the M4). Every factor is below 2^31 (counts) and the gains' magnitudes sum
        // to at most GAIN_SUM_MAX_Q < 2^32, so every partial sum is below 2^63: exact, no
        // wrap, no saturation needed.
        let m = |a: i32, b: i32| i64::from(a) * i64::from(b);
        let mut pd: i64 = 0;
        for ((&[gpd, gd], &a), &b) in self.g32.iter().zip(c0).zip(c1).take(N) {
            pd += m(gpd, a) + m(gd, b);
        }
        // S + c_0 overflows only with |S| near 2^63 (2^32 full-scale samples at the least):
        // the saturation is off the straight path.
        let first = i64::from(c0[0]);
        self.sum = match self.sum.checked_add(first) {
            Some(s) => s,
            None => cold::saturating_add(self.sum, first),
        };
        let acc = if INTEGRAL { self.with_integral(pd) } else { pd };
        self.clamp(acc)
    }

    /// `pd - I*S`, saturating. For `-2^33 <= S < 2^33` (`S >> 33` is 0 or -1) the product is
    /// exact (`|I| < 2^29`: below 2^62) and only the difference can leave `i64` (when `|pd|`
    /// is near its bound 2^63); both saturations are off the straight path.
    #[inline(always)]
    fn with_integral(&self, pd: i64) -> i64 {
        let (gi, s) = (self.gi, self.sum);
        if ((s >> 33) as i32).wrapping_add(1) as u32 <= 1 {
            match pd.checked_sub(i64::from(gi).wrapping_mul(s)) {
                Some(acc) => acc,
                None => cold::saturating_sub(pd, i64::from(gi).wrapping_mul(s)),
            }
        } else {
            cold::integral(pd, gi, s)
        }
    }

    /// The code of the accumulator: `floor(acc / 2^16)` (an arithmetic shift) clamped to
    /// `[-C, C]`, and whether the clamp changed it. `C <= i32::MAX`, so a floor outside `i32`
    /// is clamped by its sign alone and the clamp itself compares `i32`s.
    #[inline(always)]
    fn clamp(&self, acc: i64) -> IntOutput {
        let raw = acc >> GAIN_FRAC_BITS;
        // Truncation intended: compared with `raw` right after.
        let low = raw as i32;
        let (c, c_min) = (self.code_max, self.code_min);
        if i64::from(low) != raw {
            IntOutput { code: if raw < 0 { c_min } else { c }, saturated: true }
        } else if low > c {
            IntOutput { code: c, saturated: true }
        } else if low < c_min {
            IntOutput { code: c_min, saturated: true }
        } else {
            IntOutput { code: low, saturated: false }
        }
    }
}

/// The rare branches of the integer step, kept out of its straight line.
mod cold {
    #[cold]
    #[inline(never)]
    pub(super) fn saturating_add(a: i64, b: i64) -> i64 {
        a.saturating_add(b)
    }

    #[cold]
    #[inline(never)]
    pub(super) fn saturating_sub(a: i64, b: i64) -> i64 {
        a.saturating_sub(b)
    }

    /// `pd - I*S` for `|S| >= 2^33`, where the product may leave `i64`: saturated, it still
    /// has the right sign and a magnitude beyond any code, so the clamp gives the exact code.
    #[cold]
    #[inline(never)]
    pub(super) fn integral(pd: i64, gi: i32, s: i64) -> i64 {
        pd.saturating_sub(i64::from(gi).saturating_mul(s))
    }
}

/// The paper's quantized formula read literally (`QuantMode::Literal`), in `f64`, with one
/// step `h`, the first measured coordinate's `h_adc`:
///
/// `u = h * floor(-sum_i [p_i*floor(q_i/h) + d_i*floor(qdot_i/h)] - ki*floor(x_I/h))`
///
/// with `q_i = q_i[k-r]`, `qdot_i = (q_i[k-r] - q_i[k-r-1])/dt` and `x_I` the running sum of
/// `q_0[k-r]*dt` (the `ki` term only when `ki != 0`); the sum in gain order as in
/// [`crate::FloatPd`]. For the shorthand gains this is
/// `h * floor(-kp*floor(y/h) - kd*floor(ydot/h) + kphi_d*floor(zdot/h) - ...)`. The formula is
/// dimensionally loose (volts per radian times radians per step); it is the paper's reading,
/// kept for comparison. The other coordinates' `h_adc` and `h_dac` are validated but not
/// used. With `u_max`, the integer in the outer floor is clamped to `|n| <= floor(u_max / h)`
/// so `u` stays on the grid, flagged. Non-finite inputs are rejected as in
/// [`crate::FloatPd`] (state unchanged).
#[derive(Clone, Copy, Debug)]
pub struct LiteralPd<const H: usize> {
    gains: [(f64, f64); MAX_GAINS],
    n: usize,
    ki: f64,
    dt: f64,
    h: f64,
    n_max: Option<f64>,
    delay: usize,
    hist: Delay<[f64; MAX_GAINS], H>,
    integral: f64,
}

impl<const H: usize> LiteralPd<H> {
    /// Validate `cfg` (quantization present with mode `Literal`, every step finite and > 0,
    /// gains finite, `dt` > 0, `delay + 2 <= H`, `u_max / h >= 1`).
    pub fn try_new(cfg: &ControllerConfig) -> Result<Self, ConfigError> {
        let delay = validate_common(cfg, H)?;
        validate_quant(cfg, QuantMode::Literal)?;
        let h = cfg.gains.first().map_or(0.0, |g| g.h_adc);
        let n_max = match cfg.u_max {
            Some(u_max) => {
                let n = libm::floor(u_max / h);
                if !(n.is_finite() && n >= 1.0) {
                    return Err(ConfigError::OutOfRange(Field::UMax));
                }
                Some(n)
            }
            None => None,
        };
        let mut gains = [(0.0, 0.0); MAX_GAINS];
        for (slot, g) in gains.iter_mut().zip(cfg.gains.iter()) {
            *slot = (g.p, g.d);
        }
        Ok(Self {
            gains,
            n: cfg.gains.len(),
            ki: cfg.ki,
            dt: cfg.dt,
            h,
            n_max,
            delay,
            hist: Delay::new([0.0; MAX_GAINS]),
            integral: 0.0,
        })
    }

    /// The delay `r` in samples.
    pub fn delay(&self) -> usize {
        self.delay
    }

    /// The number of measured coordinates (values per sample).
    pub fn coordinates(&self) -> usize {
        self.n
    }

    /// The integral state `x_I`.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    /// Zero pre-history and zero integral, as after `try_new`.
    pub fn reset(&mut self) {
        self.hist.fill([0.0; MAX_GAINS]);
        self.integral = 0.0;
    }

    /// Start a run: load the `r + 1` samples before `t_0`, oldest first, one value per
    /// measured coordinate each (flattened); clear the integral.
    pub fn prime(&mut self, history: &[f64]) -> Result<(), InputError> {
        check_history(history, self.n, self.delay)?;
        for s in history.chunks_exact(self.n) {
            self.hist.push(sample(s, self.n)?);
        }
        self.integral = 0.0;
        Ok(())
    }

    /// Start a run from rest at `q`.
    pub fn prime_constant(&mut self, q: &[f64]) -> Result<(), InputError> {
        let s = sample(q, self.n)?;
        self.hist.fill(s);
        self.integral = 0.0;
        Ok(())
    }

    /// Push the sample taken at `t_k` and return the `u_k` to hold over `[t_k, t_k + dt)`.
    pub fn step(&mut self, q: &[f64]) -> Result<Output<f64>, InputError> {
        let new = sample(q, self.n)?;
        let q0 = *self.hist.back_after_push(&new, self.delay);
        let q1 = *self.hist.back_after_push(&new, self.delay.saturating_add(1));
        let integral = if self.ki == 0.0 { self.integral } else { self.integral + q0[0] * self.dt };
        if !integral.is_finite() {
            return Err(InputError::NonFiniteOutput);
        }
        let h = self.h;
        let mut s = 0.0;
        for (i, ((&(p, d), &a), &b)) in self.gains.iter().zip(&q0).zip(&q1).take(self.n).enumerate() {
            let qdot = (a - b) / self.dt;
            // As in FloatPd: the first P term starts the sum, later zero ones are left out.
            s = if i == 0 {
                -(p * libm::floor(a / h))
            } else if p != 0.0 {
                s - p * libm::floor(a / h)
            } else {
                s
            };
            s -= d * libm::floor(qdot / h);
        }
        if self.ki != 0.0 {
            s -= self.ki * libm::floor(integral / h);
        }
        let n = saturate(libm::floor(s), self.n_max)?;
        let u = h * n.u;
        if !u.is_finite() {
            return Err(InputError::NonFiniteOutput);
        }
        self.hist.push(new);
        self.integral = integral;
        Ok(Output { u, saturated: n.saturated })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shared::{Gain, Gains, Quantization};

    fn extreme_cfg(u_max: Option<f64>) -> ControllerConfig {
        let g = GAIN_MAX_CODES_PER_COUNT;
        ControllerConfig {
            gains: Gains::shorthand(-g, g, -g, 1.0, 1.0),
            ki: g,
            dt: 1.0,
            delay: 0,
            u_max,
            quant: Some(Quantization { mode: QuantMode::Counts, h_dac: 1.0 }),
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
            assert_eq!(g.p[0], -GAIN_MAX_Q);
            for (s0, y, z) in [
                (i64::MAX - 5, i32::MAX, i32::MIN),
                (i64::MAX, i32::MIN, i32::MAX),
                (i64::MIN + 3, i32::MIN, i32::MIN),
                (i64::MIN, i32::MAX, i32::MAX),
                (-1, 0, 0),
            ] {
                pd.prime_constant(&[0, 0]).expect("two counts");
                pd.sum = s0;
                let out = pd.step(&[y, z]).expect("two counts");
                let s = s0.saturating_add(i64::from(y));
                assert_eq!(pd.sum, s);
                let (y, z) = (i128::from(y), i128::from(z));
                let exact = -i128::from(g.p[0]) * y
                    - i128::from(g.d[0]) * y
                    - i128::from(g.d[1]) * z
                    - i128::from(g.i) * i128::from(s);
                let raw = exact >> 16;
                let c = i128::from(pd.code_max());
                let code = raw.clamp(-c, c);
                assert_eq!(i128::from(out.code), code, "s0 = {s0}");
                assert_eq!(out.saturated, code != raw);
            }
        }
    }

    /// `pd - I*S` outside `i64` with `S` in the range where `I*S` is exact: the step's
    /// saturating branch gives the clamp of the exact i128 sum.
    #[test]
    fn difference_beyond_i64_clamps_like_the_exact_sum() {
        let q = ((1i64 << 29) - 1) as f64 / 65536.0;
        let mut gains = Gains::new();
        for i in 0..2u8 {
            gains.push(Gain { index: 2 * i, p: -q, d: -q, h_adc: 1.0 }).expect("capacity 4");
        }
        for (ki, u_max) in [(-q, None), (q, Some(1000.0))] {
            let cfg = ControllerConfig {
                gains,
                ki,
                dt: 1.0,
                delay: 0,
                u_max,
                quant: Some(Quantization { mode: QuantMode::Counts, h_dac: 1.0 }),
            };
            let mut pd = IntPd::<4>::try_new(&cfg).expect("within the sum bound");
            let g = pd.gains();
            // Counts from MIN to MAX (pd near 1.5 * 2^62) for I < 0, the reverse (pd near
            // -1.5 * 2^62) for I > 0; with S near 2^33, -I*S adds up to 2^62 of the same sign.
            let (before, now) = if ki < 0.0 { (i32::MIN, i32::MAX) } else { (i32::MAX, i32::MIN) };
            pd.prime_constant(&[before, before]).expect("two counts");
            // The new S stays within [-2^33, 2^33): the exact branch of the product.
            let s0 = if ki < 0.0 { (1i64 << 33) - (1 << 31) - 1 } else { (1i64 << 33) - 1 };
            pd.sum = s0;
            let out = pd.step(&[now, now]).expect("two counts");
            let s = s0 + i64::from(now);
            assert!((-(1i64 << 33)..(1i64 << 33)).contains(&s));
            let (a, b) = (i128::from(now), i128::from(before));
            let mut exact = -i128::from(g.i) * i128::from(s);
            for k in 0..2 {
                exact -= i128::from(g.p[k]) * a + i128::from(g.d[k]) * (a - b);
            }
            assert!(exact > i128::from(i64::MAX) || exact < i128::from(i64::MIN), "not beyond i64: {exact}");
            let raw = exact >> 16;
            let c = i128::from(pd.code_max());
            assert_eq!(i128::from(out.code), raw.clamp(-c, c), "ki = {ki}");
            assert!(out.saturated);
        }
    }

    /// Four coordinates at the largest gains the sum bound allows, and one Q16 unit more.
    #[test]
    fn gain_sum_bound_is_enforced_at_its_edge() {
        // P = D = q per coordinate: |P + D| + |D| = 3q, 12q in all, within 3 units of the bound.
        let q = (GAIN_SUM_MAX_Q / 12) as f64 / 65536.0;
        let mut gains = Gains::new();
        for i in 0..4u8 {
            gains.push(Gain { index: i, p: q, d: q, h_adc: 1.0 }).expect("capacity 4");
        }
        let cfg = ControllerConfig {
            gains,
            ki: 0.0,
            dt: 1.0,
            delay: 0,
            u_max: None,
            quant: Some(Quantization { mode: QuantMode::Counts, h_dac: 1.0 }),
        };
        assert!(IntPd::<4>::try_new(&cfg).is_ok());
        let mut over = cfg;
        // Two units more on one D add four to the sum: past the bound.
        over.gains[3].d += 2.0 / 65536.0;
        assert_eq!(IntPd::<4>::try_new(&over).map(|_| ()), Err(ConfigError::GainSum));
    }
}
