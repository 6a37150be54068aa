//! Exact derivatives of a plant's right-hand side by forward-mode dual numbers: the Jacobian
//! the stiff integrator needs at every step, and the linearization `(A, B)` at the upright
//! equilibrium for the linear stability analysis.

use nalgebra::{SMatrix, SVector};

use super::{Dual, Plant, Scalar};

/// `f(x, u)` and `df/dx` at `(x, u)`, `jac[i][j] = d f_i / d x_j`: the plant's
/// [`Plant::exact_jacobian`] (dual numbers unless the plant has its own exact form).
#[inline]
pub fn jacobian<P: Plant<N>, const N: usize>(p: &P, x: &[f64; N], u: f64) -> ([f64; N], [[f64; N]; N]) {
    p.exact_jacobian(x, u)
}

/// `f(x, u)` and `df/dx` from one evaluation of the right-hand side in `Dual<N>`: the
/// default of [`Plant::exact_jacobian`].
#[inline]
pub fn dual_jacobian<P: Plant<N>, const N: usize>(p: &P, x: &[f64; N], u: f64) -> ([f64; N], [[f64; N]; N]) {
    let xd: [Dual<N>; N] = core::array::from_fn(|i| Dual::var(x[i], i));
    let fd = p.rhs(&xd, Dual::cst(u));
    let f = core::array::from_fn(|i| fd[i].v);
    let jac = core::array::from_fn(|i| fd[i].d);
    (f, jac)
}

/// `df/du` at `(x, u)`, from one evaluation in `Dual<1>`.
pub fn input_jacobian<P: Plant<N>, const N: usize>(p: &P, x: &[f64; N], u: f64) -> [f64; N] {
    let xd: [Dual<1>; N] = core::array::from_fn(|i| Dual::cst(x[i]));
    let fd = p.rhs(&xd, Dual::var(u, 0));
    core::array::from_fn(|i| fd[i].d[0])
}

/// `A = df/dx` and `B = df/du` at the origin (the upright equilibrium) with `u = 0`.
pub fn linearize<P: Plant<N>, const N: usize>(p: &P) -> (SMatrix<f64, N, N>, SVector<f64, N>) {
    let x0 = [0.0; N];
    let (_, jac) = jacobian(p, &x0, 0.0);
    let b = input_jacobian(p, &x0, 0.0);
    (SMatrix::from_fn(|i, j| jac[i][j]), SVector::from_fn(|i, _| b[i]))
}
