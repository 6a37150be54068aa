#![doc = include_str!("../README.md")]
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing))]

mod history;
pub mod law;
pub mod pd;
pub mod predictor;
pub mod quant;

use core::fmt;

pub use law::Law;
pub use pd::{FloatPd, Output, Real};
pub use quant::{AdcError, IntOutput, IntPd, LiteralPd, adc};
pub use shared::{ControllerConfig, QuantMode, Quantization};

/// A field of [`ControllerConfig`] (or of its [`Quantization`]), named in errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    Kp,
    Kd,
    KphiD,
    Ki,
    Dt,
    UMax,
    HAdc,
    HAdcPhi,
    HDac,
}

impl Field {
    /// The field's name as written in the configuration.
    pub const fn name(self) -> &'static str {
        match self {
            Field::Kp => "kp",
            Field::Kd => "kd",
            Field::KphiD => "kphi_d",
            Field::Ki => "ki",
            Field::Dt => "dt",
            Field::UMax => "u_max",
            Field::HAdc => "quant.h_adc",
            Field::HAdcPhi => "quant.h_adc_phi",
            Field::HDac => "quant.h_dac",
        }
    }
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a [`ControllerConfig`] was rejected by a `try_new`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigError {
    /// The field is NaN or infinite.
    NonFinite(Field),
    /// The field must be strictly positive.
    NonPositive(Field),
    /// `delay` needs a history of `delay + 2` samples; this controller holds `max + 2`.
    DelayTooLong { delay: u32, max: u32 },
    /// The path needs `quant` (a quantized controller was asked for with `quant: None`).
    MissingQuantization,
    /// The exact floating-point path was given a quantized configuration; use
    /// [`IntPd`] (`Counts`) or [`LiteralPd`] (`Literal`), or [`Law`] which picks.
    UnexpectedQuantization,
    /// The quantized path was given the other quantization mode.
    WrongQuantMode { expected: QuantMode, found: QuantMode },
    /// A quantity derived from this field is not representable in the path's arithmetic:
    /// an `f32` conversion overflows or underflows to zero, a fixed-point gain (codes per
    /// count) exceeds [`quant::GAIN_MAX_CODES_PER_COUNT`] or rounds to zero although the field
    /// is not zero, or `u_max / h_dac` is below 1 or above `i32::MAX` codes.
    OutOfRange(Field),
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ConfigError::NonFinite(field) => write!(f, "controller config: `{field}` is not finite"),
            ConfigError::NonPositive(field) => {
                write!(f, "controller config: `{field}` must be > 0")
            }
            ConfigError::DelayTooLong { delay, max } => {
                write!(f, "controller config: `delay` = {delay} samples exceeds this controller's history (max {max})")
            }
            ConfigError::MissingQuantization => f.write_str("controller config: this path needs `quant`, found none"),
            ConfigError::UnexpectedQuantization => f.write_str(
                "controller config: the exact floating-point path cannot apply `quant`; use the quantized path",
            ),
            ConfigError::WrongQuantMode { expected, found } => {
                write!(f, "controller config: `quant.mode` is {found:?}, this path implements {expected:?}")
            }
            ConfigError::OutOfRange(field) => write!(
                f,
                "controller config: a quantity derived from `{field}` is not representable in this path's arithmetic"
            ),
        }
    }
}

impl core::error::Error for ConfigError {}

impl ConfigError {
    /// The configuration field the error is about (`None` for the delay and for a
    /// quantization that is missing, unexpected or of the other mode).
    pub const fn field(&self) -> Option<Field> {
        match *self {
            ConfigError::NonFinite(f) | ConfigError::NonPositive(f) | ConfigError::OutOfRange(f) => Some(f),
            ConfigError::DelayTooLong { .. }
            | ConfigError::MissingQuantization
            | ConfigError::UnexpectedQuantization
            | ConfigError::WrongQuantMode { .. } => None,
        }
    }
}

/// History capacity (samples) of the controllers this project builds: the simulator's and
/// the firmware's (`qemu/src/bin/pil.rs` instantiates `IntPd<8>`). A delay of at most
/// `HISTORY - 2` samples fits.
pub const HISTORY: usize = 8;

/// The one validation of a [`ControllerConfig`] for a controller with history capacity `H`:
/// exactly what [`Law::try_new`] checks (finite gains, `dt > 0`, `u_max > 0`, quantization
/// steps `> 0`, the delay within the history, and the integer path's derived fixed-point
/// ranges). Scenes, decoded model blobs and `export` all call this, so one configuration
/// is accepted or refused the same way with the same message wherever it crosses a boundary.
pub fn validate_config<const H: usize>(cfg: &ControllerConfig) -> Result<(), ConfigError> {
    Law::<H>::try_new(cfg).map(|_| ())
}

/// Which measured signal an [`InputError`] concerns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Signal {
    /// The primary (stabilized) angle, theta.
    Y,
    /// The secondary angle, phi.
    Z,
}

/// Why a sample or a pre-history was rejected. When a call returns an error the controller's
/// state is left exactly as it was before the call (the sample is not consumed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputError {
    /// The sample is NaN or infinite.
    NonFinite(Signal),
    /// The angle's encoder count `floor(angle / h)` is outside `i32`.
    AdcOutOfRange(Signal),
    /// The control value is NaN, or infinite with no saturation configured (finite inputs
    /// whose products overflow the float type), or the integral overflowed.
    NonFiniteOutput,
    /// A pre-history must hold exactly `delay + 1` samples.
    HistoryLength { expected: usize, found: usize },
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let name = |s: Signal| match s {
            Signal::Y => "primary angle (y)",
            Signal::Z => "secondary angle (z)",
        };
        match *self {
            InputError::NonFinite(s) => write!(f, "controller input: {} is not finite", name(s)),
            InputError::AdcOutOfRange(s) => {
                write!(f, "controller input: {} is outside the i32 count range", name(s))
            }
            InputError::NonFiniteOutput => {
                f.write_str("controller: the control value overflowed (not finite) and no saturation is configured")
            }
            InputError::HistoryLength { expected, found } => {
                write!(f, "controller pre-history: expected {expected} samples (delay + 1), found {found}")
            }
        }
    }
}

impl core::error::Error for InputError {}

/// Checks shared by every path: gains finite, `dt` finite and positive, `u_max` finite and
/// positive when present, `delay + 2 <= h`. Returns the delay as `usize`.
pub(crate) fn validate_common(cfg: &ControllerConfig, h: usize) -> Result<usize, ConfigError> {
    finite(cfg.kp, Field::Kp)?;
    finite(cfg.kd, Field::Kd)?;
    finite(cfg.kphi_d, Field::KphiD)?;
    finite(cfg.ki, Field::Ki)?;
    positive(cfg.dt, Field::Dt)?;
    if let Some(u_max) = cfg.u_max {
        positive(u_max, Field::UMax)?;
    }
    let max = h.saturating_sub(2);
    let delay = usize::try_from(cfg.delay).unwrap_or(usize::MAX);
    if h < 2 || delay > max {
        return Err(ConfigError::DelayTooLong { delay: cfg.delay, max: u32::try_from(max).unwrap_or(u32::MAX) });
    }
    Ok(delay)
}

/// Checks every field of a quantization, used or not by the path, and its mode.
pub(crate) fn validate_quant(cfg: &ControllerConfig, expected: QuantMode) -> Result<Quantization, ConfigError> {
    let q = cfg.quant.ok_or(ConfigError::MissingQuantization)?;
    if q.mode != expected {
        return Err(ConfigError::WrongQuantMode { expected, found: q.mode });
    }
    positive(q.h_adc, Field::HAdc)?;
    positive(q.h_adc_phi, Field::HAdcPhi)?;
    positive(q.h_dac, Field::HDac)?;
    Ok(q)
}

pub(crate) fn finite(x: f64, field: Field) -> Result<(), ConfigError> {
    if x.is_finite() { Ok(()) } else { Err(ConfigError::NonFinite(field)) }
}

pub(crate) fn positive(x: f64, field: Field) -> Result<(), ConfigError> {
    finite(x, field)?;
    if x > 0.0 { Ok(()) } else { Err(ConfigError::NonPositive(field)) }
}
