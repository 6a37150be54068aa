//! Dense LU factorization with partial pivoting of small `N x N` matrices held on the stack.

/// `P A = L U` stored in place (unit lower `L` below the diagonal, `U` on and above).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Lu<const N: usize> {
    lu: [[f64; N]; N],
    perm: [usize; N],
}

impl<const N: usize> Lu<N> {
    /// Factorizes `a`; `None` if a pivot is zero or not finite (singular or poisoned matrix).
    #[inline]
    pub(crate) fn new(mut a: [[f64; N]; N]) -> Option<Self> {
        let mut perm: [usize; N] = core::array::from_fn(|i| i);
        for k in 0..N {
            let mut p = k;
            let mut best = a[k][k].abs();
            for (i, row) in a.iter().enumerate().skip(k + 1) {
                let v = row[k].abs();
                if v > best {
                    best = v;
                    p = i;
                }
            }
            if !(best > 0.0) || !best.is_finite() {
                return None;
            }
            if p != k {
                a.swap(p, k);
                perm.swap(p, k);
            }
            let inv = 1.0 / a[k][k];
            let pivot_row = a[k];
            for row in a.iter_mut().skip(k + 1) {
                let l = row[k] * inv;
                row[k] = l;
                for j in k + 1..N {
                    row[j] -= l * pivot_row[j];
                }
            }
        }
        Some(Self { lu: a, perm })
    }

    /// Solves `A x = b`.
    #[inline]
    pub(crate) fn solve(&self, b: &[f64; N]) -> [f64; N] {
        let mut x: [f64; N] = core::array::from_fn(|i| b[self.perm[i]]);
        for i in 0..N {
            let mut s = x[i];
            for j in 0..i {
                s -= self.lu[i][j] * x[j];
            }
            x[i] = s;
        }
        for i in (0..N).rev() {
            let mut s = x[i];
            for j in i + 1..N {
                s -= self.lu[i][j] * x[j];
            }
            x[i] = s / self.lu[i][i];
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solves_against_nalgebra() {
        // A matrix that needs pivoting (zero leading entry) and is badly scaled.
        let a = [[0.0, 2.0, -1.0, 3.0], [1e4, 1.0, 0.5, -2.0], [3.0, -7.0, 1e-3, 4.0], [-1.0, 0.25, 6.0, 1.0]];
        let b = [1.0, -2.0, 3.5, 0.125];
        let x = Lu::new(a).unwrap().solve(&b);
        let m = nalgebra::Matrix4::from_fn(|i, j| a[i][j]);
        let want = m.lu().solve(&nalgebra::Vector4::from_column_slice(&b)).unwrap();
        for i in 0..4 {
            assert!((x[i] - want[i]).abs() < 1e-13 * want[i].abs().max(1.0), "{x:?} vs {want}");
        }
        // Residual.
        for i in 0..4 {
            let r: f64 = (0..4).map(|j| a[i][j] * x[j]).sum::<f64>() - b[i];
            assert!(r.abs() < 1e-11, "residual {r}");
        }
    }

    #[test]
    fn singular_and_nan_rejected() {
        assert!(Lu::new([[1.0, 2.0], [2.0, 4.0]]).is_none());
        assert!(Lu::new([[f64::NAN, 0.0], [0.0, 1.0]]).is_none());
        assert!(Lu::new([[0.0, 0.0], [0.0, 0.0]]).is_none());
    }
}
