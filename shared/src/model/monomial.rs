//! The graded monomial order of the lift, and its allocation-free evaluation.
//!
//! The lift's nonlinear part uses every monomial `eta^k` of total degree `2..=order` in `d`
//! variables. Order: by degree ascending; within one degree, write the monomial as the
//! non-decreasing index tuple `(i1 <= i2 <= ... <= ik)` of its factors and sort the tuples
//! lexicographically. For `d = 2`, order 3: `eta0^2, eta0 eta1, eta1^2, eta0^3, eta0^2 eta1,
//! eta0 eta1^2, eta1^3` (equivalently: exponent vectors in descending lexicographic order).
//!
//! Degree `k` has `C(d+k-1, k)` monomials. The tuples of degree `k-1` whose indices are all
//! `>= i` are the *last* `C(d-i+k-2, k-1)` ones of that degree, so degree `k` is computed as
//! `eta_i * (that suffix)` for `i = 0..d`: one multiplication per monomial.

/// `C(n + k - 1, k)`: the number of monomials of degree exactly `k` in `n` variables.
/// `None` on overflow.
pub const fn degree_count(n: usize, k: usize) -> Option<usize> {
    // C(n+k-1, k) = prod_{j=1..k} (n-1+j)/j, exact at every step.
    if n == 0 {
        return if k == 0 { Some(1) } else { Some(0) };
    }
    let mut acc: usize = 1;
    let mut j = 1;
    while j <= k {
        let factor = match (n - 1).checked_add(j) {
            Some(f) => f,
            None => return None,
        };
        acc = match acc.checked_mul(factor) {
            Some(v) => v / j,
            None => return None,
        };
        j += 1;
    }
    Some(acc)
}

/// Number of lift monomials (degrees `2..=order`) in `d` variables; `None` on overflow.
pub const fn lift_terms(d: usize, order: usize) -> Option<usize> {
    let mut total: usize = 0;
    let mut k = 2;
    while k <= order {
        total = match degree_count(d, k) {
            Some(c) => match total.checked_add(c) {
                Some(t) => t,
                None => return None,
            },
            None => return None,
        };
        k += 1;
    }
    Some(total)
}

/// Writes the monomials of degree `2..=order` of `eta` into `out` in the graded order above
/// and returns how many were written. Returns `None` (writing nothing useful) if `out` is
/// shorter than [`lift_terms`]`(eta.len(), order)`.
pub fn eval_into(eta: &[f32], order: usize, out: &mut [f32]) -> Option<usize> {
    let d = eta.len();
    let needed = lift_terms(d, order)?;
    if out.len() < needed {
        return None;
    }
    // Start of the previous degree's block in `out` (degree 1 is `eta` itself).
    let mut prev_start = 0usize;
    let mut write = 0usize;
    for k in 2..=order {
        let prev_len = degree_count(d, k - 1)?;
        let (done, rest) = out.split_at_mut(write);
        let mut dst = rest.iter_mut();
        for (i, &e) in eta.iter().enumerate() {
            let suffix_len = degree_count(d - i, k - 1)?;
            let suffix_start = prev_len.checked_sub(suffix_len)?;
            if k == 2 {
                let src = eta.get(suffix_start..)?;
                for (&s, o) in src.iter().zip(dst.by_ref()) {
                    *o = e * s;
                }
            } else {
                let src = done.get(prev_start + suffix_start..prev_start + prev_len)?;
                for (&s, o) in src.iter().zip(dst.by_ref()) {
                    *o = e * s;
                }
            }
        }
        prev_start = write;
        write += degree_count(d, k)?;
    }
    Some(write)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts() {
        assert_eq!(degree_count(2, 2), Some(3));
        assert_eq!(degree_count(4, 3), Some(20));
        assert_eq!(degree_count(6, 5), Some(252));
        assert_eq!(lift_terms(2, 3), Some(7));
        assert_eq!(lift_terms(4, 3), Some(30));
        assert_eq!(lift_terms(3, 4), Some(31));
        assert_eq!(lift_terms(3, 1), Some(0));
        assert_eq!(lift_terms(usize::MAX, 3), None);
    }

    #[test]
    fn order_d2_k3() {
        let (a, b) = (3.0f32, 5.0f32);
        let mut out = [0.0f32; 7];
        assert_eq!(eval_into(&[a, b], 3, &mut out), Some(7));
        assert_eq!(out, [a * a, a * b, b * b, a * a * a, a * a * b, a * b * b, b * b * b]);
    }

    #[test]
    fn order_d3_k4_against_exponents() {
        // Independent: enumerate exponent vectors of each degree in descending lex order.
        let eta = [1.5f32, -0.5, 2.0];
        let mut out = [0.0f32; 40];
        let n = eval_into(&eta, 4, &mut out).unwrap();
        assert_eq!(n, lift_terms(3, 4).unwrap());
        let mut expected = Vec::new();
        for deg in 2..=4u32 {
            for e0 in (0..=deg).rev() {
                for e1 in (0..=deg - e0).rev() {
                    let e2 = deg - e0 - e1;
                    expected.push(eta[0].powi(e0 as i32) * eta[1].powi(e1 as i32) * eta[2].powi(e2 as i32));
                }
            }
        }
        assert_eq!(expected.len(), n);
        for (x, y) in out[..n].iter().zip(&expected) {
            assert!((x - y).abs() <= 1e-5 * y.abs().max(1.0), "{x} vs {y}");
        }
    }

    #[test]
    fn short_buffer_is_none() {
        let mut out = [0.0f32; 6];
        assert_eq!(eval_into(&[1.0, 2.0], 3, &mut out), None);
    }
}
