mod tps;

use shared::ControllerConfig;
use sim::linear::LinearPlant;
use sim::ode::Method;
use sim::plant::{Cart, Furuta};
use sim::plant::{Plant, Scalar, linearize};
use sim::taylor::internals::mesh;
use sim::taylor::*;

fn paper_cfg(dt: f64) -> ControllerConfig {
    ControllerConfig::paper(dt)
}

/// Largest relative difference per degree of two coefficient lists (relative to the first's
/// largest coefficient of that degree).
fn degree_diff(t: &TpsTable, a: &[f64], b: &[f64]) -> Vec<f64> {
    (0..=t.order())
        .map(|d| {
            let r = t.degree_range(d);
            let scale = a[r.clone()].iter().fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
            a[r.clone()].iter().zip(&b[r]).fold(0.0f64, |m, (x, y)| m.max((x - y).abs())) / scale
        })
        .collect()
}

/// Order 1 equals the exact ZOH discretization `Phi`, `Gamma` (matrix exponential), and the
/// period map's linear part equals the deflated closed-loop map of `sim::linear`.
#[test]
fn order_one_is_the_exact_zoh_map() {
    let p = Furuta::paper();
    let (a, b) = linearize(&p);
    for dt in [0.031, 0.0315] {
        let zoh = LinearPlant::new(&a, &b, 0, 2).unwrap().discretize(dt).unwrap();
        let f = flow_expansion(&p, dt, 3, &FlowOptions::default()).unwrap();
        let lin = f.table.degree_range(1);
        let mut worst = 0.0f64;
        for i in 0..4 {
            let c = &f.outputs[i][lin.clone()];
            let scale = zoh.phi.row(i).iter().fold(zoh.gamma[i].abs(), |m, v| m.max(v.abs()));
            for (k, &j) in f.state_of_var.iter().enumerate() {
                worst = worst.max((c[k] - zoh.phi[(i, j)]).abs() / scale);
            }
            worst = worst.max((c[3] - zoh.gamma[i]).abs() / scale);
        }
        assert!(worst < 1e-10, "dt={dt}: order-1 vs ZOH relative error {worst:e}");
        let pm = period_map(&p, &paper_cfg(dt), 3, &FlowOptions::default()).unwrap();
        let lp = LinearPlant::new(&a, &b, 0, 2).unwrap();
        let defl = lp.closed_loop(&paper_cfg(dt)).unwrap().deflated().unwrap();
        let scale = defl.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = (&pm.linear - &defl).abs().max() / scale;
        assert!(diff < 1e-10, "dt={dt}: period map linear part vs deflated map {diff:e}");
        eprintln!("dt={dt}: order-1 vs ZOH {worst:.2e}, M vs deflated {diff:.2e}");
    }
}

/// Halving every step changes the coefficients by the RK4 truncation error: small, and
/// ~16 times smaller at the next halving (the stiff mode does not spoil the higher orders).
#[test]
fn step_halving_converges_at_fourth_order() {
    let p = Furuta::paper();
    let order = 5;
    let runs: Vec<FlowExpansion> = [1, 2, 4]
        .iter()
        .map(|&refine| {
            let t0 = std::time::Instant::now();
            let f = flow_expansion(&p, 0.031, order, &FlowOptions { refine }).unwrap();
            eprintln!("order {order} refine {refine}: {} steps, {:.2} s", f.steps, t0.elapsed().as_secs_f64());
            f
        })
        .collect();
    let t = runs[0].table;
    let mut bad = Vec::new();
    for i in 0..4 {
        let d12 = degree_diff(t, &runs[2].outputs[i], &runs[0].outputs[i]);
        let d24 = degree_diff(t, &runs[2].outputs[i], &runs[1].outputs[i]);
        for d in (1..=order as usize).step_by(2) {
            eprintln!("x{i} degree {d}: refine 1 vs 4 {:.2e}, 2 vs 4 {:.2e}", d12[d], d24[d]);
            // Converged (the last refinement gains a factor 8, RK4: 16 in the limit, or is
            // at the rounding floor) and small.
            if !(d24[d] < 1e-7 && (d24[d] < d12[d] / 8.0 || d24[d] < 1e-8)) {
                bad.push((i, d, d12[d], d24[d]));
            }
        }
    }
    assert!(bad.is_empty(), "{bad:?}");
}

/// The truncated expansion against the exact f64 flow (the simulator's RODAS4 at tight
/// tolerance) at two distances `delta` along a fixed direction: the remainder scales like
/// `delta^(K+2)` for odd K = 1, 3, 5 (the loop is odd-symmetric: even degrees vanish, which
/// is checked too), i.e. every order up to K is right.
#[test]
fn remainder_scales_with_the_order() {
    let p = Furuta::paper();
    let cfg = paper_cfg(0.031);
    let pm = period_map(&p, &cfg, 6, &FlowOptions::default()).unwrap();
    let dir = [0.8, -2.0, 3.0, 0.5, 0.7, -0.02, 0.01];
    let method = Method::Rodas { rtol: 1e-13, atol: 1e-15 };
    let truncated = |k: u32, s: &[f64]| -> Vec<f64> {
        let keep: Vec<bool> = pm.exps.iter().map(|e| e.iter().sum::<u32>() <= k).collect();
        let mut q = pm.clone();
        for row in &mut q.coef {
            for (c, &kp) in row.iter_mut().zip(&keep) {
                if !kp {
                    *c = 0.0;
                }
            }
        }
        q.eval(s).unwrap()
    };
    for e in pm.exps.iter().zip(&pm.coef[0]).filter(|(e, _)| e.iter().sum::<u32>() % 2 == 0) {
        assert_eq!(*e.1, 0.0, "even-degree coefficient of {:?}", e.0);
    }
    for k in [1u32, 3, 5] {
        let mut errs = Vec::new();
        for delta in [0.04, 0.02] {
            let s: Vec<f64> = dir.iter().map(|v| v * delta).collect();
            let exact = pm.exact(&p, &s, method).unwrap();
            let approx = truncated(k, &s);
            errs.push(exact.iter().zip(&approx).fold(0.0f64, |m, (a, b)| m.max((a - b).abs())));
        }
        let ratio = errs[0] / errs[1];
        let want = 2f64.powi(k as i32 + 2);
        eprintln!("order {k}: remainder {:.3e} -> {:.3e}, ratio {ratio:.2} (2^(K+2) = {want})", errs[0], errs[1]);
        assert!(ratio > 0.7 * want && ratio < 1.5 * want, "order {k}: ratio {ratio} vs {want}");
    }
}

/// Central finite differences of the exact f64 map (second and third directional
/// derivatives along `dir`) at two step sizes converge to the jet's values.
#[test]
fn directional_derivatives_match_finite_differences() {
    let p = Furuta::paper();
    let cfg = paper_cfg(0.031);
    let pm = period_map(&p, &cfg, 4, &FlowOptions::default()).unwrap();
    let dir = [0.8, -2.0, 3.0, 0.5, 0.7, -0.02, 0.01];
    let method = Method::Rodas { rtol: 1e-13, atol: 1e-15 };
    let at = |h: f64| pm.exact(&p, &dir.iter().map(|v| v * h).collect::<Vec<_>>(), method).unwrap();
    // Jet: F(h dir) = sum_k h^k c_k; second derivative 2 c_2, third 6 c_3.
    let deg_coef = |k: u32| -> Vec<f64> {
        let v: Vec<f64> = (0..pm.proj.nrows()).map(|i| (0..7).map(|j| pm.proj[(i, j)] * dir[j]).sum()).collect();
        (0..7)
            .map(|r| {
                pm.exps
                    .iter()
                    .zip(&pm.coef[r])
                    .filter(|(e, _)| e.iter().sum::<u32>() == k)
                    .map(|(e, c)| c * e.iter().zip(&v).map(|(&q, x)| x.powi(q as i32)).product::<f64>())
                    .sum()
            })
            .collect()
    };
    let (c2, c3) = (deg_coef(2), deg_coef(3));
    for (h, tol2, tol3) in [(0.02, 1e-9, 5e-3), (0.01, 1e-9, 1.2e-3)] {
        let (p1, m1, p2, m2, z) = (at(h), at(-h), at(2.0 * h), at(-2.0 * h), at(0.0));
        // Even degrees vanish (odd symmetry): the second difference is measured against the
        // size of the first-order term.
        let s2 = (0..7).map(|r| (p1[r] - m1[r]).abs() / (2.0 * h * h)).fold(0.0f64, f64::max);
        let s3 = c3.iter().fold(0.0f64, |m, v| m.max(6.0 * v.abs()));
        let mut e2 = 0.0f64;
        let mut e3 = 0.0f64;
        for r in 0..7 {
            let fd2 = (p1[r] - 2.0 * z[r] + m1[r]) / (h * h);
            let fd3 = (p2[r] - 2.0 * p1[r] + 2.0 * m1[r] - m2[r]) / (2.0 * h * h * h);
            e2 = e2.max((fd2 - 2.0 * c2[r]).abs() / s2);
            e3 = e3.max((fd3 - 6.0 * c3[r]).abs() / s3);
        }
        eprintln!("h={h}: FD second derivative rel err {e2:.2e}, third {e3:.2e}");
        assert!(e2 < tol2 && e3 < tol3, "h={h}: {e2:e} {e3:e}");
    }
}

/// Orders up to 9 stay finite; coefficient size per degree is reported (conditioning).
#[test]
fn order_nine_is_finite() {
    let p = Furuta::paper();
    let f = flow_expansion(&p, 0.0315, 9, &FlowOptions { refine: 1 }).unwrap();
    for (i, c) in f.outputs.iter().enumerate() {
        let norms: Vec<f64> =
            (1..=9).map(|d| f.table.degree_range(d).map(|k| c[k].abs()).fold(0.0, f64::max)).collect();
        let text: Vec<String> = norms.iter().map(|v| format!("{v:.2e}")).collect();
        eprintln!("x{i}: max |coef| by degree 1..9 {}", text.join(" "));
        assert!(c.iter().all(|v| v.is_finite()));
    }
}

#[test]
fn bad_inputs_are_named() {
    let p = Furuta::paper();
    assert!(matches!(flow_expansion(&p, 0.0, 3, &FlowOptions::default()), Err(TaylorError::BadDt(_))));
    assert!(matches!(flow_expansion(&p, 0.03, 3, &FlowOptions { refine: 0 }), Err(TaylorError::Refine)));
    assert!(matches!(
        flow_expansion(&p, 0.03, 10, &FlowOptions::default()),
        Err(TaylorError::Order { order: 10, nvar: 4 })
    ));
    let cfg = ControllerConfig { ki: 1.0, ..paper_cfg(0.03) };
    assert!(matches!(period_map(&p, &cfg, 3, &FlowOptions::default()), Err(TaylorError::Integral(_))));
    // The cart's position is cyclic too: its expansion builds.
    let c = Cart::reference();
    assert!(flow_expansion(&c, 0.02, 3, &FlowOptions::default()).is_ok());
}

/// The order-9 expansion truncated to orders 5 and 7 is the direct expansion to that order
/// (the same mesh, [`MESH_ORDER`]), `==` on every coefficient, flow and period map, at two
/// dts; a truncation above the own order is refused.
#[test]
fn truncated_order_nine_is_the_lower_order_expansion() {
    let p = Furuta::paper();
    for dt in [0.031, 0.0325] {
        let cfg = paper_cfg(dt);
        let pm9 = period_map(&p, &cfg, 9, &FlowOptions::default()).unwrap();
        for k in [5u32, 7] {
            let direct = period_map(&p, &cfg, k, &FlowOptions::default()).unwrap();
            let cut = pm9.truncated(k).unwrap();
            assert_eq!((cut.order, cut.flow.order, cut.flow.steps), (k, k, direct.flow.steps));
            assert!(core::ptr::eq(cut.flow.table, direct.flow.table));
            assert_eq!(cut.flow.outputs, direct.flow.outputs, "dt {dt} order {k}: flow");
            assert_eq!((&cut.exps, &cut.coef), (&direct.exps, &direct.coef), "dt {dt} order {k}: map");
            assert_eq!(cut.linear, direct.linear);
            assert_eq!(cut.proj, direct.proj);
        }
        assert!(matches!(pm9.truncated(7).unwrap().truncated(9), Err(TaylorError::Order { order: 9, .. })));
    }
}

/// The expansion's RK4 (stages and update in place, the right-hand side by reference)
/// against the former by-value loop on the same mesh, bit for bit (`==` on every
/// coefficient), at order 5, dt = 31 ms.
#[test]
fn in_place_rk4_is_the_by_value_loop() {
    let p = Furuta::paper();
    let (dt, order) = (0.031, 5);
    let f = flow_expansion(&p, dt, order, &FlowOptions::default()).unwrap();
    let table = f.table;
    let mut x: [Tps; 4] = core::array::from_fn(|_| Tps::constant(table, 0.0));
    for (k, &i) in f.state_of_var.iter().enumerate() {
        x[i] = Tps::var(table, k, 0.0);
    }
    let u = Tps::var(table, 3, 0.0);
    let steps = mesh(dt, f.stiff_rate, order.max(MESH_ORDER), FlowOptions::default().refine).unwrap();
    assert_eq!(steps.len(), f.steps);
    for &h in &steps {
        let k1 = p.rhs(&x, u);
        let x2: [Tps; 4] = core::array::from_fn(|i| x[i] + k1[i] * (0.5 * h));
        let k2 = p.rhs(&x2, u);
        let x3: [Tps; 4] = core::array::from_fn(|i| x[i] + k2[i] * (0.5 * h));
        let k3 = p.rhs(&x3, u);
        let x4: [Tps; 4] = core::array::from_fn(|i| x[i] + k3[i] * h);
        let k4 = p.rhs(&x4, u);
        x = core::array::from_fn(|i| x[i] + (k1[i] + (k2[i] + k3[i]) * 2.0 + k4[i]) * (h / 6.0));
    }
    for (i, xi) in x.iter().enumerate() {
        assert!(xi.coefficients() == f.outputs[i].as_slice(), "component {i}");
    }
}

/// The right-hand side by reference (`Scalar::mul_ref` etc.) against the former by-value
/// formula, bit for bit, on truncated power series (random dense jets and the odd jets of
/// the expansion at the upright, orders 5 and 9) and on f64.
#[test]
fn rhs_by_reference_is_the_by_value_formula() {
    fn by_value<S: Scalar>(f: &Furuta, x: &[S; 4], u: S) -> [S; 4] {
        let p = f.params();
        let [th, wt, _phi, wp] = *x;
        let (s, c) = th.sin_cos();
        let s2 = s * s;
        let sc = s * c;
        let ja_eff = s2 * p.jp + p.ja;
        let delta = s2 * f.delta_s2() + f.delta0();
        let motor = u * p.n - wp * p.k;
        let a = motor - sc * wt * wp * (2.0 * p.jp) - wp * p.b2 - s * wt * wt * f.mrl();
        let b = sc * wp * wp * p.jp - wt * p.b1 + s * f.mgl();
        let inv = S::cst(1.0) / delta;
        let mrl_c = c * f.mrl();
        let th_dd = (ja_eff * b + mrl_c * a) * inv;
        let ph_dd = (a * p.jp + mrl_c * b) * inv;
        [wt, th_dd, wp, ph_dd]
    }
    let f = Furuta::paper();
    let mut seed = 0x9e37_79b9_7f4a_7c15u64;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    for order in [5, 9] {
        let t = TpsTable::get(4, order).unwrap();
        for odd in [false, true] {
            let jet = |k: usize, rnd: &mut dyn FnMut() -> f64| {
                let c: Vec<f64> = t
                    .exponents()
                    .iter()
                    .map(|e| {
                        let d: u32 = e.iter().sum();
                        let v = rnd() * 0.3f64.powi(d as i32);
                        if odd && d % 2 == 0 { 0.0 } else { v + if d == 1 && e[k] == 1 { 1.0 } else { 0.0 } }
                    })
                    .collect();
                Tps::from_coefficients(t, &c)
            };
            let x = [jet(0, &mut rnd), jet(1, &mut rnd), Tps::constant(t, 0.0), jet(2, &mut rnd)];
            let u = jet(3, &mut rnd);
            let got = f.rhs(&x, u);
            let want = by_value(&f, &x, u);
            for i in 0..4 {
                let same =
                    got[i].coefficients().iter().zip(want[i].coefficients()).all(|(a, b)| a.to_bits() == b.to_bits());
                assert!(same && got[i].coefficients().len() == t.len(), "order {order} odd {odd} component {i}");
            }
        }
    }
    for (x, u) in [([0.3, -1.2, 4.0, 2.5], 1.7), ([-2.9, 3.0, -1.0, -7.0], -12.0)] {
        let (got, want) = (f.rhs(&x, u), by_value(&f, &x, u));
        assert!(got.iter().zip(&want).all(|(a, b)| a.to_bits() == b.to_bits()));
    }
}

/// Any gain vector on a plant written as equations: the period map's linear part is the
/// closed-loop ZOH map of `sim::linear` (deflated when the secondary coordinate is cyclic and
/// has no P gain, the full map otherwise), and the expansion's remainder against the exact
/// flow falls like `delta^4` at order 3 (even degrees vanish: the plants are odd).
#[test]
fn equation_scenes_expand_with_their_gain_vectors() {
    use sim::scene::Scene;
    fn check<P: Plant<N>, const N: usize>(p: &P, scene: &Scene, want_dim: usize) {
        let cfg = scene.controller_config();
        let pm = period_map(p, &cfg, 3, &FlowOptions::default()).unwrap();
        assert_eq!(pm.dim(), want_dim, "{}: {:?}", scene.name, pm.names);
        let (a, b) = linearize(p);
        let map = LinearPlant::new(&a, &b, P::PRIMARY, P::SECONDARY).unwrap().closed_loop(&cfg).unwrap();
        let reference = if pm.flow.secondary.is_some() { map.deflated().unwrap() } else { map.matrix.clone() };
        let scale = reference.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let diff = (&pm.linear - &reference).abs().max() / scale;
        eprintln!("{}: {} coordinates {:?}, M vs ZOH map {diff:.2e}", scene.name, pm.dim(), pm.names);
        assert!(diff < 1e-10, "{}: {diff:e}", scene.name);
        let dir: Vec<f64> = (0..pm.dim()).map(|k| [0.8, -0.5, 0.6, 0.3, -0.4, 0.2][k % 6]).collect();
        let method = Method::Rodas { rtol: 1e-13, atol: 1e-15 };
        let errs: Vec<f64> = [0.02, 0.01]
            .iter()
            .map(|&delta| {
                let s: Vec<f64> = dir.iter().map(|v| v * delta).collect();
                let exact = pm.exact(p, &s, method).unwrap();
                let approx = pm.eval(&s).unwrap();
                exact.iter().zip(&approx).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
            })
            .collect();
        let ratio = errs[0] / errs[1];
        eprintln!(
            "{}: order-3 remainder {:.3e} -> {:.3e}, ratio {ratio:.2} (want 2^5 = 32)",
            scene.name, errs[0], errs[1]
        );
        assert!(ratio > 0.7 * 32.0 && ratio < 1.5 * 32.0, "{}: ratio {ratio}", scene.name);
    }
    // (scene, period map dimension): the Duffing chain and the cart-pole keep every state
    // (their second coordinate enters or has a P gain) and r + 1 = 2 registers per measured
    // coordinate; the Furuta as equations is deflated like the built-in plant.
    for (name, dim) in [("duffing-chain", 6), ("cartpole-pd", 8), ("pendulum-pd", 4), ("furuta-equations", 7)] {
        let scene = Scene::load(name, &[]).unwrap();
        sim::with_plant!(sim::closed_loop::build_plant(&scene).unwrap(), p => check(&p, &scene, dim));
    }
}
