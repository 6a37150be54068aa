//! A plant written as equations in a scene: `M(q) q'' = f(q, q', u)` from a mass matrix and
//! forces, or from a Lagrangian `L(q, q')` and generalized forces `Q(q, q', u)` by symbolic
//! differentiation (`M = d2L/dq'2`, `f = Q + dL/dq - d2L/dq'dq q'`).
//!
//! State ordering: `(q_1, q_1', q_2, q_2', ...)`, named `x, x_dot, ...`: the coordinate
//! first, then its velocity, as the built-in plants lay out `(theta, w_theta, phi, w_phi)`,
//! so a controller reading coordinates reads states `0, 2, 4, ...`. The states are
//! deviations from the equilibrium (zero unless the scene names one with `equilibrium`): a
//! controller's encoders read zero there, and the linearization is taken at the origin.
//!
//! All expressions are compiled once into one [`Tape`] (shared subexpressions computed
//! once); the right-hand side evaluates it and solves `M a = f` by LU with partial pivoting,
//! generically over [`Scalar`]. The register file and the matrix live on the stack for
//! small scalars (`f64`, dual numbers): no allocation per evaluation.

use std::collections::HashSet;
use std::sync::{Arc, Mutex, OnceLock};

use super::{Plant, Scalar};
use crate::expr::{self, Evaluated, ExprError, Graph, Id, Names, Parsed, Tape};

/// Largest number of generalized coordinates of an equations plant (states `N = 2n <= 8`).
pub const MAX_COORDINATES: usize = 4;

/// Grid points per coordinate over `[-pi, pi]` (around the equilibrium) at which the mass
/// matrix is checked: symmetric, positive definite and not near-singular.
pub const MASS_GRID: usize = 9;

/// How an equations plant is written.
#[derive(Clone, Debug, PartialEq)]
pub enum Form {
    /// `mass[i][j]` (expressions in the coordinates) and `forces[i]`.
    Mass { mass: Vec<Vec<String>>, forces: Vec<String> },
    /// A Lagrangian and the generalized (non-conservative) forces.
    Lagrangian { lagrangian: String, generalized_forces: Vec<String> },
}

/// Everything that defines an equations plant (what the scene's `[plant]` table gives).
#[derive(Clone, Debug, PartialEq)]
pub struct EquationsSpec {
    pub coordinates: Vec<String>,
    pub parameters: Vec<(String, f64)>,
    pub form: Form,
    /// The equilibrium (absolute coordinates); `None` is the origin.
    pub equilibrium: Option<Vec<f64>>,
}

/// A bad equations plant: the scene key (`plant.forces[1]`) and what is wrong (with the
/// column in the expression where there is one).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("`{key}`: {message}")]
pub struct EquationsError {
    pub key: String,
    pub message: String,
}

fn fail<T>(key: impl Into<String>, message: impl Into<String>) -> Result<T, EquationsError> {
    Err(EquationsError { key: key.into(), message: message.into() })
}

/// A name as a `&'static str` (state names of the [`Plant`] trait), each distinct name
/// leaked once for the process.
fn intern(s: &str) -> &'static str {
    static NAMES: OnceLock<Mutex<HashSet<&'static str>>> = OnceLock::new();
    let set = NAMES.get_or_init(|| Mutex::new(HashSet::new()));
    let mut set = match set.lock() {
        Ok(g) => g,
        Err(p) => p.into_inner(),
    };
    if let Some(&n) = set.get(s) {
        return n;
    }
    let leaked: &'static str = Box::leak(s.to_string().into_boxed_str());
    set.insert(leaked);
    leaked
}

/// The compiled model shared by every [`EquationsPlant`] of one spec.
#[derive(Debug)]
pub struct EquationsModel {
    n: usize,
    coordinates: Vec<String>,
    state_names: Vec<&'static str>,
    /// Outputs: the upper triangle of `M` row by row (`n(n+1)/2`), then `f` (`n`).
    tape: Tape,
    /// The same outputs, then their derivatives by each input `v` of `0..2n` (coordinates,
    /// velocities) in the same layout: the symbolic Jacobian (`None` when the derivatives
    /// outgrow the graph's limits; the Jacobian then comes from dual numbers).
    jac_tape: Option<Tape>,
    /// Bit `k` set: output `k` of the Jacobian tape is identically zero.
    jac_zero: u128,
    /// Bit `s` set: state `s` is one neither `M` nor `f` depends on (a zero column of the
    /// Jacobian's acceleration rows).
    jac_zero_cols: u8,
    /// `sum q'_i dL/dq'_i - L` (Lagrangian form only).
    energy: Option<Tape>,
    equilibrium: Vec<f64>,
    /// `equilibrium` padded with zeros to [`MAX_COORDINATES`] (the right-hand side's copy).
    equilibrium_pad: [f64; MAX_COORDINATES],
    /// Some coordinate of the equilibrium is not zero (the inputs add it).
    shifted: bool,
}

impl EquationsModel {
    /// Parses, differentiates, compiles and checks the spec.
    pub fn new(spec: &EquationsSpec) -> Result<Self, EquationsError> {
        let n = spec.coordinates.len();
        if n == 0 {
            return fail("plant.coordinates", "lists no coordinates");
        }
        if n > MAX_COORDINATES {
            return fail(
                "plant.coordinates",
                format!(
                    "lists {n} coordinates; at most {MAX_COORDINATES} are supported (states = 2 x coordinates <= {})",
                    2 * MAX_COORDINATES
                ),
            );
        }
        let names = names(spec)?;
        let mut g = Graph::new();
        let parse = |g: &mut Graph, key: &str, src: &str| -> Result<Parsed, EquationsError> {
            expr::parse(src, &names, g).map_err(|e| expr_error(key, src, &e))
        };
        let (mass, forces, energy): (Vec<Vec<(Id, String, Option<Parsed>)>>, Vec<Id>, Option<Id>) = match &spec.form {
            Form::Mass { mass, forces } => {
                if mass.len() != n {
                    return fail(
                        "plant.mass",
                        format!("has {} rows; the mass matrix must be {n} x {n}, one row per coordinate", mass.len()),
                    );
                }
                let mut rows = Vec::with_capacity(n);
                for (i, row) in mass.iter().enumerate() {
                    if row.len() != n {
                        return fail(
                            format!("plant.mass[{i}]"),
                            format!("has {} entries; the mass matrix must be {n} x {n} (square)", row.len()),
                        );
                    }
                    let mut r = Vec::with_capacity(n);
                    for (j, src) in row.iter().enumerate() {
                        let key = format!("plant.mass[{i}][{j}]");
                        let p = parse(&mut g, &key, src)?;
                        // The mass matrix is M(q): no velocity, no input.
                        for &(v, col) in &p.uses {
                            if v as usize >= n {
                                return fail(
                                    key,
                                    format!(
                                        "column {col}: the mass matrix may depend on the coordinates only, not on `{}`",
                                        names.vars.get(v as usize).map_or("?", String::as_str)
                                    ),
                                );
                            }
                        }
                        r.push((p.root, key, Some(p)));
                    }
                    rows.push(r);
                }
                if forces.len() != n {
                    return fail(
                        "plant.forces",
                        format!("has {} entries for {n} coordinates; give one force per coordinate", forces.len()),
                    );
                }
                let mut f = Vec::with_capacity(n);
                for (i, src) in forces.iter().enumerate() {
                    f.push(parse(&mut g, &format!("plant.forces[{i}]"), src)?.root);
                }
                (rows, f, None)
            }
            Form::Lagrangian { lagrangian, generalized_forces } => {
                let l = parse(&mut g, "plant.lagrangian", lagrangian)?.root;
                if generalized_forces.len() != n {
                    return fail(
                        "plant.generalized_forces",
                        format!(
                            "has {} entries for {n} coordinates; give one generalized force per coordinate",
                            generalized_forces.len()
                        ),
                    );
                }
                let mut q = Vec::with_capacity(n);
                for (i, src) in generalized_forces.iter().enumerate() {
                    q.push(parse(&mut g, &format!("plant.generalized_forces[{i}]"), src)?.root);
                }
                // p_i = dL/dq'_i; M_ij = dp_i/dq'_j; f_i = Q_i + dL/dq_i - sum_j dp_i/dq_j q'_j.
                let p: Vec<Id> = (0..n).map(|i| g.diff(l, (n + i) as u16)).collect();
                let mut rows = Vec::with_capacity(n);
                for (i, &pi) in p.iter().enumerate() {
                    let mut r = Vec::with_capacity(n);
                    for j in 0..n {
                        let m = g.diff(pi, (n + j) as u16);
                        if g.deps(m) >> n != 0 {
                            return fail(
                                "plant.lagrangian",
                                format!(
                                    "d2L/d{}d{} depends on the velocities or the input: only kinetic energies \
                                     quadratic in the velocities are supported",
                                    names.vars.get(n + i).map_or("?", String::as_str),
                                    names.vars.get(n + j).map_or("?", String::as_str)
                                ),
                            );
                        }
                        r.push((m, "plant.lagrangian".to_string(), None));
                    }
                    rows.push(r);
                }
                let mut f = Vec::with_capacity(n);
                for (i, &pi) in p.iter().enumerate() {
                    let dl = g.diff(l, i as u16);
                    let mut fi = g.add(q.get(i).copied().unwrap_or(0), dl);
                    for j in 0..n {
                        let d = g.diff(pi, j as u16);
                        let v = g.var((n + j) as u16);
                        let t = g.mul(d, v);
                        fi = g.sub(fi, t);
                    }
                    f.push(fi);
                }
                let mut e = g.neg(l);
                for (i, &pi) in p.iter().enumerate() {
                    let v = g.var((n + i) as u16);
                    let t = g.mul(v, pi);
                    e = g.add(e, t);
                }
                (rows, f, Some(e))
            }
        };
        if g.too_large() {
            return fail(
                "plant",
                format!("the equations' expression graph exceeds {} nodes after differentiation", expr::MAX_NODES),
            );
        }
        let n_inputs = 2 * n + 1;
        let mut roots = Vec::with_capacity(n * (n + 1) / 2 + n);
        for i in 0..n {
            for j in i..n {
                roots.push(mass.get(i).and_then(|r| r.get(j)).map_or(0, |e| e.0));
            }
        }
        roots.extend_from_slice(&forces);
        let compile = |roots: &[Id]| {
            Tape::compile(&g, roots, n_inputs)
                .map_err(|e| EquationsError { key: "plant".into(), message: e.to_string() })
        };
        let tape = compile(&roots)?;
        let energy = match energy {
            Some(e) => Some(compile(&[e])?),
            None => None,
        };
        let mut jac_roots = roots.clone();
        for v in 0..2 * n {
            for &r in &roots {
                jac_roots.push(g.diff(r, v as u16));
            }
        }
        let jac_tape = if g.too_large() { None } else { Tape::compile(&g, &jac_roots, n_inputs).ok() };
        // Derivatives that are identically zero (no dependence): skipped by the Jacobian.
        let mut jac_zero = 0u128;
        for (k, &r) in jac_roots.iter().enumerate().skip(roots.len()) {
            if g.constant(r) == Some(0.0) {
                jac_zero |= 1u128.checked_shl(k as u32).unwrap_or(0);
            }
        }
        let equilibrium = match &spec.equilibrium {
            None => vec![0.0; n],
            Some(e) => {
                if e.len() != n {
                    return fail(
                        "plant.equilibrium",
                        format!("has {} values for {n} coordinates (one per coordinate, in order)", e.len()),
                    );
                }
                if let Some((i, v)) = e.iter().enumerate().find(|(_, v)| !v.is_finite()) {
                    return fail(format!("plant.equilibrium[{i}]"), format!("must be finite, got {v}"));
                }
                e.clone()
            }
        };
        let mut state_names = Vec::with_capacity(2 * n);
        for c in &spec.coordinates {
            state_names.push(intern(c));
            state_names.push(intern(&format!("{c}_dot")));
        }
        let mut equilibrium_pad = [0.0; MAX_COORDINATES];
        for (p, e) in equilibrium_pad.iter_mut().zip(&equilibrium) {
            *p = *e;
        }
        let block = roots.len();
        let mut jac_zero_cols = 0u8;
        for state in 0..2 * n {
            let base = jac_block_start(state, n, block);
            if (base..base + block).all(|k| jac_zero.checked_shr(k as u32).unwrap_or(0) & 1 == 1) {
                jac_zero_cols |= 1 << state;
            }
        }
        let model = Self {
            n,
            coordinates: spec.coordinates.clone(),
            state_names,
            tape,
            jac_tape,
            jac_zero,
            jac_zero_cols,
            energy,
            shifted: equilibrium.iter().any(|&e| e != 0.0),
            equilibrium,
            equilibrium_pad,
        };
        model.check_mass(&g, &mass)?;
        model.check_equilibrium(&spec.form)?;
        Ok(model)
    }

    /// Number of generalized coordinates.
    pub fn coordinates(&self) -> usize {
        self.n
    }

    /// Names of the generalized coordinates, in order.
    pub fn coordinate_names(&self) -> &[String] {
        &self.coordinates
    }

    /// The compiled tape (mass upper triangle, then forces).
    pub fn tape(&self) -> &Tape {
        &self.tape
    }

    /// The compiled Jacobian tape (the values, then their derivatives by each state), if
    /// the derivatives stayed within the graph's limits.
    pub fn jac_tape(&self) -> Option<&Tape> {
        self.jac_tape.as_ref()
    }

    pub fn equilibrium(&self) -> &[f64] {
        &self.equilibrium
    }

    /// The coordinates' values at grid point `k` of the mass check (only the coordinates
    /// the mass matrix depends on vary).
    fn describe_point(&self, q: &[f64]) -> String {
        self.coordinates.iter().zip(q).map(|(c, v)| format!("{c} = {v:.4}")).collect::<Vec<_>>().join(", ")
    }

    /// Mass matrix checks over the grid: symmetric (mass form), positive definite, and its
    /// determinant not below `1e-9` of the product of its diagonal (Hadamard's bound: the
    /// ratio is 1 for a diagonal matrix and 0 for a singular one), as the built-in plants
    /// check `Delta`.
    fn check_mass(&self, g: &Graph, mass: &[Vec<(Id, String, Option<Parsed>)>]) -> Result<(), EquationsError> {
        let n = self.n;
        let mut dep = 0u32;
        for row in mass {
            for e in row {
                dep |= g.deps(e.0);
            }
        }
        let varying: Vec<usize> = (0..n).filter(|&i| dep & (1 << i) != 0).collect();
        let points = MASS_GRID.pow(varying.len() as u32);
        let mut lower = Vec::new();
        for (i, row) in mass.iter().enumerate() {
            for (j, e) in row.iter().enumerate() {
                if j < i {
                    lower.push((i, j, e.0, e.1.clone()));
                }
            }
        }
        let lower_roots: Vec<Id> = lower.iter().map(|e| e.2).collect();
        let lower_tape = Tape::compile(g, &lower_roots, 2 * n + 1)
            .map_err(|e| EquationsError { key: "plant.mass".into(), message: e.to_string() })?;
        let key = match mass.first().and_then(|r| r.first()) {
            Some((_, _, Some(_))) => "plant.mass",
            _ => "plant.lagrangian",
        };
        let what = if key == "plant.mass" { "the mass matrix" } else { "d2L/dqdot2 (the mass matrix)" };
        for k in 0..points {
            let mut q = self.equilibrium.clone();
            let mut rest = k;
            for &i in &varying {
                let step = rest % MASS_GRID;
                rest /= MASS_GRID;
                let angle = -std::f64::consts::PI + 2.0 * std::f64::consts::PI * step as f64 / (MASS_GRID - 1) as f64;
                if let Some(v) = q.get_mut(i) {
                    *v += angle;
                }
            }
            let mut inputs = vec![0.0; 2 * n + 1];
            inputs.get_mut(..n).unwrap_or_default().copy_from_slice(&q);
            let out = self.tape.eval_f64(&inputs);
            let m = |i: usize, j: usize| -> f64 {
                let (a, b) = if i <= j { (i, j) } else { (j, i) };
                out.get(upper_index(n, a, b)).copied().unwrap_or(f64::NAN)
            };
            if !lower.is_empty() {
                let lo = lower_tape.eval_f64(&inputs);
                for ((i, j, _, lkey), v) in lower.iter().zip(&lo) {
                    let u = m(*j, *i);
                    if !(v.is_finite() && u.is_finite()) {
                        return fail(
                            lkey.clone(),
                            format!(
                                "{what} is not finite at {}: M[{j}][{i}] = {u}, M[{i}][{j}] = {v}",
                                self.describe_point(&q)
                            ),
                        );
                    }
                    if (v - u).abs() > 1e-12 * (v.abs() + u.abs()) && (v - u).abs() > 1e-300 {
                        return fail(
                            lkey.clone(),
                            format!(
                                "{what} is not symmetric: M[{i}][{j}] = {v:e} but M[{j}][{i}] = {u:e} at {}",
                                self.describe_point(&q)
                            ),
                        );
                    }
                }
            }
            // Cholesky: positive definite, and the determinant against the diagonal.
            let mut l = vec![0.0; n * n];
            let mut det = 1.0;
            let mut diag = 1.0;
            for i in 0..n {
                let mii = m(i, i);
                if !mii.is_finite() {
                    return fail(key, format!("{what} has M[{i}][{i}] = {mii} at {}", self.describe_point(&q)));
                }
                diag *= mii;
                for j in 0..=i {
                    let mut s = m(i, j);
                    for k2 in 0..j {
                        s -= l.get(i * n + k2).copied().unwrap_or(0.0) * l.get(j * n + k2).copied().unwrap_or(0.0);
                    }
                    if i == j {
                        if !(s > 0.0) {
                            return fail(
                                key,
                                format!(
                                    "{what} is singular or not positive definite at {} (pivot {i} of its Cholesky \
                                     factorization is {s:e}); a mass matrix must be positive definite",
                                    self.describe_point(&q)
                                ),
                            );
                        }
                        det *= s;
                        if let Some(x) = l.get_mut(i * n + i) {
                            *x = s.sqrt();
                        }
                    } else {
                        let d = l.get(j * n + j).copied().unwrap_or(f64::NAN);
                        if let Some(x) = l.get_mut(i * n + j) {
                            *x = s / d;
                        }
                    }
                }
            }
            if det < 1e-9 * diag {
                return fail(
                    key,
                    format!(
                        "{what} is nearly singular at {}: its determinant {det:e} is below 1e-9 of the product of \
                         its diagonal terms ({diag:e})",
                        self.describe_point(&q)
                    ),
                );
            }
        }
        Ok(())
    }

    /// At the equilibrium at rest with `u = 0`: every output finite, the forces zero (to
    /// rounding against their derivatives), and the Jacobian finite.
    fn check_equilibrium(&self, form: &Form) -> Result<(), EquationsError> {
        let n = self.n;
        let force_key = |i: usize| match form {
            Form::Mass { .. } => format!("plant.forces[{i}]"),
            Form::Lagrangian { .. } => format!("plant.generalized_forces[{i}] (with the Lagrangian's terms)"),
        };
        let at = self.describe_point(&self.equilibrium);
        let mut inputs = vec![crate::plant::Dual::<9>::cst(0.0); 2 * n + 1];
        for (i, v) in inputs.iter_mut().enumerate() {
            let base = if i < n { self.equilibrium.get(i).copied().unwrap_or(0.0) } else { 0.0 };
            *v = crate::plant::Dual::var(base, i);
        }
        let mut regs = vec![crate::plant::Dual::<9>::cst(0.0); self.tape.n_regs()];
        self.tape.eval(&inputs, &mut regs);
        let nm = n * (n + 1) / 2;
        for (k, &o) in self.tape.outputs().iter().enumerate() {
            let v = regs.get(o as usize).copied().unwrap_or(crate::plant::Dual::cst(f64::NAN));
            let key = if k < nm {
                match form {
                    Form::Mass { .. } => "plant.mass".to_string(),
                    Form::Lagrangian { .. } => "plant.lagrangian".to_string(),
                }
            } else {
                force_key(k - nm)
            };
            if !v.v.is_finite() {
                return fail(key, format!("is {} (not finite) at the equilibrium ({at}, at rest, u = 0)", v.v));
            }
            if let Some(d) = v.d.iter().take(2 * n + 1).find(|d| !d.is_finite()) {
                return fail(
                    key,
                    format!("has a derivative {d} (not finite) at the equilibrium ({at}, at rest, u = 0)"),
                );
            }
            if k >= nm {
                let scale: f64 = v.d.iter().take(2 * n + 1).map(|d| d.abs()).sum();
                if !(v.v.abs() <= 1e-10 * scale) && v.v != 0.0 {
                    return fail(
                        key,
                        format!(
                            "is {:e} at rest at the equilibrium ({at}, u = 0), not zero: the plant would not stay \
                             there; name the equilibrium to stabilize with `plant.equilibrium = [...]` (one value \
                             per coordinate)",
                            v.v
                        ),
                    );
                }
            }
        }
        Ok(())
    }

    /// The tape's inputs at state `x`: the coordinates (deviation plus equilibrium), the
    /// velocities, `u` (`2n + 1` of the 9 slots; the loops run over the `N / 2`
    /// coordinates the state has, a constant).
    #[inline(always)]
    fn inputs<S: Scalar, const N: usize>(&self, x: &[S; N], u: S) -> [S; 9] {
        let n = N / 2;
        let nan = S::cst(f64::NAN);
        let mut inputs = [S::cst(0.0); 9];
        for i in 0..n {
            let q = x.get(2 * i).copied().unwrap_or(nan);
            let e = self.equilibrium_pad.get(i).copied().unwrap_or(0.0);
            if let Some(s) = inputs.get_mut(i) {
                *s = if e == 0.0 { q } else { q + e };
            }
            if let Some(s) = inputs.get_mut(n + i) {
                *s = x.get(2 * i + 1).copied().unwrap_or(nan);
            }
        }
        if let Some(s) = inputs.get_mut(2 * n) {
            *s = u;
        }
        inputs
    }

    /// [`Self::inputs`] for `f64`, written into the tape's first `2C + 1` registers.
    #[inline(always)]
    fn load_f64<const N: usize, const C: usize>(&self, regs: &mut [f64], x: &[f64; N], u: f64) {
        let (q, rest) = regs.split_at_mut(C.min(regs.len()));
        let (v, rest) = rest.split_at_mut(C.min(rest.len()));
        if self.shifted {
            for ((s, pair), e) in q.iter_mut().zip(x.chunks_exact(2)).zip(&self.equilibrium_pad) {
                let xq = pair.first().copied().unwrap_or(f64::NAN);
                *s = if *e == 0.0 { xq } else { xq + e };
            }
        } else {
            for (s, pair) in q.iter_mut().zip(x.chunks_exact(2)) {
                *s = pair.first().copied().unwrap_or(f64::NAN);
            }
        }
        for (s, pair) in v.iter_mut().zip(x.chunks_exact(2)) {
            *s = pair.get(1).copied().unwrap_or(f64::NAN);
        }
        if let Some(s) = rest.first_mut() {
            *s = u;
        }
    }

    /// [`Self::rhs`] for `f64` and `C` coordinates, `K = C (C + 1) / 2 + C` tape outputs:
    /// the same operations on the same operands in the same order as the generic path,
    /// without its bookkeeping (no input array, the outputs read at once, the solve by
    /// [`lu_factor`] and [`lu_apply`], which [`solve_small`] equals to the bit).
    #[inline(always)]
    fn rhs_f64<const N: usize, const C: usize, const K: usize>(&self, x: &[f64; N], u: f64) -> [f64; N] {
        const { assert!(K == C * (C + 1) / 2 + C, "K is the value tape's output count") };
        // The outputs read where the tape left them (no copy), as in `jacobian_c`.
        self.tape.eval_loaded(
            |regs| self.load_f64::<N, C>(regs, x, u),
            |e| match e.outputs_fixed::<K>() {
                Some(o) => Self::rhs_f64_from::<N, C>(|k| o.get(k), x),
                None => Self::rhs_f64_from::<N, C>(|_| f64::NAN, x),
            },
        )
    }

    /// [`Self::rhs_f64`] from the evaluated value tape's outputs, `out(k)`.
    #[inline(always)]
    fn rhs_f64_from<const N: usize, const C: usize>(out: impl Fn(usize) -> f64, x: &[f64; N]) -> [f64; N] {
        let mut lu = [[0.0; C]; C];
        for (i, row) in lu.iter_mut().enumerate() {
            for (j, s) in row.iter_mut().enumerate() {
                let (p, q) = if i <= j { (i, j) } else { (j, i) };
                *s = out(upper_index(C, p, q));
            }
        }
        let mut qdd = [0.0; C];
        for (i, s) in qdd.iter_mut().enumerate() {
            *s = out(C * (C + 1) / 2 + i);
        }
        let perm = lu_factor(&mut lu);
        lu_apply(&lu, &perm, &mut qdd);
        let mut out = [0.0; N];
        for ((o, pair), a) in out.chunks_exact_mut(2).zip(x.chunks_exact(2)).zip(qdd) {
            if let ([d0, d1], [_, v]) = (o, pair) {
                *d0 = *v;
                *d1 = a;
            }
        }
        out
    }

    /// `dx/dt` for `N = 2n` states (`N` is checked by [`EquationsPlant::new`]).
    #[inline]
    fn rhs<S: Scalar, const N: usize>(&self, x: &[S; N], u: S) -> [S; N] {
        let n = N / 2;
        if S::IS_F64 {
            // `re` and `cst` are identities for `f64`.
            let xf = x.map(S::re);
            let out = match n {
                1 => self.rhs_f64::<N, 1, 2>(&xf, u.re()),
                2 => self.rhs_f64::<N, 2, 5>(&xf, u.re()),
                3 => self.rhs_f64::<N, 3, 9>(&xf, u.re()),
                _ => self.rhs_f64::<N, 4, 14>(&xf, u.re()),
            };
            return out.map(S::cst);
        }
        let inputs = self.inputs(x, u);
        let mut out = [S::cst(0.0); N];
        // q'': small scalars on the stack, the solve unrolled for the coordinate count; a
        // power series (kilobytes) through a heap scratch.
        let mut qdd = [S::cst(f64::NAN); MAX_COORDINATES];
        if core::mem::size_of::<S>() <= 128 {
            qdd = self.tape.eval_with(&inputs, |e| match n {
                1 => solve_small::<S, 1>(e),
                2 => solve_small::<S, 2>(e),
                3 => solve_small::<S, 3>(e),
                _ => solve_small::<S, 4>(e),
            });
        } else {
            let nm = n * (n + 1) / 2;
            let mut scratch = vec![S::cst(0.0); nm + n + n * n];
            let (outs, a) = scratch.split_at_mut(nm + n);
            self.tape.eval_outputs(inputs.get(..2 * n + 1).unwrap_or_default(), outs);
            for i in 0..n {
                for j in 0..n {
                    let (p, q) = if i <= j { (i, j) } else { (j, i) };
                    if let Some(s) = a.get_mut(i * n + j) {
                        *s = outs.get(upper_index(n, p, q)).copied().unwrap_or(S::cst(f64::NAN));
                    }
                }
            }
            let (_, b) = outs.split_at_mut(nm.min(outs.len()));
            lu_solve(a, b, n);
            for (d, s) in qdd.iter_mut().zip(b.iter()) {
                *d = *s;
            }
        }
        for i in 0..n {
            if let Some(s) = out.get_mut(2 * i) {
                *s = inputs.get(n + i).copied().unwrap_or(S::cst(f64::NAN));
            }
            if let Some(s) = out.get_mut(2 * i + 1) {
                *s = qdd.get(i).copied().unwrap_or(S::cst(f64::NAN));
            }
        }
        out
    }

    /// `f(x, u)` and `df/dx` in `f64` from the symbolic derivatives of `M` and `f`:
    /// `q'' = M^-1 f`, `dq''/dx_k = M^-1 (df/dx_k - dM/dx_k q'')`; `f` is [`rhs`]'s to the
    /// bit. `jt` is the Jacobian tape.
    #[inline(always)]
    fn jacobian<const N: usize>(&self, jt: &Tape, x: &[f64; N], u: f64) -> ([f64; N], [[f64; N]; N]) {
        let mut f = [0.0; N];
        let mut jac = [[0.0; N]; N];
        // `N = 2n`: the coordinate count is the state's, known at compile time.
        // `K`: the tape's outputs, `(C (C + 1) / 2 + C) (2C + 1)`.
        match N / 2 {
            1 => self.jacobian_c::<N, 1, 6>(jt, x, u, &mut f, &mut jac),
            2 => self.jacobian_c::<N, 2, 25>(jt, x, u, &mut f, &mut jac),
            3 => self.jacobian_c::<N, 3, 63>(jt, x, u, &mut f, &mut jac),
            _ => self.jacobian_c::<N, 4, 126>(jt, x, u, &mut f, &mut jac),
        }
        (f, jac)
    }

    /// [`Self::jacobian`] for `C = n` coordinates (the loops unrolled), into `f` and `jac`
    /// (zero on entry).
    #[inline(always)]
    fn jacobian_c<const N: usize, const C: usize, const K: usize>(
        &self,
        jt: &Tape,
        x: &[f64; N],
        u: f64,
        f: &mut [f64; N],
        jac: &mut [[f64; N]; N],
    ) {
        const { assert!(K == (C * (C + 1) / 2 + C) * (2 * C + 1), "K is the Jacobian tape's output count") };
        // The outputs read where the tape left them (no copy); a tape with fewer outputs
        // (never compiled so) gives NaN.
        jt.eval_loaded(
            |regs| self.load_f64::<N, C>(regs, x, u),
            |e| match e.outputs_fixed::<K>() {
                Some(o) => self.jacobian_from::<N, C>(|k| o.get(k), x, f, jac),
                None => self.jacobian_from::<N, C>(|_| f64::NAN, x, f, jac),
            },
        )
    }

    /// [`Self::jacobian_c`] from the evaluated Jacobian tape's outputs, `out(k)`.
    #[inline(always)]
    fn jacobian_from<const N: usize, const C: usize>(
        &self,
        out: impl Fn(usize) -> f64,
        x: &[f64; N],
        f: &mut [f64; N],
        jac: &mut [[f64; N]; N],
    ) {
        let nan = f64::NAN;
        let nm = C * (C + 1) / 2;
        let block = nm + C;
        let zero = |k: usize| self.jac_zero.checked_shr(k as u32).unwrap_or(0) & 1 == 1;
        // M factored once; q'' and every column solved with the factors (the same
        // arithmetic as `solve_small`, so q'' is the right-hand side's to the bit).
        let mut lu = [[0.0; C]; C];
        for (i, row) in lu.iter_mut().enumerate() {
            for (j, s) in row.iter_mut().enumerate() {
                let (p, q) = if i <= j { (i, j) } else { (j, i) };
                *s = out(upper_index(C, p, q));
            }
        }
        let perm = lu_factor(&mut lu);
        let mut qdd = [0.0; C];
        for (i, s) in qdd.iter_mut().enumerate() {
            *s = out(nm + i);
        }
        lu_apply(&lu, &perm, &mut qdd);
        for i in 0..C {
            if let Some(s) = f.get_mut(2 * i) {
                *s = x.get(2 * i + 1).copied().unwrap_or(nan);
            }
            if let Some(s) = f.get_mut(2 * i + 1) {
                *s = qdd.get(i).copied().unwrap_or(nan);
            }
            // d(q'_i)/dx: 1 at the velocity's own state.
            if let Some(s) = jac.get_mut(2 * i).and_then(|r| r.get_mut(2 * i + 1)) {
                *s = 1.0;
            }
        }
        for state in 0..N {
            let base = jac_block_start(state, C, block);
            // A state neither M nor f depends on: a zero column.
            if self.jac_zero_cols >> state & 1 == 1 {
                continue;
            }
            let mut c = [0.0; C];
            for (i, ci) in c.iter_mut().enumerate() {
                let mut s = if zero(base + nm + i) { 0.0 } else { out(base + nm + i) };
                for (j, qj) in qdd.iter().enumerate() {
                    let (p, q) = if i <= j { (i, j) } else { (j, i) };
                    let k = base + upper_index(C, p, q);
                    if !zero(k) {
                        s -= out(k) * qj;
                    }
                }
                *ci = s;
            }
            lu_apply(&lu, &perm, &mut c);
            for (i, ci) in c.iter().enumerate() {
                if let Some(s) = jac.get_mut(2 * i + 1).and_then(|r| r.get_mut(state)) {
                    *s = *ci;
                }
            }
        }
    }
}

/// First output of the Jacobian tape's block for `state` (`q_i` at `2i`, `q'_i` at `2i + 1`)
/// with `n` coordinates: the value block (`M`'s upper triangle, then `f`) comes first, then one
/// block of `block` derivatives per tape input (`q` then `q'`).
fn jac_block_start(state: usize, n: usize, block: usize) -> usize {
    let input = if state % 2 == 0 { state / 2 } else { n + state / 2 };
    (1 + input) * block
}

/// Index of `M[a][b]` (`a <= b`) in the upper triangle stored row by row.
#[doc(hidden)]
pub fn upper_index(n: usize, a: usize, b: usize) -> usize {
    a * n - a * a.saturating_sub(1) / 2 - a + b
}

/// `M q'' = f` for `C` coordinates from the tape's outputs (`M`'s upper triangle, then
/// `f`): LU with partial pivoting on the values, [`lu_solve`]'s arithmetic in its order
/// (so every scalar type gets its values), on arrays of the coordinate count.
#[inline(always)]
fn solve_small<S: Scalar, const C: usize>(outs: &Evaluated<'_, S>) -> [S; MAX_COORDINATES] {
    let nan = S::cst(f64::NAN);
    let nm = C * (C + 1) / 2;
    let mut a = [[nan; C]; C];
    for (i, row) in a.iter_mut().enumerate() {
        for (j, s) in row.iter_mut().enumerate() {
            let (p, q) = if i <= j { (i, j) } else { (j, i) };
            *s = outs.output(upper_index(C, p, q));
        }
    }
    let mut b = [nan; C];
    for (i, s) in b.iter_mut().enumerate() {
        *s = outs.output(nm + i);
    }
    let at = |a: &[[S; C]; C], i: usize, j: usize| a.get(i).and_then(|r| r.get(j)).copied().unwrap_or(nan);
    for k in 0..C {
        let mut p = k;
        let mut best = at(&a, k, k).re().abs();
        for i in k + 1..C {
            let v = at(&a, i, k).re().abs();
            if v > best {
                best = v;
                p = i;
            }
        }
        if p != k {
            a.swap(k, p);
            b.swap(k, p);
        }
        let piv = at(&a, k, k);
        let bk = b.get(k).copied().unwrap_or(nan);
        for i in k + 1..C {
            let l = at(&a, i, k) / piv;
            for j in k + 1..C {
                let v = at(&a, i, j).sub_ref(&l.mul_ref(&at(&a, k, j)));
                if let Some(s) = a.get_mut(i).and_then(|r| r.get_mut(j)) {
                    *s = v;
                }
            }
            if let Some(s) = b.get_mut(i) {
                *s = s.sub_ref(&l.mul_ref(&bk));
            }
        }
    }
    let mut x = [nan; MAX_COORDINATES];
    for k in (0..C).rev() {
        let mut s = b.get(k).copied().unwrap_or(nan);
        for j in k + 1..C {
            s = s.sub_ref(&at(&a, k, j).mul_ref(&x.get(j).copied().unwrap_or(nan)));
        }
        if let Some(d) = x.get_mut(k) {
            *d = s / at(&a, k, k);
        }
    }
    x
}

/// [`solve_small`]'s elimination of `a` alone: the multipliers stored below the diagonal,
/// the pivot row of each step returned.
#[inline(always)]
fn lu_factor<const C: usize>(a: &mut [[f64; C]; C]) -> [usize; C] {
    let mut perm = [0usize; C];
    let at = |a: &[[f64; C]; C], i: usize, j: usize| a.get(i).and_then(|r| r.get(j)).copied().unwrap_or(f64::NAN);
    for k in 0..C {
        let mut p = k;
        let mut best = at(a, k, k).abs();
        for i in k + 1..C {
            let v = at(a, i, k).abs();
            if v > best {
                best = v;
                p = i;
            }
        }
        if let Some(s) = perm.get_mut(k) {
            *s = p;
        }
        // Columns from `k` on only: the multipliers of earlier steps stay with the rows they
        // were computed for, as `lu_apply` reads them in its interleaved order.
        // The swap with the pivot row `p > k` by constant indices (a comparison with each
        // candidate row): no run-time indexing once the loops unroll.
        for r in k + 1..C {
            if r != p {
                continue;
            }
            for j in k..C {
                let (x, y) = (at(a, k, j), at(a, r, j));
                if let Some(s) = a.get_mut(k).and_then(|row| row.get_mut(j)) {
                    *s = y;
                }
                if let Some(s) = a.get_mut(r).and_then(|row| row.get_mut(j)) {
                    *s = x;
                }
            }
        }
        let piv = at(a, k, k);
        for i in k + 1..C {
            let l = at(a, i, k) / piv;
            for j in k + 1..C {
                let v = at(a, i, j) - l * at(a, k, j);
                if let Some(s) = a.get_mut(i).and_then(|r| r.get_mut(j)) {
                    *s = v;
                }
            }
            if let Some(s) = a.get_mut(i).and_then(|r| r.get_mut(k)) {
                *s = l;
            }
        }
    }
    perm
}

/// Solves `A x = b` in place with the factors of [`lu_factor`], in [`solve_small`]'s order
/// of operations (so the result is its to the bit).
#[inline(always)]
fn lu_apply<const C: usize>(a: &[[f64; C]; C], perm: &[usize; C], b: &mut [f64; C]) {
    let at = |i: usize, j: usize| a.get(i).and_then(|r| r.get(j)).copied().unwrap_or(f64::NAN);
    for k in 0..C {
        let p = perm.get(k).copied().unwrap_or(k);
        // As in `lu_factor`: the swap by constant indices.
        for r in k + 1..C {
            if r == p {
                b.swap(k, r);
            }
        }
        let bk = b.get(k).copied().unwrap_or(f64::NAN);
        for i in k + 1..C {
            if let Some(s) = b.get_mut(i) {
                *s -= at(i, k) * bk;
            }
        }
    }
    for k in (0..C).rev() {
        let mut s = b.get(k).copied().unwrap_or(f64::NAN);
        for j in k + 1..C {
            s -= at(k, j) * b.get(j).copied().unwrap_or(f64::NAN);
        }
        if let Some(x) = b.get_mut(k) {
            *x = s / at(k, k);
        }
    }
}

/// Solves `A x = b` in place (`b` becomes `x`) by LU with partial pivoting on the values:
/// [`solve_small`] on slices, for scalars too large for the stack.
#[doc(hidden)]
pub fn lu_solve<S: Scalar>(a: &mut [S], b: &mut [S], n: usize) {
    let nan = S::cst(f64::NAN);
    let at = |a: &[S], i: usize, j: usize| a.get(i * n + j).copied().unwrap_or(nan);
    for k in 0..n {
        let mut p = k;
        let mut best = at(a, k, k).re().abs();
        for i in k + 1..n {
            let v = at(a, i, k).re().abs();
            if v > best {
                best = v;
                p = i;
            }
        }
        if p != k {
            for j in 0..n {
                a.swap(k * n + j, p * n + j);
            }
            b.swap(k, p);
        }
        let piv = at(a, k, k);
        for i in k + 1..n {
            let l = at(a, i, k) / piv;
            for j in k + 1..n {
                let v = at(a, i, j).sub_ref(&l.mul_ref(&at(a, k, j)));
                if let Some(s) = a.get_mut(i * n + j) {
                    *s = v;
                }
            }
            let bk = b.get(k).copied().unwrap_or(nan);
            if let Some(s) = b.get_mut(i) {
                *s = s.sub_ref(&l.mul_ref(&bk));
            }
        }
    }
    for k in (0..n).rev() {
        let mut s = b.get(k).copied().unwrap_or(nan);
        for j in k + 1..n {
            s = s.sub_ref(&at(a, k, j).mul_ref(&b.get(j).copied().unwrap_or(nan)));
        }
        if let Some(x) = b.get_mut(k) {
            *x = s / at(a, k, k);
        }
    }
}

fn expr_error(key: &str, src: &str, e: &ExprError) -> EquationsError {
    EquationsError { key: key.into(), message: format!("{e} in \"{src}\"") }
}

/// The variables (coordinates, velocities, `u`) and parameters of a spec, with the names
/// checked: identifiers, distinct, no function names.
fn names(spec: &EquationsSpec) -> Result<Names, EquationsError> {
    let mut vars: Vec<String> = spec.coordinates.clone();
    for (i, c) in spec.coordinates.iter().enumerate() {
        let key = format!("plant.coordinates[{i}]");
        if !expr::is_identifier(c) {
            return fail(key, format!("`{c}` is not a name (letters, digits and `_`, not starting with a digit)"));
        }
        if expr::is_function(c) || c == "u" {
            return fail(key, format!("`{c}` is reserved (a function or the input `u`)"));
        }
    }
    for c in &spec.coordinates {
        vars.push(format!("{c}_dot"));
    }
    vars.push("u".into());
    for (i, a) in vars.iter().enumerate() {
        if vars.iter().skip(i + 1).any(|b| b == a) {
            return fail(
                "plant.coordinates",
                format!("the name `{a}` occurs twice among the coordinates and velocities"),
            );
        }
    }
    for (p, v) in &spec.parameters {
        let key = format!("plant.parameters.{p}");
        if !expr::is_identifier(p) {
            return fail(key, format!("`{p}` is not a name (letters, digits and `_`, not starting with a digit)"));
        }
        if expr::is_function(p) {
            return fail(key, format!("`{p}` is a function name"));
        }
        if vars.contains(p) {
            return fail(key, format!("`{p}` is also a coordinate, a velocity or the input `u`"));
        }
        if !v.is_finite() {
            return fail(key, format!("must be finite, got {v}"));
        }
    }
    Ok(Names { vars, params: spec.parameters.clone() })
}

/// A plant written as equations with `N = 2n` states.
#[derive(Clone, Debug)]
pub struct EquationsPlant<const N: usize> {
    model: Arc<EquationsModel>,
}

impl<const N: usize> EquationsPlant<N> {
    /// The plant of a model with `N / 2` coordinates, `None` if the counts differ.
    pub fn new(model: Arc<EquationsModel>) -> Option<Self> {
        (2 * model.n == N).then_some(Self { model })
    }

    pub fn model(&self) -> &EquationsModel {
        &self.model
    }
}

impl<const N: usize> Plant<N> for EquationsPlant<N> {
    /// The first coordinate.
    const PRIMARY: usize = 0;
    /// The second coordinate; with one coordinate, its velocity (a controller with no gain
    /// on the secondary angle reads it and ignores it).
    const SECONDARY: usize = if N >= 4 { 2 } else { 1 };

    fn name(&self) -> &'static str {
        "equations"
    }

    fn state_names(&self) -> [&'static str; N] {
        core::array::from_fn(|i| self.model.state_names.get(i).copied().unwrap_or("?"))
    }

    #[inline]
    fn rhs<S: Scalar>(&self, x: &[S; N], u: S) -> [S; N] {
        self.model.rhs(x, u)
    }

    /// From the compiled symbolic derivatives (one `f64` tape and `2n + 1` small solves),
    /// else from dual numbers.
    fn exact_jacobian(&self, x: &[f64; N], u: f64) -> ([f64; N], [[f64; N]; N]) {
        match self.model.jac_tape.as_ref() {
            Some(jt) => self.model.jacobian(jt, x, u),
            None => crate::plant::linearize::dual_jacobian(self, x, u),
        }
    }

    /// The Lagrangian form's energy function `sum q'_i dL/dq'_i - L`; NaN for the
    /// mass-matrix form, which does not give the potential.
    fn energy(&self, x: &[f64; N]) -> f64 {
        let Some(t) = &self.model.energy else { return f64::NAN };
        let n = self.model.n;
        let mut inputs = vec![0.0; 2 * n + 1];
        for i in 0..n {
            if let Some(s) = inputs.get_mut(i) {
                *s = x.get(2 * i).copied().unwrap_or(f64::NAN) + self.model.equilibrium.get(i).copied().unwrap_or(0.0);
            }
            if let Some(s) = inputs.get_mut(n + i) {
                *s = x.get(2 * i + 1).copied().unwrap_or(f64::NAN);
            }
        }
        t.eval_f64(&inputs).first().copied().unwrap_or(f64::NAN)
    }
}

/// The mass-matrix layout and the LU solve of the right-hand side, public only for the
/// crate's tests (`tests/plant/equations.rs`): not part of the API.
#[doc(hidden)]
pub mod internals {
    pub use super::{lu_solve, upper_index};
}
