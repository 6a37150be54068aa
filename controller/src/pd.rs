//! The exact floating-point control law, generic over `f32` (device) and `f64` (host).
//!
//! Owns [`FloatPd`], its [`Output`] and the small [`Real`] trait it needs. It does not quantize
//! (that is [`crate::quant`]) and does not touch the predictor.

use core::ops::{Add, Div, Mul, Neg, Sub};

use shared::ControllerConfig;

use crate::history::Delay;
use crate::{ConfigError, Field, InputError, MAX_GAINS, Signal, validate_common};

/// The arithmetic the float law needs; implemented for `f32` and `f64`.
pub trait Real:
    Copy
    + Default
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    const ZERO: Self;
    /// Nearest value of this type (`as` conversion: overflow gives infinity).
    fn from_f64(x: f64) -> Self;
    fn to_f64(self) -> f64;
    fn is_finite(self) -> bool;
    fn is_nan(self) -> bool;
}

impl Real for f64 {
    const ZERO: Self = 0.0;
    fn from_f64(x: f64) -> Self {
        x
    }
    fn to_f64(self) -> f64 {
        self
    }
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
    fn is_nan(self) -> bool {
        f64::is_nan(self)
    }
}

impl Real for f32 {
    const ZERO: Self = 0.0;
    fn from_f64(x: f64) -> Self {
        x as f32
    }
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
    fn is_nan(self) -> bool {
        f32::is_nan(self)
    }
}

/// One control value: `u` to hold over the next sampling period, and whether saturation
/// `|u| <= u_max` changed it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Output<T> {
    pub u: T,
    pub saturated: bool,
}

/// Clamp to `[-m, m]` when `u_max` is set; NaN, or infinity without saturation, is an error.
pub(crate) fn saturate<T: Real>(u: T, u_max: Option<T>) -> Result<Output<T>, InputError> {
    if u.is_nan() {
        return Err(InputError::NonFiniteOutput);
    }
    match u_max {
        Some(m) if u > m => Ok(Output { u: m, saturated: true }),
        Some(m) if u < -m => Ok(Output { u: -m, saturated: true }),
        _ if u.is_finite() => Ok(Output { u, saturated: false }),
        _ => Err(InputError::NonFiniteOutput),
    }
}

/// The sampled-data PD/PID law with a delay of `r = cfg.delay` samples on the measured
/// coordinates `q_i` of `cfg.gains`, in exact floating point:
///
/// `u_k = -sum_i [p_i*q_i[k-r] + d_i*(q_i[k-r] - q_i[k-r-1])/dt] - ki*x_I`
///
/// with `x_I = sum_{j=0..=k} q_0[j-r]*dt` (pre-history samples are not integrated). The sum
/// runs in gain order, each coordinate's P term then its D term; a P term of a coordinate
/// after the first is left out when `p_i` is zero (so the shorthand's arm angle, P = 0, adds
/// no signed zero). `H` is the history capacity; it must satisfy `r + 2 <= H`.
///
/// A fresh or [`reset`](Self::reset) controller has an all-zero pre-history; load another
/// one with [`prime`](Self::prime) or [`prime_constant`](Self::prime_constant).
///
/// Non-finite inputs are rejected: [`step`](Self::step) returns an [`InputError`] and leaves
/// the state untouched (the sample is not consumed, the delay line does not advance), so a
/// NaN can never enter the history or the integral.
#[derive(Clone, Copy, Debug)]
pub struct FloatPd<T: Real, const H: usize> {
    /// `(p_i, d_i)` per measured coordinate; entries `n..` are zero and unused.
    gains: [(T, T); MAX_GAINS],
    n: usize,
    ki: T,
    dt: T,
    u_max: Option<T>,
    delay: usize,
    hist: Delay<[T; MAX_GAINS], H>,
    integral: T,
}

fn convert<T: Real>(x: f64, field: Field) -> Result<T, ConfigError> {
    let t = T::from_f64(x);
    // Overflow to infinity, or a non-zero value flushed to zero, changes the law.
    if !t.is_finite() || (x != 0.0 && t == T::ZERO) {
        return Err(ConfigError::OutOfRange(field));
    }
    Ok(t)
}

/// The `n` values of `q` as one history sample (the rest zero), after checking them.
pub(crate) fn sample<T: Real>(q: &[T], n: usize) -> Result<[T; MAX_GAINS], InputError> {
    if q.len() != n {
        return Err(InputError::Measurements { expected: n, found: q.len() });
    }
    let mut s = [T::ZERO; MAX_GAINS];
    for (i, (slot, &v)) in s.iter_mut().zip(q).enumerate() {
        if !v.is_finite() {
            return Err(InputError::NonFinite(Signal(i as u8)));
        }
        *slot = v;
    }
    Ok(s)
}

/// Checks a flattened pre-history (`r + 1` samples of `n` values, oldest first).
pub(crate) fn check_history<T: Real>(history: &[T], n: usize, delay: usize) -> Result<(), InputError> {
    let expected = delay.saturating_add(1).saturating_mul(n);
    if history.len() != expected || n == 0 {
        return Err(InputError::HistoryLength { expected, found: history.len() });
    }
    for s in history.chunks_exact(n) {
        sample(s, n)?;
    }
    Ok(())
}

impl<T: Real, const H: usize> FloatPd<T, H> {
    /// Validate `cfg` (no quantization; one to [`MAX_GAINS`] gains on distinct indices, all
    /// finite; `dt`, `u_max` finite and > 0; `delay + 2 <= H`; every value representable in
    /// `T`) and build the controller.
    pub fn try_new(cfg: &ControllerConfig) -> Result<Self, ConfigError> {
        let delay = validate_common(cfg, H)?;
        if cfg.quant.is_some() {
            return Err(ConfigError::UnexpectedQuantization);
        }
        let u_max = match cfg.u_max {
            Some(m) => Some(convert::<T>(m, Field::UMax)?),
            None => None,
        };
        let mut gains = [(T::ZERO, T::ZERO); MAX_GAINS];
        for (i, (slot, g)) in gains.iter_mut().zip(cfg.gains.iter()).enumerate() {
            let at = i as u8;
            *slot = (convert(g.p, Field::P(at))?, convert(g.d, Field::D(at))?);
        }
        Ok(Self {
            gains,
            n: cfg.gains.len(),
            ki: convert(cfg.ki, Field::Ki)?,
            dt: convert(cfg.dt, Field::Dt)?,
            u_max,
            delay,
            hist: Delay::new([T::ZERO; MAX_GAINS]),
            integral: T::ZERO,
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

    /// The integral state `x_I` (sum of the delayed `q_0 * dt` so far).
    pub fn integral(&self) -> T {
        self.integral
    }

    /// Zero pre-history and zero integral, as after `try_new`.
    pub fn reset(&mut self) {
        self.hist.fill([T::ZERO; MAX_GAINS]);
        self.integral = T::ZERO;
    }

    /// Start a run: load the `r + 1` samples taken before `t_0`, oldest first, each one value
    /// per measured coordinate in gain order (flattened: `(r + 1) * n` values), and clear the
    /// integral. On error nothing changes.
    pub fn prime(&mut self, history: &[T]) -> Result<(), InputError> {
        check_history(history, self.n, self.delay)?;
        for s in history.chunks_exact(self.n) {
            self.hist.push(sample(s, self.n)?);
        }
        self.integral = T::ZERO;
        Ok(())
    }

    /// Start a run from rest at `q` (one value per measured coordinate): every pre-history
    /// sample equal, integral cleared.
    pub fn prime_constant(&mut self, q: &[T]) -> Result<(), InputError> {
        let s = sample(q, self.n)?;
        self.hist.fill(s);
        self.integral = T::ZERO;
        Ok(())
    }

    /// Push the sample `q` (one value per measured coordinate) taken at `t_k` and return the
    /// `u_k` to hold over `[t_k, t_k + dt)`.
    pub fn step(&mut self, q: &[T]) -> Result<Output<T>, InputError> {
        let new = sample(q, self.n)?;
        let q0 = *self.hist.back_after_push(&new, self.delay);
        let q1 = *self.hist.back_after_push(&new, self.delay.saturating_add(1));
        let integral = if self.ki == T::ZERO { self.integral } else { self.integral + q0[0] * self.dt };
        if !integral.is_finite() {
            return Err(InputError::NonFiniteOutput);
        }
        let dt = self.dt;
        let mut u = T::ZERO;
        for (i, ((&(p, d), &a), &b)) in self.gains.iter().zip(&q0).zip(&q1).take(self.n).enumerate() {
            // The first P term starts the sum (`-(p*a)`, exactly today's `-kp*y`).
            u = if i == 0 {
                -(p * a)
            } else if p != T::ZERO {
                u - p * a
            } else {
                u
            };
            u = u - d * (a - b) / dt;
        }
        let u = u - self.ki * integral;
        let out = saturate(u, self.u_max)?;
        self.hist.push(new);
        self.integral = integral;
        Ok(out)
    }
}
