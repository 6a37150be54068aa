//! The `f64` path of an equations plant's right-hand side and Jacobian (the hot path of
//! `simulate`) against the generic path every other scalar takes: the value part of a dual
//! number goes through the generic tape evaluation and solve, the same operations in the
//! same order, so the two agree bit for bit; the symbolic Jacobian's `f` is the rhs's to
//! the bit and its derivatives agree with the dual numbers' to rounding.

use sim::closed_loop::{AnyPlant, build_plant};
use sim::plant::linearize::dual_jacobian;
use sim::plant::{Dual, Plant, Scalar};
use sim::scene::{SceneBuilder, bundled_names};

/// A xorshift generator: the same states on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// Uniform in `[-1, 1)`.
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 52) as f64 - 1.0
    }
}

/// States of every size class: ordinary, small, large, tiny (down to subnormal), huge
/// (overflowing to infinities and NaN), and exact zeros (signed).
fn states<const N: usize>(rng: &mut Rng, count: usize) -> Vec<([f64; N], f64)> {
    (0..count)
        .map(|k| {
            let x = core::array::from_fn(|_| {
                let m = rng.unit();
                match k % 7 {
                    0 => m,
                    1 => 1e-3 * m,
                    2 => 1e3 * m,
                    3 => m * 10f64.powi((rng.next() % 320) as i32 - 320),
                    4 => m * 10f64.powi((rng.next() % 300) as i32),
                    5 => 0.0,
                    _ => -0.0,
                }
            });
            (x, 10.0 * rng.unit())
        })
        .collect()
}

/// Equal bits, or both NaN (a NaN's payload is not a result).
fn same(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// Checks one plant; returns the number of states compared.
fn check<P: Plant<N>, const N: usize>(name: &str, p: &P, rng: &mut Rng) -> usize {
    let xs = states::<N>(rng, 700);
    for (x, u) in &xs {
        let fast = p.rhs(x, *u);
        let xd: [Dual<1>; N] = core::array::from_fn(|i| Dual::cst(x[i]));
        let generic = p.rhs(&xd, Dual::cst(*u));
        for (i, (a, b)) in fast.iter().zip(&generic).enumerate() {
            assert!(same(*a, b.v), "{name}: rhs[{i}] at x = {x:?}, u = {u}: f64 {a:e} but generic {:e}", b.v);
        }
        let (f, jac) = p.exact_jacobian(x, *u);
        for (i, (a, b)) in f.iter().zip(&fast).enumerate() {
            assert!(same(*a, *b), "{name}: the Jacobian's f[{i}] {a:e} differs from the rhs's {b:e} at x = {x:?}");
        }
        // The derivatives against the dual numbers', where the state is ordinary.
        if x.iter().all(|v| v.abs() <= 1e3) && f.iter().all(|v| v.is_finite()) {
            let (_, dual) = dual_jacobian(p, x, *u);
            for (i, (r, d)) in jac.iter().zip(&dual).enumerate() {
                let scale = d.iter().map(|v| v.abs()).fold(1.0, f64::max);
                for (j, (a, b)) in r.iter().zip(d).enumerate() {
                    assert!(
                        (a - b).abs() <= 1e-9 * scale,
                        "{name}: d f[{i}] / d x[{j}] = {a:e} but the dual numbers give {b:e} at x = {x:?}"
                    );
                }
            }
        }
    }
    xs.len()
}

#[test]
fn f64_path_equals_the_generic_path_bit_for_bit_on_every_equation_scene() {
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let mut scenes = Vec::new();
    for name in bundled_names() {
        let scene = SceneBuilder::load(name).unwrap().build().unwrap();
        let n = match build_plant(&scene).unwrap() {
            AnyPlant::Furuta(_) | AnyPlant::Cart(_) => continue,
            AnyPlant::Equations1(p) => check(name, &p, &mut rng),
            AnyPlant::Equations2(p) => check(name, &p, &mut rng),
            AnyPlant::Equations3(p) => check(name, &p, &mut rng),
            AnyPlant::Equations4(p) => check(name, &p, &mut rng),
        };
        scenes.push((name, n));
    }
    eprintln!("compared {scenes:?}");
    // Every plant size the bundled scenes have, the Furuta among them.
    assert!(scenes.iter().any(|(n, _)| *n == "furuta-equations"), "{scenes:?}");
    assert!(scenes.len() >= 4, "{scenes:?}");
}
