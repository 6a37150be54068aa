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
    deg_start: Vec<usize>,
    /// The multiplication table, rows concatenated: row `i` is
    /// `flat[row_start[i]..row_start[i + 1]]`, its entry `j` the index of `exps[i] + exps[j]`,
    /// for every `j` with `deg(i) + deg(j) <= order` (a prefix of the graded order).
    flat: Vec<u16>,
    row_start: Vec<u32>,
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
    c: [f64; TPS_CAPACITY],
    t: Option<&'static TpsTable>,
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
    fn nilpotent(mut self) -> Self {
        self.c[0] = 0.0;
        self
    }

    /// `1 / self` by the geometric series of the nilpotent part (exact to the order).
    fn recip(self) -> Self {
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
fn mul_flat(t: &TpsTable, a: &[f64; TPS_CAPACITY], b: &[f64; TPS_CAPACITY]) -> [f64; TPS_CAPACITY] {
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
const SCRATCH: usize = 1024;
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

#[cfg(test)]
mod tests {
    use super::*;

    fn eval(t: &TpsTable, c: &[f64], x: &[f64]) -> f64 {
        t.exponents()
            .iter()
            .zip(c)
            .map(|(e, c)| c * e.iter().zip(x).map(|(&k, v)| v.powi(k as i32)).product::<f64>())
            .sum()
    }

    #[test]
    fn table_counts_and_graded_order() {
        let t = TpsTable::get(4, 9).unwrap();
        assert_eq!(t.len(), 715);
        assert_eq!(monomial_count(4, 7), Some(330));
        assert_eq!(t.degree_range(0), 0..1);
        assert_eq!(t.degree_range(1), 1..5);
        assert_eq!(t.exponents()[1], vec![1, 0, 0, 0]);
        assert!(TpsTable::get(5, 8).is_none(), "C(13,5) = 1287 > capacity");
        assert!(core::ptr::eq(t, TpsTable::get(4, 9).unwrap()));
        for (i, e) in t.exponents().iter().enumerate() {
            assert_eq!(t.index(e), Some(i));
        }
    }

    /// Products, quotients and sin/cos of jets against the Taylor coefficients of the same
    /// functions computed independently: the jet of `f` at 0 evaluated at a small point
    /// equals `f` there up to the truncation order (error ~ |x|^(order+1)).
    #[test]
    fn jet_arithmetic_matches_functions() {
        let t = TpsTable::get(3, 9).unwrap();
        let x = [Tps::var(t, 0, 0.3), Tps::var(t, 1, -0.2), Tps::var(t, 2, 1.1)];
        let f = |x: [Tps; 3]| {
            let (s, c) = (x[0] * x[1]).sin_cos();
            s * x[2] / (c + x[0] * x[0] + 1.0) - x[1] * 2.0
        };
        let ff = |x: [f64; 3]| {
            let (s, c) = (x[0] * x[1]).sin_cos();
            s * x[2] / (c + x[0] * x[0] + 1.0) - x[1] * 2.0
        };
        let j = f(x);
        let x0 = [0.3, -0.2, 1.1];
        assert!((j.re() - ff(x0)).abs() < 1e-15);
        let mut prev = f64::INFINITY;
        for h in [1e-1, 5e-2, 2.5e-2] {
            let d = [h, -0.7 * h, 0.4 * h];
            let exact = ff([x0[0] + d[0], x0[1] + d[1], x0[2] + d[2]]);
            let err = (eval(t, j.coefficients(), &d) - exact).abs();
            // Degree-10 remainder: halving h divides it by ~2^10.
            assert!(err < 1e-9 && err < prev / 500.0 || err < 1e-14, "h={h}: {err} (prev {prev})");
            prev = err;
        }
    }

    /// The flat-table product is bit-identical to the former product (a loop over one `Vec`
    /// per row indexing the result directly: the same terms in the same order per
    /// coefficient), on dense, sparse, nilpotent, odd and even operands (the last two with
    /// whole zero degrees, which the product skips; `-0.0` entries too) at orders 1..9;
    /// `TPS_BENCH=flat` / `TPS_BENCH=plain` run one of them many times (time with `/usr/bin/time`).
    #[test]
    fn flat_product_is_bit_identical_to_the_row_loop() {
        let mut seed = 0x9e3779b97f4a7c15u64;
        let mut rnd = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for order in [1, 5, 7, 9] {
            let t = TpsTable::get(4, order).unwrap();
            let n = t.len();
            let mut ops = Vec::new();
            for kind in 0..7 {
                let mut c = [0.0; TPS_CAPACITY];
                for (i, v) in c[..n].iter_mut().enumerate() {
                    let deg: u32 = t.exponents()[i].iter().sum();
                    *v = match kind {
                        0 => rnd() * 10f64.powi((i % 7) as i32 - 3),
                        1 if deg == 0 => 0.0,
                        2 if i % 3 == 0 => 0.0,
                        3 if deg < 2 => 0.0,
                        // Odd and even jets (skipped degree blocks), one with -0.0 entries.
                        4 if deg % 2 == 0 => 0.0,
                        5 if deg % 2 == 1 => -0.0,
                        6 if deg % 2 == 1 || deg == 0 => 0.0,
                        _ => rnd(),
                    };
                }
                ops.push(c);
            }
            // The table as one Vec per row, from the exponents (the product's former form).
            let rows: Vec<Vec<u16>> = t
                .exponents()
                .iter()
                .map(|ei| {
                    t.exponents()
                        .iter()
                        .map_while(|ej| {
                            t.index(&ei.iter().zip(ej).map(|(x, y)| x + y).collect::<Vec<u32>>()).map(|k| k as u16)
                        })
                        .collect()
                })
                .collect();
            let mul_plain = |a: &[f64; TPS_CAPACITY], b: &[f64; TPS_CAPACITY]| {
                let mut c = [0.0; TPS_CAPACITY];
                for (i, row) in rows.iter().enumerate() {
                    let ai = a[i];
                    if ai == 0.0 {
                        continue;
                    }
                    for (s, &k) in b[..row.len()].iter().zip(row) {
                        c[k as usize] += ai * s;
                    }
                }
                c
            };
            for a in &ops {
                for b in &ops {
                    let got = mul_flat(t, a, b);
                    let want = mul_plain(a, b);
                    assert!(got.iter().zip(&want).all(|(x, y)| x.to_bits() == y.to_bits()), "order {order}");
                }
            }
            // `TPS_BENCH=plain` or `flat`: 200,000 / order products of one kind, to compare
            // the two runs' user CPU time.
            if let Ok(kind) = std::env::var("TPS_BENCH") {
                let reps = 200_000 / order as usize;
                let mut acc = 0.0;
                for r in 0..reps {
                    acc += if kind == "flat" {
                        mul_flat(t, &ops[r % 4], &ops[0])
                    } else {
                        mul_plain(&ops[r % 4], &ops[0])
                    }[n - 1];
                }
                eprintln!("order {order}: {reps} {kind} products ({acc:.1e})");
            }
        }
    }

    /// `mul_flat` as of e794cbf (one inner loop per nonzero degree of `b`), kept as the
    /// reference of the one-slice-per-row paths.
    fn mul_flat_e794cbf(t: &TpsTable, a: &[f64; TPS_CAPACITY], b: &[f64; TPS_CAPACITY]) -> [f64; TPS_CAPACITY] {
        let mut acc = [0.0; SCRATCH];
        let order = t.order as usize;
        let ds = &t.deg_start;
        let nonzero_degrees = |c: &[f64; TPS_CAPACITY]| -> u32 {
            (0..=order)
                .filter(|&d| c[ds[d]..ds[d + 1]].iter().fold(0u64, |m, v| m | v.to_bits() << 1) != 0)
                .fold(0u32, |m, d| m | 1 << d)
        };
        let (amask, bmask) = (nonzero_degrees(a), nonzero_degrees(b));
        for da in (0..=order).filter(|&d| amask >> d & 1 == 1) {
            for i in ds[da]..ds[da + 1] {
                let ai = a[i];
                if ai == 0.0 {
                    continue;
                }
                let row = &t.flat[t.row_start[i] as usize..t.row_start[i + 1] as usize];
                for db in (0..=order - da).filter(|&d| bmask >> d & 1 == 1) {
                    let (lo, hi) = (ds[db], ds[db + 1]);
                    for (s, &k) in b[lo..hi].iter().zip(&row[lo..hi]) {
                        acc[usize::from(k) & (SCRATCH - 1)] += ai * s;
                    }
                }
            }
        }
        let mut c = [0.0; TPS_CAPACITY];
        c.copy_from_slice(&acc[..TPS_CAPACITY]);
        c
    }

    /// `recip` as of e794cbf (nine full Horner products at order 9).
    fn recip_e794cbf(b: &Tps) -> Tps {
        let (b0, t) = (b.c[0], b.t.unwrap());
        let x = b.nilpotent().scaled(-1.0 / b0);
        let mut s = Tps::constant(t, 1.0);
        for _ in 0..t.order {
            s = Tps { c: mul_flat_e794cbf(t, &x.c, &s.c), t: Some(t) };
            s.c[0] += 1.0;
        }
        s *= 1.0 / b0;
        s
    }

    /// Operands of every shape the product's paths tell apart, at every table the tests and
    /// the study use (and more: 1..=5 variables, orders 0..=12 where a table fits): dense,
    /// odd and even jets, jets from a degree on (powers of a nilpotent series, odd or even
    /// from there), random zero degrees (masks neither a run nor every other degree), single
    /// zeros, `-0.0` entries, and NaN, +inf, -inf entries in otherwise zero or nonzero degrees
    /// (where skipping a zero term and forming it differ).
    fn product_operands(t: &TpsTable, rnd: &mut dyn FnMut() -> f64) -> Vec<[f64; TPS_CAPACITY]> {
        let n = t.len();
        let order = t.order();
        let deg = |i: usize| -> u32 { t.exponents()[i].iter().sum() };
        let mut ops = Vec::new();
        for kind in 0..16u32 {
            let holes = (rnd() * 4096.0) as u32 | 1 << (rnd() * 13.0) as u32;
            let from = ((rnd() + 0.5) * (order as f64 + 1.0)) as u32;
            let mut c = [0.0; TPS_CAPACITY];
            for (i, v) in c[..n].iter_mut().enumerate() {
                let d = deg(i);
                let x = rnd() * 10f64.powi((i % 5) as i32 - 2);
                *v = match kind {
                    0 => x,
                    1 if d % 2 == 0 => 0.0,
                    2 if d % 2 == 1 => -0.0,
                    3 if d < from => 0.0,
                    4 if d < from || (d - from) % 2 == 1 => 0.0,
                    5 if d == 0 || d % 2 == 1 => 0.0,
                    6 if holes >> d & 1 == 0 => 0.0,
                    7 if i % 3 == 0 => 0.0,
                    8 if i % 4 == 1 => -0.0,
                    _ => x,
                };
            }
            // Non-finite entries: in a zero degree of an odd jet, in a nonzero one, in a
            // dense series, at the constant term.
            let put = |c: &mut [f64; TPS_CAPACITY], v: f64, i: usize| {
                if i < n {
                    c[i] = v;
                }
            };
            match kind {
                9 => {
                    c = ops[1];
                    put(&mut c, f64::NAN, t.degree_range(2).start);
                }
                10 => {
                    c = ops[1];
                    put(&mut c, f64::INFINITY, t.degree_range(3).start + 1);
                }
                11 => put(&mut c, f64::NEG_INFINITY, n / 2),
                12 => put(&mut c, f64::NAN, 0),
                13 => {
                    c = ops[2];
                    put(&mut c, f64::INFINITY, n - 1);
                }
                14 => {
                    c = [0.0; TPS_CAPACITY];
                    put(&mut c, -0.0, n - 1);
                }
                15 => c = [0.0; TPS_CAPACITY],
                _ => {}
            }
            ops.push(c);
        }
        ops
    }

    /// The same bits, a NaN matching any NaN: Rust leaves a NaN's sign and payload to the
    /// compiler (an `addsd` of two NaNs returns its first operand's, and which one is first is
    /// codegen's choice: e794cbf's own NaN signs change with inlining), so only where the NaNs
    /// are is the result's. (The study never has one: `flow_expansion` rejects non-finite
    /// coefficients.)
    fn same_bits(x: &[f64], y: &[f64]) -> bool {
        x.len() == y.len() && x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits() || p.is_nan() && q.is_nan())
    }

    /// The product (one slice of `b` per row when `b`'s nonzero degrees are a run or every
    /// other degree of one, else a loop per degree) and `1 / x` (Horner forming only the
    /// degrees that change) against e794cbf's loops kept above, bit for bit, on
    /// [`product_operands`] (all pairs, and each operand's reciprocal with its constant term
    /// as drawn, set to 0, 1.5 and -inf).
    #[test]
    fn products_and_reciprocals_are_e794cbf_bit_for_bit() {
        let mut seed = 0x853c_49e6_748f_ea9bu64;
        let mut rnd = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let mut tables = 0;
        for nvar in 1..=5 {
            for order in 0..=TPS_MAX_ORDER {
                let Some(t) = TpsTable::get(nvar, order) else { continue };
                tables += 1;
                let n = t.len();
                let ops = product_operands(t, &mut rnd);
                for (p, a) in ops.iter().enumerate() {
                    for (q, b) in ops.iter().enumerate() {
                        let (got, want) = (mul_flat(t, a, b), mul_flat_e794cbf(t, a, b));
                        assert!(same_bits(&got, &want), "nvar {nvar} order {order} operands {p} x {q}");
                        let got = Tps { c: *a, t: Some(t) }.mul_ref(&Tps { c: *b, t: Some(t) });
                        assert!(
                            same_bits(got.coefficients(), &want[..n]),
                            "mul_ref nvar {nvar} order {order} operands {p} x {q}"
                        );
                    }
                    for c0 in [a[0], 0.0, 1.5, f64::NEG_INFINITY] {
                        let mut c = *a;
                        c[0] = c0;
                        let x = Tps { c, t: Some(t) };
                        assert!(
                            same_bits(x.recip().coefficients(), recip_e794cbf(&x).coefficients()),
                            "recip nvar {nvar} order {order} operand {p} c0 {c0}"
                        );
                    }
                }
            }
        }
        assert!(tables >= 40, "{tables} tables");
    }

    /// `sin_cos` and `1 / x` (in place, by reference) against their former by-value loops,
    /// bit for bit, on dense jets with and without a constant term at orders 5 and 9.
    #[test]
    fn in_place_series_are_the_by_value_loops() {
        fn sin_cos_by_value(x: Tps) -> (Tps, Tps) {
            let (s0, c0) = x.c[0].sin_cos();
            let t = x.t.unwrap();
            let y = x.nilpotent();
            let (mut sin_y, mut cos_y, mut p) = (Tps::constant(t, 0.0), Tps::constant(t, 1.0), Tps::constant(t, 1.0));
            let mut fact = 1.0;
            for n in 1..=t.order {
                p = p * y;
                fact *= n as f64;
                let term = p * (1.0 / fact);
                match n % 4 {
                    1 => sin_y = sin_y + term,
                    2 => cos_y = cos_y - term,
                    3 => sin_y = sin_y - term,
                    _ => cos_y = cos_y + term,
                }
            }
            (sin_y * c0 + cos_y * s0, cos_y * c0 - sin_y * s0)
        }
        fn recip_by_value(b: Tps) -> Tps {
            let (b0, t) = (b.c[0], b.t.unwrap());
            let x = b.nilpotent() * (-1.0 / b0);
            let mut s = Tps::constant(t, 1.0);
            for _ in 0..t.order {
                s = x * s + 1.0;
            }
            s * (1.0 / b0)
        }
        let bits = |a: &Tps, b: &Tps| {
            a.coefficients().len() == b.coefficients().len()
                && a.coefficients().iter().zip(b.coefficients()).all(|(x, y)| x.to_bits() == y.to_bits())
        };
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        for order in [5, 9] {
            let t = TpsTable::get(4, order).unwrap();
            for c0 in [0.0, 0.7, -2.3] {
                let c: Vec<f64> = (0..t.len())
                    .map(|i| {
                        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
                        if i == 0 { c0 } else { ((seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 0.5 }
                    })
                    .collect();
                let x = Tps::from_coefficients(t, &c);
                let ((s, co), (s_old, co_old)) = (x.sin_cos(), sin_cos_by_value(x));
                assert!(bits(&s, &s_old) && bits(&co, &co_old), "sin_cos order {order} c0 {c0}");
                let b = x + 3.0;
                assert!(bits(&(Tps::cst(1.0) / b), &(recip_by_value(b) * 1.0)), "recip order {order} c0 {c0}");
                // The by-reference operators against the by-value ones.
                let y = x.scaled(-0.3) + 0.1;
                assert!(
                    bits(&x.mul_ref(&y), &(x * y)) && bits(&x.add_ref(&y), &(x + y)) && bits(&x.sub_ref(&y), &(x - y))
                );
                let mut z = Tps::constant(t, 0.0);
                z.assign_axpy(&x, &y, 0.37);
                assert!(bits(&z, &(x + y * 0.37)));
            }
        }
    }

    #[test]
    fn sin_cos_identity_and_bare_constants() {
        let t = TpsTable::get(2, 8).unwrap();
        let x = Tps::var(t, 0, 0.7) * Tps::var(t, 1, -0.4) + Tps::var(t, 1, -0.4);
        let (s, c) = x.sin_cos();
        let one = s * s + c * c;
        assert!((one.coefficients()[0] - 1.0).abs() < 1e-15);
        assert!(one.coefficients()[1..].iter().all(|v| v.abs() < 1e-13), "{one:?}");
        // cst(1)/x: the constant takes x's table.
        let q = Tps::cst(1.0) / x;
        let back = q * x;
        assert!((back.re() - 1.0).abs() < 1e-15 && back.coefficients()[1..].iter().all(|v| v.abs() < 1e-12));
    }
}
