//! The tests of `ssm::tangent`.

use ssm::dynamics::{Kernel, RbfMap, ReducedDynamics};
use ssm::poly::Poly;
use ssm::ridge::Conditioning;
use ssm::tangent::*;

use ssm::fixtures::random_rbf;
use ssm::internals::{rbf_jacobian_any, rbf_step_and_jacobian};

/// The plain loop [`poly_map_jacobian`] had before [`PolyJacobian`] (every variable's
/// power multiplied in, `z^0 = 1` included; a fresh power table per call).
fn poly_map_jacobian_plain(p: &Poly, eta: &[f64], jac: &mut [f64]) {
    let d = p.dim_in;
    jac.iter_mut().for_each(|v| *v = 0.0);
    for i in 0..d.min(p.dim_out) {
        jac[i * d + i] = 1.0;
    }
    let stride = ssm::poly::max_degree(&p.exps) as usize + 1;
    let mut pow = vec![1.0; d * stride];
    for i in 0..d {
        let z = eta[i] / p.scale[i];
        for e in 1..stride {
            pow[i * stride + e] = pow[i * stride + e - 1] * z;
        }
    }
    for (k, e) in p.exps.iter().enumerate() {
        for j in 0..d {
            if e[j] == 0 {
                continue;
            }
            let mut g = e[j] as f64 * pow[j * stride + e[j] as usize - 1] / p.scale[j];
            for (i, &ei) in e.iter().enumerate() {
                if i != j {
                    g *= pow[i * stride + ei as usize];
                }
            }
            for out in 0..p.dim_out {
                jac[out * d + j] += p.coef[k * p.dim_out + out] * g;
            }
        }
    }
}

/// The prepared polynomial Jacobian against the plain loop, bit for bit, in dimensions
/// 2..=6 and orders 1..=5 (with and without the constant term) at random states, the
/// prepared one reused across states.
#[test]
fn prepared_poly_jacobian_equals_the_plain_loop() {
    let mut rng = ssm::testing::XorShift64::new(0x2545_f491_4f6c_dd1d);
    let mut rnd = move || rng.centered();
    // d 2..=6 by the fixed-size terms, 1 and 7 by the general loop.
    for d in 1..=7 {
        for order in 1..=5u32 {
            for min_deg in [0u32, 1] {
                let exps = ssm::poly::exponents(d, min_deg, order);
                let p = Poly {
                    dim_in: d,
                    dim_out: d,
                    scale: (0..d).map(|_| 0.3 + rnd().abs()).collect(),
                    coef: (0..exps.len() * d).map(|_| rnd() * 3.0).collect(),
                    exps,
                };
                let mut pj = PolyJacobian::new(&p);
                let (mut a, mut b, mut c) = (vec![7.0; d * d], vec![-7.0; d * d], vec![3.0; d * d]);
                for t in 0..20 {
                    // Exact zeros in some states (zero powers, signed zero products).
                    let eta: Vec<f64> = (0..d).map(|i| if (t + i) % 7 == 3 { 0.0 } else { rnd() }).collect();
                    pj.eval(&eta, &mut a);
                    poly_map_jacobian_plain(&p, &eta, &mut b);
                    poly_map_jacobian(&p, &eta, &mut c);
                    assert!(
                        a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()),
                        "d {d} order {order}: {a:?} vs {b:?}"
                    );
                    assert!(c.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "d {d} order {order}");
                }
            }
        }
    }
}

/// The fused step and Jacobian against `RbfMap::step` and [`rbf_jacobian`], bit for bit,
/// in dimensions 2..=6 at random states and exactly at a centre (the same error); and
/// [`Tangent`] in Benettin's order (Jacobian, then the step from the same state) along an
/// orbit, with steps from other states in between: the separate calls' values bit for bit.
#[test]
fn fused_rbf_step_and_jacobian_equal_the_separate_ones() {
    let mut rng = ssm::testing::XorShift64::new(0x9e37_79b9_7f4a_7c15);
    let mut rnd = move || rng.centered();
    for d in 2..=6 {
        let m = random_rbf(d, 200, false, &mut rnd);
        let (mut ja, mut jb, mut next) = (vec![0.0; d * d], vec![0.0; d * d], vec![0.0; d]);
        let mut feat = Vec::new();
        for t in 0..40 {
            let eta: Vec<f64> = if t == 0 {
                (0..d).map(|j| m.centers[40 * d + j] * m.scale[j]).collect()
            } else {
                (0..d).map(|_| rnd()).collect()
            };
            let ra = rbf_step_and_jacobian(&m, &eta, &mut ja, &mut next).unwrap();
            let rb = rbf_jacobian(&m, &eta, &mut jb);
            assert_eq!(ra, rb, "d {d} state {t}");
            assert!(ja.iter().zip(&jb).all(|(x, y)| x.to_bits() == y.to_bits()), "d {d} state {t}");
            if ra.is_ok() {
                let mut stepped = eta.clone();
                m.step(&mut stepped, &mut feat);
                assert!(
                    next.iter().zip(&stepped).all(|(x, y)| x.to_bits() == y.to_bits()),
                    "d {d} state {t}: {next:?} vs {stepped:?}"
                );
            }
        }
        // Benettin's order (Jacobian at x, then the step from x) through `Tangent`
        // against the separate calls, and a step from another state in between.
        let m = random_rbf(d, 100, true, &mut rnd);
        let dynamics = ReducedDynamics::Rbf(m.clone());
        let tangent = Tangent::new(&dynamics).unwrap();
        let mut x: Vec<f64> = (0..d).map(|_| 0.2 * rnd()).collect();
        let (mut out, mut other) = (vec![0.0; d], vec![0.0; d]);
        for t in 0..500 {
            tangent.jacobian(&x, &mut ja).unwrap();
            rbf_jacobian(&m, &x, &mut jb).unwrap();
            assert!(ja.iter().zip(&jb).all(|(a, b)| a.to_bits() == b.to_bits()), "d {d} step {t}");
            if t % 7 == 3 {
                let y: Vec<f64> = x.iter().map(|v| v * 0.5).collect();
                tangent.step(&y, &mut other);
                let mut stepped = y.clone();
                m.step(&mut stepped, &mut feat);
                assert!(other.iter().zip(&stepped).all(|(a, b)| a.to_bits() == b.to_bits()), "d {d} step {t}");
            }
            tangent.step(&x, &mut out);
            let mut stepped = x.clone();
            m.step(&mut stepped, &mut feat);
            assert!(out.iter().zip(&stepped).all(|(a, b)| a.to_bits() == b.to_bits()), "d {d} step {t}");
            x.copy_from_slice(&out);
        }
    }
}

/// The fixed-dimension Jacobian of the linear kernel against the general loop, bit for
/// bit, in dimensions 2..=6 on random maps (300 centres) at random states, including a
/// state exactly at a centre (the kink: the same error and the same partial sums);
/// `RBF_JAC_BENCH=fixed` / `any` time one of them.
#[test]
fn fixed_dimension_jacobian_equals_the_general_loop() {
    let mut rng = ssm::testing::XorShift64::new(0x853c_49e6_748f_ea9b);
    let mut rnd = move || rng.centered();
    let cond = Conditioning::NONE;
    for d in 2..=6 {
        let k = 300;
        let m = RbfMap {
            dim: d,
            kernel: Kernel::Linear,
            dt: 0.03,
            scale: (0..d).map(|_| 0.5 + rnd().abs()).collect(),
            centers: (0..k * d).map(|_| rnd()).collect(),
            coef: (0..(k + d + 1) * d).map(|_| rnd() * 10.0).collect(),
            conditioning: cond,
        };
        let (mut a, mut b) = (vec![7.0; d * d], vec![-7.0; d * d]);
        for t in 0..50 {
            let eta: Vec<f64> = if t == 0 {
                (0..d).map(|j| m.centers[40 * d + j] * m.scale[j]).collect()
            } else {
                (0..d).map(|_| rnd()).collect()
            };
            let ra = rbf_jacobian(&m, &eta, &mut a);
            let rb = rbf_jacobian_any(&m, &eta, &mut b);
            assert_eq!(ra, rb, "d {d} state {t}");
            assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()), "d {d} state {t}: {a:?} vs {b:?}");
        }
        if let Ok(kind) = std::env::var("RBF_JAC_BENCH") {
            let eta: Vec<f64> = (0..d).map(|_| rnd()).collect();
            let t0 = std::time::Instant::now();
            for _ in 0..20_000 {
                let _ =
                    if kind == "fixed" { rbf_jacobian(&m, &eta, &mut a) } else { rbf_jacobian_any(&m, &eta, &mut a) };
            }
            eprintln!("d {d}: 20000 {kind} Jacobians of 300 centres: {:?}", t0.elapsed());
        }
    }
}
