//! Expressions of a plant written as equations: a lexer and Pratt parser with column
//! positions, a hash-consed expression graph with constant folding and symbolic
//! differentiation (for the Lagrangian form), and compilation of a set of expressions to one
//! flat instruction tape ([`Tape`]) evaluated generically over [`Scalar`](crate::scalar::Scalar) (`f64`, dual
//! numbers for exact Jacobians, truncated power series for the equation-driven SSM).
//!
//! Why hand-written: the expression crates (`meval`, `fasteval`, `evalexpr`) evaluate in
//! `f64` only, have no symbolic derivative and report positions loosely; what a plant needs
//! (one grammar, derivatives, evaluation over any [`Scalar`](crate::scalar::Scalar), shared subexpressions between
//! the mass matrix and the forces) is a few hundred lines on top of `std`.
//!
//! Grammar: numbers (`2`, `0.5`, `1e-3`), names (parameters, coordinates, `<coord>_dot`,
//! `u`, resolved by the caller's [`Names`]), `+ - * / ^` (`^` right-associative and binding
//! tighter than unary minus: `-x^2 = -(x^2)`), parentheses and the functions
//! `sin cos tan exp log sqrt abs tanh atan2 min max`. Parameters are constants: they are
//! folded into the graph when an expression is parsed.
// Parses untrusted input: no indexing that can panic (CI runs clippy).
#![cfg_attr(not(test), deny(clippy::indexing_slicing))]

#[cfg(target_arch = "x86_64")]
mod native;
/// Where there is no code generator, no tape has native code.
#[cfg(not(target_arch = "x86_64"))]
mod native {
    #[derive(Debug, PartialEq)]
    pub(super) enum Native {}

    impl Native {
        pub(super) fn compile(_: &[super::Instr], _: usize, _: &[u16]) -> Option<Native> {
            None
        }

        pub(super) fn run(&self, _: &mut [f64]) -> bool {
            match *self {}
        }
    }
}
mod tape;
pub use tape::{Evaluated, Instr, MAX_REGS, Op, Outputs, Tape, TapeError};

use std::collections::HashMap;

/// Switches and constructors of the tape compiler, public only for the crate's tests
/// (`tests/expr/`, `tests/plant/`): not part of the API.
#[doc(hidden)]
pub mod internals {
    pub use super::tape::{WITHOUT_CHAIN_FUSION, WITHOUT_NATIVE};
}

/// Runs `f` with every tape it compiles (in this thread) interpreted, without native code:
/// for comparisons of the two (benchmarks, tests). The values are the same bit for bit.
pub fn interpreted<T>(f: impl FnOnce() -> T) -> T {
    /// Restores the switch, also when `f` panics.
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            tape::WITHOUT_NATIVE.with(|c| c.set(self.0));
        }
    }
    let _restore = Restore(tape::WITHOUT_NATIVE.with(|c| c.replace(true)));
    f()
}

/// Longest expression accepted, in characters.
pub const MAX_EXPR_LEN: usize = 4000;
/// Deepest nesting of parentheses, unary minus and function calls accepted.
pub const MAX_DEPTH: usize = 64;
/// Largest expression graph (after symbolic differentiation) accepted, in nodes.
pub const MAX_NODES: usize = 100_000;
/// Largest variable count of a graph (coordinates, velocities and the input).
pub const MAX_VARS: usize = 16;

/// A bad expression: the 1-based column (in characters) and what is wrong there.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("column {col}: {message}")]
pub struct ExprError {
    pub col: usize,
    pub message: String,
}

fn err<T>(col: usize, message: impl Into<String>) -> Result<T, ExprError> {
    Err(ExprError { col, message: message.into() })
}

/// Index of a node in a [`Graph`].
pub type Id = u32;

/// A function of one argument.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum F1 {
    Sin,
    Cos,
    Tan,
    Exp,
    Log,
    Sqrt,
    Abs,
    Tanh,
    /// `-1, 0, 1` (the derivative of `abs`; not in the language).
    Sign,
}

impl F1 {
    fn eval(self, x: f64) -> f64 {
        match self {
            F1::Sin => x.sin(),
            F1::Cos => x.cos(),
            F1::Tan => x.tan(),
            F1::Exp => x.exp(),
            F1::Log => x.ln(),
            F1::Sqrt => x.sqrt(),
            F1::Abs => x.abs(),
            F1::Tanh => x.tanh(),
            F1::Sign => sign(x),
        }
    }
}

fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// A node of the expression graph; operands are earlier nodes, so node order is a
/// topological order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// A constant (its bits, so that nodes hash).
    Const(u64),
    /// Input variable `k`.
    Var(u16),
    Add(Id, Id),
    Sub(Id, Id),
    Mul(Id, Id),
    Div(Id, Id),
    Neg(Id),
    /// An integer power.
    PowI(Id, i32),
    /// A real constant power (its bits).
    PowC(Id, u64),
    Fn1(F1, Id),
    Atan2(Id, Id),
    /// `if re(a) <= re(b) { t } else { f }`: `min`, `max` and their derivatives.
    Sel(Id, Id, Id, Id),
}

/// Hash-consed expression graph: equal subexpressions are one node, so the tape computes
/// them once (a `sin(theta)` shared by the mass matrix and the forces is one instruction).
#[derive(Clone, Debug, Default)]
pub struct Graph {
    nodes: Vec<Node>,
    /// Bit mask of the variables each node depends on.
    deps: Vec<u32>,
    index: HashMap<Node, Id>,
    too_large: bool,
}

impl Graph {
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// True once an operation would have grown the graph past [`MAX_NODES`] (the
    /// operations then return node 0; callers check this before using the result).
    pub fn too_large(&self) -> bool {
        self.too_large
    }

    pub fn node(&self, id: Id) -> Option<Node> {
        self.nodes.get(id as usize).copied()
    }

    /// Bit mask of the variables `id` depends on.
    pub fn deps(&self, id: Id) -> u32 {
        self.deps.get(id as usize).copied().unwrap_or(0)
    }

    fn push(&mut self, n: Node) -> Id {
        if let Some(&id) = self.index.get(&n) {
            return id;
        }
        if self.nodes.len() >= MAX_NODES {
            self.too_large = true;
            return 0;
        }
        let d = |id: Id| self.deps(id);
        let mask = match n {
            Node::Const(_) => 0,
            Node::Var(k) => 1u32.checked_shl(u32::from(k)).unwrap_or(0),
            Node::Neg(a) | Node::PowI(a, _) | Node::PowC(a, _) | Node::Fn1(_, a) => d(a),
            Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) | Node::Div(a, b) | Node::Atan2(a, b) => d(a) | d(b),
            Node::Sel(a, b, t, f) => d(a) | d(b) | d(t) | d(f),
        };
        let id = self.nodes.len() as Id;
        self.nodes.push(n);
        self.deps.push(mask);
        self.index.insert(n, id);
        id
    }

    /// The constant value of `id`, if it is a constant.
    pub fn constant(&self, id: Id) -> Option<f64> {
        match self.node(id) {
            Some(Node::Const(b)) => Some(f64::from_bits(b)),
            _ => None,
        }
    }

    pub fn cst(&mut self, v: f64) -> Id {
        // One zero: -0.0 and 0.0 are the same constant here.
        let v = if v == 0.0 { 0.0 } else { v };
        self.push(Node::Const(v.to_bits()))
    }

    pub fn var(&mut self, k: u16) -> Id {
        self.push(Node::Var(k))
    }

    pub fn add(&mut self, a: Id, b: Id) -> Id {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => self.cst(x + y),
            (Some(x), _) if x == 0.0 => b,
            (_, Some(y)) if y == 0.0 => a,
            _ => self.push(Node::Add(a, b)),
        }
    }

    pub fn sub(&mut self, a: Id, b: Id) -> Id {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => self.cst(x - y),
            (_, Some(y)) if y == 0.0 => a,
            (Some(x), _) if x == 0.0 => self.neg(b),
            _ => self.push(Node::Sub(a, b)),
        }
    }

    pub fn mul(&mut self, a: Id, b: Id) -> Id {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => self.cst(x * y),
            (Some(x), _) | (_, Some(x)) if x == 0.0 => self.cst(0.0),
            (Some(x), _) if x == 1.0 => b,
            (_, Some(y)) if y == 1.0 => a,
            (Some(x), _) if x == -1.0 => self.neg(b),
            (_, Some(y)) if y == -1.0 => self.neg(a),
            _ => self.push(Node::Mul(a, b)),
        }
    }

    pub fn div(&mut self, a: Id, b: Id) -> Id {
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => self.cst(x / y),
            (Some(x), _) if x == 0.0 => self.cst(0.0),
            (_, Some(y)) if y == 1.0 => a,
            _ => self.push(Node::Div(a, b)),
        }
    }

    pub fn neg(&mut self, a: Id) -> Id {
        match self.node(a) {
            Some(Node::Const(b)) => self.cst(-f64::from_bits(b)),
            Some(Node::Neg(x)) => x,
            _ => self.push(Node::Neg(a)),
        }
    }

    pub fn powi(&mut self, a: Id, n: i32) -> Id {
        match (self.constant(a), n) {
            (_, 0) => self.cst(1.0),
            (_, 1) => a,
            (Some(x), _) => self.cst(x.powi(n)),
            _ => self.push(Node::PowI(a, n)),
        }
    }

    /// `a^p` for a real constant `p`: an integer power when `p` is a small integer.
    pub fn powc(&mut self, a: Id, p: f64) -> Id {
        if p.fract() == 0.0 && p.abs() <= 64.0 {
            return self.powi(a, p as i32);
        }
        match self.constant(a) {
            Some(x) => self.cst(x.powf(p)),
            None => self.push(Node::PowC(a, p.to_bits())),
        }
    }

    /// `a^b`: [`Graph::powc`] for a constant exponent, else `exp(b log a)`.
    pub fn pow(&mut self, a: Id, b: Id) -> Id {
        match self.constant(b) {
            Some(p) => self.powc(a, p),
            None => {
                let l = self.f1(F1::Log, a);
                let e = self.mul(b, l);
                self.f1(F1::Exp, e)
            }
        }
    }

    pub fn f1(&mut self, f: F1, a: Id) -> Id {
        match self.constant(a) {
            Some(x) => self.cst(f.eval(x)),
            None => self.push(Node::Fn1(f, a)),
        }
    }

    pub fn atan2(&mut self, y: Id, x: Id) -> Id {
        match (self.constant(y), self.constant(x)) {
            (Some(a), Some(b)) => self.cst(a.atan2(b)),
            _ => self.push(Node::Atan2(y, x)),
        }
    }

    /// `if a <= b { t } else { f }` (by value at the evaluation point).
    pub fn sel(&mut self, a: Id, b: Id, t: Id, f: Id) -> Id {
        if t == f {
            return t;
        }
        match (self.constant(a), self.constant(b)) {
            (Some(x), Some(y)) => {
                if x <= y {
                    t
                } else {
                    f
                }
            }
            _ => self.push(Node::Sel(a, b, t, f)),
        }
    }

    /// `d root / d var_k`, by the chain rule over the nodes `root` depends on (in
    /// topological order, so without recursion).
    pub fn diff(&mut self, root: Id, k: u16) -> Id {
        let bit = 1u32.checked_shl(u32::from(k)).unwrap_or(0);
        let zero = self.cst(0.0);
        if self.deps(root) & bit == 0 {
            return zero;
        }
        let one = self.cst(1.0);
        // Nodes root reaches that depend on var k.
        let n = root as usize + 1;
        let mut need = vec![false; n];
        if let Some(r) = need.get_mut(root as usize) {
            *r = true;
        }
        for i in (0..n).rev() {
            if !need.get(i).copied().unwrap_or(false) {
                continue;
            }
            let Some(node) = self.node(i as Id) else { continue };
            for c in children(node) {
                if self.deps(c) & bit != 0 {
                    if let Some(s) = need.get_mut(c as usize) {
                        *s = true;
                    }
                }
            }
        }
        let mut d: Vec<Id> = vec![zero; n];
        for i in 0..n {
            if !need.get(i).copied().unwrap_or(false) {
                continue;
            }
            let Some(node) = self.node(i as Id) else { continue };
            let dd = |c: Id| d.get(c as usize).copied().unwrap_or(zero);
            let di = match node {
                Node::Const(_) => zero,
                Node::Var(v) => {
                    if v == k {
                        one
                    } else {
                        zero
                    }
                }
                Node::Add(a, b) => {
                    let (x, y) = (dd(a), dd(b));
                    self.add(x, y)
                }
                Node::Sub(a, b) => {
                    let (x, y) = (dd(a), dd(b));
                    self.sub(x, y)
                }
                Node::Mul(a, b) => {
                    let (x, y) = (dd(a), dd(b));
                    let p = self.mul(x, b);
                    let q = self.mul(a, y);
                    self.add(p, q)
                }
                Node::Div(a, b) => {
                    // (a/b)' = a'/b - (a/b) b'/b
                    let (x, y) = (dd(a), dd(b));
                    let p = self.div(x, b);
                    let ab = i as Id;
                    let q = self.mul(ab, y);
                    let q = self.div(q, b);
                    self.sub(p, q)
                }
                Node::Neg(a) => {
                    let x = dd(a);
                    self.neg(x)
                }
                Node::PowI(a, m) => {
                    let x = dd(a);
                    let p = self.powi(a, m.saturating_sub(1));
                    let c = self.cst(f64::from(m));
                    let p = self.mul(c, p);
                    self.mul(p, x)
                }
                Node::PowC(a, bits) => {
                    let x = dd(a);
                    let pw = f64::from_bits(bits);
                    let p = self.powc(a, pw - 1.0);
                    let c = self.cst(pw);
                    let p = self.mul(c, p);
                    self.mul(p, x)
                }
                Node::Fn1(f, a) => {
                    let x = dd(a);
                    let me = i as Id;
                    let g = match f {
                        F1::Sin => self.f1(F1::Cos, a),
                        F1::Cos => {
                            let s = self.f1(F1::Sin, a);
                            self.neg(s)
                        }
                        F1::Tan => {
                            let t2 = self.powi(me, 2);
                            self.add(one, t2)
                        }
                        F1::Exp => me,
                        F1::Log => self.div(one, a),
                        F1::Sqrt => {
                            let two = self.cst(2.0);
                            let den = self.mul(two, me);
                            self.div(one, den)
                        }
                        F1::Abs => self.f1(F1::Sign, a),
                        F1::Tanh => {
                            let t2 = self.powi(me, 2);
                            self.sub(one, t2)
                        }
                        F1::Sign => zero,
                    };
                    self.mul(g, x)
                }
                Node::Atan2(y, x) => {
                    // (x y' - y x') / (x^2 + y^2)
                    let (dy, dx) = (dd(y), dd(x));
                    let p = self.mul(x, dy);
                    let q = self.mul(y, dx);
                    let num = self.sub(p, q);
                    let x2 = self.powi(x, 2);
                    let y2 = self.powi(y, 2);
                    let den = self.add(x2, y2);
                    self.div(num, den)
                }
                Node::Sel(a, b, t, f) => {
                    let (dt, df) = (dd(t), dd(f));
                    self.sel(a, b, dt, df)
                }
            };
            if let Some(s) = d.get_mut(i) {
                *s = di;
            }
        }
        d.get(root as usize).copied().unwrap_or(zero)
    }

    /// The value of `root` in `f64` at `vars` (a reference evaluator for tests and checks;
    /// the plant evaluates compiled [`Tape`]s).
    pub fn eval_f64(&self, root: Id, vars: &[f64]) -> f64 {
        let n = root as usize + 1;
        let mut v = vec![0.0; n];
        for i in 0..n {
            let Some(node) = self.node(i as Id) else { continue };
            let g = |c: Id| v.get(c as usize).copied().unwrap_or(f64::NAN);
            let x = match node {
                Node::Const(b) => f64::from_bits(b),
                Node::Var(k) => vars.get(k as usize).copied().unwrap_or(f64::NAN),
                Node::Add(a, b) => g(a) + g(b),
                Node::Sub(a, b) => g(a) - g(b),
                Node::Mul(a, b) => g(a) * g(b),
                Node::Div(a, b) => g(a) / g(b),
                Node::Neg(a) => -g(a),
                // The tape's own power functions, so that both evaluations agree bit for bit.
                Node::PowI(a, m) => tape::powi(g(a), m),
                Node::PowC(a, b) => {
                    let mut c = [0.0];
                    tape::power_coefficients(g(a), f64::from_bits(b), &mut c);
                    c[0]
                }
                Node::Fn1(f, a) => f.eval(g(a)),
                Node::Atan2(y, x) => g(y).atan2(g(x)),
                Node::Sel(a, b, t, f) => {
                    if g(a) <= g(b) {
                        g(t)
                    } else {
                        g(f)
                    }
                }
            };
            if let Some(s) = v.get_mut(i) {
                *s = x;
            }
        }
        v.get(root as usize).copied().unwrap_or(f64::NAN)
    }
}

/// The operands of a node.
pub(crate) fn children(n: Node) -> impl Iterator<Item = Id> {
    let (a, k): ([Id; 4], usize) = match n {
        Node::Const(_) | Node::Var(_) => ([0; 4], 0),
        Node::Neg(a) | Node::PowI(a, _) | Node::PowC(a, _) | Node::Fn1(_, a) => ([a, 0, 0, 0], 1),
        Node::Add(a, b) | Node::Sub(a, b) | Node::Mul(a, b) | Node::Div(a, b) | Node::Atan2(a, b) => ([a, b, 0, 0], 2),
        Node::Sel(a, b, t, f) => ([a, b, t, f], 4),
    };
    a.into_iter().take(k)
}

/// The names an expression may use.
#[derive(Clone, Debug, Default)]
pub struct Names {
    /// Variables, by index (the tape's inputs).
    pub vars: Vec<String>,
    /// Parameters and their values (folded in as constants).
    pub params: Vec<(String, f64)>,
}

impl Names {
    fn describe(&self) -> String {
        let vars: Vec<&str> = self.vars.iter().map(String::as_str).collect();
        let params: Vec<&str> = self.params.iter().map(|(n, _)| n.as_str()).collect();
        format!(
            "variables: {}; parameters: {}",
            if vars.is_empty() { "none".to_string() } else { vars.join(", ") },
            if params.is_empty() { "none".to_string() } else { params.join(", ") }
        )
    }
}

/// The functions of the language and their argument counts.
pub const FUNCTIONS: &[(&str, usize)] = &[
    ("sin", 1),
    ("cos", 1),
    ("tan", 1),
    ("exp", 1),
    ("log", 1),
    ("sqrt", 1),
    ("abs", 1),
    ("tanh", 1),
    ("atan2", 2),
    ("min", 2),
    ("max", 2),
];

/// Whether `name` is a function of the language.
pub fn is_function(name: &str) -> bool {
    FUNCTIONS.iter().any(|(f, _)| *f == name)
}

/// Whether `name` is a valid name: an ASCII letter or `_`, then letters, digits and `_`.
pub fn is_identifier(name: &str) -> bool {
    let mut c = name.chars();
    matches!(c.next(), Some(f) if f.is_ascii_alphabetic() || f == '_')
        && c.all(|ch| ch.is_ascii_alphanumeric() || ch == '_')
}

#[derive(Clone, Debug, PartialEq)]
enum Tok {
    Num(f64),
    Ident(String),
    Sym(char),
}

fn lex(src: &str) -> Result<Vec<(Tok, usize)>, ExprError> {
    let chars: Vec<char> = src.chars().collect();
    if chars.len() > MAX_EXPR_LEN {
        return err(1, format!("the expression has {} characters, the limit is {MAX_EXPR_LEN}", chars.len()));
    }
    let mut out = Vec::new();
    let mut i = 0;
    let at = |i: usize| chars.get(i).copied();
    while let Some(c) = at(i) {
        let col = i + 1;
        if c.is_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() || (c == '.' && at(i + 1).is_some_and(|d| d.is_ascii_digit())) {
            let start = i;
            while at(i).is_some_and(|d| d.is_ascii_digit() || d == '.') {
                i += 1;
            }
            if matches!(at(i), Some('e' | 'E'))
                && (at(i + 1).is_some_and(|d| d.is_ascii_digit())
                    || (matches!(at(i + 1), Some('+' | '-')) && at(i + 2).is_some_and(|d| d.is_ascii_digit())))
            {
                i += 2;
                while at(i).is_some_and(|d| d.is_ascii_digit()) {
                    i += 1;
                }
            }
            let text: String = chars.get(start..i).unwrap_or_default().iter().collect();
            match text.parse::<f64>() {
                Ok(v) if v.is_finite() => out.push((Tok::Num(v), col)),
                Ok(_) => return err(col, format!("number `{text}` is out of range")),
                Err(_) => return err(col, format!("`{text}` is not a number")),
            }
            if at(i).is_some_and(|d| d.is_ascii_alphabetic() || d == '_') {
                return err(i + 1, format!("a name cannot follow the number `{text}` directly (write `*`)"));
            }
        } else if c.is_ascii_alphabetic() || c == '_' {
            let start = i;
            while at(i).is_some_and(|d| d.is_ascii_alphanumeric() || d == '_') {
                i += 1;
            }
            out.push((Tok::Ident(chars.get(start..i).unwrap_or_default().iter().collect()), col));
        } else if "+-*/^(),".contains(c) {
            out.push((Tok::Sym(c), col));
            i += 1;
        } else {
            return err(col, format!("unexpected character {c:?}"));
        }
    }
    Ok(out)
}

/// A parsed expression: its node and the first column at which each variable is used.
#[derive(Clone, Debug)]
pub struct Parsed {
    pub root: Id,
    /// `(variable, column)` of the first use of each variable, in order of first use.
    pub uses: Vec<(u16, usize)>,
}

impl Parsed {
    /// The column of the first use of variable `k`, if used.
    pub fn column_of(&self, k: u16) -> Option<usize> {
        self.uses.iter().find(|(v, _)| *v == k).map(|(_, c)| *c)
    }
}

struct Parser<'a> {
    toks: Vec<(Tok, usize)>,
    pos: usize,
    end_col: usize,
    names: &'a Names,
    g: &'a mut Graph,
    uses: Vec<(u16, usize)>,
}

/// Parses `src` into `g` with the names `names`.
pub fn parse(src: &str, names: &Names, g: &mut Graph) -> Result<Parsed, ExprError> {
    let toks = lex(src)?;
    let end_col = src.chars().count() + 1;
    if toks.is_empty() {
        return err(1, "empty expression");
    }
    let mut p = Parser { toks, pos: 0, end_col, names, g, uses: Vec::new() };
    let root = p.expr(0, 0)?;
    if let Some((t, col)) = p.toks.get(p.pos) {
        let what = match t {
            Tok::Sym(')') => "unmatched `)`".to_string(),
            t => format!("unexpected {} after a complete expression (missing operator?)", describe(t)),
        };
        return err(*col, what);
    }
    if p.g.too_large() {
        return err(1, format!("the expression graph exceeds {MAX_NODES} nodes"));
    }
    Ok(Parsed { root, uses: p.uses })
}

fn describe(t: &Tok) -> String {
    match t {
        Tok::Num(v) => format!("number {v}"),
        Tok::Ident(s) => format!("name `{s}`"),
        Tok::Sym(c) => format!("`{c}`"),
    }
}

impl Parser<'_> {
    fn peek(&self) -> Option<&(Tok, usize)> {
        self.toks.get(self.pos)
    }

    fn next(&mut self) -> Option<(Tok, usize)> {
        let t = self.toks.get(self.pos).cloned();
        self.pos += 1;
        t
    }

    fn col(&self) -> usize {
        self.peek().map_or(self.end_col, |t| t.1)
    }

    fn expect(&mut self, c: char, what: &str) -> Result<(), ExprError> {
        match self.next() {
            Some((Tok::Sym(s), _)) if s == c => Ok(()),
            Some((t, col)) => err(col, format!("expected `{c}` {what}, found {}", describe(&t))),
            None => err(self.end_col, format!("expected `{c}` {what}, found the end")),
        }
    }

    fn expr(&mut self, min_bp: u8, depth: usize) -> Result<Id, ExprError> {
        if depth > MAX_DEPTH {
            return err(self.col(), format!("nested more than {MAX_DEPTH} deep"));
        }
        let mut lhs = self.prefix(depth)?;
        loop {
            let op = match self.peek() {
                Some((Tok::Sym(c @ ('+' | '-' | '*' | '/' | '^')), _)) => *c,
                _ => break,
            };
            let (l_bp, r_bp) = match op {
                '+' | '-' => (1, 2),
                '*' | '/' => (3, 4),
                _ => (8, 7),
            };
            if l_bp < min_bp {
                break;
            }
            self.pos += 1;
            let rhs = self.expr(r_bp, depth + 1)?;
            lhs = match op {
                '+' => self.g.add(lhs, rhs),
                '-' => self.g.sub(lhs, rhs),
                '*' => self.g.mul(lhs, rhs),
                '/' => self.g.div(lhs, rhs),
                _ => self.g.pow(lhs, rhs),
            };
        }
        Ok(lhs)
    }

    fn prefix(&mut self, depth: usize) -> Result<Id, ExprError> {
        let Some((tok, col)) = self.next() else {
            return err(self.end_col, "expected a number, name or `(`, found the end");
        };
        match tok {
            Tok::Num(v) => Ok(self.g.cst(v)),
            Tok::Sym('(') => {
                let e = self.expr(0, depth + 1)?;
                self.expect(')', &format!("to close the `(` at column {col}"))?;
                Ok(e)
            }
            // Unary minus binds looser than `^` and tighter than `*`.
            Tok::Sym('-') => {
                let e = self.expr(5, depth + 1)?;
                Ok(self.g.neg(e))
            }
            Tok::Ident(name) => {
                if matches!(self.peek(), Some((Tok::Sym('('), _))) {
                    self.pos += 1;
                    return self.call(&name, col, depth);
                }
                self.name(&name, col)
            }
            t => err(col, format!("expected a number, name or `(`, found {}", describe(&t))),
        }
    }

    fn name(&mut self, name: &str, col: usize) -> Result<Id, ExprError> {
        if let Some(k) = self.names.vars.iter().position(|v| v == name) {
            let k = k as u16;
            if !self.uses.iter().any(|(v, _)| *v == k) {
                self.uses.push((k, col));
            }
            return Ok(self.g.var(k));
        }
        if let Some((_, v)) = self.names.params.iter().find(|(p, _)| p == name) {
            return Ok(self.g.cst(*v));
        }
        if is_function(name) {
            return err(col, format!("`{name}` is a function: write `{name}(...)`"));
        }
        err(col, format!("unknown name `{name}` ({})", self.names.describe()))
    }

    fn call(&mut self, name: &str, col: usize, depth: usize) -> Result<Id, ExprError> {
        let Some(&(_, arity)) = FUNCTIONS.iter().find(|(f, _)| *f == name) else {
            return err(
                col,
                format!(
                    "unknown function `{name}` (functions: {})",
                    FUNCTIONS.iter().map(|(f, _)| *f).collect::<Vec<_>>().join(" ")
                ),
            );
        };
        let mut args = Vec::new();
        if matches!(self.peek(), Some((Tok::Sym(')'), _))) {
            self.pos += 1;
        } else {
            loop {
                args.push(self.expr(0, depth + 1)?);
                match self.next() {
                    Some((Tok::Sym(','), _)) => {}
                    Some((Tok::Sym(')'), _)) => break,
                    Some((t, c)) => {
                        return err(
                            c,
                            format!("expected `,` or `)` in the arguments of `{name}`, found {}", describe(&t)),
                        );
                    }
                    None => {
                        return err(self.end_col, format!("expected `)` to close `{name}(` at column {col}"));
                    }
                }
            }
        }
        if args.len() != arity {
            return err(
                col,
                format!("`{name}` takes {arity} argument{}, got {}", if arity == 1 { "" } else { "s" }, args.len()),
            );
        }
        let a = |i: usize| args.get(i).copied().unwrap_or(0);
        let g = &mut *self.g;
        Ok(match name {
            "sin" => g.f1(F1::Sin, a(0)),
            "cos" => g.f1(F1::Cos, a(0)),
            "tan" => g.f1(F1::Tan, a(0)),
            "exp" => g.f1(F1::Exp, a(0)),
            "log" => g.f1(F1::Log, a(0)),
            "sqrt" => g.f1(F1::Sqrt, a(0)),
            "abs" => g.f1(F1::Abs, a(0)),
            "tanh" => g.f1(F1::Tanh, a(0)),
            "atan2" => g.atan2(a(0), a(1)),
            "min" => g.sel(a(0), a(1), a(0), a(1)),
            _ => g.sel(a(0), a(1), a(1), a(0)),
        })
    }
}
