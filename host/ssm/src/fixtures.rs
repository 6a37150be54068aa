//! Hand-made models for the tests of this crate and of the crates above it, built from the
//! generators of [`crate::testing`]. A module of its own: [`crate::testing`] sits below
//! [`crate::dynamics`], whose tests use it, so models cannot live there.

use crate::dynamics::{Kernel, RbfMap};
use crate::ridge::Conditioning;

/// A random linear-kernel RBF map in dimension `d` with `k` centres drawn from `rnd`: a
/// contraction (`0.9 eta` plus small terms) when `small`, so Benettin runs stay bounded.
pub fn random_rbf(d: usize, k: usize, small: bool, rnd: &mut impl FnMut() -> f64) -> RbfMap {
    let scale: Vec<f64> = (0..d).map(|_| 0.5 + rnd().abs()).collect();
    let mut coef: Vec<f64> = (0..(k + d + 1) * d).map(|_| rnd() * if small { 0.002 } else { 10.0 }).collect();
    if small {
        for j in 0..d {
            coef[(k + j) * d + j] = -0.1 * scale[j];
        }
    }
    RbfMap {
        dim: d,
        kernel: Kernel::Linear,
        dt: 0.03,
        scale,
        centers: (0..k * d).map(|_| rnd()).collect(),
        coef,
        conditioning: Conditioning::NONE,
    }
}
