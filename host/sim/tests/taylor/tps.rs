use sim::plant::Scalar;
use sim::taylor::internals::{SCRATCH, mul_flat};
use sim::taylor::tps::*;

fn eval(t: &TpsTable, c: &[f64], x: &[f64]) -> f64 {
    t.exponents().iter().zip(c).map(|(e, c)| c * e.iter().zip(x).map(|(&k, v)| v.powi(k as i32)).product::<f64>()).sum()
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
                acc += if kind == "flat" { mul_flat(t, &ops[r % 4], &ops[0]) } else { mul_plain(&ops[r % 4], &ops[0]) }
                    [n - 1];
            }
            eprintln!("order {order}: {reps} {kind} products ({acc:.1e})");
        }
    }
}

/// `mul_flat` as of e794cbf (one inner loop per nonzero degree of `b`), kept as the
/// reference of the one-slice-per-row paths.
fn mul_flat_e794cbf(t: &TpsTable, a: &[f64; TPS_CAPACITY], b: &[f64; TPS_CAPACITY]) -> [f64; TPS_CAPACITY] {
    let mut acc = [0.0; SCRATCH];
    let order = t.order() as usize;
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
    for _ in 0..t.order() {
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
        for n in 1..=t.order() {
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
        for _ in 0..t.order() {
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
            assert!(bits(&x.mul_ref(&y), &(x * y)) && bits(&x.add_ref(&y), &(x + y)) && bits(&x.sub_ref(&y), &(x - y)));
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
