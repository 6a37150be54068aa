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

/// Reusable buffers for polynomial evaluation (keeps allocation out of integration loops).
#[derive(Clone, Debug, Default)]
pub struct PolyScratch {
    z: Vec<f64>,
    pow: Vec<f64>,
    phi: Vec<f64>,
    /// The largest total degree of the polynomials evaluated with this scratch so far.
    max_deg: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binom(n: usize, k: usize) -> usize {
        (0..k).fold(1, |acc, i| acc * (n - i) / (i + 1))
    }

    /// One output alone ([`Poly::eval_one`]) is [`Poly::eval_into`]'s, bit for bit, with a
    /// scratch reused across polynomials of other degrees; out of range: NaN.
    #[test]
    fn one_output_is_the_same_bits() {
        let mut st = 3u64;
        let mut r = || {
            st = st.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((st >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
        };
        let mut sc = PolyScratch::default();
        for (d, max, q) in [(4usize, 7u32, 4usize), (4, 3, 21), (2, 5, 3)] {
            let exps = exponents(d, 1, max);
            let scale: Vec<f64> = (0..d).map(|_| 0.5 + r().abs()).collect();
            let coef: Vec<f64> = (0..exps.len() * q).map(|_| r()).collect();
            let p = Poly { dim_in: d, dim_out: q, scale, exps, coef };
            let mut out = vec![0.0; q];
            for _ in 0..5 {
                let eta: Vec<f64> = (0..d).map(|_| r()).collect();
                p.eval_into(&eta, &mut sc, &mut out);
                for (i, o) in out.iter().enumerate() {
                    assert_eq!(p.eval_one(&eta, &mut sc, i).to_bits(), o.to_bits(), "d {d} order {max} output {i}");
                }
            }
            assert!(p.eval_one(&vec![0.1; d], &mut sc, q).is_nan());
        }
    }

    #[test]
    fn order_and_count() {
        let e = exponents(2, 1, 3);
        let expect: Vec<Vec<u32>> = vec![
            vec![1, 0],
            vec![0, 1],
            vec![2, 0],
            vec![1, 1],
            vec![0, 2],
            vec![3, 0],
            vec![2, 1],
            vec![1, 2],
            vec![0, 3],
        ];
        assert_eq!(e, expect);
        for d in 1..=4usize {
            for k in 1..=6u32 {
                let n = exponents(d, k, k).len();
                assert_eq!(n, binom(d + k as usize - 1, k as usize), "d={d} k={k}");
                assert_eq!(count(d, 1, k), Some(exponents(d, 1, k).len()), "d={d} k={k}");
                assert_eq!(count(d, 2, k), Some(exponents(d, 2, k).len()), "d={d} k={k}");
            }
        }
        // Counted without listing, overflow reported.
        assert_eq!(count(100, 1, 3), Some(176_850));
        assert_eq!(count(usize::MAX, 1, 3), None);
    }

    #[test]
    fn eval_matches_direct_formula() {
        // f(eta) = [3 z1 - z1 z2^2, 2 z2^3] with z = eta / scale.
        let exps = exponents(2, 1, 3);
        let mut coef = vec![0.0; exps.len() * 2];
        coef[0] = 3.0; // z1 -> out 0
        coef[7 * 2] = -1.0; // z1 z2^2 -> out 0
        coef[8 * 2 + 1] = 2.0; // z2^3 -> out 1
        let p = Poly { dim_in: 2, dim_out: 2, scale: vec![2.0, 0.5], exps, coef };
        let eta = [0.7, -0.3];
        let (z1, z2) = (0.7 / 2.0, -0.3 / 0.5);
        let v = p.eval(&eta);
        assert!((v[0] - (3.0 * z1 - z1 * z2 * z2)).abs() < 1e-15);
        assert!((v[1] - 2.0 * z2 * z2 * z2).abs() < 1e-15);
        let a = p.linear_part();
        assert_eq!(a, vec![1.5, 0.0, 0.0, 0.0]);
    }
}
