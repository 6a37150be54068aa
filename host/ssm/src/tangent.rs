//! Tangent maps of fitted reduced maps: analytic Jacobians of the RBF map ([`rbf_jacobian`])
//! and of the polynomial map ([`poly_map_jacobian`], [`PolyJacobian`] prepared for many
//! states), and [`Tangent`], one reduced map's step and Jacobian for Benettin's method (a
//! linear-kernel RBF map gives both from one pass over its centres). Lyapunov spectra of a
//! reduced map are `chaos::benettin_qr` with these (the `chaos` crate knows no model type).

use std::cell::RefCell;

use crate::dynamics::{Kernel, PreparedDynamics, RbfMap, ReducedDynamics, StepScratch};
use crate::poly::Poly;

/// Message for the non-differentiable points of the linear kernel.
pub const RBF_KINK: &str = "state exactly at an RBF centre (the linear kernel has a kink there)";

/// Jacobian (row-major `d x d`) of the RBF map `eta -> eta + sum_i C_i phi(||z - c_i||) + A z + b`,
/// `z = eta / s`: `I + sum_i C_i phi'(r_i) / r_i (z - c_i)^T / s + A / s` (linear kernel:
/// `phi'(r) / r = 1 / r`). Fails only exactly at a centre of the linear kernel.
pub fn rbf_jacobian(m: &RbfMap, eta: &[f64], jac: &mut [f64]) -> Result<(), &'static str> {
    if m.kernel == Kernel::Linear {
        match m.dim {
            2 => return rbf_jacobian_linear::<2>(m, eta, jac),
            3 => return rbf_jacobian_linear::<3>(m, eta, jac),
            4 => return rbf_jacobian_linear::<4>(m, eta, jac),
            5 => return rbf_jacobian_linear::<5>(m, eta, jac),
            6 => return rbf_jacobian_linear::<6>(m, eta, jac),
            _ => {}
        }
    }
    rbf_jacobian_any(m, eta, jac)
}

/// [`rbf_jacobian`] of the linear kernel in dimension `D` known at compile time: the same
/// operations on every entry in the same order (the sum over centres accumulated from the
/// identity, then the linear rows), with the rows of fixed length so the compiler unrolls
/// and vectorizes them.
fn rbf_jacobian_linear<const D: usize>(m: &RbfMap, eta: &[f64], jac: &mut [f64]) -> Result<(), &'static str> {
    let k = m.n_centers();
    let z: [f64; D] = core::array::from_fn(|j| eta[j] / m.scale[j]);
    let scale: [f64; D] = core::array::from_fn(|j| m.scale[j]);
    let mut acc = [[0.0; D]; D];
    for (i, row) in acc.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    jac.iter_mut().for_each(|v| *v = 0.0);
    let mut kink = false;
    for (ctr, w) in m.centers.chunks_exact(D).zip(m.coef.chunks_exact(D)).take(k) {
        let mut diff = [0.0; D];
        let mut r2 = 0.0;
        for j in 0..D {
            diff[j] = z[j] - ctr[j];
            r2 += diff[j] * diff[j];
        }
        if r2 == 0.0 {
            kink = true;
            break;
        }
        let r = r2.sqrt();
        let den: [f64; D] = core::array::from_fn(|j| r * scale[j]);
        for (row, &w) in acc.iter_mut().zip(w) {
            for j in 0..D {
                row[j] += w * diff[j] / den[j];
            }
        }
    }
    for (dst, row) in jac.chunks_exact_mut(D).zip(&acc) {
        dst[..D].copy_from_slice(row);
    }
    if kink {
        return Err(RBF_KINK);
    }
    for j in 0..D {
        for out in 0..D {
            jac[out * D + j] += m.coef[(k + j) * D + out] / scale[j];
        }
    }
    Ok(())
}

/// One step of a linear-kernel RBF map in dimension `D` and its Jacobian at `eta`, from one
/// pass over the centres (a Benettin run needs both at every state): `jac` as
/// [`rbf_jacobian`] and `next` as `RbfMap::step` would give them, bit for bit. The step's
/// features are the distances `r_i = sqrt(sum_j (z_j - c_ij)^2)` the Jacobian computes
/// anyway (the same sum in the same order), then the scaled state and 1, and `next` adds
/// `coef * feature` to `eta` feature by feature in the step's order. At a kink (a state
/// exactly at a centre) the error is the Jacobian's and `next` is not set.
fn rbf_step_and_jacobian_linear<const D: usize>(
    m: &RbfMap,
    eta: &[f64],
    jac: &mut [f64],
    next: &mut [f64],
) -> Result<(), &'static str> {
    let k = m.n_centers();
    let z: [f64; D] = core::array::from_fn(|j| eta[j] / m.scale[j]);
    let scale: [f64; D] = core::array::from_fn(|j| m.scale[j]);
    let mut acc = [[0.0; D]; D];
    for (i, row) in acc.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let mut nx: [f64; D] = core::array::from_fn(|j| eta[j]);
    jac.iter_mut().for_each(|v| *v = 0.0);
    let mut kink = false;
    for (ctr, w) in m.centers.chunks_exact(D).zip(m.coef.chunks_exact(D)).take(k) {
        let mut diff = [0.0; D];
        let mut r2 = 0.0;
        for j in 0..D {
            diff[j] = z[j] - ctr[j];
            r2 += diff[j] * diff[j];
        }
        if r2 == 0.0 {
            kink = true;
            break;
        }
        let r = r2.sqrt();
        for j in 0..D {
            nx[j] += w[j] * r;
        }
        let den: [f64; D] = core::array::from_fn(|j| r * scale[j]);
        for (row, &w) in acc.iter_mut().zip(w) {
            for j in 0..D {
                row[j] += w * diff[j] / den[j];
            }
        }
    }
    for (dst, row) in jac.chunks_exact_mut(D).zip(&acc) {
        dst[..D].copy_from_slice(row);
    }
    if kink {
        return Err(RBF_KINK);
    }
    for j in 0..D {
        for out in 0..D {
            jac[out * D + j] += m.coef[(k + j) * D + out] / scale[j];
        }
    }
    // The linear features eta_j / s_j (the step's own quotients), then the constant 1.
    for j2 in 0..D {
        let f = eta[j2] / m.scale[j2];
        for j in 0..D {
            nx[j] += m.coef[(k + j2) * D + j] * f;
        }
    }
    for j in 0..D {
        nx[j] += m.coef[(k + D) * D + j] * 1.0;
    }
    next[..D].copy_from_slice(&nx);
    Ok(())
}

/// [`rbf_step_and_jacobian_linear`] for the dimension of `m`; `None` when `m` is not a
/// linear-kernel map of dimension 2..=6 (then the step and the Jacobian are computed apart).
#[doc(hidden)]
pub fn rbf_step_and_jacobian(
    m: &RbfMap,
    eta: &[f64],
    jac: &mut [f64],
    next: &mut [f64],
) -> Option<Result<(), &'static str>> {
    if m.kernel != Kernel::Linear {
        return None;
    }
    Some(match m.dim {
        2 => rbf_step_and_jacobian_linear::<2>(m, eta, jac, next),
        3 => rbf_step_and_jacobian_linear::<3>(m, eta, jac, next),
        4 => rbf_step_and_jacobian_linear::<4>(m, eta, jac, next),
        5 => rbf_step_and_jacobian_linear::<5>(m, eta, jac, next),
        6 => rbf_step_and_jacobian_linear::<6>(m, eta, jac, next),
        _ => return None,
    })
}

/// [`rbf_jacobian`] for any kernel and dimension.
#[doc(hidden)]
pub fn rbf_jacobian_any(m: &RbfMap, eta: &[f64], jac: &mut [f64]) -> Result<(), &'static str> {
    let d = m.dim;
    let k = m.n_centers();
    jac.iter_mut().for_each(|v| *v = 0.0);
    for i in 0..d {
        jac[i * d + i] = 1.0;
    }
    // Scratch: the difference to a centre, the scaled state and the linear kernel's
    // denominators `r s_j` (each the same value as computed per entry, so the same Jacobian).
    let mut buf = [0.0; 48];
    let mut buf_v = Vec::new();
    let buf: &mut [f64] = if d <= 16 {
        &mut buf[..3 * d]
    } else {
        buf_v.resize(3 * d, 0.0);
        &mut buf_v
    };
    let (diff, rest) = buf.split_at_mut(d);
    let (z, den) = rest.split_at_mut(d);
    for j in 0..d {
        z[j] = eta[j] / m.scale[j];
    }
    for c in 0..k {
        let ctr = &m.centers[c * d..(c + 1) * d];
        let mut r2 = 0.0;
        for j in 0..d {
            diff[j] = z[j] - ctr[j];
            r2 += diff[j] * diff[j];
        }
        if m.kernel == Kernel::Linear {
            if r2 == 0.0 {
                return Err(RBF_KINK);
            }
            let r = r2.sqrt();
            for j in 0..d {
                den[j] = r * m.scale[j];
            }
            for out in 0..d {
                let w = m.coef[c * d + out];
                let row = &mut jac[out * d..(out + 1) * d];
                for j in 0..d {
                    row[j] += w * diff[j] / den[j];
                }
            }
            continue;
        }
        // Other kernels: d phi(||z - c||) / d z = phi'(r) / r (z - c), smooth everywhere.
        let g = m.kernel.dphi_over_r(r2.sqrt()).ok_or(RBF_KINK)?;
        for out in 0..d {
            let w = m.coef[c * d + out] * g;
            for j in 0..d {
                jac[out * d + j] += w * diff[j] / m.scale[j];
            }
        }
    }
    for j in 0..d {
        for out in 0..d {
            jac[out * d + j] += m.coef[(k + j) * d + out] / m.scale[j];
        }
    }
    Ok(())
}

/// Jacobian (row-major `d x d`) of the polynomial map `eta -> eta + P(eta)`, `P` evaluated
/// on `z = eta / s`: `I + dP/dz / s`. For many evaluations of one map, [`PolyJacobian`]
/// prepares the monomials once (the same Jacobian, bit for bit).
pub fn poly_map_jacobian(p: &Poly, eta: &[f64], jac: &mut [f64]) {
    PolyJacobian::new(p).eval(eta, jac);
}

/// [`poly_map_jacobian`] of one polynomial, prepared for repeated evaluation (Benettin runs
/// take one Jacobian per map step): the largest degree and each monomial's non-zero
/// exponents are found once, and the powers live in a buffer kept between calls. Every
/// entry is the same product in the same order as the plain loop over all variables, which
/// multiplies by `z_i^0 = 1` where this skips (exact), so the Jacobian is the same bit for bit.
pub struct PolyJacobian<'a> {
    p: &'a Poly,
    /// Powers per variable: `pow[i * stride + e] = z_i^e`, `e = 0..stride`.
    stride: usize,
    pow: Vec<f64>,
    /// `dpow[i * stride + e] = e z_i^(e - 1) / s_i`, `e = 1..stride`: the first factor of
    /// every derivative with respect to `z_i` of a monomial with exponent `e` in it (the
    /// plain loop formed it per monomial; it is the same quotient of the same operands).
    dpow: Vec<f64>,
    /// Non-zero exponents `(variable, exponent)` of every monomial, in variable order;
    /// monomial `k`'s are `factors[starts[k]..starts[k + 1]]`.
    factors: Vec<(usize, usize)>,
    starts: Vec<usize>,
}

impl<'a> PolyJacobian<'a> {
    pub fn new(p: &'a Poly) -> Self {
        let stride = crate::poly::max_degree(&p.exps) as usize + 1;
        let mut factors = Vec::new();
        let mut starts = Vec::with_capacity(p.exps.len() + 1);
        for e in &p.exps {
            starts.push(factors.len());
            factors.extend(e.iter().enumerate().filter(|(_, ei)| **ei != 0).map(|(i, &ei)| (i, ei as usize)));
        }
        starts.push(factors.len());
        Self { p, stride, pow: vec![1.0; p.dim_in * stride], dpow: vec![0.0; p.dim_in * stride], factors, starts }
    }

    /// The Jacobian at `eta` into `jac` (row-major `d x d`).
    pub fn eval(&mut self, eta: &[f64], jac: &mut [f64]) {
        let p = self.p;
        let d = p.dim_in;
        let stride = self.stride;
        jac.iter_mut().for_each(|v| *v = 0.0);
        for i in 0..d.min(p.dim_out) {
            jac[i * d + i] = 1.0;
        }
        let pow = &mut self.pow;
        let dpow = &mut self.dpow;
        for i in 0..d {
            let z = eta[i] / p.scale[i];
            for e in 1..stride {
                pow[i * stride + e] = pow[i * stride + e - 1] * z;
            }
            for e in 1..stride {
                dpow[i * stride + e] = e as f64 * pow[i * stride + e - 1] / p.scale[i];
            }
        }
        let (pow, dpow) = (&self.pow[..], &self.dpow[..]);
        let fixed = match d {
            _ if p.dim_out != d || jac.len() < d * d || p.coef.len() < self.starts.len().saturating_sub(1) * d => false,
            2 => self.terms_fixed::<2>(jac),
            3 => self.terms_fixed::<3>(jac),
            4 => self.terms_fixed::<4>(jac),
            5 => self.terms_fixed::<5>(jac),
            6 => self.terms_fixed::<6>(jac),
            _ => false,
        };
        if fixed {
            return;
        }
        for (k, w) in self.starts.windows(2).enumerate() {
            let f = &self.factors[w[0]..w[1]];
            for &(j, ej) in f {
                let mut g = dpow[j * stride + ej];
                for &(i, ei) in f {
                    if i != j {
                        g *= pow[i * stride + ei];
                    }
                }
                for out in 0..p.dim_out {
                    jac[out * d + j] += p.coef[k * p.dim_out + out] * g;
                }
            }
        }
    }

    /// The monomials' terms of [`PolyJacobian::eval`] for a square map of dimension `D`
    /// (`jac` already zero with the identity on its diagonal): the sums of every entry in
    /// the same order (monomial by monomial), kept in a local `D x D` array by column so the
    /// `D` outputs of one term are added side by side, then written to `jac`.
    #[inline]
    fn terms_fixed<const D: usize>(&self, jac: &mut [f64]) -> bool {
        let stride = self.stride;
        let (pow, dpow, coef) = (&self.pow[..], &self.dpow[..], &self.p.coef[..]);
        // acc[j][out] = jac[out * D + j]
        let mut acc = [[0.0; D]; D];
        for (j, col) in acc.iter_mut().enumerate() {
            for (out, v) in col.iter_mut().enumerate() {
                *v = jac[out * D + j];
            }
        }
        for (w, c) in self.starts.windows(2).zip(coef.chunks_exact(D)) {
            let f = &self.factors[w[0]..w[1]];
            let c: &[f64; D] = c.try_into().unwrap_or(&[0.0; D]);
            for &(j, ej) in f {
                let mut g = dpow[j * stride + ej];
                for &(i, ei) in f {
                    if i != j {
                        g *= pow[i * stride + ei];
                    }
                }
                let col = &mut acc[j];
                for out in 0..D {
                    col[out] += c[out] * g;
                }
            }
        }
        for (j, col) in acc.iter().enumerate() {
            for (out, v) in col.iter().enumerate() {
                jac[out * D + j] = *v;
            }
        }
        true
    }
}

/// Jacobian of a discrete reduced map at `eta`.
pub fn map_jacobian(dynamics: &ReducedDynamics, eta: &[f64], jac: &mut [f64]) -> Result<(), &'static str> {
    match dynamics {
        ReducedDynamics::Rbf(m) => rbf_jacobian(m, eta, jac),
        ReducedDynamics::Map { increment, .. } => {
            poly_map_jacobian(increment, eta, jac);
            Ok(())
        }
        ReducedDynamics::Flow { .. } => Err("continuous flow: no map Jacobian"),
    }
}

/// One discrete reduced map's step and Jacobian, for Benettin's method, which takes the
/// Jacobian at `x` and then the step from the same `x`: for a linear-kernel RBF map the
/// Jacobian call keeps the step it computed in the same pass (and the state it is for), and
/// the step call uses it when its state is that one, bit for bit (else it steps as usual).
/// Interior state (the kept step, the polynomial Jacobian's tables, the step's scratch) is
/// behind `RefCell`s so that both calls take `&self`.
pub struct Tangent<'a> {
    dynamics: &'a ReducedDynamics,
    map: PreparedDynamics<'a>,
    dt: f64,
    dim: usize,
    scratch: RefCell<StepScratch>,
    fused: RefCell<Option<(Vec<f64>, Vec<f64>)>>,
    next: RefCell<Vec<f64>>,
    poly: Option<RefCell<PolyJacobian<'a>>>,
}

impl<'a> Tangent<'a> {
    /// The tangent map of `dynamics`; `None` for a continuous flow (no map step).
    pub fn new(dynamics: &'a ReducedDynamics) -> Option<Self> {
        let dt = dynamics.map_dt()?;
        let dim = dynamics_dim(dynamics);
        let poly = match dynamics {
            ReducedDynamics::Map { increment, .. } => Some(RefCell::new(PolyJacobian::new(increment))),
            _ => None,
        };
        Some(Self {
            dynamics,
            map: dynamics.prepare(),
            dt,
            dim,
            scratch: RefCell::new(StepScratch::default()),
            fused: RefCell::new(None),
            next: RefCell::new(vec![0.0; dim]),
            poly,
        })
    }

    /// Dimension of the reduced state.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Map step, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// One map step from `x` into `out`.
    pub fn step(&self, x: &[f64], out: &mut [f64]) {
        if let Some((at, next)) = self.fused.borrow_mut().take() {
            if at.iter().zip(x).all(|(a, b)| a.to_bits() == b.to_bits()) {
                out.copy_from_slice(&next);
                return;
            }
        }
        out.copy_from_slice(x);
        self.map.step(out, self.dt, &mut self.scratch.borrow_mut());
    }

    /// The Jacobian (row-major `d x d`) at `x`; fails only exactly at a centre of a
    /// linear-kernel RBF map ([`RBF_KINK`]).
    pub fn jacobian(&self, x: &[f64], j: &mut [f64]) -> Result<(), &'static str> {
        if let Some(pj) = &self.poly {
            pj.borrow_mut().eval(x, j);
            return Ok(());
        }
        if let ReducedDynamics::Rbf(m) = self.dynamics {
            let mut next = self.next.borrow_mut();
            if let Some(r) = rbf_step_and_jacobian(m, x, j, &mut next) {
                let mut slot = self.fused.borrow_mut();
                *slot = None;
                r?;
                *slot = Some((x.to_vec(), next.clone()));
                return Ok(());
            }
        }
        map_jacobian(self.dynamics, x, j)
    }
}

/// Dimension of the reduced state of `dynamics`.
pub fn dynamics_dim(dynamics: &ReducedDynamics) -> usize {
    match dynamics {
        ReducedDynamics::Rbf(m) => m.dim,
        ReducedDynamics::Map { increment, .. } => increment.dim_in,
        ReducedDynamics::Flow { field, .. } => field.dim_in,
    }
}
