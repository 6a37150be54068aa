//! Units. Time is in seconds everywhere inside the workspace's code: integrators, the
//! closed loop, multipliers' rates (1/s), frequencies (Hz), fitted models' steps. The one
//! exception is the sampling period as a *named parameter value*: scene files
//! (`controller.dt_ms`), the parametric study's axis (`dt_ms` fields and arguments, e.g.
//! 31.41 ms, exact in decimal) and report labels carry it in milliseconds, always in a name
//! ending in `_ms`. It becomes seconds only through [`ms_to_s`] (and a duration is shown in
//! ms only through [`s_to_ms`]); no other conversion factor appears in the code.

/// Milliseconds to seconds.
#[inline]
pub fn ms_to_s(ms: f64) -> f64 {
    ms * 1e-3
}

/// Seconds to milliseconds (for display and the `_ms` report fields).
#[inline]
pub fn s_to_ms(s: f64) -> f64 {
    s * 1e3
}
