//! Scalars the plant right-hand sides are generic over: `f64`, and forward-mode dual numbers
//! with `M` derivative components, which give exact Jacobians in one evaluation.

use core::ops::{Add, Div, Mul, Neg, Sub};

/// The arithmetic a plant's right-hand side may use.
pub trait Scalar:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
{
    /// `true` for `f64` alone: generic code may then take a path written for plain floats
    /// (the same operations in the same order), converting with `re` and `cst`, identities
    /// for `f64`.
    const IS_F64: bool = false;
    /// A constant (zero derivative).
    fn cst(v: f64) -> Self;
    /// The value part.
    fn re(self) -> f64;
    /// `(sin x, cos x)`.
    fn sin_cos(self) -> (Self, Self);
    /// `g(self)` for a smooth function `g` given by its Taylor coefficients at the value:
    /// `coef(x0, out)` fills `out[k] = g^(k)(x0) / k!` for every `k < out.len()`. Each type
    /// asks for as many as it carries (one for `f64`, two for [`Dual`], the order plus one
    /// for a truncated power series), so one coefficient rule serves every scalar.
    fn apply<F: Fn(f64, &mut [f64])>(self, coef: F) -> Self;
    /// `self * o` by reference: `*`'s value bit for bit. A large scalar (a truncated power
    /// series, [`crate::taylor::Tps`], 5.7 kB) overrides these four so its operands are
    /// not copied; for `f64` they are the operators.
    #[inline(always)]
    fn mul_ref(&self, o: &Self) -> Self {
        *self * *o
    }
    /// `self + o` by reference (`+`'s value).
    #[inline(always)]
    fn add_ref(&self, o: &Self) -> Self {
        *self + *o
    }
    /// `self - o` by reference (`-`'s value).
    #[inline(always)]
    fn sub_ref(&self, o: &Self) -> Self {
        *self - *o
    }
    /// `self * f` by reference (`*`'s value).
    #[inline(always)]
    fn scaled(&self, f: f64) -> Self {
        *self * f
    }
    /// The slice as plain floats when `Self` is `f64` (for code written for `f64` only,
    /// such as a tape's native code), else `None`.
    #[inline(always)]
    fn as_f64s(xs: &mut [Self]) -> Option<&mut [f64]> {
        let _ = xs;
        None
    }
}

impl Scalar for f64 {
    const IS_F64: bool = true;
    #[inline(always)]
    fn cst(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn re(self) -> f64 {
        self
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        f64::sin_cos(self)
    }
    #[inline(always)]
    fn apply<F: Fn(f64, &mut [f64])>(self, coef: F) -> Self {
        let mut c = [0.0];
        coef(self, &mut c);
        c[0]
    }
    #[inline(always)]
    fn as_f64s(xs: &mut [Self]) -> Option<&mut [f64]> {
        Some(xs)
    }
}

/// A forward-mode dual number: value `v` and derivatives `d` with respect to `M` seeds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dual<const M: usize> {
    pub v: f64,
    pub d: [f64; M],
}

impl<const M: usize> Dual<M> {
    /// The `k`-th independent variable with value `v` (derivative 1 in slot `k`).
    pub fn var(v: f64, k: usize) -> Self {
        let mut d = [0.0; M];
        if let Some(slot) = d.get_mut(k) {
            *slot = 1.0;
        }
        Self { v, d }
    }
    #[inline(always)]
    fn map_d(self, f: impl Fn(f64) -> f64) -> [f64; M] {
        let mut d = self.d;
        for x in &mut d {
            *x = f(*x);
        }
        d
    }
}

impl<const M: usize> Add for Dual<M> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        let mut d = self.d;
        for (a, b) in d.iter_mut().zip(o.d) {
            *a += b;
        }
        Self { v: self.v + o.v, d }
    }
}
impl<const M: usize> Sub for Dual<M> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        let mut d = self.d;
        for (a, b) in d.iter_mut().zip(o.d) {
            *a -= b;
        }
        Self { v: self.v - o.v, d }
    }
}
impl<const M: usize> Mul for Dual<M> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        let mut d = self.d;
        for (a, b) in d.iter_mut().zip(o.d) {
            *a = *a * o.v + self.v * b;
        }
        Self { v: self.v * o.v, d }
    }
}
impl<const M: usize> Div for Dual<M> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        let q = self.v / o.v;
        let mut d = self.d;
        for (a, b) in d.iter_mut().zip(o.d) {
            *a = (*a - q * b) / o.v;
        }
        Self { v: q, d }
    }
}
impl<const M: usize> Neg for Dual<M> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        Self { v: -self.v, d: self.map_d(|x| -x) }
    }
}
impl<const M: usize> Add<f64> for Dual<M> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: f64) -> Self {
        Self { v: self.v + o, d: self.d }
    }
}
impl<const M: usize> Sub<f64> for Dual<M> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: f64) -> Self {
        Self { v: self.v - o, d: self.d }
    }
}
impl<const M: usize> Mul<f64> for Dual<M> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: f64) -> Self {
        Self { v: self.v * o, d: self.map_d(|x| x * o) }
    }
}
impl<const M: usize> Div<f64> for Dual<M> {
    type Output = Self;
    #[inline(always)]
    fn div(self, o: f64) -> Self {
        Self { v: self.v / o, d: self.map_d(|x| x / o) }
    }
}

impl<const M: usize> Scalar for Dual<M> {
    #[inline(always)]
    fn cst(v: f64) -> Self {
        Self { v, d: [0.0; M] }
    }
    #[inline(always)]
    fn re(self) -> f64 {
        self.v
    }
    #[inline(always)]
    fn sin_cos(self) -> (Self, Self) {
        let (s, c) = self.v.sin_cos();
        (Self { v: s, d: self.map_d(|x| x * c) }, Self { v: c, d: self.map_d(|x| -x * s) })
    }
    #[inline(always)]
    fn apply<F: Fn(f64, &mut [f64])>(self, coef: F) -> Self {
        let mut c = [0.0; 2];
        coef(self.v, &mut c);
        Self { v: c[0], d: self.map_d(|x| x * c[1]) }
    }
}
