//! [`Law`]: the path a [`ControllerConfig`] asks for, behind one coordinates-in, volts-out
//! interface (what a host simulator calls). Owns no arithmetic of its own.

use shared::{ControllerConfig, MAX_GAINS, QuantMode};

use crate::pd::{FloatPd, Output, check_history};
use crate::quant::{IntPd, LiteralPd, count};
use crate::{ConfigError, InputError, Signal};

/// The control law selected by `cfg.quant`:
/// - `None`: [`FloatPd<f64, H>`] on the measured coordinates;
/// - `Counts`: [`adc`](crate::adc) of each coordinate with its own `h_adc`, [`IntPd<H>`],
///   then `u = h_dac * code`;
/// - `Literal`: [`LiteralPd<H>`] on the measured coordinates.
///
/// Every call takes one value per entry of `cfg.gains`, in that order.
#[derive(Clone, Copy, Debug)]
pub enum Law<const H: usize> {
    Exact(FloatPd<f64, H>),
    Counts { pd: IntPd<H>, h_adc: [f64; MAX_GAINS] },
    Literal(LiteralPd<H>),
}

/// The encoder counts of one sample.
fn counts_of(q: &[f64], h_adc: &[f64; MAX_GAINS], n: usize) -> Result<[i32; MAX_GAINS], InputError> {
    if q.len() != n {
        return Err(InputError::Measurements { expected: n, found: q.len() });
    }
    let mut c = [0; MAX_GAINS];
    for (i, ((slot, &v), &h)) in c.iter_mut().zip(q).zip(h_adc).enumerate() {
        *slot = count(v, h, Signal(i as u8))?;
    }
    Ok(c)
}

impl<const H: usize> Law<H> {
    /// Validate `cfg` with the rules of the selected path.
    pub fn try_new(cfg: &ControllerConfig) -> Result<Self, ConfigError> {
        match cfg.quant {
            None => FloatPd::try_new(cfg).map(Law::Exact),
            Some(q) => match q.mode {
                QuantMode::Counts => {
                    let pd = IntPd::try_new(cfg)?;
                    let mut h_adc = [0.0; MAX_GAINS];
                    for (h, g) in h_adc.iter_mut().zip(cfg.gains.iter()) {
                        *h = g.h_adc;
                    }
                    Ok(Law::Counts { pd, h_adc })
                }
                QuantMode::Literal => LiteralPd::try_new(cfg).map(Law::Literal),
            },
        }
    }

    /// The number of measured coordinates (values per sample).
    pub fn coordinates(&self) -> usize {
        match self {
            Law::Exact(pd) => pd.coordinates(),
            Law::Counts { pd, .. } => pd.coordinates(),
            Law::Literal(pd) => pd.coordinates(),
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

    /// Start a run: the `r + 1` samples before `t_0`, oldest first, one value per measured
    /// coordinate each (flattened). On error nothing changes.
    pub fn prime(&mut self, history: &[f64]) -> Result<(), InputError> {
        match self {
            Law::Exact(pd) => pd.prime(history),
            Law::Literal(pd) => pd.prime(history),
            Law::Counts { pd, h_adc } => {
                let n = pd.coordinates();
                check_history(history, n, pd.delay())?;
                for s in history.chunks_exact(n) {
                    counts_of(s, h_adc, n)?;
                }
                for s in history.chunks_exact(n) {
                    pd.push_history(counts_of(s, h_adc, n)?);
                }
                pd.clear_integral();
                Ok(())
            }
        }
    }

    /// Start a run from rest at `q`.
    pub fn prime_constant(&mut self, q: &[f64]) -> Result<(), InputError> {
        match self {
            Law::Exact(pd) => pd.prime_constant(q),
            Law::Literal(pd) => pd.prime_constant(q),
            Law::Counts { pd, h_adc } => {
                let c = counts_of(q, h_adc, pd.coordinates())?;
                pd.prime_constant(c.get(..pd.coordinates()).unwrap_or(&[]))
            }
        }
    }

    /// Push the coordinates sampled at `t_k`, return the voltage to hold over
    /// `[t_k, t_k + dt)`. On error nothing changes.
    pub fn step(&mut self, q: &[f64]) -> Result<Output<f64>, InputError> {
        match self {
            Law::Exact(pd) => pd.step(q),
            Law::Literal(pd) => pd.step(q),
            Law::Counts { pd, h_adc } => {
                let c = counts_of(q, h_adc, pd.coordinates())?;
                let out = pd.step_counts(&c);
                Ok(Output { u: pd.volts(out.code), saturated: out.saturated })
            }
        }
    }
}
