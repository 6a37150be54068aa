use super::*;
use crate::scalar::{Dual, Scalar};
use crate::taylor::tps::{Tps, TpsTable};

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
        let mut regs = vec![Dual::<3>::cst(0.0); tape.n_regs];
        tape.eval(&inputs, &mut regs);
        let d = regs[tape.outputs[0] as usize];
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
        let mut regs = vec![Tps::constant(t, 0.0); tape.n_regs];
        tape.eval(&inputs, &mut regs);
        regs[tape.outputs[0] as usize]
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
    let sincos = tape.instrs.iter().filter(|i| matches!(i.op, Op::SinCos(_))).count();
    let single = tape.instrs.iter().filter(|i| matches!(i.op, Op::Fn1(F1::Sin | F1::Cos, _))).count();
    assert_eq!((sincos, single), (1, 0), "{:?}", tape.instrs);
    let out = tape.eval_f64(&[0.3, 0.0, 2.0]);
    assert_eq!(out[0], 0.5 * 0.3f64.sin() * 0.3f64.cos() + 0.3f64.sin());
    assert_eq!(out[1], 0.3f64.cos().powi(2) + 0.3f64.sin() * 2.0);
    // A long sum reuses registers.
    let mut g = Graph::new();
    let src = (0..50).map(|k| format!("sin(x + {k})")).collect::<Vec<_>>().join(" + ");
    let p = parse(&src, &n, &mut g).unwrap();
    let tape = Tape::compile(&g, &[p.root], 3).unwrap();
    assert!(tape.n_regs < 8, "{} registers for {} instructions", tape.n_regs, tape.len());
    let want: f64 = (0..50).fold(0.0, |s, k| s + (0.3 + k as f64).sin());
    assert!((tape.eval_f64(&[0.3, 0.0, 0.0])[0] - want).abs() < 1e-12);
}

#[test]
fn constants_fold() {
    let mut g = Graph::new();
    let p = parse("m*g*2 + 0*x + 1*y - (3 - 3)", &names(), &mut g).unwrap();
    let tape = Tape::compile(&g, &[p.root], 3).unwrap();
    assert_eq!(tape.eval_f64(&[5.0, 7.0, 0.0])[0], 9.81 + 7.0);
    assert!(tape.len() <= 2, "{:?}", tape.instrs);
    let c = parse("m*g", &names(), &mut g).unwrap();
    let tape = Tape::compile(&g, &[c.root], 3).unwrap();
    assert_eq!(tape.eval_f64(&[0.0; 3]), vec![0.5 * 9.81]);
}
