mod tape;

use sim::expr::*;
use sim::scalar::{Dual, Scalar};
use sim::taylor::tps::{Tps, TpsTable};

fn names() -> Names {
    Names { vars: vec!["x".into(), "y".into(), "x_dot".into()], params: vec![("m".into(), 0.5), ("g".into(), 9.81)] }
}

fn eval(src: &str, vars: &[f64]) -> f64 {
    let mut g = Graph::new();
    let p = parse(src, &names(), &mut g).unwrap_or_else(|e| panic!("{src}: {e}"));
    let tape = Tape::compile(&g, &[p.root], 3).unwrap();
    let v = tape.eval_f64(vars)[0];
    let r = g.eval_f64(p.root, vars);
    assert!(v == r || (v.is_nan() && r.is_nan()), "{src}: tape {v} vs graph {r}");
    v
}

fn error(src: &str) -> ExprError {
    let mut g = Graph::new();
    match parse(src, &names(), &mut g) {
        Ok(_) => panic!("{src} parsed"),
        Err(e) => e,
    }
}

#[test]
fn precedence_and_associativity() {
    let v = [0.3, -1.7, 2.0];
    let (x, y) = (0.3f64, -1.7f64);
    assert_eq!(eval("-x^2", &v), -(x * x));
    assert_eq!(eval("2^3^2", &v), 512.0);
    assert_eq!(eval("x - y - 1", &v), (x - y) - 1.0);
    assert_eq!(eval("x / y / 2", &v), (x / y) / 2.0);
    assert_eq!(eval("-x*y", &v), -x * y);
    assert_eq!(eval("m*g*x", &v), 0.5 * 9.81 * x);
    assert_eq!(eval("(x + y) * 2", &v), (x + y) * 2.0);
    assert_eq!(eval("x^-2", &v), 1.0 / (x * x));
    assert_eq!(eval("1.5e-1 + .5", &v), 0.65);
    assert!((eval("x^0.5", &v) - x.sqrt()).abs() < 1e-15);
    assert!((eval("x^y", &v) - x.powf(y)).abs() < 1e-13 * x.powf(y));
    assert_eq!(eval("min(x, y) + max(x, y)", &v), x + y);
    assert_eq!(eval("abs(y)", &v), 1.7);
    assert_eq!(eval("atan2(y, x)", &v), y.atan2(x));
    assert_eq!(
        eval("tanh(x) + tan(x) + exp(x) + log(x) + sqrt(x)", &v),
        x.tanh() + x.tan() + x.exp() + x.ln() + x.sqrt()
    );
}

#[test]
fn errors_name_the_column() {
    let cases: &[(&str, usize, &str)] = &[
        ("x + * 2", 5, "expected a number"),
        ("sin(x", 6, "expected `)` to close `sin(` at column 1"),
        ("thetta + x", 1, "unknown name `thetta`"),
        ("x + sin", 5, "is a function"),
        ("atan2(x)", 1, "takes 2 arguments, got 1"),
        ("sinh(x)", 1, "unknown function `sinh`"),
        ("1.2.3", 1, "not a number"),
        ("x y", 3, "missing operator"),
        ("", 1, "empty expression"),
        ("x)", 2, "unmatched `)`"),
        ("(x + 1", 7, "to close the `(` at column 1"),
        ("x # 2", 3, "unexpected character '#'"),
        ("2x", 2, "cannot follow the number"),
        ("x +", 4, "found the end"),
        ("1e999", 1, "out of range"),
    ];
    for (src, col, what) in cases {
        let e = error(src);
        assert_eq!(e.col, *col, "{src}: {e}");
        assert!(e.message.contains(what), "{src}: {e}");
    }
    let deep = format!("{}x{}", "(".repeat(200), ")".repeat(200));
    assert!(error(&deep).message.contains("nested more than"));
    let long = "x+".repeat(MAX_EXPR_LEN) + "x";
    assert!(error(&long).message.contains("limit"));
}

/// Every function and operator: the dual-number evaluation of the tape gives the symbolic
/// derivative of the graph, and both match central differences.
#[test]
fn derivatives_agree_three_ways() {
    let srcs = [
        "sin(x)*cos(y) + tan(x*y)",
        "exp(x) / (1 + y^2) - log(2 + x) * sqrt(3 + y)",
        "abs(y) * x^3 + tanh(x - y) + atan2(y, x)",
        "min(x, y) * max(x, 2*y) + x^2.5 - 1/x",
        "x^y + (x + y)^-3",
        "-x*x_dot^2 + m*g*sin(x)",
    ];
    let pt = [0.7, -0.4, 1.3];
    for src in srcs {
        let mut g = Graph::new();
        let p = parse(src, &names(), &mut g).unwrap();
        let tape = Tape::compile(&g, &[p.root], 3).unwrap();
        let inputs: Vec<Dual<3>> = pt.iter().enumerate().map(|(i, &v)| Dual::var(v, i)).collect();
        let mut regs = vec![Dual::<3>::cst(0.0); tape.n_regs()];
        tape.eval(&inputs, &mut regs);
        let d = regs[tape.outputs()[0] as usize];
        assert_eq!(d.v, tape.eval_f64(&pt)[0], "{src}");
        for k in 0..3 {
            let dk = g.diff(p.root, k as u16);
            let sym = g.eval_f64(dk, &pt);
            let h = 1e-6;
            let (mut a, mut b) = (pt, pt);
            a[k] += h;
            b[k] -= h;
            let fd = (g.eval_f64(p.root, &a) - g.eval_f64(p.root, &b)) / (2.0 * h);
            let scale = d.d[k].abs().max(1.0);
            assert!((d.d[k] - sym).abs() <= 1e-13 * scale, "{src} d/dx{k}: dual {} vs symbolic {sym}", d.d[k]);
            assert!((d.d[k] - fd).abs() <= 1e-7 * scale, "{src} d/dx{k}: dual {} vs fd {fd}", d.d[k]);
        }
    }
}

/// The truncated power series evaluation of each function equals the same function built
/// from identities the series type already has (sin_cos, division, products).
#[test]
fn power_series_of_functions_match_identities() {
    let t = TpsTable::get(2, 7).unwrap();
    let run = |src: &str| -> Tps {
        let mut g = Graph::new();
        let p = parse(src, &names(), &mut g).unwrap();
        let tape = Tape::compile(&g, &[p.root], 3).unwrap();
        let inputs = [Tps::var(t, 0, 0.4), Tps::var(t, 1, 0.9), Tps::constant(t, 0.0)];
        let mut regs = vec![Tps::constant(t, 0.0); tape.n_regs()];
        tape.eval(&inputs, &mut regs);
        regs[tape.outputs()[0] as usize]
    };
    let close = |a: &Tps, b: &Tps, what: &str| {
        let err = a.coefficients().iter().zip(b.coefficients()).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(err < 1e-12, "{what}: {err:e}");
    };
    close(&run("tan(x)"), &run("sin(x)/cos(x)"), "tan");
    close(&run("tanh(y)"), &run("(exp(2*y) - 1)/(exp(2*y) + 1)"), "tanh");
    close(&run("log(exp(x + y))"), &run("x + y"), "log exp");
    close(&run("sqrt(y)*sqrt(y)"), &run("y"), "sqrt");
    close(&run("atan2(sin(x), cos(x))"), &run("x"), "atan2");
    close(&run("y^1.5"), &run("y*sqrt(y)"), "real power");
    close(&run("exp(x)*exp(-x)"), &run("1 + 0*x"), "exp");
}

#[test]
fn shared_subexpressions_and_registers() {
    let mut g = Graph::new();
    let n = names();
    let a = parse("m*sin(x)*cos(x) + sin(x)", &n, &mut g).unwrap();
    let b = parse("cos(x)^2 + sin(x)*x_dot", &n, &mut g).unwrap();
    let tape = Tape::compile(&g, &[a.root, b.root], 3).unwrap();
    // One sin_cos for both expressions.
    let sincos = tape.instrs().iter().filter(|i| matches!(i.op, Op::SinCos(_))).count();
    let single = tape.instrs().iter().filter(|i| matches!(i.op, Op::Fn1(F1::Sin | F1::Cos, _))).count();
    assert_eq!((sincos, single), (1, 0), "{:?}", tape.instrs());
    let out = tape.eval_f64(&[0.3, 0.0, 2.0]);
    assert_eq!(out[0], 0.5 * 0.3f64.sin() * 0.3f64.cos() + 0.3f64.sin());
    assert_eq!(out[1], 0.3f64.cos().powi(2) + 0.3f64.sin() * 2.0);
    // A long sum reuses registers.
    let mut g = Graph::new();
    let src = (0..50).map(|k| format!("sin(x + {k})")).collect::<Vec<_>>().join(" + ");
    let p = parse(&src, &n, &mut g).unwrap();
    let tape = Tape::compile(&g, &[p.root], 3).unwrap();
    assert!(tape.n_regs() < 8, "{} registers for {} instructions", tape.n_regs(), tape.len());
    let want: f64 = (0..50).fold(0.0, |s, k| s + (0.3 + k as f64).sin());
    assert!((tape.eval_f64(&[0.3, 0.0, 0.0])[0] - want).abs() < 1e-12);
}

#[test]
fn constants_fold() {
    let mut g = Graph::new();
    let p = parse("m*g*2 + 0*x + 1*y - (3 - 3)", &names(), &mut g).unwrap();
    let tape = Tape::compile(&g, &[p.root], 3).unwrap();
    assert_eq!(tape.eval_f64(&[5.0, 7.0, 0.0])[0], 9.81 + 7.0);
    assert!(tape.len() <= 2, "{:?}", tape.instrs());
    let c = parse("m*g", &names(), &mut g).unwrap();
    let tape = Tape::compile(&g, &[c.root], 3).unwrap();
    assert_eq!(tape.eval_f64(&[0.0; 3]), vec![0.5 * 9.81]);
}

/// The tape's value in every evaluation path at `vars`: the `f64` register array, the
/// `f64` slice (both native code on x86-64), and the value part of dual numbers (the
/// interpreter), each checked against the graph's
/// reference evaluation bit for bit (NaN against NaN).
fn check_paths(src: &str, g: &Graph, root: Id, tape: &Tape, vars: &[f64; 3]) {
    // On x86-64 the `f64` paths run the tape's native code.
    assert_eq!(tape.is_native(), cfg!(target_arch = "x86_64"), "{src}: native code");
    let want = g.eval_f64(root, vars);
    let same = |a: f64, b: f64| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
    let fast = tape.eval_f64(vars)[0];
    assert!(same(fast, want), "{src} at {vars:?}: tape {fast:e} vs graph {want:e}");
    let mut regs = vec![0.0; tape.n_regs()];
    tape.eval(vars, &mut regs);
    let slice = regs[tape.outputs()[0] as usize];
    assert!(same(slice, want), "{src} at {vars:?}: slice path {slice:e} vs graph {want:e}");
    let duals: Vec<Dual<3>> = vars.iter().enumerate().map(|(i, &v)| Dual::var(v, i)).collect();
    let mut out = [Dual::<3>::cst(0.0)];
    tape.eval_outputs(&duals, &mut out);
    assert!(same(out[0].v, want), "{src} at {vars:?}: dual value {:e} vs graph {want:e}", out[0].v);
}

/// Points with the special values: signed zeros, infinities, NaN, huge and tiny numbers.
fn special_points() -> Vec<[f64; 3]> {
    let s = [0.0, -0.0, 1.0, -2.5, 0.3, f64::INFINITY, f64::NEG_INFINITY, f64::NAN, 1e300, -1e-300];
    let mut pts = Vec::new();
    for (i, &a) in s.iter().enumerate() {
        for (j, &b) in s.iter().enumerate() {
            pts.push([a, b, s[(i + 2 * j) % s.len()]]);
        }
    }
    pts
}

/// Each rewrite of the compiler fires on its pattern and keeps the value bit for bit.
#[test]
fn tape_rewrites_fire_and_keep_every_bit() {
    let cases: &[(&str, &dyn Fn(&Op) -> bool)] = &[
        // Integer powers as products, shared with an explicit product (common subexpression).
        ("x^2 + x*x", &|op| matches!(op, Op::Add(a, b) if a == b)),
        ("x^5 - y^-3", &|op| matches!(op, Op::RDivC(..))),
        // `a + b` and `b + a` computed once.
        ("(x + y)*sin(x_dot) + (y + x)*cos(x_dot)", &|op| matches!(op, Op::DotAdd(a, _, c, _) if a == c)),
        // Negations folded into their users.
        ("x + -y", &|op| matches!(op, Op::Sub(..))),
        ("x - -y", &|op| matches!(op, Op::Add(..))),
        ("-(2*x) + y", &|op| matches!(op, Op::MulCAdd(_, k, _) if *k == -2.0)),
        ("(-x)*3 - y", &|op| matches!(op, Op::MulCSub(_, k, _) if *k == -3.0)),
        // Products fused into their one user.
        ("x*y + x_dot", &|op| matches!(op, Op::MulAdd(..))),
        ("x*y - x_dot", &|op| matches!(op, Op::MulSub(..))),
        ("x_dot - x*y", &|op| matches!(op, Op::SubMul(..))),
        ("x_dot - m*x", &|op| matches!(op, Op::SubMulC(..))),
        ("g*x + 1", &|op| matches!(op, Op::MulCAddC(..))),
        ("g*x - 1", &|op| matches!(op, Op::MulCAddC(_, _, k) if *k == -1.0)),
        ("x*y*x_dot", &|op| matches!(op, Op::MulMul(..))),
        ("m*x*y", &|op| matches!(op, Op::MulCMul(..))),
        // Sums and differences of two products.
        ("x*y + x_dot*x", &|op| matches!(op, Op::DotAdd(..))),
        ("x*y - x_dot*x", &|op| matches!(op, Op::DotSub(..))),
        ("m*x + g*y", &|op| matches!(op, Op::DotCAdd(..))),
        ("m*x - g*y", &|op| matches!(op, Op::DotCSub(..))),
        ("x*y + g*x_dot", &|op| matches!(op, Op::DotMCAdd(..))),
        ("g*x_dot + x*y", &|op| matches!(op, Op::DotMCAdd(..))),
        ("x*y - g*x_dot", &|op| matches!(op, Op::DotMCSub(..))),
        ("g*x_dot - x*y", &|op| matches!(op, Op::DotCMSub(..))),
        ("x*(-y) + x_dot", &|op| matches!(op, Op::SubMul(..))),
        // Fused product chains fused into their one user.
        ("x*y*g + 1", &|op| matches!(op, Op::MulMulCAddC(..))),
        ("x^2*m - 3", &|op| matches!(op, Op::MulMulCAddC(_, _, k1, k2) if *k1 == 0.5 && *k2 == -3.0)),
        ("x_dot - x*y*x", &|op| matches!(op, Op::SubMulMul(..))),
        ("x_dot - m*x*y", &|op| matches!(op, Op::SubMulCMul(..))),
    ];
    for (src, fired) in cases {
        let mut g = Graph::new();
        let p = parse(src, &names(), &mut g).unwrap();
        let tape = Tape::compile(&g, &[p.root], 3).unwrap();
        assert!(tape.instrs().iter().any(|i| fired(&i.op)), "{src}: {:?}", tape.instrs());
        for pt in special_points() {
            check_paths(src, &g, p.root, &tape, &pt);
        }
    }
    // A product read twice is computed once and not fused.
    let mut g = Graph::new();
    let p = parse("x*y + sin(x*y)", &names(), &mut g).unwrap();
    let tape = Tape::compile(&g, &[p.root], 3).unwrap();
    assert_eq!(tape.instrs().iter().filter(|i| matches!(i.op, Op::Mul(..))).count(), 1, "{:?}", tape.instrs());
    assert!(!tape.instrs().iter().any(|i| matches!(i.op, Op::MulAdd(..))), "{:?}", tape.instrs());
    // A product that is also an output keeps its register.
    let a = parse("x*y", &names(), &mut g).unwrap();
    let b = parse("x*y + 1", &names(), &mut g).unwrap();
    let tape = Tape::compile(&g, &[a.root, b.root], 3).unwrap();
    let out = tape.eval_f64(&[2.0, 3.0, 0.0]);
    assert_eq!(out, vec![6.0, 7.0]);
}

/// Random expressions of the whole language (a fixed-seed generator) at random and special
/// points: the compiled tape equals the graph's reference evaluation bit for bit in every
/// path, NaN and infinities included.
#[test]
fn random_expressions_evaluate_like_the_graph() {
    let mut seed: u64 = 0x9e37_79b9_7f4a_7c15;
    let mut next = move |n: u64| {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        (seed >> 33) % n
    };
    fn random_expr(next: &mut dyn FnMut(u64) -> u64, depth: u32) -> String {
        let leaves = ["x", "y", "x_dot", "m", "g", "2", "0.5", "3", "0", "1"];
        if depth == 0 || next(4) == 0 {
            return leaves[next(leaves.len() as u64) as usize].to_string();
        }
        let k = next(16);
        let pick = next(8) as usize;
        let (a, b, c, d) = (
            random_expr(next, depth - 1),
            random_expr(next, depth - 1),
            random_expr(next, depth - 1),
            random_expr(next, depth - 1),
        );
        match k {
            0 => format!("({a} + {b})"),
            1 => format!("({a} - {b})"),
            2 | 3 => format!("{a} * {b}"),
            4 => format!("({a}) / ({b})"),
            5 => format!("-({a})"),
            6 => format!("({a})^{}", ["2", "3", "-2", "5", "0.5", "1.5", "4", "-1"][pick]),
            7 => format!("{}({a})", ["sin", "cos", "tan", "exp", "log", "sqrt", "abs", "tanh"][pick]),
            8 => format!("atan2({a}, {b})"),
            9 => format!("{}({a}, {b})", ["min", "max"][pick % 2]),
            10 => format!("sin({a})*cos({a}) + {b}"),
            11 => format!("{a} - {b} * {c}"),
            12 => format!("{a} - {b} * {c} * {d}"),
            13 => format!("{a} * {b} * 0.5 + 3"),
            _ => format!("{a}*{b} + {c}*{d}"),
        }
    }
    let mut fired = [false; 5];
    for _ in 0..400 {
        let src = random_expr(&mut next, 4);
        let mut g = Graph::new();
        let p = parse(&src, &names(), &mut g).unwrap_or_else(|e| panic!("{src}: {e}"));
        let tape = Tape::compile(&g, &[p.root], 3).unwrap();
        for i in tape.instrs() {
            match i.op {
                Op::MulAdd(..) | Op::MulSub(..) | Op::SubMul(..) | Op::DotAdd(..) | Op::DotSub(..) => fired[0] = true,
                Op::MulCAdd(..)
                | Op::MulCSub(..)
                | Op::SubMulC(..)
                | Op::MulCAddC(..)
                | Op::DotCAdd(..)
                | Op::DotCSub(..)
                | Op::DotMCAdd(..)
                | Op::DotMCSub(..)
                | Op::DotCMSub(..) => fired[1] = true,
                Op::MulMul(..) | Op::MulCMul(..) => fired[2] = true,
                Op::SinCos(_) => fired[3] = true,
                Op::MulMulCAddC(..) | Op::SubMulMul(..) | Op::SubMulCMul(..) => fired[4] = true,
                _ => {}
            }
        }
        let mut pts = special_points();
        for _ in 0..10 {
            pts.push([0.0; 3].map(|_| (next(20_001) as f64 - 10_000.0) / 2_500.0));
        }
        for pt in &pts {
            check_paths(&src, &g, p.root, &tape, pt);
        }
    }
    assert_eq!(fired, [true; 5], "every fused shape and sin_cos occur among the random expressions");
}

/// Tapes of every stack register array size (up to 16, 32, 64, 128 and 256 registers,
/// read and written without bounds checks) give the graph's values bit for bit at the
/// special points, in `f64`, on slices and as the value part of dual numbers.
#[test]
fn every_register_array_size_evaluates_like_the_graph() {
    let n = names();
    for (count, regs) in [(5, 16), (20, 32), (45, 64), (100, 128), (220, 256)] {
        let mut g = Graph::new();
        let roots: Vec<Id> =
            (0..count).map(|k| parse(&format!("sin(x + {k})*y - x_dot/{}", k + 1), &n, &mut g).unwrap().root).collect();
        let tape = Tape::compile(&g, &roots, 3).unwrap();
        assert!(tape.n_regs() <= regs && 2 * tape.n_regs() > regs, "{count} roots: {} registers", tape.n_regs());
        for pt in special_points() {
            let fast = tape.eval_f64(&pt);
            let mut slice = vec![0.0; tape.n_regs()];
            tape.eval(&pt, &mut slice);
            let duals: Vec<Dual<3>> = pt.iter().enumerate().map(|(i, &v)| Dual::var(v, i)).collect();
            let mut dual = vec![Dual::<3>::cst(0.0); count];
            tape.eval_outputs(&duals, &mut dual);
            for (k, &r) in roots.iter().enumerate() {
                let want = g.eval_f64(r, &pt).to_bits();
                let got = [fast[k], slice[tape.outputs()[k] as usize], dual[k].v];
                for v in got {
                    let same = v.to_bits() == want || (v.is_nan() && f64::from_bits(want).is_nan());
                    assert!(same, "{count} roots, root {k} at {pt:?}: {v:e} vs {:e}", f64::from_bits(want));
                }
            }
        }
    }
}

/// Tapes past the stack register arrays (more than 256 registers) evaluate on the heap,
/// with the same values; the register limit is a named error.
#[test]
fn large_tapes_and_the_register_limit() {
    let mut g = Graph::new();
    let n = names();
    let roots: Vec<Id> = (0..300).map(|k| parse(&format!("sin(x + {k})*y + {k}"), &n, &mut g).unwrap().root).collect();
    let tape = Tape::compile(&g, &roots, 3).unwrap();
    assert!(tape.n_regs() > 256, "{} registers", tape.n_regs());
    let out = tape.eval_f64(&[0.3, -1.5, 0.0]);
    for (k, (&r, v)) in roots.iter().zip(&out).enumerate() {
        assert_eq!(v.to_bits(), g.eval_f64(r, &[0.3, -1.5, 0.0]).to_bits(), "root {k}");
    }
    assert_eq!(
        Tape::compile(&g, &roots, MAX_REGS + 1).unwrap_err().to_string(),
        format!("the expressions need more than {MAX_REGS} registers")
    );
}

/// Native code calls `sin` and `cos` directly: a `sin_cos` whose result overwrites its own
/// argument's register, one whose argument is live after it, and one in a tape whose
/// registers spill to memory give the graph's values bit for bit.
#[test]
fn native_sin_cos_keeps_its_argument_and_the_live_registers() {
    let n = names();
    let cases = [
        ("sin(x*y)*cos(x*y)", true),
        ("sin(x*y)*cos(x*y) + x*y", false),
        ("sin(x)*x_dot + cos(x)*y - x*(y + x_dot)", false),
    ];
    let mut overwrites = false;
    for (src, _) in cases {
        let mut g = Graph::new();
        let p = parse(src, &n, &mut g).unwrap();
        let tape = Tape::compile(&g, &[p.root], 3).unwrap();
        for i in tape.instrs() {
            if let Op::SinCos(a) = i.op {
                overwrites |= i.dst == a || i.dst2 == a;
            }
        }
        for pt in special_points() {
            check_paths(src, &g, p.root, &tape, &pt);
        }
    }
    assert!(overwrites, "a sin_cos writes over its argument's register");
    // Many values live across calls, most of them in memory (more registers than are held).
    let mut g = Graph::new();
    let roots: Vec<Id> = (0..30)
        .map(|k| parse(&format!("(x + {k})*y + sin(x_dot*{k})*cos(x_dot*{k})"), &n, &mut g).unwrap().root)
        .collect();
    let tape = Tape::compile(&g, &roots, 3).unwrap();
    assert!(tape.n_regs() > 16, "{} registers", tape.n_regs());
    for pt in special_points() {
        let out = tape.eval_f64(&pt);
        for (k, &r) in roots.iter().enumerate() {
            let want = g.eval_f64(r, &pt);
            let same = out[k].to_bits() == want.to_bits() || (out[k].is_nan() && want.is_nan());
            assert!(same, "root {k} at {pt:?}: {:e} vs {want:e}", out[k]);
        }
    }
}
