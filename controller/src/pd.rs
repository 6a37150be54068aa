//! The exact floating-point control law, generic over `f32` (device) and `f64` (host).
//!
//! Owns [`FloatPd`], its [`Output`] and the small [`Real`] trait it needs. It does not quantize
//! (that is [`crate::quant`]) and does not touch the predictor.

use core::ops::{Add, Div, Mul, Neg, Sub};

use shared::ControllerConfig;

use crate::history::Delay;
use crate::{ConfigError, Field, InputError, Signal, validate_common};

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

/// The sampled-data PD/PID law with a delay of `r = cfg.delay` samples, in exact floating
/// point:
///
/// `u_i = -kp*y_{i-r} - kd*(y_{i-r} - y_{i-r-1})/dt + kphi_d*(z_{i-r} - z_{i-r-1})/dt - ki*x_I`
///
/// with `x_I = sum_{j=0..=i} y_{j-r}*dt` (pre-history samples are not integrated). `H` is the
/// history capacity; it must satisfy `r + 2 <= H`.
///
/// A fresh or [`reset`](Self::reset) controller has an all-zero pre-history; load another
/// one with [`prime`](Self::prime) or [`prime_constant`](Self::prime_constant).
///
/// Non-finite inputs are rejected: [`step`](Self::step) returns an [`InputError`] and leaves
/// the state untouched (the sample is not consumed, the delay line does not advance), so a
/// NaN can never enter the history or the integral.
#[derive(Clone, Copy, Debug)]
pub struct FloatPd<T: Real, const H: usize> {
    kp: T,
    kd: T,
    kphi_d: T,
    ki: T,
    dt: T,
    u_max: Option<T>,
    delay: usize,
    hist: Delay<(T, T), H>,
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

impl<T: Real, const H: usize> FloatPd<T, H> {
    /// Validate `cfg` (no quantization; finite gains; `dt`, `u_max` finite and > 0;
    /// `delay + 2 <= H`; every value representable in `T`) and build the controller.
    pub fn try_new(cfg: &ControllerConfig) -> Result<Self, ConfigError> {
        let delay = validate_common(cfg, H)?;
        if cfg.quant.is_some() {
            return Err(ConfigError::UnexpectedQuantization);
        }
        let u_max = match cfg.u_max {
            Some(m) => Some(convert::<T>(m, Field::UMax)?),
            None => None,
        };
        Ok(Self {
            kp: convert(cfg.kp, Field::Kp)?,
            kd: convert(cfg.kd, Field::Kd)?,
            kphi_d: convert(cfg.kphi_d, Field::KphiD)?,
            ki: convert(cfg.ki, Field::Ki)?,
            dt: convert(cfg.dt, Field::Dt)?,
            u_max,
            delay,
            hist: Delay::new((T::ZERO, T::ZERO)),
            integral: T::ZERO,
        })
    }

    /// The delay `r` in samples.
    pub fn delay(&self) -> usize {
        self.delay
    }

    /// The integral state `x_I` (sum of the delayed `y * dt` so far).
    pub fn integral(&self) -> T {
        self.integral
    }

    /// Zero pre-history and zero integral, as after `try_new`.
    pub fn reset(&mut self) {
        self.hist.fill((T::ZERO, T::ZERO));
        self.integral = T::ZERO;
    }

    /// Start a run: load the `r + 1` samples `(y, z)` taken before `t_0`, oldest first
    /// (`y_{-r-1}, ..., y_{-1}`), and clear the integral. On error nothing changes.
    pub fn prime(&mut self, history: &[(T, T)]) -> Result<(), InputError> {
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
        self.integral = T::ZERO;
        Ok(())
    }

    /// Start a run from rest at `(y, z)`: every pre-history sample equal, integral cleared.
    pub fn prime_constant(&mut self, y: T, z: T) -> Result<(), InputError> {
        check(y, z)?;
        self.hist.fill((y, z));
        self.integral = T::ZERO;
        Ok(())
    }

    /// Push the sample taken at `t_i` and return the `u_i` to hold over `[t_i, t_i + dt)`.
    pub fn step(&mut self, y: T, z: T) -> Result<Output<T>, InputError> {
        check(y, z)?;
        let (y0, z0) = self.hist.back_after_push((y, z), self.delay);
        let (y1, z1) = self.hist.back_after_push((y, z), self.delay.saturating_add(1));
        let integral = if self.ki == T::ZERO { self.integral } else { self.integral + y0 * self.dt };
        if !integral.is_finite() {
            return Err(InputError::NonFiniteOutput);
        }
        let u = -self.kp * y0 - self.kd * (y0 - y1) / self.dt + self.kphi_d * (z0 - z1) / self.dt - self.ki * integral;
        let out = saturate(u, self.u_max)?;
        self.hist.push((y, z));
        self.integral = integral;
        Ok(out)
    }
}

fn check<T: Real>(y: T, z: T) -> Result<(), InputError> {
    if !y.is_finite() {
        return Err(InputError::NonFinite(Signal::Y));
    }
    if !z.is_finite() {
        return Err(InputError::NonFinite(Signal::Z));
    }
    Ok(())
}
