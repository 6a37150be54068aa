//! Truncated multivariate Taylor series (jets, "TPS"): polynomials in `nvar` variables
//! truncated at total degree `order`, with the arithmetic of [`Scalar`] so a plant's
//! right-hand side (and an integrator written over it) runs on them unchanged.
//!
//! Monomials are indexed in graded order (by total degree, then lexicographically with the
//! first variable's exponent largest), the order [`TpsTable::exponents`] lists. Products are
//! truncated: a term of degree above `order` is never formed. A [`TpsTable`] holds the
//! indexing and the multiplication table; tables are built once per `(nvar, order)` and
//! kept for the life of the process ([`TpsTable::get`]), so a [`Tps`] is `Copy` (a
//! fixed-capacity coefficient array and a `&'static` table).

use std::collections::HashMap;
use std::sync::{Mutex, OnceLock};

use core::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

use crate::plant::Scalar;

/// Capacity of a [`Tps`]: the number of monomials of degree <= 9 in 4 variables
/// (`C(13, 4)`), enough for 3 plant states plus the input up to order 9.
pub const TPS_CAPACITY: usize = 715;

/// Largest order a table is built for.
pub const TPS_MAX_ORDER: u32 = 12;

/// Monomial indexing and the truncated multiplication table of one `(nvar, order)`.
#[derive(Debug)]
pub struct TpsTable {
    nvar: usize,
    order: u32,
    exps: Vec<Vec<u32>>,
    /// `deg_start[d]` = index of the first monomial of degree `d` (length `order + 2`).
    /// Public (read-only use) only for the crate's tests, as `flat` and `row_start`.
    #[doc(hidden)]
    pub deg_start: Vec<usize>,
    /// The multiplication table, rows concatenated: row `i` is
    /// `flat[row_start[i]..row_start[i + 1]]`, its entry `j` the index of `exps[i] + exps[j]`,
    /// for every `j` with `deg(i) + deg(j) <= order` (a prefix of the graded order).
    #[doc(hidden)]
    pub flat: Vec<u16>,
    #[doc(hidden)]
    pub row_start: Vec<u32>,
    /// The table's rows restricted to the `j` of even (`[0]`) or odd (`[1]`) degree, in the
    /// same order: `par_flat[q][par_row_start[q][i]..par_row_start[q][i + 1]]`.
    par_flat: [Vec<u16>; 2],
    par_row_start: [Vec<u32>; 2],
    /// `par_start[d]`: number of monomials of degree below `d` and of `d`'s parity (the offset
    /// of degree `d` in a row of `par_flat`; length `order + 2`).
    par_start: Vec<usize>,
}

/// Number of monomials of degree `<= order` in `nvar` variables, `C(nvar + order, nvar)`;
/// `None` on overflow.
pub fn monomial_count(nvar: usize, order: u32) -> Option<usize> {
    let mut c: u128 = 1;
    for i in 0..nvar as u128 {
        c = c.checked_mul(order as u128 + i + 1)? / (i + 1);
    }
    usize::try_from(c).ok()
}

fn push_degree(out: &mut Vec<Vec<u32>>, cur: &mut [u32], pos: usize, left: u32) {
    if pos + 1 == cur.len() {
        cur[pos] = left;
        out.push(cur.to_vec());
        cur[pos] = 0;
        return;
    }
    for k in (0..=left).rev() {
        cur[pos] = k;
        push_degree(out, cur, pos + 1, left - k);
    }
    cur[pos] = 0;
}

impl TpsTable {
    fn build(nvar: usize, order: u32) -> Self {
        let mut exps = Vec::new();
        let mut deg_start = Vec::with_capacity(order as usize + 2);
        for d in 0..=order {
            deg_start.push(exps.len());
            if nvar == 0 {
                if d == 0 {
                    exps.push(Vec::new());
                }
                continue;
            }
            let mut cur = vec![0u32; nvar];
            push_degree(&mut exps, &mut cur, 0, d);
        }
        deg_start.push(exps.len());
        let index: HashMap<&[u32], u16> = exps.iter().enumerate().map(|(i, e)| (e.as_slice(), i as u16)).collect();
        let prod = exps
            .iter()
            .map(|ei| {
                let di: u32 = ei.iter().sum();
                let end = deg_start[(order - di) as usize + 1];
                exps[..end]
                    .iter()
                    .map(|ej| {
                        let s: Vec<u32> = ei.iter().zip(ej).map(|(a, b)| a + b).collect();
                        index[s.as_slice()]
                    })
                    .collect()
            })
            .collect::<Vec<Vec<u16>>>();
        let mut flat = Vec::new();
        let mut row_start = Vec::with_capacity(prod.len() + 1);
        for row in &prod {
            row_start.push(flat.len() as u32);
            flat.extend_from_slice(row);
        }
        row_start.push(flat.len() as u32);
        let deg_of = |j: usize| deg_start.partition_point(|&s| s <= j) - 1;
        let par_start: Vec<usize> = (0..deg_start.len())
            .map(|d| (0..d).filter(|e| (d - e) % 2 == 0).map(|e| deg_start[e + 1] - deg_start[e]).sum())
            .collect();
        let mut par_flat: [Vec<u16>; 2] = [Vec::new(), Vec::new()];
        let mut par_row_start: [Vec<u32>; 2] = [Vec::with_capacity(prod.len() + 1), Vec::with_capacity(prod.len() + 1)];
        for row in &prod {
            for q in 0..2 {
                par_row_start[q].push(par_flat[q].len() as u32);
                par_flat[q].extend(row.iter().enumerate().filter(|&(j, _)| deg_of(j) % 2 == q).map(|(_, &k)| k));
            }
        }
        for q in 0..2 {
            par_row_start[q].push(par_flat[q].len() as u32);
        }
        Self { nvar, order, exps, deg_start, flat, row_start, par_flat, par_row_start, par_start }
    }

    /// The shared table of `(nvar, order)`, built on first use. `None` if it would not fit a
    /// [`Tps`] (more than [`TPS_CAPACITY`] monomials) or `order > TPS_MAX_ORDER`.
    pub fn get(nvar: usize, order: u32) -> Option<&'static TpsTable> {
        if order > TPS_MAX_ORDER || monomial_count(nvar, order)? > TPS_CAPACITY {
            return None;
        }
        static TABLES: OnceLock<Mutex<Vec<&'static TpsTable>>> = OnceLock::new();
        let tables = TABLES.get_or_init(|| Mutex::new(Vec::new()));
        let mut guard = match tables.lock() {
            Ok(g) => g,
            Err(poisoned) => poisoned.into_inner(),
        };
        if let Some(t) = guard.iter().find(|t| t.nvar == nvar && t.order == order) {
            return Some(t);
        }
        // At most one table per (nvar, order) with at most TPS_CAPACITY monomials is ever
        // built: a bounded amount of memory kept for the process's lifetime.
        let t: &'static TpsTable = Box::leak(Box::new(Self::build(nvar, order)));
        guard.push(t);
        Some(t)
    }

    pub fn nvar(&self) -> usize {
        self.nvar
    }

    pub fn order(&self) -> u32 {
        self.order
    }

    /// Number of monomials.
    pub fn len(&self) -> usize {
        self.exps.len()
    }

    /// Always false (the constant monomial is always there).
    pub fn is_empty(&self) -> bool {
        self.exps.is_empty()
    }

    /// Exponent vectors in index order.
    pub fn exponents(&self) -> &[Vec<u32>] {
        &self.exps
    }

    /// Index range of the monomials of degree `d`.
    pub fn degree_range(&self, d: u32) -> core::ops::Range<usize> {
        let d = d.min(self.order + 1) as usize;
        self.deg_start[d]..self.deg_start.get(d + 1).copied().unwrap_or(self.exps.len())
    }

    /// Index of an exponent vector, if it is a monomial of this table.
    pub fn index(&self, e: &[u32]) -> Option<usize> {
        if e.len() != self.nvar {
            return None;
        }
        let d: u32 = e.iter().sum();
        if d > self.order {
            return None;
        }
        self.degree_range(d).find(|&i| self.exps[i] == e)
    }
}

/// A truncated multivariate Taylor series. A series without a table is a constant (what
/// [`Scalar::cst`] makes); it takes its partner's table in binary operations.
#[derive(Clone, Copy)]
pub struct Tps {
    // Public only for the crate's tests (the former product and reciprocal as references).
    #[doc(hidden)]
    pub c: [f64; TPS_CAPACITY],
    #[doc(hidden)]
    pub t: Option<&'static TpsTable>,
}

impl core::fmt::Debug for Tps {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Tps").field("coefficients", &self.coefficients()).finish()
    }
}

impl Tps {
    /// The constant `v` over `table`.
    pub fn constant(table: &'static TpsTable, v: f64) -> Self {
        let mut c = [0.0; TPS_CAPACITY];
        c[0] = v;
        Self { c, t: Some(table) }
    }

    /// Variable `k` (0-based) with value `v` at the expansion point.
    pub fn var(table: &'static TpsTable, k: usize, v: f64) -> Self {
        let mut s = Self::constant(table, v);
        let mut e = vec![0u32; table.nvar];
        if let Some(slot) = e.get_mut(k) {
            *slot = 1;
            if let Some(i) = table.index(&e) {
                s.c[i] = 1.0;
            }
        }
        s
    }

    /// From coefficients in table order (missing ones are zero, extra ones ignored).
    pub fn from_coefficients(table: &'static TpsTable, coef: &[f64]) -> Self {
        let mut c = [0.0; TPS_CAPACITY];
        let n = coef.len().min(table.len());
        c[..n].copy_from_slice(&coef[..n]);
        Self { c, t: Some(table) }
    }

    /// The table (`None` for a bare constant).
    pub fn table(&self) -> Option<&'static TpsTable> {
        self.t
    }

    /// Coefficients in table order (one entry for a bare constant).
    pub fn coefficients(&self) -> &[f64] {
        &self.c[..self.len()]
    }

    fn len(&self) -> usize {
        self.t.map_or(1, |t| t.len())
    }

    /// Largest absolute coefficient of degree `d`.
    pub fn degree_norm(&self, d: u32) -> f64 {
        match self.t {
            Some(t) => self.c[t.degree_range(d)].iter().fold(0.0, |m, v| m.max(v.abs())),
            None => {
                if d == 0 {
                    self.c[0].abs()
                } else {
                    0.0
                }
            }
        }
    }

    fn pick(a: Option<&'static TpsTable>, b: Option<&'static TpsTable>) -> Option<&'static TpsTable> {
        debug_assert!(
            match (a, b) {
                (Some(x), Some(y)) => core::ptr::eq(x, y),
                _ => true,
            },
            "Tps operands over different tables"
        );
        a.or(b)
    }

    /// The part without the constant term.
    pub fn nilpotent(mut self) -> Self {
        self.c[0] = 0.0;
        self
    }

    /// `1 / self` by the geometric series of the nilpotent part (exact to the order).
    pub fn recip(self) -> Self {
        let b0 = self.c[0];
        let Some(t) = self.t else {
            return Self { c: Self::scalar_array(1.0 / b0), t: None };
        };
        // 1/b = (1/b0) sum_n x^n, x = -(b - b0)/b0, Horner: s = 1 + x s.
        let x = self.nilpotent().scaled(-1.0 / b0);
        let mut s = Self::constant(t, 1.0);
        let xmask = nonzero_degrees(t, &x.c);
        if xmask & 1 == 1 {
            // A constant term (`b0` zero or not finite): the plain Horner loop.
            for _ in 0..t.order {
                s = x.mul_ref(&s);
                s.c[0] += 1.0;
            }
        } else if xmask != 0 {
            // With `m >= 1` the lowest nonzero degree of `x`, the Horner iterates `s_n` and
            // `s_(n-1)` are the same bits below degree `m n` (degree `d` of `x s` reads the
            // degrees `<= d - m` of `s` only, in the same terms and order), so iteration `n`
            // forms the degrees `>= m n` only and the iterations past `m n > order` change
            // nothing: the loop above bit for bit, at about a third of its products
            // (`m = 2`, order 9: degrees >= 2, 4, 6, 8 of four products instead of nine full).
            // `x == 0` leaves `s = 1`, as the loop does.
            let m = xmask.trailing_zeros();
            let n = t.len();
            for k in 1..=t.order {
                let dmin = m * k;
                if dmin > t.order {
                    break;
                }
                let lo = t.deg_start[dmin as usize];
                let p = mul_flat_from(t, &x.c, &s.c, dmin as usize);
                s.c[lo..n].copy_from_slice(&p[lo..n]);
            }
        }
        s *= 1.0 / b0;
        s
    }

    /// `self * o` without copying either operand (a `Tps` is 5.7 kB): [`Mul`]'s product,
    /// bit for bit (the same `mul_flat`, `self` the row operand).
    pub fn mul_ref(&self, o: &Tps) -> Tps {
        match (self.t, o.t) {
            (None, _) => o.scaled(self.c[0]),
            (_, None) => self.scaled(o.c[0]),
            (Some(t), Some(_)) => {
                let _ = Self::pick(self.t, o.t);
                Self { c: mul_flat(t, &self.c, &o.c), t: Some(t) }
            }
        }
    }

    /// `self * f` by reference (`Mul<f64>`'s values).
    pub fn scaled(&self, f: f64) -> Tps {
        let n = self.len();
        let mut c = [0.0; TPS_CAPACITY];
        for (o, a) in c[..n].iter_mut().zip(&self.c[..n]) {
            *o = a * f;
        }
        Tps { c, t: self.t }
    }

    /// `self + o` by reference (`Add`'s values; coefficients past a series' length are zero).
    pub fn add_ref(&self, o: &Tps) -> Tps {
        let mut r = *self;
        r += o;
        r
    }

    /// `self - o` by reference (`Sub`'s values).
    pub fn sub_ref(&self, o: &Tps) -> Tps {
        let mut r = *self;
        r -= o;
        r
    }

    /// `self = x + k * f` coefficient by coefficient (`x + k * f`'s values: the product
    /// rounded, then the sum), in place.
    pub fn assign_axpy(&mut self, x: &Tps, k: &Tps, f: f64) {
        let t = Self::pick(x.t, k.t);
        let n = x.len().max(k.len());
        let old = self.len();
        for ((o, a), b) in self.c[..n].iter_mut().zip(&x.c[..n]).zip(&k.c[..n]) {
            *o = a + b * f;
        }
        if old > n {
            self.c[n..old].fill(0.0);
        }
        self.t = t;
    }

    /// `self = self + (k1 + (k2 + k3) * 2 + k4) * f` coefficient by coefficient, in place:
    /// the classical RK4 update, with the by-value expression's roundings.
    pub fn rk4_update(&mut self, k: [&Tps; 4], f: f64) {
        let t = k.iter().fold(self.t, |m, q| Self::pick(m, q.t));
        let n = k.iter().fold(self.len(), |m, q| m.max(q.len()));
        let [k1, k2, k3, k4] = k;
        for (j, x) in self.c[..n].iter_mut().enumerate() {
            *x += (k1.c[j] + (k2.c[j] + k3.c[j]) * 2.0 + k4.c[j]) * f;
        }
        self.t = t;
    }

    fn scalar_array(v: f64) -> [f64; TPS_CAPACITY] {
        let mut c = [0.0; TPS_CAPACITY];
        c[0] = v;
        c
    }
}

impl Add for Tps {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        let t = Self::pick(self.t, o.t);
        let n = self.len().max(o.len());
        let mut c = self.c;
        for (a, b) in c[..n].iter_mut().zip(&o.c[..n]) {
            *a += b;
        }
        Self { c, t }
    }
}

impl Sub for Tps {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        let t = Self::pick(self.t, o.t);
        let n = self.len().max(o.len());
        let mut c = self.c;
        for (a, b) in c[..n].iter_mut().zip(&o.c[..n]) {
            *a -= b;
        }
        Self { c, t }
    }
}

impl AddAssign<&Tps> for Tps {
    /// `self + o` in place (`Add`'s values).
    fn add_assign(&mut self, o: &Tps) {
        self.t = Self::pick(self.t, o.t);
        let n = self.len().max(o.len());
        for (a, b) in self.c[..n].iter_mut().zip(&o.c[..n]) {
            *a += b;
        }
    }
}

impl SubAssign<&Tps> for Tps {
    /// `self - o` in place (`Sub`'s values).
    fn sub_assign(&mut self, o: &Tps) {
        self.t = Self::pick(self.t, o.t);
        let n = self.len().max(o.len());
        for (a, b) in self.c[..n].iter_mut().zip(&o.c[..n]) {
            *a -= b;
        }
    }
}

impl MulAssign<f64> for Tps {
    /// `self * o` in place (`Mul<f64>`'s values).
    fn mul_assign(&mut self, o: f64) {
        let n = self.len();
        for a in &mut self.c[..n] {
            *a *= o;
        }
    }
}

impl Mul for Tps {
    type Output = Self;
    fn mul(self, o: Self) -> Self {
        match (self.t, o.t) {
            (None, _) => o * self.c[0],
            (_, None) => self * o.c[0],
            (Some(t), Some(_)) => {
                let _ = Self::pick(self.t, o.t);
                Self { c: mul_flat(t, &self.c, &o.c), t: Some(t) }
            }
        }
    }
}

/// The truncated product's coefficients, row by row of the table (`i` ascending, rows with
/// `a[i] == 0` skipped, `j` ascending in a row: the same sums in the same order as ever). The
/// rows are one flat array and the sums go to a power-of-two scratch indexed through a mask,
/// so the inner loop has no bounds check: less CPU per product than indexing the result
/// (`TPS_BENCH` in the tests compares them).
///
/// Whole degrees of `a` or `b` that are zero are skipped: a term `a[i] b[j]` that is exactly
/// zero never changes a sum (the scratch starts at `+0.0`, and in round-to-nearest a sum is
/// `-0.0` only when both terms are, so it never holds `-0.0`: `+0.0 + (+-0.0) = +0.0` and
/// `x + (+-0.0) = x`), so the result is bit-identical to the full loop for finite operands.
/// The jets of a plant odd about its equilibrium (the Furuta pendulum upright) have only
/// odd or only even degrees: about half the terms.
#[inline]
#[doc(hidden)]
pub fn mul_flat(t: &TpsTable, a: &[f64; TPS_CAPACITY], b: &[f64; TPS_CAPACITY]) -> [f64; TPS_CAPACITY] {
    mul_flat_from(t, a, b, 0)
}

/// Bit `d` set: degree `d` of `c` has a nonzero (or NaN) coefficient (the bits without the
/// sign are nonzero; an OR over the block, which vectorizes, not an early exit).
fn nonzero_degrees(t: &TpsTable, c: &[f64; TPS_CAPACITY]) -> u32 {
    let ds = &t.deg_start;
    let mut mask = 0;
    for d in 0..=t.order as usize {
        // The OR of the bits, then the sign shifted out (the same as ORing the shifted bits).
        let bits = c[ds[d]..ds[d + 1]].iter().fold(0u64, |m, v| m | v.to_bits());
        mask |= u32::from(bits << 1 != 0) << d;
    }
    mask
}

/// [`mul_flat`]'s coefficients of degree `>= dmin` (the same sums in the same order; the
/// lower ones are `+0.0`): its loop without the terms of lower degrees.
///
/// When the nonzero degrees of `b` are one run `lo..=hi` (a dense series, or one from
/// degree `lo` on) or every other degree of one (an odd or an even jet), the degrees of `b`
/// a row reads are one contiguous slice of it (of its even or odd degrees packed, for the
/// jets): one inner loop per row, not one per degree of `b` (less CPU than the loop per
/// degree on order-9 odd and dense products). The same terms (`a[i]` nonzero, degrees of
/// `b` nonzero) in the same order, so the same bits for every input. Other masks take the
/// loop per degree.
#[inline]
fn mul_flat_from(t: &TpsTable, a: &[f64; TPS_CAPACITY], b: &[f64; TPS_CAPACITY], dmin: usize) -> [f64; TPS_CAPACITY] {
    let mut acc = [0.0; SCRATCH];
    let (amask, bmask) = (nonzero_degrees(t, a), nonzero_degrees(t, b));
    if bmask != 0 {
        let (lo, hi) = (bmask.trailing_zeros() as usize, 31 - bmask.leading_zeros() as usize);
        let run = (u32::MAX >> (31 - hi)) & (u32::MAX << lo);
        let every_other = run & if lo % 2 == 0 { 0x5555_5555 } else { 0xaaaa_aaaa };
        if bmask == run {
            mul_rows(t, a, amask, b, &t.flat, &t.row_start, &t.deg_start, 1, lo, hi, dmin, &mut acc);
        } else if bmask == every_other {
            let q = lo % 2;
            let (ds, ps) = (&t.deg_start, &t.par_start);
            let mut packed = [0.0; TPS_CAPACITY];
            for d in (lo..=hi).step_by(2) {
                packed[ps[d]..ps[d] + ds[d + 1] - ds[d]].copy_from_slice(&b[ds[d]..ds[d + 1]]);
            }
            mul_rows(t, a, amask, &packed, &t.par_flat[q], &t.par_row_start[q], ps, 2, lo, hi, dmin, &mut acc);
        } else {
            mul_blocks(t, a, amask, b, bmask, dmin, &mut acc);
        }
    }
    let mut c = [0.0; TPS_CAPACITY];
    c.copy_from_slice(&acc[..TPS_CAPACITY]);
    c
}

/// The product's terms by rows of `a` (degrees in `amask`, `a[i] == 0` skipped) against the
/// degrees `lo, lo + step, ..= hi` of `b`, above `dmin` in total, as one slice per row:
/// `flat`/`row_start` the rows over those degrees, `b` and the rows indexed through `start`
/// (`start[d]`: where degree `d` begins in them).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn mul_rows(
    t: &TpsTable,
    a: &[f64; TPS_CAPACITY],
    amask: u32,
    b: &[f64; TPS_CAPACITY],
    flat: &[u16],
    row_start: &[u32],
    start: &[usize],
    step: usize,
    lo: usize,
    hi: usize,
    dmin: usize,
    acc: &mut [f64; SCRATCH],
) {
    let order = t.order as usize;
    let ds = &t.deg_start;
    for da in (0..=order.saturating_sub(lo)).filter(|&d| amask >> d & 1 == 1) {
        // Degrees of `b` this block reads: from the first of the run at or above
        // `dmin - da` to the last at or below `min(hi, order - da)`.
        let first = lo.max(dmin.saturating_sub(da));
        let first = first + (first - lo) % step;
        let top = hi.min(order - da);
        let top = top - (top - lo) % step;
        if first > top {
            continue;
        }
        let (s, e) = (start[first], start[top] + ds[top + 1] - ds[top]);
        let bs = &b[s..e];
        for i in ds[da]..ds[da + 1] {
            let ai = a[i];
            if ai == 0.0 {
                continue;
            }
            let r = row_start[i] as usize;
            for (x, &k) in bs.iter().zip(&flat[r + s..r + e]) {
                acc[usize::from(k) & (SCRATCH - 1)] += ai * x;
            }
        }
    }
}

/// The product's terms by rows of `a` (degrees in `amask`, `a[i] == 0` skipped) and, in a
/// row, by degrees of `b` (those in `bmask`, at or above `dmin` in total).
fn mul_blocks(
    t: &TpsTable,
    a: &[f64; TPS_CAPACITY],
    amask: u32,
    b: &[f64; TPS_CAPACITY],
    bmask: u32,
    dmin: usize,
    acc: &mut [f64; SCRATCH],
) {
    let order = t.order as usize;
    let ds = &t.deg_start;
    for da in (0..=order).filter(|&d| amask >> d & 1 == 1) {
        for i in ds[da]..ds[da + 1] {
            let ai = a[i];
            if ai == 0.0 {
                continue;
            }
            let row = &t.flat[t.row_start[i] as usize..t.row_start[i + 1] as usize];
            // The row holds every `j` of degree <= order - da, in graded order.
            for db in (dmin.saturating_sub(da)..=order - da).filter(|&d| bmask >> d & 1 == 1) {
                let (lo, hi) = (ds[db], ds[db + 1]);
                for (s, &k) in b[lo..hi].iter().zip(&row[lo..hi]) {
                    acc[usize::from(k) & (SCRATCH - 1)] += ai * s;
                }
            }
        }
    }
}

/// [`mul_flat`]'s scratch: a power of two, at least [`TPS_CAPACITY`] (every index of a
/// table is below its length, so the mask never changes one).
#[doc(hidden)]
pub const SCRATCH: usize = 1024;
const _: () = assert!(SCRATCH.is_power_of_two() && SCRATCH >= TPS_CAPACITY);

impl Div for Tps {
    type Output = Self;
    fn div(self, o: Self) -> Self {
        match o.t {
            None => self / o.c[0],
            Some(_) => self * o.recip(),
        }
    }
}

impl Neg for Tps {
    type Output = Self;
    fn neg(self) -> Self {
        self * -1.0
    }
}

impl Add<f64> for Tps {
    type Output = Self;
    fn add(mut self, o: f64) -> Self {
        self.c[0] += o;
        self
    }
}

impl Sub<f64> for Tps {
    type Output = Self;
    fn sub(mut self, o: f64) -> Self {
        self.c[0] -= o;
        self
    }
}

impl Mul<f64> for Tps {
    type Output = Self;
    fn mul(mut self, o: f64) -> Self {
        let n = self.len();
        for a in &mut self.c[..n] {
            *a *= o;
        }
        self
    }
}

impl Div<f64> for Tps {
    type Output = Self;
    fn div(mut self, o: f64) -> Self {
        let n = self.len();
        for a in &mut self.c[..n] {
            *a /= o;
        }
        self
    }
}

impl Scalar for Tps {
    fn cst(v: f64) -> Self {
        Self { c: Self::scalar_array(v), t: None }
    }

    fn re(self) -> f64 {
        self.c[0]
    }

    fn mul_ref(&self, o: &Self) -> Self {
        Tps::mul_ref(self, o)
    }

    fn add_ref(&self, o: &Self) -> Self {
        Tps::add_ref(self, o)
    }

    fn sub_ref(&self, o: &Self) -> Self {
        Tps::sub_ref(self, o)
    }

    fn scaled(&self, f: f64) -> Self {
        Tps::scaled(self, f)
    }

    /// `g(x0 + y) = sum_k g_k y^k` over the nilpotent part `y` (which vanishes beyond the
    /// order), summed by Horner from the highest degree.
    fn apply<F: Fn(f64, &mut [f64])>(self, coef: F) -> Self {
        let mut g = [0.0; TPS_MAX_ORDER as usize + 1];
        let Some(t) = self.t else {
            coef(self.c[0], &mut g[..1]);
            return Self::cst(g[0]);
        };
        let k = (t.order as usize).min(TPS_MAX_ORDER as usize);
        coef(self.c[0], &mut g[..=k]);
        let y = self.nilpotent();
        let mut s = Self::constant(t, g[k]);
        for &gk in g[..k].iter().rev() {
            s = s.mul_ref(&y) + gk;
        }
        s
    }

    /// `sin(x0 + y) = sin x0 cos y + cos x0 sin y` (likewise cos), with the series of the
    /// nilpotent part `y` summed to the order.
    fn sin_cos(self) -> (Self, Self) {
        let (s0, c0) = self.c[0].sin_cos();
        let Some(t) = self.t else {
            return (Self::cst(s0), Self::cst(c0));
        };
        let y = self.nilpotent();
        let mut sin_y = Self::constant(t, 0.0);
        let mut cos_y = Self::constant(t, 1.0);
        let mut p = Self::constant(t, 1.0);
        let mut fact = 1.0;
        for n in 1..=t.order {
            p = p.mul_ref(&y);
            fact *= n as f64;
            // `sin_y += p * (1 / fact)` etc. in place: the product rounded, then the sum.
            let f = 1.0 / fact;
            let len = t.len();
            let (sum, add) = match n % 4 {
                1 => (&mut sin_y, true),
                2 => (&mut cos_y, false),
                3 => (&mut sin_y, false),
                _ => (&mut cos_y, true),
            };
            for (o, v) in sum.c[..len].iter_mut().zip(&p.c[..len]) {
                if add {
                    *o += v * f;
                } else {
                    *o -= v * f;
                }
            }
        }
        // (sin_y c0 + cos_y s0, cos_y c0 - sin_y s0), each product rounded, then the sum.
        let n = t.len();
        let mut sin = Self::constant(t, 0.0);
        let mut cos = Self::constant(t, 0.0);
        for (((so, co), a), b) in sin.c[..n].iter_mut().zip(&mut cos.c[..n]).zip(&sin_y.c[..n]).zip(&cos_y.c[..n]) {
            *so = a * c0 + b * s0;
            *co = b * c0 - a * s0;
        }
        (sin, cos)
    }
}
