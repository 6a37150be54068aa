#![doc = include_str!("../README.md")]
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic, clippy::indexing_slicing))]

mod history;
pub mod law;
pub mod pd;
pub mod predictor;
pub mod quant;

#[cfg(test)]
mod legacy_tests;

use core::fmt;

pub use law::Law;
pub use pd::{FloatPd, Output, Real};
pub use quant::{AdcError, IntOutput, IntPd, LiteralPd, adc};
pub use shared::{ControllerConfig, Gain, Gains, MAX_GAINS, QuantMode, Quantization};

/// A field of [`ControllerConfig`] (or of its [`Quantization`]), named in errors. The gain
/// fields carry the position of the coordinate in the gain vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// `gains[i].p`.
    P(u8),
    /// `gains[i].d`.
    D(u8),
    /// `gains[i].h_adc`, the coordinate's encoder resolution.
    HAdc(u8),
    Ki,
    Dt,
    UMax,
    HDac,
}

impl fmt::Display for Field {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Field::P(i) => write!(f, "gains[{i}].p"),
            Field::D(i) => write!(f, "gains[{i}].d"),
            Field::HAdc(i) => write!(f, "gains[{i}].h_adc"),
            Field::Ki => f.write_str("ki"),
            Field::Dt => f.write_str("dt"),
            Field::UMax => f.write_str("u_max"),
            Field::HDac => f.write_str("quant.h_dac"),
        }
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
    /// The gain vector is empty: at least one coordinate must be measured.
    NoGains,
    /// Two entries of the gain vector measure the same state index.
    DuplicateIndex { index: u8 },
    /// The integer path: the fixed-point gains' magnitudes `sum_i |P_i + D_i| + |D_i|`
    /// exceed [`quant::GAIN_SUM_MAX_Q`] (the bound that keeps every step exact in `i64`).
    GainSum,
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
            ConfigError::NoGains => f.write_str("controller config: `gains` is empty; measure at least one coordinate"),
            ConfigError::DuplicateIndex { index } => {
                write!(f, "controller config: two entries of `gains` measure the same state index {index}")
            }
            ConfigError::GainSum => write!(
                f,
                "controller config: the fixed-point gains sum to more than {} codes per count over all coordinates \
                 (sum of |p_i + d_i/dt| + |d_i/dt| in codes per count); lower the gains or the resolutions",
                quant::GAIN_SUM_MAX_CODES_PER_COUNT
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
            | ConfigError::NoGains
            | ConfigError::DuplicateIndex { .. }
            | ConfigError::GainSum
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

/// Which measured signal an [`InputError`] concerns: the position of the coordinate in the
/// gain vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Signal(pub u8);

impl fmt::Display for Signal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "measured coordinate {} (gains[{}])", self.0, self.0)
    }
}

/// Why a sample or a pre-history was rejected. When a call returns an error the controller's
/// state is left exactly as it was before the call (the sample is not consumed).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InputError {
    /// The sample is NaN or infinite.
    NonFinite(Signal),
    /// The coordinate's encoder count `floor(q / h_adc)` is outside `i32`.
    AdcOutOfRange(Signal),
    /// The control value is NaN, or infinite with no saturation configured (finite inputs
    /// whose products overflow the float type), or the integral overflowed.
    NonFiniteOutput,
    /// A sample must hold one value per measured coordinate.
    Measurements { expected: usize, found: usize },
    /// A pre-history must hold exactly `delay + 1` samples of one value per measured
    /// coordinate (`expected` values, oldest sample first).
    HistoryLength { expected: usize, found: usize },
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            InputError::NonFinite(s) => write!(f, "controller input: {s} is not finite"),
            InputError::AdcOutOfRange(s) => {
                write!(f, "controller input: {s} is outside the i32 count range")
            }
            InputError::NonFiniteOutput => {
                f.write_str("controller: the control value overflowed (not finite) and no saturation is configured")
            }
            InputError::Measurements { expected, found } => {
                write!(f, "controller input: expected {expected} measured values (one per gain), found {found}")
            }
            InputError::HistoryLength { expected, found } => write!(
                f,
                "controller pre-history: expected {expected} values ((delay + 1) samples x measured coordinates), found {found}"
            ),
        }
    }
}

impl core::error::Error for InputError {}

/// Checks shared by every path: a gain vector of one to [`MAX_GAINS`] coordinates on
/// distinct state indices, gains finite, `dt` finite and positive, `u_max` finite and
/// positive when present, `delay + 2 <= h`. Returns the delay as `usize`.
pub(crate) fn validate_common(cfg: &ControllerConfig, h: usize) -> Result<usize, ConfigError> {
    let gains = cfg.gains.as_slice();
    if gains.is_empty() {
        return Err(ConfigError::NoGains);
    }
    for (i, g) in gains.iter().enumerate() {
        // At most MAX_GAINS (4) entries: the position fits u8.
        let at = i as u8;
        finite(g.p, Field::P(at))?;
        finite(g.d, Field::D(at))?;
        if gains.iter().take(i).any(|o| o.index == g.index) {
            return Err(ConfigError::DuplicateIndex { index: g.index });
        }
    }
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
    for (i, g) in cfg.gains.iter().enumerate() {
        positive(g.h_adc, Field::HAdc(i as u8))?;
    }
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
