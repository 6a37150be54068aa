//! [`Law`]: the path a [`ControllerConfig`] asks for, behind one angles-in, volts-out
//! interface (what a host simulator calls). Owns no arithmetic of its own.

use shared::{ControllerConfig, QuantMode};

use crate::pd::{FloatPd, Output};
use crate::quant::{IntPd, LiteralPd, count};
use crate::{ConfigError, InputError, Signal};

/// The control law selected by `cfg.quant`:
/// - `None`: [`FloatPd<f64, H>`] on the angles;
/// - `Counts`: [`adc`](crate::adc) of both angles (`h_adc`, `h_adc_phi`), [`IntPd<H>`], then
///   `u = h_dac * code`;
/// - `Literal`: [`LiteralPd<H>`] on the angles.
#[derive(Clone, Copy, Debug)]
pub enum Law<const H: usize> {
    Exact(FloatPd<f64, H>),
    Counts { pd: IntPd<H>, h_adc: f64, h_adc_phi: f64 },
    Literal(LiteralPd<H>),
}

impl<const H: usize> Law<H> {
    /// Validate `cfg` with the rules of the selected path.
    pub fn try_new(cfg: &ControllerConfig) -> Result<Self, ConfigError> {
        match cfg.quant {
            None => FloatPd::try_new(cfg).map(Law::Exact),
            Some(q) => match q.mode {
                QuantMode::Counts => {
                    Ok(Law::Counts { pd: IntPd::try_new(cfg)?, h_adc: q.h_adc, h_adc_phi: q.h_adc_phi })
                }
                QuantMode::Literal => LiteralPd::try_new(cfg).map(Law::Literal),
            },
        }
    }

    /// Zero pre-history and zero integral.
    pub fn reset(&mut self) {
        match self {
            Law::Exact(pd) => pd.reset(),
            Law::Counts { pd, .. } => pd.reset(),
            Law::Literal(pd) => pd.reset(),
        }
    }

    /// Start a run: the `r + 1` angle samples `(theta, phi)` before `t_0`, oldest first.
    /// On error nothing changes.
    pub fn prime(&mut self, history: &[(f64, f64)]) -> Result<(), InputError> {
        match self {
            Law::Exact(pd) => pd.prime(history),
            Law::Literal(pd) => pd.prime(history),
            Law::Counts { pd, h_adc, h_adc_phi } => {
                let expected = pd.delay().saturating_add(1);
                if history.len() != expected {
                    return Err(InputError::HistoryLength { expected, found: history.len() });
                }
                for &(y, z) in history {
                    count(y, *h_adc, Signal::Y)?;
                    count(z, *h_adc_phi, Signal::Z)?;
                }
                for &(y, z) in history {
                    pd.push_history((count(y, *h_adc, Signal::Y)?, count(z, *h_adc_phi, Signal::Z)?));
                }
                pd.clear_integral();
                Ok(())
            }
        }
    }

    /// Start a run from rest at `(theta, phi)`.
    pub fn prime_constant(&mut self, y: f64, z: f64) -> Result<(), InputError> {
        match self {
            Law::Exact(pd) => pd.prime_constant(y, z),
            Law::Literal(pd) => pd.prime_constant(y, z),
            Law::Counts { pd, h_adc, h_adc_phi } => {
                let q_y = count(y, *h_adc, Signal::Y)?;
                let q_z = count(z, *h_adc_phi, Signal::Z)?;
                pd.prime_constant(q_y, q_z);
                Ok(())
            }
        }
    }

    /// Push the angles sampled at `t_i`, return the voltage to hold over `[t_i, t_i + dt)`.
    /// On error nothing changes.
    pub fn step(&mut self, y: f64, z: f64) -> Result<Output<f64>, InputError> {
        match self {
            Law::Exact(pd) => pd.step(y, z),
            Law::Literal(pd) => pd.step(y, z),
            Law::Counts { pd, h_adc, h_adc_phi } => {
                let q_y = count(y, *h_adc, Signal::Y)?;
                let q_z = count(z, *h_adc_phi, Signal::Z)?;
                let out = pd.step(q_y, q_z);
                Ok(Output { u: pd.volts(out.code), saturated: out.saturated })
            }
        }
    }
}
