//! One step of RODAS4, the stiffly accurate, L-stable Rosenbrock method of order 4 with an
//! embedded order-3 solution (Hairer & Wanner, *Solving Ordinary Differential Equations II*,
//! 2nd ed., Springer 1996, section IV.7).
//!
//! Coefficients: Hairer's `rodas.f`, subroutine `ROCOE`/`RODAS4` with `METH = 1`
//! (<http://www.unige.ch/~hairer/prog/stiff/rodas.f>); the same set is transcribed in
//! SciML OrdinaryDiffEq.jl, `src/tableaus/rosenbrock_tableaus.jl`, `Rodas4Tableau`. Only the
//! autonomous form is needed (the input is held constant over a step), so the `c_i`, `d_i`
//! and the dense-output coefficients are not used.
//!
//! Stage form (`rodas.f`): with `E = I/(h*gamma) - J`,
//! `E k_i = f(y + sum_j a_ij k_j) + sum_j (c_ij/h) k_j`, `i = 1..6`, where stage 5 is
//! evaluated at `Y5 = y + a51 k1 + .. + a54 k4` and stage 6 at `Y6 = Y5 + k5`; the solution is
//! `Y6 + k6` and the embedded (order-3) solution `Y6`, so `k6` is the error estimate.

use super::lu::Lu;

pub(crate) const GAMMA: f64 = 0.25;

const A21: f64 = 1.544;
const A31: f64 = 0.946_678_528_081_582_6;
const A32: f64 = 0.255_701_169_898_328_4;
const A41: f64 = 3.314_825_187_068_521;
const A42: f64 = 2.896_124_015_972_201;
const A43: f64 = 0.998_641_913_997_781_7;
const A51: f64 = 1.221_224_509_226_641;
const A52: f64 = 6.019_134_481_288_629;
const A53: f64 = 12.537_083_329_320_87;
const A54: f64 = -0.687_886_036_105_895;

const C21: f64 = -5.6688;
const C31: f64 = -2.430_093_356_833_875;
const C32: f64 = -0.206_359_915_709_191_5;
const C41: f64 = -0.107_352_905_815_137_5;
const C42: f64 = -9.594_562_251_023_355;
const C43: f64 = -20.470_286_148_096_16;
const C51: f64 = 7.496_443_313_967_647;
const C52: f64 = -10.246_804_314_643_52;
const C53: f64 = -33.999_903_528_199_05;
const C54: f64 = 11.708_908_932_061_6;
const C61: f64 = 8.083_246_795_921_522;
const C62: f64 = -7.981_132_988_064_893;
const C63: f64 = -31.521_594_328_743_71;
const C64: f64 = 16.319_305_431_231_36;
const C65: f64 = -6.058_818_238_834_054;

/// The iteration matrix `E = I/(h*gamma) - J`, factorized; `None` if singular.
#[inline]
pub(crate) fn factor<const N: usize>(jac: &[[f64; N]; N], h: f64) -> Option<Lu<N>> {
    let fac = 1.0 / (h * GAMMA);
    let mut e = [[0.0; N]; N];
    for i in 0..N {
        for j in 0..N {
            e[i][j] = -jac[i][j];
        }
        e[i][i] += fac;
    }
    Lu::new(e)
}

#[inline(always)]
fn comb<const N: usize, const K: usize>(base: Option<&[f64; N]>, terms: [(f64, &[f64; N]); K]) -> [f64; N] {
    core::array::from_fn(|i| {
        let mut s = match base {
            Some(b) => b[i],
            None => 0.0,
        };
        for (c, v) in terms {
            s += c * v[i];
        }
        s
    })
}

/// One RODAS4 step of size `h` from `y` with `f0 = f(y)` and `E` factorized for this `h`.
/// `rhs` evaluates `f`. Returns the new state and the error estimate `k6`.
#[inline]
pub(crate) fn step<const N: usize>(
    rhs: &mut impl FnMut(&[f64; N]) -> [f64; N],
    lu: &Lu<N>,
    y: &[f64; N],
    f0: &[f64; N],
    h: f64,
) -> ([f64; N], [f64; N]) {
    let inv_h = 1.0 / h;
    let k1 = lu.solve(f0);

    let f = rhs(&comb(Some(y), [(A21, &k1)]));
    let k2 = lu.solve(&comb(Some(&f), [(C21 * inv_h, &k1)]));

    let f = rhs(&comb(Some(y), [(A31, &k1), (A32, &k2)]));
    let k3 = lu.solve(&comb(Some(&f), [(C31 * inv_h, &k1), (C32 * inv_h, &k2)]));

    let f = rhs(&comb(Some(y), [(A41, &k1), (A42, &k2), (A43, &k3)]));
    let k4 = lu.solve(&comb(Some(&f), [(C41 * inv_h, &k1), (C42 * inv_h, &k2), (C43 * inv_h, &k3)]));

    let y5 = comb(Some(y), [(A51, &k1), (A52, &k2), (A53, &k3), (A54, &k4)]);
    let f = rhs(&y5);
    let k5 =
        lu.solve(&comb(Some(&f), [(C51 * inv_h, &k1), (C52 * inv_h, &k2), (C53 * inv_h, &k3), (C54 * inv_h, &k4)]));

    let y6 = comb(Some(&y5), [(1.0, &k5)]);
    let f = rhs(&y6);
    let k6 = lu.solve(&comb(
        Some(&f),
        [(C61 * inv_h, &k1), (C62 * inv_h, &k2), (C63 * inv_h, &k3), (C64 * inv_h, &k4), (C65 * inv_h, &k5)],
    ));
    (comb(Some(&y6), [(1.0, &k6)]), k6)
}
