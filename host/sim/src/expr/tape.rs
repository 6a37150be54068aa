//! A set of expressions compiled to one flat instruction tape over a register file:
//! constants folded into the instructions that use them, `sin`/`cos` of one argument one
//! `sin_cos`, registers reused once a value is dead. Evaluation is a loop over the tape,
//! generic over [`Scalar`]; it reads inputs and writes registers the caller provides, so
//! it neither allocates nor touches strings.

use super::{F1, Graph, Id, Node, children};
use crate::scalar::Scalar;

/// One operation; register indices are `u16`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Op {
    Const(f64),
    Var(u16),
    Add(u16, u16),
    Sub(u16, u16),
    Mul(u16, u16),
    Div(u16, u16),
    Neg(u16),
    /// `x + c`.
    AddC(u16, f64),
    /// `x - c`.
    SubC(u16, f64),
    /// `c - x`.
    RSubC(f64, u16),
    /// `x * c`.
    MulC(u16, f64),
    /// `x / c`.
    DivC(u16, f64),
    /// `c / x`.
    RDivC(f64, u16),
    PowI(u16, i32),
    PowC(u16, f64),
    Fn1(F1, u16),
    /// `sin` into `dst`, `cos` into `dst2`.
    SinCos(u16),
    Atan2(u16, u16),
    Sel(u16, u16, u16, u16),
}

/// An instruction: an operation and its destination register(s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instr {
    pub op: Op,
    pub dst: u16,
    /// The second destination of [`Op::SinCos`] (else equal to `dst`).
    pub dst2: u16,
}

/// Compiled expressions.
#[derive(Clone, Debug, PartialEq)]
pub struct Tape {
    pub instrs: Vec<Instr>,
    /// Registers the evaluation needs.
    pub n_regs: usize,
    /// Number of inputs (variables).
    pub n_inputs: usize,
    /// The register holding each output, in the order the roots were given.
    pub outputs: Vec<u16>,
}

/// Why a tape could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TapeError {
    #[error("the expressions need more than {0} registers")]
    TooManyRegisters(usize),
}

/// Largest register count of a tape.
pub const MAX_REGS: usize = u16::MAX as usize;

/// A value of the SSA program before register allocation.
#[derive(Clone, Copy, Debug)]
enum Val {
    /// A constant folded into its users (materialized by `Op::Const` when needed).
    Const(f64),
    /// Index of the SSA instruction computing it (and which of its two results).
    Ssa(usize, bool),
}

impl Tape {
    /// Compiles `roots` of `g`, with `n_inputs` variables.
    pub fn compile(g: &Graph, roots: &[Id], n_inputs: usize) -> Result<Tape, TapeError> {
        let n = roots.iter().map(|&r| r as usize + 1).max().unwrap_or(0);
        let mut live = vec![false; n];
        for &r in roots {
            if let Some(l) = live.get_mut(r as usize) {
                *l = true;
            }
        }
        for i in (0..n).rev() {
            if !live.get(i).copied().unwrap_or(false) {
                continue;
            }
            if let Some(node) = g.node(i as Id) {
                for c in children(node) {
                    if let Some(l) = live.get_mut(c as usize) {
                        *l = true;
                    }
                }
            }
        }
        // SSA program: ops whose operands are SSA indices (u16 placeholders resolved below).
        let mut prog: Vec<(SsaOp, bool)> = Vec::new();
        let mut val: Vec<Option<Val>> = vec![None; n];
        let get = |val: &Vec<Option<Val>>, c: Id| val.get(c as usize).copied().flatten();
        for i in 0..n {
            if !live.get(i).copied().unwrap_or(false) {
                continue;
            }
            let Some(node) = g.node(i as Id) else { continue };
            if val.get(i).copied().flatten().is_some() {
                continue; // the partner of an earlier sin_cos
            }
            let v = |c: Id| get(&val, c).unwrap_or(Val::Const(f64::NAN));
            let op = match node {
                Node::Const(b) => {
                    if let Some(s) = val.get_mut(i) {
                        *s = Some(Val::Const(f64::from_bits(b)));
                    }
                    continue;
                }
                Node::Var(k) => SsaOp::Var(k),
                Node::Add(a, b) => match (v(a), v(b)) {
                    (Val::Const(c), x) | (x, Val::Const(c)) => SsaOp::AddC(x, c),
                    (x, y) => SsaOp::Bin(BinOp::Add, x, y),
                },
                Node::Sub(a, b) => match (v(a), v(b)) {
                    (x, Val::Const(c)) => SsaOp::SubC(x, c),
                    (Val::Const(c), y) => SsaOp::RSubC(c, y),
                    (x, y) => SsaOp::Bin(BinOp::Sub, x, y),
                },
                Node::Mul(a, b) => match (v(a), v(b)) {
                    (Val::Const(c), x) | (x, Val::Const(c)) => SsaOp::MulC(x, c),
                    (x, y) => SsaOp::Bin(BinOp::Mul, x, y),
                },
                Node::Div(a, b) => match (v(a), v(b)) {
                    (x, Val::Const(c)) => SsaOp::DivC(x, c),
                    (Val::Const(c), y) => SsaOp::RDivC(c, y),
                    (x, y) => SsaOp::Bin(BinOp::Div, x, y),
                },
                Node::Neg(a) => SsaOp::Neg(v(a)),
                Node::PowI(a, m) => SsaOp::PowI(v(a), m),
                Node::PowC(a, b) => SsaOp::PowC(v(a), f64::from_bits(b)),
                Node::Fn1(f @ (F1::Sin | F1::Cos), a) => {
                    let partner = if f == F1::Sin { F1::Cos } else { F1::Sin };
                    let other = g.index.get(&Node::Fn1(partner, a)).copied();
                    match other {
                        Some(o) if live.get(o as usize).copied().unwrap_or(false) => {
                            let k = prog.len();
                            prog.push((SsaOp::SinCos(v(a)), true));
                            let (s, c) = (Val::Ssa(k, false), Val::Ssa(k, true));
                            let (mine, theirs) = if f == F1::Sin { (s, c) } else { (c, s) };
                            if let Some(slot) = val.get_mut(i) {
                                *slot = Some(mine);
                            }
                            if let Some(slot) = val.get_mut(o as usize) {
                                *slot = Some(theirs);
                            }
                            continue;
                        }
                        _ => SsaOp::Fn1(f, v(a)),
                    }
                }
                Node::Fn1(f, a) => SsaOp::Fn1(f, v(a)),
                Node::Atan2(y, x) => SsaOp::Bin(BinOp::Atan2, v(y), v(x)),
                Node::Sel(a, b, t, f) => SsaOp::Sel(v(a), v(b), v(t), v(f)),
            };
            let k = prog.len();
            prog.push((op, false));
            if let Some(s) = val.get_mut(i) {
                *s = Some(Val::Ssa(k, false));
            }
        }
        // Outputs that are constants (or a bare constant operand of a Sel/Bin) get a Const op.
        let mut b = Builder { prog, consts: Vec::new() };
        let out_vals: Vec<Val> = roots.iter().map(|&r| get(&val, r).unwrap_or(Val::Const(f64::NAN))).collect();
        b.allocate(&out_vals, n_inputs)
    }

    /// Evaluates the tape: `inputs` (at least `n_inputs`) into `regs` (at least
    /// `n_regs`); the outputs are then `regs[outputs[i]]`.
    #[inline]
    pub fn eval<S: Scalar>(&self, inputs: &[S], regs: &mut [S]) {
        for ins in &self.instrs {
            let r = |k: u16| regs.get(k as usize).copied().unwrap_or(S::cst(f64::NAN));
            let value = match ins.op {
                Op::Const(c) => S::cst(c),
                Op::Var(k) => inputs.get(k as usize).copied().unwrap_or(S::cst(f64::NAN)),
                Op::Add(a, b) => with2(regs, a, b, |x, y| x.add_ref(y)),
                Op::Sub(a, b) => with2(regs, a, b, |x, y| x.sub_ref(y)),
                Op::Mul(a, b) => with2(regs, a, b, |x, y| x.mul_ref(y)),
                Op::Div(a, b) => r(a) / r(b),
                Op::Neg(a) => -r(a),
                Op::AddC(a, c) => r(a) + c,
                Op::SubC(a, c) => r(a) - c,
                Op::RSubC(c, a) => -r(a) + c,
                Op::MulC(a, c) => with1(regs, a, |x| x.scaled(c)),
                Op::DivC(a, c) => r(a) / c,
                Op::RDivC(c, a) => S::cst(c) / r(a),
                Op::PowI(a, m) => powi(r(a), m),
                Op::PowC(a, p) => r(a).apply(|x0, out| power_coefficients(x0, p, out)),
                Op::Fn1(f, a) => fn1(f, r(a)),
                Op::SinCos(a) => {
                    let (s, c) = r(a).sin_cos();
                    if let Some(slot) = regs.get_mut(ins.dst2 as usize) {
                        *slot = c;
                    }
                    s
                }
                Op::Atan2(y, x) => atan2(r(y), r(x)),
                Op::Sel(a, b, t, f) => {
                    if r(a).re() <= r(b).re() {
                        r(t)
                    } else {
                        r(f)
                    }
                }
            };
            if let Some(slot) = regs.get_mut(ins.dst as usize) {
                *slot = value;
            }
        }
    }

    /// Evaluates in `f64` and returns the outputs (allocates: for checks, not for the rhs).
    pub fn eval_f64(&self, inputs: &[f64]) -> Vec<f64> {
        let mut regs = vec![0.0; self.n_regs];
        self.eval(inputs, &mut regs);
        self.outputs.iter().map(|&o| regs.get(o as usize).copied().unwrap_or(f64::NAN)).collect()
    }

    /// Number of instructions (the cost of one evaluation, in tape steps).
    pub fn len(&self) -> usize {
        self.instrs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.instrs.is_empty()
    }
}

#[inline(always)]
fn with1<S: Scalar>(regs: &[S], a: u16, f: impl FnOnce(&S) -> S) -> S {
    match regs.get(a as usize) {
        Some(x) => f(x),
        None => S::cst(f64::NAN),
    }
}

#[inline(always)]
fn with2<S: Scalar>(regs: &[S], a: u16, b: u16, f: impl FnOnce(&S, &S) -> S) -> S {
    match (regs.get(a as usize), regs.get(b as usize)) {
        (Some(x), Some(y)) => f(x, y),
        _ => S::cst(f64::NAN),
    }
}

/// `x^m` by binary powering (`x*x` for `m = 2`); a negative power is `1 / x^|m|`.
pub(super) fn powi<S: Scalar>(x: S, m: i32) -> S {
    let mut e = m.unsigned_abs();
    let mut base = x;
    let mut acc: Option<S> = None;
    while e > 0 {
        if e & 1 == 1 {
            acc = Some(match acc {
                None => base,
                Some(a) => a.mul_ref(&base),
            });
        }
        e >>= 1;
        if e > 0 {
            base = base.mul_ref(&base);
        }
    }
    let p = acc.unwrap_or(S::cst(1.0));
    if m < 0 { S::cst(1.0) / p } else { p }
}

/// Taylor coefficients of `x^p` at `x0`: `c_k = c_{k-1} (p - k + 1) / (k x0)`.
pub(super) fn power_coefficients(x0: f64, p: f64, out: &mut [f64]) {
    let mut c = if p == 0.5 { x0.sqrt() } else { x0.powf(p) };
    for (k, o) in out.iter_mut().enumerate() {
        if k > 0 {
            c *= (p - (k as f64 - 1.0)) / (k as f64 * x0);
        }
        *o = c;
    }
}

/// Taylor coefficients `t_k` of `tan` (`s = 1`) or `tanh` (`s = -1`) at `x0`, from
/// `t' = 1 + s t^2`: `(k+1) t_{k+1} = [k = 0] + s sum_j t_j t_{k-j}`.
fn tan_coefficients(t0: f64, s: f64, out: &mut [f64]) {
    let n = out.len();
    if let Some(o) = out.first_mut() {
        *o = t0;
    }
    for k in 0..n.saturating_sub(1) {
        let mut sum = 0.0;
        for j in 0..=k {
            sum += out.get(j).copied().unwrap_or(0.0) * out.get(k - j).copied().unwrap_or(0.0);
        }
        let v = (if k == 0 { 1.0 } else { 0.0 } + s * sum) / (k as f64 + 1.0);
        if let Some(o) = out.get_mut(k + 1) {
            *o = v;
        }
    }
}

/// Taylor coefficients of `atan` at `s0`: `a_k = r_{k-1} / k` with `r` the series of
/// `1 / (1 + s^2)`: `D0 r_k = -(2 s0 r_{k-1} + r_{k-2})`, `D0 = 1 + s0^2`.
fn atan_coefficients(s0: f64, out: &mut [f64]) {
    let d0 = 1.0 + s0 * s0;
    let (mut r_prev2, mut r_prev) = (0.0, 1.0 / d0);
    for (k, o) in out.iter_mut().enumerate() {
        *o = match k {
            0 => s0.atan(),
            1 => r_prev,
            _ => {
                let r = -(2.0 * s0 * r_prev + r_prev2) / d0;
                r_prev2 = r_prev;
                r_prev = r;
                r / k as f64
            }
        };
    }
}

fn fn1<S: Scalar>(f: F1, x: S) -> S {
    match f {
        F1::Sin => x.sin_cos().0,
        F1::Cos => x.sin_cos().1,
        F1::Tan => x.apply(|x0, out| tan_coefficients(x0.tan(), 1.0, out)),
        F1::Tanh => x.apply(|x0, out| tan_coefficients(x0.tanh(), -1.0, out)),
        F1::Exp => x.apply(|x0, out| {
            let mut c = x0.exp();
            for (k, o) in out.iter_mut().enumerate() {
                if k > 0 {
                    c /= k as f64;
                }
                *o = c;
            }
        }),
        F1::Log => x.apply(|x0, out| {
            for (k, o) in out.iter_mut().enumerate() {
                *o = if k == 0 {
                    x0.ln()
                } else {
                    let sgn = if k % 2 == 1 { 1.0 } else { -1.0 };
                    sgn / (k as f64 * x0.powi(k as i32))
                };
            }
        }),
        F1::Sqrt => x.apply(|x0, out| power_coefficients(x0, 0.5, out)),
        F1::Abs => {
            if x.re() < 0.0 {
                -x
            } else {
                x
            }
        }
        F1::Sign => x.apply(|x0, out| {
            for (k, o) in out.iter_mut().enumerate() {
                *o = if k == 0 { super::sign(x0) } else { 0.0 };
            }
        }),
    }
}

/// `atan2(y, x) = atan2(y0, x0) + atan(s)`, `s = (x0 y - y0 x) / (x0 x + y0 y)`, whose value
/// is exactly 0 (so `f64` gets `atan2(y0, x0)` itself).
/// Where `s` is undefined (at the origin, or with an infinite argument) atan2 is not
/// differentiable: the value alone, `atan2(y0, x0)`.
fn atan2<S: Scalar>(y: S, x: S) -> S {
    let (y0, x0) = (y.re(), x.re());
    let base = y0.atan2(x0);
    let s = (y * x0 - x * y0) / (x * x0 + y * y0);
    if !s.re().is_finite() {
        return S::cst(base);
    }
    s.apply(atan_coefficients) + base
}

#[derive(Clone, Copy, Debug)]
enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Atan2,
}

#[derive(Clone, Copy, Debug)]
enum SsaOp {
    Var(u16),
    Bin(BinOp, Val, Val),
    Neg(Val),
    AddC(Val, f64),
    SubC(Val, f64),
    RSubC(f64, Val),
    MulC(Val, f64),
    DivC(Val, f64),
    RDivC(f64, Val),
    PowI(Val, i32),
    PowC(Val, f64),
    Fn1(F1, Val),
    SinCos(Val),
    Sel(Val, Val, Val, Val),
}

impl SsaOp {
    fn operands(&self) -> Vec<Val> {
        match *self {
            SsaOp::Var(_) => vec![],
            SsaOp::Bin(_, a, b) => vec![a, b],
            SsaOp::Neg(a)
            | SsaOp::AddC(a, _)
            | SsaOp::SubC(a, _)
            | SsaOp::RSubC(_, a)
            | SsaOp::MulC(a, _)
            | SsaOp::DivC(a, _)
            | SsaOp::RDivC(_, a)
            | SsaOp::PowI(a, _)
            | SsaOp::PowC(a, _)
            | SsaOp::Fn1(_, a)
            | SsaOp::SinCos(a) => vec![a],
            SsaOp::Sel(a, b, t, f) => vec![a, b, t, f],
        }
    }
}

struct Builder {
    prog: Vec<(SsaOp, bool)>,
    /// Constants needed in registers (operands of `Bin`/`Sel`, or outputs).
    consts: Vec<f64>,
}

impl Builder {
    /// Linear-scan register allocation: a register is freed after the last use of its value;
    /// outputs are never freed.
    fn allocate(&mut self, outputs: &[Val], n_inputs: usize) -> Result<Tape, TapeError> {
        // Constants that must live in registers: emitted first, as extra SSA values.
        let mut needed: Vec<f64> = Vec::new();
        let note = |v: Val, needed: &mut Vec<f64>| {
            if let Val::Const(c) = v {
                if !needed.iter().any(|x| x.to_bits() == c.to_bits()) {
                    needed.push(c);
                }
            }
        };
        for (op, _) in &self.prog {
            match op {
                SsaOp::Bin(_, a, b) => {
                    note(*a, &mut needed);
                    note(*b, &mut needed);
                }
                SsaOp::Sel(a, b, t, f) => {
                    for v in [a, b, t, f] {
                        note(*v, &mut needed);
                    }
                }
                other => {
                    for v in other.operands() {
                        note(v, &mut needed);
                    }
                }
            }
        }
        for &v in outputs {
            note(v, &mut needed);
        }
        self.consts = needed;
        let nc = self.consts.len();
        let np = self.prog.len();
        // Value slots: consts are 0..nc (slot c), SSA k (first) is nc + 2k, (second) nc + 2k + 1.
        let slot = |v: Val, consts: &[f64]| -> usize {
            match v {
                Val::Const(c) => consts.iter().position(|x| x.to_bits() == c.to_bits()).unwrap_or(0),
                Val::Ssa(k, second) => nc + 2 * k + usize::from(second),
            }
        };
        let n_slots = nc + 2 * np;
        // Position (instruction index in the final order: consts first) of each slot's last use.
        let mut last = vec![0usize; n_slots];
        let mut is_output = vec![false; n_slots];
        for (k, (op, _)) in self.prog.iter().enumerate() {
            for v in op.operands() {
                if let Some(l) = last.get_mut(slot(v, &self.consts)) {
                    *l = nc + k;
                }
            }
        }
        for &v in outputs {
            if let Some(o) = is_output.get_mut(slot(v, &self.consts)) {
                *o = true;
            }
        }
        let mut reg_of = vec![u16::MAX; n_slots];
        let mut free: Vec<u16> = Vec::new();
        let mut n_regs = 0usize;
        let mut take = |free: &mut Vec<u16>| -> Result<u16, TapeError> {
            if let Some(r) = free.pop() {
                return Ok(r);
            }
            if n_regs >= MAX_REGS {
                return Err(TapeError::TooManyRegisters(MAX_REGS));
            }
            n_regs += 1;
            Ok((n_regs - 1) as u16)
        };
        let mut instrs = Vec::with_capacity(nc + np);
        for (c_idx, &c) in self.consts.iter().enumerate() {
            let r = take(&mut free)?;
            if let Some(s) = reg_of.get_mut(c_idx) {
                *s = r;
            }
            instrs.push(Instr { op: Op::Const(c), dst: r, dst2: r });
        }
        for (k, (op, two)) in self.prog.iter().enumerate() {
            let pos = nc + k;
            let reg = |v: Val| reg_of.get(slot(v, &self.consts)).copied().unwrap_or(0);
            let op2 = match *op {
                SsaOp::Var(i) => Op::Var(i),
                SsaOp::Bin(b, x, y) => {
                    let (x, y) = (reg(x), reg(y));
                    match b {
                        BinOp::Add => Op::Add(x, y),
                        BinOp::Sub => Op::Sub(x, y),
                        BinOp::Mul => Op::Mul(x, y),
                        BinOp::Div => Op::Div(x, y),
                        BinOp::Atan2 => Op::Atan2(x, y),
                    }
                }
                SsaOp::Neg(a) => Op::Neg(reg(a)),
                SsaOp::AddC(a, c) => Op::AddC(reg(a), c),
                SsaOp::SubC(a, c) => Op::SubC(reg(a), c),
                SsaOp::RSubC(c, a) => Op::RSubC(c, reg(a)),
                SsaOp::MulC(a, c) => Op::MulC(reg(a), c),
                SsaOp::DivC(a, c) => Op::DivC(reg(a), c),
                SsaOp::RDivC(c, a) => Op::RDivC(c, reg(a)),
                SsaOp::PowI(a, m) => Op::PowI(reg(a), m),
                SsaOp::PowC(a, p) => Op::PowC(reg(a), p),
                SsaOp::Fn1(f, a) => Op::Fn1(f, reg(a)),
                SsaOp::SinCos(a) => Op::SinCos(reg(a)),
                SsaOp::Sel(a, b, t, f) => Op::Sel(reg(a), reg(b), reg(t), reg(f)),
            };
            // Free operands whose last use is here (before choosing the destination: an
            // instruction may overwrite its own operand, the evaluation reads them first).
            // SinCos writes two registers, the first after reading: a freed operand may be
            // reused for either.
            for v in op.operands() {
                let s = slot(v, &self.consts);
                if last.get(s).copied() == Some(pos) && !is_output.get(s).copied().unwrap_or(true) {
                    if let Some(r) = reg_of.get(s).copied() {
                        if r != u16::MAX && !free.contains(&r) {
                            free.push(r);
                        }
                    }
                }
            }
            let dst = take(&mut free)?;
            let dst2 = if *two { take(&mut free)? } else { dst };
            if let Some(s) = reg_of.get_mut(nc + 2 * k) {
                *s = dst;
            }
            if *two {
                if let Some(s) = reg_of.get_mut(nc + 2 * k + 1) {
                    *s = dst2;
                }
            }
            instrs.push(Instr { op: op2, dst, dst2 });
            // A result nobody reads (and no output) frees its register at once.
            for (s, is_two) in [(nc + 2 * k, false), (nc + 2 * k + 1, true)] {
                if is_two && !*two {
                    continue;
                }
                let unused = last.get(s).copied() == Some(0) && !is_output.get(s).copied().unwrap_or(true);
                if unused {
                    let r = if is_two { dst2 } else { dst };
                    if !free.contains(&r) {
                        free.push(r);
                    }
                }
            }
        }
        // Constants used by nothing after their definition stay allocated (few, harmless).
        let outputs = outputs.iter().map(|&v| reg_of.get(slot(v, &self.consts)).copied().unwrap_or(0)).collect();
        Ok(Tape { instrs, n_regs, n_inputs, outputs })
    }
}
