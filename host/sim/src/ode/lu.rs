//! Dense LU factorization with partial pivoting of small `N x N` matrices held on the stack.

/// `P A = L U` stored in place (unit lower `L` below the diagonal, `U` on and above).
#[derive(Clone, Copy, Debug)]
pub struct Lu<const N: usize> {
    lu: [[f64; N]; N],
    perm: [usize; N],
}

impl<const N: usize> Lu<N> {
    /// Factorizes `a`; `None` if a pivot is zero or not finite (singular or poisoned matrix).
    #[inline]
    pub fn new(mut a: [[f64; N]; N]) -> Option<Self> {
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
    pub fn solve(&self, b: &[f64; N]) -> [f64; N] {
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
