//! Multivariate monomials in a fixed order, evaluated on scaled coordinates.
//!
//! Order (documented, relied on by saved models): monomials are grouped by total degree,
//! lowest first; within one degree the exponent vectors are in descending lexicographic
//! order. For d = 2, degrees 1..=3:
//! `z1, z2, z1^2, z1 z2, z2^2, z1^3, z1^2 z2, z1 z2^2, z2^3`.
//!
//! Scaling: a polynomial is evaluated on `z = eta / scale` (per coordinate), where `scale`
//! is the largest absolute value of that coordinate in the training data, so training
//! monomials lie in [-1, 1] and high orders stay well conditioned.

use serde::{Deserialize, Serialize};

/// All exponent vectors of `dim` variables with total degree in `min..=max`, in the order
/// described in the module docs.
pub fn exponents(dim: usize, min: u32, max: u32) -> Vec<Vec<u32>> {
    let mut out = Vec::new();
    for deg in min..=max {
        let mut cur = vec![0u32; dim];
        push_degree(&mut out, &mut cur, 0, deg);
    }
    out
}

/// Number of exponent vectors [`exponents`]`(dim, min, max)` would list, computed without
/// listing them (`C(dim + k - 1, k)` per degree `k`); `None` on overflow of `usize`.
pub fn count(dim: usize, min: u32, max: u32) -> Option<usize> {
    let mut total: usize = 0;
    for k in min..=max {
        // C(dim + k - 1, k) = prod_{j=1..k} (dim - 1 + j) / j, exact at every step.
        let per = if dim == 0 {
            usize::from(k == 0)
        } else {
            let mut acc: u128 = 1;
            for j in 1..=u128::from(k) {
                acc = acc.checked_mul(dim as u128 - 1 + j)? / j;
                if acc > usize::MAX as u128 {
                    return None;
                }
            }
            acc as usize
        };
        total = total.checked_add(per)?;
    }
    Some(total)
}

fn push_degree(out: &mut Vec<Vec<u32>>, cur: &mut Vec<u32>, i: usize, left: u32) {
    if i + 1 == cur.len() {
        cur[i] = left;
        out.push(cur.clone());
        return;
    }
    if cur.is_empty() {
        return;
    }
    for k in (0..=left).rev() {
        cur[i] = k;
        push_degree(out, cur, i + 1, left - k);
    }
    cur[i] = 0;
}

/// A vector-valued polynomial `f(eta) = C^T phi(eta / scale)`, with `phi` the monomials.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Poly {
    /// Number of input variables.
    pub dim_in: usize,
    /// Number of outputs.
    pub dim_out: usize,
    /// Per-input scaling (monomials are evaluated on `eta[i] / scale[i]`).
    pub scale: Vec<f64>,
    /// Exponent vectors, one per monomial, in the documented order.
    pub exps: Vec<Vec<u32>>,
    /// Coefficients, row-major `exps.len() x dim_out`: row `k` multiplies monomial `k`.
    pub coef: Vec<f64>,
}

/// Evaluates all monomials `exps` at `z` into `out` (length `exps.len()`).
/// `pow` is scratch of length `dim * (max_degree + 1)`.
pub fn eval_monomials(exps: &[Vec<u32>], z: &[f64], max_deg: u32, pow: &mut Vec<f64>, out: &mut [f64]) {
    let _ = eval_monomials_upto(exps, z, max_deg, pow, out);
}

/// [`eval_monomials`] with powers up to `max_deg` only: `false` (and `out` partly written)
/// when an exponent exceeds it. The values do not depend on `max_deg` (each power is the
/// previous one times `z_i`), so any bound at least the largest exponent gives the same.
fn eval_monomials_upto(exps: &[Vec<u32>], z: &[f64], max_deg: u32, pow: &mut Vec<f64>, out: &mut [f64]) -> bool {
    let d = z.len();
    let stride = max_deg as usize + 1;
    pow.clear();
    pow.resize(d * stride, 1.0);
    for (i, &zi) in z.iter().enumerate() {
        for k in 1..stride {
            pow[i * stride + k] = pow[i * stride + k - 1] * zi;
        }
    }
    for (o, e) in out.iter_mut().zip(exps) {
        let mut v = 1.0;
        for (i, &k) in e.iter().enumerate() {
            if k > max_deg {
                return false;
            }
            v *= pow[i * stride + k as usize];
        }
        *o = v;
    }
    true
}

/// Largest total degree in `exps` (0 when empty).
pub fn max_degree(exps: &[Vec<u32>]) -> u32 {
    exps.iter().map(|e| e.iter().sum::<u32>()).max().unwrap_or(0)
}

impl Poly {
    /// The monomials' values at `eta` (unscaled) into `scratch.phi`, for
    /// [`Poly::eval_into`] and [`Poly::eval_one`].
    fn monomials_into(&self, eta: &[f64], scratch: &mut PolyScratch) {
        let nm = self.exps.len();
        scratch.z.clear();
        scratch.z.extend(eta.iter().zip(&self.scale).map(|(e, s)| e / s));
        scratch.phi.resize(nm, 0.0);
        // The scratch's largest degree so far bounds the exponents of a polynomial evaluated
        // again (no pass over the monomials for their degree); a larger exponent is found
        // in the pass itself and the bound raised.
        if !eval_monomials_upto(&self.exps, &scratch.z, scratch.max_deg, &mut scratch.pow, &mut scratch.phi) {
            scratch.max_deg = scratch.max_deg.max(max_degree(&self.exps));
            eval_monomials(&self.exps, &scratch.z, scratch.max_deg, &mut scratch.pow, &mut scratch.phi);
        }
    }

    /// Evaluates the polynomial at `eta` (unscaled) into `out` (length `dim_out`), using
    /// `scratch` for the scaled point, powers and monomial values.
    pub fn eval_into(&self, eta: &[f64], scratch: &mut PolyScratch, out: &mut [f64]) {
        self.monomials_into(eta, scratch);
        out.iter_mut().for_each(|o| *o = 0.0);
        for (k, &p) in scratch.phi.iter().enumerate() {
            let row = &self.coef[k * self.dim_out..(k + 1) * self.dim_out];
            for (o, c) in out.iter_mut().zip(row) {
                *o += c * p;
            }
        }
    }

    /// Output `i` of [`Poly::eval_into`] alone (`i < dim_out`, else `NaN`): the same
    /// operations in the same order, so the same bits, at the cost of one output's sum.
    pub fn eval_one(&self, eta: &[f64], scratch: &mut PolyScratch, i: usize) -> f64 {
        if i >= self.dim_out {
            return f64::NAN;
        }
        self.monomials_into(eta, scratch);
        let mut o = 0.0;
        for (k, &p) in scratch.phi.iter().enumerate() {
            o += self.coef[k * self.dim_out + i] * p;
        }
        o
    }

    /// Allocating convenience wrapper around [`Poly::eval_into`].
    pub fn eval(&self, eta: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.dim_out];
        self.eval_into(eta, &mut PolyScratch::default(), &mut out);
        out
    }

    /// The Jacobian at the origin in unscaled coordinates (`dim_out x dim_in`, row-major):
    /// the coefficients of the degree-1 monomials divided by the scales.
    pub fn linear_part(&self) -> Vec<f64> {
        let mut a = vec![0.0; self.dim_out * self.dim_in];
        for (k, e) in self.exps.iter().enumerate() {
            if e.iter().sum::<u32>() != 1 {
                continue;
            }
            let j = e.iter().position(|&p| p == 1).unwrap_or(0);
            for i in 0..self.dim_out {
                a[i * self.dim_in + j] = self.coef[k * self.dim_out + i] / self.scale[j];
            }
        }
        a
    }
}

/// A [`Poly`] prepared for many evaluations (a map iterated for thousands of steps): the
/// same values as [`Poly::eval_into`] and [`Poly::eval_one`], bit for bit, for less work.
///
/// [`Poly::eval_into`] forms each monomial as the product, in variable order, of the powers
/// `z_i^{k_i}` of all `dim_in` variables, `z_i^0 = 1` included, starting from 1. Multiplying
/// by 1 is exact, so the same value is the product of the non-zero exponents' powers alone,
/// and that product with its last factor left out is the value of another monomial (the
/// exponent vector with its last non-zero entry set to zero), which in a full degree range
/// is itself one of the polynomial's monomials. Preparing lists, per monomial, that
/// parent and the last factor's power: then every monomial is one product (`parent * power`)
/// of values already formed, the same multiplications in the same order as the plain loop.
/// Parents missing from the polynomial's own list are added as hidden values. The sums over
/// the monomials are then the plain loop's (each output from 0, in monomial order), with
/// the outputs kept in registers for up to four outputs.
#[derive(Clone, Debug)]
pub struct PreparedPoly<'a> {
    p: &'a Poly,
    /// Powers per variable: `pow[i * stride + e] = z_i^e`, `e = 0..stride`.
    stride: usize,
    /// Value `n + 1` (value 0 is the constant 1) is `vals[parent] * pow[power]`, with
    /// `(parent, power) = nodes[n]`; parents come before their children.
    nodes: Vec<(u32, u32)>,
    /// The value of monomial `k` is `vals[of[k]]`.
    of: Vec<u32>,
    /// `of[k] == k + 1` for every `k` ([`PreparedPoly::in_order`]).
    in_order: bool,
}

impl<'a> PreparedPoly<'a> {
    /// Prepares `p`; `None` when `p`'s shape is inconsistent (an exponent vector of another
    /// length than `dim_in`, fewer scales than inputs, coefficients not `exps.len() x
    /// dim_out`) or too large to index with `u32`: use [`Poly::eval_into`] then.
    pub fn new(p: &'a Poly) -> Option<Self> {
        let d = p.dim_in;
        if p.exps.iter().any(|e| e.len() != d)
            || p.scale.len() < d
            || Some(p.coef.len()) != p.exps.len().checked_mul(p.dim_out)
        {
            return None;
        }
        let stride = usize::try_from(max_degree(&p.exps)).ok()?.checked_add(1)?;
        u32::try_from(d.checked_mul(stride)?).ok()?;
        let mut nodes: Vec<(u32, u32)> = Vec::new();
        // Index of every value formed so far, by its exponent vector (the constant is 0).
        let mut index: std::collections::HashMap<Vec<u32>, u32> = std::collections::HashMap::new();
        index.insert(vec![0; d], 0);
        let mut of = Vec::with_capacity(p.exps.len());
        for e in &p.exps {
            of.push(Self::value_of(e, stride, &mut nodes, &mut index)?);
        }
        let in_order = nodes.len() == of.len() && of.iter().enumerate().all(|(k, &n)| n as usize == k + 1);
        Some(PreparedPoly { p, stride, nodes, of, in_order })
    }

    /// The value index of exponent vector `e`, formed (with its missing parents) when new.
    fn value_of(
        e: &[u32],
        stride: usize,
        nodes: &mut Vec<(u32, u32)>,
        index: &mut std::collections::HashMap<Vec<u32>, u32>,
    ) -> Option<u32> {
        if let Some(&n) = index.get(e) {
            return Some(n);
        }
        // `e` is not all zero (the constant is in the index): its last non-zero exponent.
        let j = e.iter().rposition(|&k| k != 0)?;
        let mut parent = e.to_vec();
        parent[j] = 0;
        let pn = Self::value_of(&parent, stride, nodes, index)?;
        let power = u32::try_from(j * stride + e[j] as usize).ok()?;
        nodes.push((pn, power));
        let n = u32::try_from(nodes.len()).ok()?;
        index.insert(e.to_vec(), n);
        Some(n)
    }

    /// The polynomial prepared.
    pub fn poly(&self) -> &'a Poly {
        self.p
    }

    /// The powers at `eta` (unscaled) into `scratch.pow`, and `scratch.phi` sized for the
    /// values (value 0, the constant, set).
    fn powers_into(&self, eta: &[f64], scratch: &mut PolyScratch) {
        let p = self.p;
        let stride = self.stride;
        scratch.pow.clear();
        scratch.pow.resize(p.dim_in * stride, 1.0);
        for (i, (e, s)) in eta.iter().zip(&p.scale).take(p.dim_in).enumerate() {
            let z = e / s;
            let row = &mut scratch.pow[i * stride..(i + 1) * stride];
            for k in 1..stride {
                row[k] = row[k - 1] * z;
            }
        }
        scratch.phi.clear();
        scratch.phi.resize(self.nodes.len() + 1, 1.0);
    }

    /// The powers and all values at `eta` (unscaled) into `scratch` (`pow`, `phi`).
    fn values_into(&self, eta: &[f64], scratch: &mut PolyScratch) {
        self.powers_into(eta, scratch);
        let (pow, vals) = (&scratch.pow, &mut scratch.phi);
        for (n, &(parent, power)) in self.nodes.iter().enumerate() {
            vals[n + 1] = vals[parent as usize] * pow[power as usize];
        }
    }

    /// Whether value `k + 1` is monomial `k` for every `k` (no hidden values, the monomials
    /// in the order their values are formed: a full degree range in the documented order).
    /// Then one pass forms each value and adds it to the sums.
    #[doc(hidden)]
    pub fn in_order(&self) -> bool {
        self.in_order
    }

    /// [`Poly::eval_into`] (the same bits): the polynomial at `eta` (unscaled) into `out`
    /// (length `dim_out`).
    pub fn eval_into(&self, eta: &[f64], scratch: &mut PolyScratch, out: &mut [f64]) {
        let coef = &self.p.coef;
        if self.in_order() && (1..=4).contains(&self.p.dim_out) {
            self.powers_into(eta, scratch);
            let (nodes, pow, vals) = (&self.nodes, &scratch.pow, &mut scratch.phi);
            match self.p.dim_out {
                1 => write(out, fused::<1>(nodes, pow, vals, coef)),
                2 => write(out, fused::<2>(nodes, pow, vals, coef)),
                3 => write(out, fused::<3>(nodes, pow, vals, coef)),
                _ => write(out, fused::<4>(nodes, pow, vals, coef)),
            }
            return;
        }
        self.values_into(eta, scratch);
        let vals = &scratch.phi;
        match self.p.dim_out {
            1 => write(out, contract::<1>(coef, vals, &self.of)),
            2 => write(out, contract::<2>(coef, vals, &self.of)),
            3 => write(out, contract::<3>(coef, vals, &self.of)),
            4 => write(out, contract::<4>(coef, vals, &self.of)),
            q => {
                out.iter_mut().for_each(|o| *o = 0.0);
                for (row, &n) in coef.chunks_exact(q).zip(&self.of) {
                    let v = vals[n as usize];
                    for (o, c) in out.iter_mut().zip(row) {
                        *o += c * v;
                    }
                }
            }
        }
    }

    /// [`Poly::eval_one`] (the same bits): output `i` alone (`i < dim_out`, else `NaN`).
    pub fn eval_one(&self, eta: &[f64], scratch: &mut PolyScratch, i: usize) -> f64 {
        let q = self.p.dim_out;
        if i >= q {
            return f64::NAN;
        }
        let mut o = 0.0;
        if self.in_order() {
            self.powers_into(eta, scratch);
            let (pow, vals) = (&scratch.pow, &mut scratch.phi);
            for (n, (&(parent, power), row)) in self.nodes.iter().zip(self.p.coef.chunks_exact(q)).enumerate() {
                let v = vals[parent as usize] * pow[power as usize];
                vals[n + 1] = v;
                o += row[i] * v;
            }
            return o;
        }
        self.values_into(eta, scratch);
        let vals = &scratch.phi;
        for (row, &n) in self.p.coef.chunks_exact(q).zip(&self.of) {
            o += row[i] * vals[n as usize];
        }
        o
    }
}

/// One pass of an in-order plan ([`PreparedPoly::in_order`]): value `k + 1` formed and added,
/// times coefficient row `k`, to the `N` sums (from 0, in monomial order, in registers).
fn fused<const N: usize>(nodes: &[(u32, u32)], pow: &[f64], vals: &mut [f64], coef: &[f64]) -> [f64; N] {
    let mut acc = [0.0; N];
    for (n, (&(parent, power), row)) in nodes.iter().zip(coef.chunks_exact(N)).enumerate() {
        let v = vals[parent as usize] * pow[power as usize];
        vals[n + 1] = v;
        for (a, c) in acc.iter_mut().zip(row) {
            *a += c * v;
        }
    }
    acc
}

/// `out` as [`Poly::eval_into`] leaves it: the first `N` entries `acc`, any further ones 0.
fn write<const N: usize>(out: &mut [f64], acc: [f64; N]) {
    out.iter_mut().for_each(|o| *o = 0.0);
    out.iter_mut().zip(acc).for_each(|(o, a)| *o = a);
}

/// `sum_k coef[k, :] vals[of[k]]`, each of the `N` outputs summed from 0 in monomial order
/// (the plain loop's order), in registers.
fn contract<const N: usize>(coef: &[f64], vals: &[f64], of: &[u32]) -> [f64; N] {
    let mut acc = [0.0; N];
    for (row, &n) in coef.chunks_exact(N).zip(of) {
        let v = vals[n as usize];
        for (a, c) in acc.iter_mut().zip(row) {
            *a += c * v;
        }
    }
    acc
}

/// Reusable buffers for polynomial evaluation (keeps allocation out of integration loops).
#[derive(Clone, Debug, Default)]
pub struct PolyScratch {
    z: Vec<f64>,
    pow: Vec<f64>,
    phi: Vec<f64>,
    /// The largest total degree of the polynomials evaluated with this scratch so far.
    max_deg: u32,
}
