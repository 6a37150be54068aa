//! A set of expressions compiled to one flat instruction tape over a register file.
//!
//! Compilation works on an SSA program built from the hash-consed graph and applies only
//! rewrites that keep every value bit for bit (for `f64`, dual numbers and power series
//! alike): constants folded into the instructions that use them, common subexpressions
//! computed once (also those the graph cannot see: `x*x` from `x^2`, `a + b` and `b + a`),
//! `sin`/`cos` of one argument one `sin_cos`, negations folded into the operation that
//! uses them (`a + (-b)` is `a - b`, `(-a)*c` is `a*(-c)`), integer powers as the same
//! products `powi` forms, and an operation fused with the product feeding it when that
//! product has no other use (`a*b + c` as one instruction: the same two roundings, one
//! dispatch), and likewise a fused product chain with its one user (`c - (a*b)*d`).
//! Registers are reused once a value is dead; the inputs occupy the first
//! registers. Evaluation is a loop over the tape, generic over [`Scalar`]; small scalars
//! (`f64`, dual numbers) run on a register array on the stack whose size is a power of
//! two, so that a masked index needs no bounds check and evaluation neither allocates
//! nor touches strings. In `f64` on x86-64, the tape runs as native code compiled once with
//! it (`native`): the same operations in the same order, so the same values bit for bit,
//! without the loop's dispatch.

use std::collections::HashMap;
use std::sync::Arc;

use super::native::Native;
use super::{F1, Graph, Id, Node, children};
use crate::scalar::Scalar;

/// One operation; register indices are `u16`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Op {
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
    /// `a*b + c` (the product rounded, then the sum).
    MulAdd(u16, u16, u16),
    /// `a*b - c`.
    MulSub(u16, u16, u16),
    /// `c - a*b` (operands `c, a, b`).
    SubMul(u16, u16, u16),
    /// `a*k + c`.
    MulCAdd(u16, f64, u16),
    /// `a*k - c`.
    MulCSub(u16, f64, u16),
    /// `c - a*k` (operands `c, a, k`).
    SubMulC(u16, u16, f64),
    /// `a*k1 + k2`.
    MulCAddC(u16, f64, f64),
    /// `(a*b)*c`.
    MulMul(u16, u16, u16),
    /// `(a*k)*b`.
    MulCMul(u16, f64, u16),
    /// `a*b + c*d`.
    DotAdd(u16, u16, u16, u16),
    /// `a*b - c*d`.
    DotSub(u16, u16, u16, u16),
    /// `a*k1 + c*k2`.
    DotCAdd(u16, f64, u16, f64),
    /// `a*k1 - c*k2`.
    DotCSub(u16, f64, u16, f64),
    /// `a*b + c*k`.
    DotMCAdd(u16, u16, u16, f64),
    /// `a*b - c*k`.
    DotMCSub(u16, u16, u16, f64),
    /// `a*k - c*d`.
    DotCMSub(u16, f64, u16, u16),
    /// `(a*b)*k1 + k2`.
    MulMulCAddC(u16, u16, f64, f64),
    /// `c - (a*b)*d` (operands `c, a, b, d`).
    SubMulMul(u16, u16, u16, u16),
    /// `c - (a*k)*b` (operands `c, a, k, b`).
    SubMulCMul(u16, u16, f64, u16),
    /// The end of the tape: its last instruction, and only there (the evaluation loop
    /// stops on it instead of testing for the end at every instruction).
    End,
}

impl Op {
    /// The registers the operation reads, appended to `out`.
    pub(super) fn registers(&self, out: &mut Vec<u16>) {
        match *self {
            Op::Neg(a)
            | Op::AddC(a, _)
            | Op::SubC(a, _)
            | Op::RSubC(_, a)
            | Op::MulC(a, _)
            | Op::DivC(a, _)
            | Op::RDivC(_, a)
            | Op::PowI(a, _)
            | Op::PowC(a, _)
            | Op::Fn1(_, a)
            | Op::SinCos(a)
            | Op::MulCAddC(a, _, _) => out.push(a),
            Op::Add(a, b)
            | Op::Sub(a, b)
            | Op::Mul(a, b)
            | Op::Div(a, b)
            | Op::Atan2(a, b)
            | Op::MulCAdd(a, _, b)
            | Op::MulCSub(a, _, b)
            | Op::SubMulC(a, b, _)
            | Op::MulCMul(a, _, b)
            | Op::DotCAdd(a, _, b, _)
            | Op::DotCSub(a, _, b, _)
            | Op::MulMulCAddC(a, b, _, _) => out.extend([a, b]),
            Op::MulAdd(a, b, c)
            | Op::MulSub(a, b, c)
            | Op::SubMul(a, b, c)
            | Op::MulMul(a, b, c)
            | Op::DotMCAdd(a, b, c, _)
            | Op::DotMCSub(a, b, c, _)
            | Op::DotCMSub(a, _, b, c)
            | Op::SubMulCMul(a, b, _, c) => out.extend([a, b, c]),
            Op::Sel(a, b, c, d) | Op::DotAdd(a, b, c, d) | Op::DotSub(a, b, c, d) | Op::SubMulMul(a, b, c, d) => {
                out.extend([a, b, c, d])
            }
            Op::End => {}
        }
    }
}

/// An instruction: an operation and its destination register(s).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Instr {
    pub op: Op,
    pub dst: u16,
    /// The second destination of [`Op::SinCos`] (else equal to `dst`).
    pub dst2: u16,
}

/// Compiled expressions. The fields are private and set once by [`Tape::compile`], which
/// checks that every register index they hold is below `n_regs`: the evaluation on a stack
/// array of at least `n_regs` registers relies on it to read and write without bounds checks.
#[derive(Clone, Debug, PartialEq)]
pub struct Tape {
    /// Constants some operation reads from a register (an operand of a two-register
    /// operation, or an output): loaded into their registers before the instructions run.
    consts: Vec<(u16, f64)>,
    instrs: Vec<Instr>,
    /// Registers the evaluation needs, the inputs' included.
    n_regs: usize,
    /// Number of inputs (variables): registers `0..n_inputs` hold them.
    n_inputs: usize,
    /// The register holding each output, in the order the roots were given.
    outputs: Vec<u16>,
    /// The `f64` evaluation as native code, where the platform has it; shared by clones.
    native: Option<Arc<Native>>,
}

/// Why a tape could not be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TapeError {
    #[error("the expressions need more than {0} registers")]
    TooManyRegisters(usize),
    /// A compiled tape that breaks the invariants its evaluation relies on (an error of
    /// the tape compiler, never of the expressions).
    #[error("the compiled tape is malformed: {0}")]
    Malformed(String),
}

/// Largest register count of a tape.
pub const MAX_REGS: usize = u16::MAX as usize;

/// Largest integer power computed as products (beyond it, `powi` at run time).
const MAX_EXPANDED_POWER: u32 = 64;

thread_local! {
    /// Tests compile with and without [`Ssa::fuse_chains`] to compare the values.
    pub static WITHOUT_CHAIN_FUSION: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
    /// Tests and benchmarks compile without native code to compare the values and costs.
    pub static WITHOUT_NATIVE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// A value of the SSA program before register allocation.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Val {
    /// A constant folded into its users (loaded into a register when one must hold it).
    Const(f64),
    /// Input `k` (register `k`).
    In(u16),
    /// Index of the SSA instruction computing it (and which of its two results).
    Ssa(usize, bool),
}

impl Val {
    /// A hashable identity (constants by their bits).
    fn key(self) -> (u8, u64) {
        match self {
            Val::Const(c) => (0, c.to_bits()),
            Val::In(k) => (1, u64::from(k)),
            Val::Ssa(k, second) => (2, 2 * k as u64 + u64::from(second)),
        }
    }
}

impl Tape {
    /// Compiles `roots` of `g`, with `n_inputs` variables.
    pub fn compile(g: &Graph, roots: &[Id], n_inputs: usize) -> Result<Tape, TapeError> {
        if n_inputs > MAX_REGS {
            return Err(TapeError::TooManyRegisters(MAX_REGS));
        }
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
        let mut b = Ssa::default();
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
            let out = match node {
                Node::Const(bits) => Val::Const(f64::from_bits(bits)),
                // A variable past the inputs reads NaN, as a missing input does.
                Node::Var(k) if usize::from(k) < n_inputs => Val::In(k),
                Node::Var(_) => Val::Const(f64::NAN),
                Node::Add(x, y) => match (v(x), v(y)) {
                    (Val::Const(c), x) | (x, Val::Const(c)) => b.emit(SsaOp::AddC(x, c)),
                    (x, y) => b.emit(SsaOp::Bin(BinOp::Add, x, y)),
                },
                Node::Sub(x, y) => match (v(x), v(y)) {
                    (x, Val::Const(c)) => b.emit(SsaOp::SubC(x, c)),
                    (Val::Const(c), y) => b.emit(SsaOp::RSubC(c, y)),
                    (x, y) => b.emit(SsaOp::Bin(BinOp::Sub, x, y)),
                },
                Node::Mul(x, y) => match (v(x), v(y)) {
                    (Val::Const(c), x) | (x, Val::Const(c)) => b.emit(SsaOp::MulC(x, c)),
                    (x, y) => b.emit(SsaOp::Bin(BinOp::Mul, x, y)),
                },
                Node::Div(x, y) => match (v(x), v(y)) {
                    (x, Val::Const(c)) => b.emit(SsaOp::DivC(x, c)),
                    (Val::Const(c), y) => b.emit(SsaOp::RDivC(c, y)),
                    (x, y) => b.emit(SsaOp::Bin(BinOp::Div, x, y)),
                },
                Node::Neg(x) => b.emit(SsaOp::Neg(v(x))),
                Node::PowI(x, m) => b.powi(v(x), m),
                Node::PowC(x, p) => b.emit(SsaOp::PowC(v(x), f64::from_bits(p))),
                Node::Fn1(f @ (F1::Sin | F1::Cos), x) => {
                    let partner = if f == F1::Sin { F1::Cos } else { F1::Sin };
                    let other = g.index.get(&Node::Fn1(partner, x)).copied();
                    match other {
                        Some(o) if live.get(o as usize).copied().unwrap_or(false) => {
                            let (s, c) = b.sin_cos(v(x));
                            let theirs = if f == F1::Sin { c } else { s };
                            if let Some(slot) = val.get_mut(o as usize) {
                                *slot = Some(theirs);
                            }
                            if f == F1::Sin { s } else { c }
                        }
                        _ => b.emit(SsaOp::Fn1(f, v(x))),
                    }
                }
                Node::Fn1(f, x) => b.emit(SsaOp::Fn1(f, v(x))),
                Node::Atan2(y, x) => b.emit(SsaOp::Bin(BinOp::Atan2, v(y), v(x))),
                Node::Sel(x, y, t, f) => b.emit(SsaOp::Sel(v(x), v(y), v(t), v(f))),
            };
            if let Some(s) = val.get_mut(i) {
                *s = Some(out);
            }
        }
        let out_vals: Vec<Val> = roots.iter().map(|&r| get(&val, r).unwrap_or(Val::Const(f64::NAN))).collect();
        b.fuse(&out_vals);
        let chains = !WITHOUT_CHAIN_FUSION.with(std::cell::Cell::get);
        if chains {
            b.fuse_chains(&out_vals);
        }
        b.allocate(&out_vals, n_inputs)
    }

    /// Constants loaded into registers before the instructions run: `(register, value)`.
    pub fn consts(&self) -> &[(u16, f64)] {
        &self.consts
    }

    /// The instructions, in evaluation order (without the closing [`Op::End`]).
    pub fn instrs(&self) -> &[Instr] {
        self.instrs.split_last().map_or(&[], |(_, rest)| rest)
    }

    /// Registers the evaluation needs, the inputs' included.
    pub fn n_regs(&self) -> usize {
        self.n_regs
    }

    /// Number of inputs: registers `0..n_inputs` hold them.
    pub fn n_inputs(&self) -> usize {
        self.n_inputs
    }

    /// The register holding each output, in the order the roots were given.
    pub fn outputs(&self) -> &[u16] {
        &self.outputs
    }

    /// The invariants the unchecked evaluation relies on: the tape ends with its only
    /// [`Op::End`], and every register an instruction, a constant or an output names is
    /// below `n_regs`, and so are the inputs.
    fn validate(self) -> Result<Tape, TapeError> {
        let n_regs = self.n_regs;
        let bad = |r: u16| usize::from(r) >= n_regs;
        let ends = self.instrs.iter().filter(|i| i.op == Op::End).count();
        if ends != 1 || self.instrs.last().map(|i| i.op) != Some(Op::End) {
            return Err(TapeError::Malformed(format!("{ends} `End` instructions, and not exactly one at the end")));
        }
        let mut regs: Vec<u16> = Vec::new();
        for ins in self.instrs() {
            regs.clear();
            ins.op.registers(&mut regs);
            regs.push(ins.dst);
            regs.push(ins.dst2);
            if let Some(&r) = regs.iter().find(|&&r| bad(r)) {
                return Err(TapeError::Malformed(format!("{ins:?} names register {r} of {n_regs}")));
            }
        }
        if let Some(r) = self.consts.iter().map(|&(r, _)| r).chain(self.outputs.iter().copied()).find(|&r| bad(r)) {
            return Err(TapeError::Malformed(format!("a constant or an output in register {r} of {n_regs}")));
        }
        if self.n_inputs > n_regs {
            return Err(TapeError::Malformed(format!("{} inputs in {n_regs} registers", self.n_inputs)));
        }
        // Native code unless tests or benchmarks turned it off, or the platform has no code
        // generator or no executable memory.
        let native = if WITHOUT_NATIVE.with(std::cell::Cell::get) {
            None
        } else {
            Native::compile(&self.instrs, n_regs, &self.outputs).map(Arc::new)
        };
        Ok(Tape { native, ..self })
    }

    /// Whether `f64` evaluations run as native code (else they are interpreted).
    pub fn is_native(&self) -> bool {
        self.native.is_some()
    }

    /// Evaluates the tape: `inputs` (`n_inputs` of them; missing ones read NaN) into `regs`
    /// (at least `n_regs`); the outputs are then `regs[outputs[i]]`.
    #[inline]
    pub fn eval<S: Scalar>(&self, inputs: &[S], regs: &mut [S]) {
        for (k, r) in regs.iter_mut().enumerate().take(self.n_inputs) {
            *r = inputs.get(k).copied().unwrap_or(S::cst(f64::NAN));
        }
        self.run(regs);
    }

    /// Evaluates the tape and hands the result to `f`, which reads the outputs by index
    /// ([`Evaluated::output`]) straight from the registers. Small scalars use a register
    /// array on the stack (no allocation); a large scalar (a truncated power series) a
    /// register file on the heap.
    #[inline]
    pub fn eval_with<S: Scalar, T>(&self, inputs: &[S], f: impl FnOnce(&Evaluated<'_, S>) -> T) -> T {
        // Every input given (those past `n_inputs` land in registers the tape writes before
        // it reads them), NaN for the missing ones.
        let n_inputs = self.n_inputs;
        let load = |regs: &mut [S]| {
            for (r, x) in regs.iter_mut().zip(inputs) {
                *r = *x;
            }
            if inputs.len() < n_inputs {
                for r in regs.iter_mut().take(n_inputs).skip(inputs.len()) {
                    *r = S::cst(f64::NAN);
                }
            }
        };
        self.eval_loaded(load, f)
    }

    /// [`Tape::eval_with`] with the inputs written by `load` straight into the register
    /// file (all zero when `load` gets it; it writes the inputs to registers `0..n_inputs`,
    /// and any register past them is overwritten before the tape reads it): no input array
    /// is built and copied.
    #[inline(always)]
    pub fn eval_loaded<S: Scalar, T>(&self, load: impl FnOnce(&mut [S]), f: impl FnOnce(&Evaluated<'_, S>) -> T) -> T {
        if core::mem::size_of::<S>() <= 128 {
            match self.n_regs {
                0..=16 => return self.eval_loaded_on::<S, T, 16>(load, f),
                17..=32 => return self.eval_loaded_on::<S, T, 32>(load, f),
                33..=64 => return self.eval_loaded_on::<S, T, 64>(load, f),
                65..=128 => return self.eval_loaded_on::<S, T, 128>(load, f),
                129..=256 => return self.eval_loaded_on::<S, T, 256>(load, f),
                _ => {}
            }
        }
        let mut regs = vec![S::cst(0.0); self.n_regs];
        load(regs.as_mut_slice());
        self.run(regs.as_mut_slice());
        f(&Evaluated { regs: &regs, outputs: &self.outputs })
    }

    /// [`Tape::eval_loaded`] on an array of `R` registers, at least `n_regs`: every index the
    /// tape holds is below `n_regs` ([`Tape::validate`]), so the loop reads and writes
    /// without bounds checks. Forced inline only in builds without debug assertions: an
    /// unoptimized build would otherwise give every caller the frames of all five array
    /// sizes, megabytes for a power series, which never takes this path.
    #[cfg_attr(not(debug_assertions), inline(always))]
    #[cfg_attr(debug_assertions, inline)]
    fn eval_loaded_on<S: Scalar, T, const R: usize>(
        &self,
        load: impl FnOnce(&mut [S]),
        f: impl FnOnce(&Evaluated<'_, S>) -> T,
    ) -> T {
        assert!(self.n_regs <= R, "a register file of {R} for a tape of {} registers", self.n_regs);
        let mut regs = Fixed([S::cst(0.0); R]);
        load(regs.0.as_mut_slice());
        self.run(&mut regs);
        f(&Evaluated { regs: &regs.0, outputs: &self.outputs })
    }

    /// Evaluates the tape and writes its outputs, in order, to `out` (as many as both
    /// have).
    #[inline]
    pub fn eval_outputs<S: Scalar>(&self, inputs: &[S], out: &mut [S]) {
        self.eval_with(inputs, |e| {
            for (k, o) in out.iter_mut().enumerate() {
                *o = e.output(k);
            }
        })
    }

    /// The instruction loop over any register file.
    #[inline(always)]
    fn run<S: Scalar, F: Regs<S> + ?Sized>(&self, regs: &mut F) {
        for &(r, c) in &self.consts {
            regs.put(r, S::cst(c));
        }
        if let (Some(native), Some(file)) = (&self.native, regs.f64_file()) {
            if native.run(file) {
                return;
            }
        }
        let mut next = self.instrs.iter();
        loop {
            // SAFETY: the last instruction is the only `End` (`Tape::validate`; the fields are
            // private), and the loop stops there, so the iterator never runs out.
            let ins = unsafe { next.next().unwrap_unchecked() };
            if !exec(ins, regs) {
                break;
            }
        }
    }

    /// Evaluates in `f64` and returns the outputs (allocates: for checks, not for the rhs).
    pub fn eval_f64(&self, inputs: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.outputs.len()];
        self.eval_outputs(inputs, &mut out);
        out
    }

    /// Number of instructions (the cost of one evaluation, in tape steps).
    pub fn len(&self) -> usize {
        self.instrs().len()
    }

    pub fn is_empty(&self) -> bool {
        self.instrs().is_empty()
    }
}

/// [`exec`] in `f64` on a slice: what native code calls for the operations it does not
/// compute itself.
#[cfg(target_arch = "x86_64")]
pub(super) fn exec_f64(ins: &Instr, regs: &mut [f64]) {
    exec::<f64, [f64]>(ins, regs);
}

/// Runs one instruction on `regs`; `false` for the closing [`Op::End`].
#[inline(always)]
fn exec<S: Scalar, F: Regs<S> + ?Sized>(ins: &Instr, regs: &mut F) -> bool {
    let value = match ins.op {
        Op::End => return false,
        Op::Add(a, b) => regs.with2(a, b, |x, y| x.add_ref(y)),
        Op::Sub(a, b) => regs.with2(a, b, |x, y| x.sub_ref(y)),
        Op::Mul(a, b) => regs.with2(a, b, |x, y| x.mul_ref(y)),
        Op::Div(a, b) => regs.read(a) / regs.read(b),
        Op::Neg(a) => -regs.read(a),
        Op::AddC(a, c) => regs.read(a) + c,
        Op::SubC(a, c) => regs.read(a) - c,
        Op::RSubC(c, a) => -regs.read(a) + c,
        Op::MulC(a, c) => regs.with1(a, |x| x.scaled(c)),
        Op::DivC(a, c) => regs.read(a) / c,
        Op::RDivC(c, a) => S::cst(c) / regs.read(a),
        Op::PowI(a, m) => powi(regs.read(a), m),
        Op::PowC(a, p) => regs.read(a).apply(|x0, out| power_coefficients(x0, p, out)),
        Op::Fn1(f, a) => fn1(f, regs.read(a)),
        Op::SinCos(a) => {
            let (s, c) = regs.read(a).sin_cos();
            regs.put(ins.dst2, c);
            s
        }
        Op::Atan2(y, x) => atan2(regs.read(y), regs.read(x)),
        Op::Sel(a, b, t, f) => {
            if regs.read(a).re() <= regs.read(b).re() {
                regs.read(t)
            } else {
                regs.read(f)
            }
        }
        Op::MulAdd(a, b, c) => {
            let p = regs.with2(a, b, |x, y| x.mul_ref(y));
            regs.with1(c, |z| p.add_ref(z))
        }
        Op::MulSub(a, b, c) => {
            let p = regs.with2(a, b, |x, y| x.mul_ref(y));
            regs.with1(c, |z| p.sub_ref(z))
        }
        Op::SubMul(c, a, b) => {
            let p = regs.with2(a, b, |x, y| x.mul_ref(y));
            regs.with1(c, |z| z.sub_ref(&p))
        }
        Op::MulCAdd(a, k, c) => {
            let p = regs.with1(a, |x| x.scaled(k));
            regs.with1(c, |z| p.add_ref(z))
        }
        Op::MulCSub(a, k, c) => {
            let p = regs.with1(a, |x| x.scaled(k));
            regs.with1(c, |z| p.sub_ref(z))
        }
        Op::SubMulC(c, a, k) => {
            let p = regs.with1(a, |x| x.scaled(k));
            regs.with1(c, |z| z.sub_ref(&p))
        }
        Op::MulCAddC(a, k1, k2) => regs.with1(a, |x| x.scaled(k1)) + k2,
        Op::MulMul(a, b, c) => {
            let p = regs.with2(a, b, |x, y| x.mul_ref(y));
            regs.with1(c, |z| p.mul_ref(z))
        }
        Op::MulCMul(a, k, b) => {
            let p = regs.with1(a, |x| x.scaled(k));
            regs.with1(b, |z| p.mul_ref(z))
        }
        Op::DotAdd(a, b, c, d) => {
            let p = regs.with2(a, b, |x, y| x.mul_ref(y));
            let q = regs.with2(c, d, |x, y| x.mul_ref(y));
            p.add_ref(&q)
        }
        Op::DotSub(a, b, c, d) => {
            let p = regs.with2(a, b, |x, y| x.mul_ref(y));
            let q = regs.with2(c, d, |x, y| x.mul_ref(y));
            p.sub_ref(&q)
        }
        Op::DotCAdd(a, k1, c, k2) => {
            let p = regs.with1(a, |x| x.scaled(k1));
            let q = regs.with1(c, |x| x.scaled(k2));
            p.add_ref(&q)
        }
        Op::DotCSub(a, k1, c, k2) => {
            let p = regs.with1(a, |x| x.scaled(k1));
            let q = regs.with1(c, |x| x.scaled(k2));
            p.sub_ref(&q)
        }
        Op::DotMCAdd(a, b, c, k) => {
            let p = regs.with2(a, b, |x, y| x.mul_ref(y));
            let q = regs.with1(c, |x| x.scaled(k));
            p.add_ref(&q)
        }
        Op::DotMCSub(a, b, c, k) => {
            let p = regs.with2(a, b, |x, y| x.mul_ref(y));
            let q = regs.with1(c, |x| x.scaled(k));
            p.sub_ref(&q)
        }
        Op::DotCMSub(a, k, c, d) => {
            let p = regs.with1(a, |x| x.scaled(k));
            let q = regs.with2(c, d, |x, y| x.mul_ref(y));
            p.sub_ref(&q)
        }
        Op::MulMulCAddC(a, b, k1, k2) => regs.with2(a, b, |x, y| x.mul_ref(y)).scaled(k1) + k2,
        Op::SubMulMul(c, a, b, d) => {
            let p = regs.with2(a, b, |x, y| x.mul_ref(y));
            let q = regs.with1(d, |z| p.mul_ref(z));
            regs.with1(c, |z| z.sub_ref(&q))
        }
        Op::SubMulCMul(c, a, k, b) => {
            let p = regs.with1(a, |x| x.scaled(k));
            let q = regs.with1(b, |z| p.mul_ref(z));
            regs.with1(c, |z| z.sub_ref(&q))
        }
    };
    regs.put(ins.dst, value);
    true
}

/// The registers after an evaluation ([`Tape::eval_with`]).
pub struct Evaluated<'a, S> {
    regs: &'a [S],
    outputs: &'a [u16],
}

impl<S: Scalar> Evaluated<'_, S> {
    /// Output `k` (NaN past the last).
    #[inline(always)]
    pub fn output(&self, k: usize) -> S {
        read_output(self.regs, self.outputs, k)
    }

    /// The first `K` outputs to read in place (the output count checked once), or `None`
    /// when the tape has fewer.
    #[inline(always)]
    pub fn outputs_fixed<const K: usize>(&self) -> Option<Outputs<'_, S, K>> {
        let outputs = self.outputs.get(..K)?.try_into().ok()?;
        Some(Outputs { regs: self.regs, outputs })
    }
}

/// The first `K` outputs of an evaluation ([`Evaluated::outputs_fixed`]), read straight from
/// the registers: no copy of the outputs.
pub struct Outputs<'a, S, const K: usize> {
    regs: &'a [S],
    outputs: &'a [u16; K],
}

impl<S: Scalar, const K: usize> Outputs<'_, S, K> {
    /// Output `k` (NaN for `k >= K`).
    #[inline(always)]
    pub fn get(&self, k: usize) -> S {
        read_output(self.regs, self.outputs, k)
    }
}

/// Output `k` of an evaluation over `regs` (NaN past the last of `outputs`).
#[inline(always)]
fn read_output<S: Scalar>(regs: &[S], outputs: &[u16], k: usize) -> S {
    match outputs.get(k) {
        Some(&r) => {
            debug_assert!(usize::from(r) < regs.len());
            // SAFETY: `Evaluated` and `Outputs` are built only by `Tape::eval_loaded` over at
            // least the tape's `n_regs` registers, with the tape's outputs, and every output
            // register is below `n_regs` (`Tape::validate`).
            *unsafe { regs.get_unchecked(usize::from(r)) }
        }
        None => S::cst(f64::NAN),
    }
}

/// A register file: a slice (indices checked, NaN outside) or a [`Fixed`] array.
trait Regs<S: Scalar> {
    fn at(&self, i: u16) -> Option<&S>;
    fn put(&mut self, i: u16, v: S);
    /// The registers as `f64`s, when `S` is `f64`.
    fn f64_file(&mut self) -> Option<&mut [f64]>;
    #[inline(always)]
    fn read(&self, i: u16) -> S {
        self.at(i).copied().unwrap_or(S::cst(f64::NAN))
    }
    #[inline(always)]
    fn with1(&self, a: u16, f: impl FnOnce(&S) -> S) -> S {
        match self.at(a) {
            Some(x) => f(x),
            None => S::cst(f64::NAN),
        }
    }
    #[inline(always)]
    fn with2(&self, a: u16, b: u16, f: impl FnOnce(&S, &S) -> S) -> S {
        match (self.at(a), self.at(b)) {
            (Some(x), Some(y)) => f(x, y),
            _ => S::cst(f64::NAN),
        }
    }
}

impl<S: Scalar> Regs<S> for [S] {
    #[inline(always)]
    fn at(&self, i: u16) -> Option<&S> {
        self.get(usize::from(i))
    }
    #[inline(always)]
    fn put(&mut self, i: u16, v: S) {
        if let Some(s) = self.get_mut(usize::from(i)) {
            *s = v;
        }
    }
    #[inline(always)]
    fn f64_file(&mut self) -> Option<&mut [f64]> {
        S::as_f64s(self)
    }
}

/// `R` registers, `R >= n_regs` of the tape run on them ([`Tape::eval_loaded`] asserts it):
/// every register index of a tape is below its `n_regs` ([`Tape::validate`], and the fields
/// are private), so every access is in bounds without a check.
struct Fixed<S, const R: usize>([S; R]);

impl<S: Scalar, const R: usize> Regs<S> for Fixed<S, R> {
    #[inline(always)]
    fn at(&self, i: u16) -> Option<&S> {
        debug_assert!(usize::from(i) < R);
        // SAFETY: `i` is a register index of the tape being run (see the type's comment).
        Some(unsafe { self.0.get_unchecked(usize::from(i)) })
    }
    #[inline(always)]
    fn put(&mut self, i: u16, v: S) {
        debug_assert!(usize::from(i) < R);
        // SAFETY: as for `at`.
        unsafe { *self.0.get_unchecked_mut(usize::from(i)) = v }
    }
    #[inline(always)]
    fn f64_file(&mut self) -> Option<&mut [f64]> {
        S::as_f64s(&mut self.0)
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
        // The sign bit, as `f64::abs` clears it: `abs(-0)` is `+0`.
        F1::Abs => {
            if x.re().is_sign_negative() {
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
    // The value is `base` itself (also a signed zero, as `f64::atan2` gives it).
    s.apply(|s0, out| {
        atan_coefficients(s0, out);
        if let Some(o) = out.first_mut() {
            *o = if s0 == 0.0 { base } else { *o + base };
        }
    })
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum BinOp {
    Add,
    Sub,
    Mul,
    Div,
    Atan2,
}

/// An operation of the SSA program (the shapes of [`Op`], over values).
#[derive(Clone, Copy, Debug, PartialEq)]
enum SsaOp {
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
    MulAdd(Val, Val, Val),
    MulSub(Val, Val, Val),
    SubMul(Val, Val, Val),
    MulCAdd(Val, f64, Val),
    MulCSub(Val, f64, Val),
    SubMulC(Val, Val, f64),
    MulCAddC(Val, f64, f64),
    MulMul(Val, Val, Val),
    MulCMul(Val, f64, Val),
    DotAdd(Val, Val, Val, Val),
    DotSub(Val, Val, Val, Val),
    DotCAdd(Val, f64, Val, f64),
    DotCSub(Val, f64, Val, f64),
    DotMCAdd(Val, Val, Val, f64),
    DotMCSub(Val, Val, Val, f64),
    DotCMSub(Val, f64, Val, Val),
    MulMulCAddC(Val, Val, f64, f64),
    SubMulMul(Val, Val, Val, Val),
    SubMulCMul(Val, Val, f64, Val),
}

/// Hash key of an operation: a tag and up to four words (values and constants by bits).
type Key = (u8, [(u8, u64); 4]);

impl SsaOp {
    fn operands(&self) -> Vec<Val> {
        match *self {
            SsaOp::Bin(_, a, b)
            | SsaOp::MulCAdd(a, _, b)
            | SsaOp::MulCSub(a, _, b)
            | SsaOp::SubMulC(a, b, _)
            | SsaOp::MulCMul(a, _, b)
            | SsaOp::DotCAdd(a, _, b, _)
            | SsaOp::DotCSub(a, _, b, _)
            | SsaOp::MulMulCAddC(a, b, _, _) => vec![a, b],
            SsaOp::DotMCAdd(a, b, c, _)
            | SsaOp::DotMCSub(a, b, c, _)
            | SsaOp::DotCMSub(a, _, b, c)
            | SsaOp::SubMulCMul(a, b, _, c) => vec![a, b, c],
            SsaOp::DotAdd(a, b, c, d) | SsaOp::DotSub(a, b, c, d) | SsaOp::SubMulMul(a, b, c, d) => vec![a, b, c, d],
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
            | SsaOp::SinCos(a)
            | SsaOp::MulCAddC(a, _, _) => vec![a],
            SsaOp::Sel(a, b, t, f) => vec![a, b, t, f],
            SsaOp::MulAdd(a, b, c) | SsaOp::MulSub(a, b, c) | SsaOp::SubMul(a, b, c) | SsaOp::MulMul(a, b, c) => {
                vec![a, b, c]
            }
        }
    }

    fn key(&self) -> Key {
        let v = |x: Val| x.key();
        let c = |x: f64| (0u8, x.to_bits());
        let z = (0u8, 0u64);
        match *self {
            // `a + b` is `b + a` bit for bit for every scalar (sums of coefficients).
            SsaOp::Bin(BinOp::Add, a, b) => {
                let (p, q) = if v(a) <= v(b) { (a, b) } else { (b, a) };
                (0, [v(p), v(q), z, z])
            }
            SsaOp::Bin(op, a, b) => (1 + op as u8, [v(a), v(b), z, z]),
            SsaOp::Neg(a) => (10, [v(a), z, z, z]),
            SsaOp::AddC(a, k) => (11, [v(a), c(k), z, z]),
            SsaOp::SubC(a, k) => (12, [v(a), c(k), z, z]),
            SsaOp::RSubC(k, a) => (13, [v(a), c(k), z, z]),
            SsaOp::MulC(a, k) => (14, [v(a), c(k), z, z]),
            SsaOp::DivC(a, k) => (15, [v(a), c(k), z, z]),
            SsaOp::RDivC(k, a) => (16, [v(a), c(k), z, z]),
            SsaOp::PowI(a, m) => (17, [v(a), (0, u64::from(m as u32)), z, z]),
            SsaOp::PowC(a, p) => (18, [v(a), c(p), z, z]),
            SsaOp::Fn1(f, a) => (19, [v(a), (0, f as u64), z, z]),
            SsaOp::SinCos(a) => (20, [v(a), z, z, z]),
            SsaOp::Sel(a, b, t, f) => (21, [v(a), v(b), v(t), v(f)]),
            SsaOp::MulAdd(a, b, x) => (22, [v(a), v(b), v(x), z]),
            SsaOp::MulSub(a, b, x) => (23, [v(a), v(b), v(x), z]),
            SsaOp::SubMul(x, a, b) => (24, [v(x), v(a), v(b), z]),
            SsaOp::MulCAdd(a, k, x) => (25, [v(a), c(k), v(x), z]),
            SsaOp::MulCSub(a, k, x) => (26, [v(a), c(k), v(x), z]),
            SsaOp::SubMulC(x, a, k) => (27, [v(x), v(a), c(k), z]),
            SsaOp::MulCAddC(a, k1, k2) => (28, [v(a), c(k1), c(k2), z]),
            SsaOp::MulMul(a, b, x) => (29, [v(a), v(b), v(x), z]),
            SsaOp::MulCMul(a, k, b) => (30, [v(a), c(k), v(b), z]),
            SsaOp::DotAdd(a, b, x, y) => (31, [v(a), v(b), v(x), v(y)]),
            SsaOp::DotSub(a, b, x, y) => (32, [v(a), v(b), v(x), v(y)]),
            SsaOp::DotCAdd(a, k1, x, k2) => (33, [v(a), c(k1), v(x), c(k2)]),
            SsaOp::DotCSub(a, k1, x, k2) => (34, [v(a), c(k1), v(x), c(k2)]),
            SsaOp::DotMCAdd(a, b, x, k) => (35, [v(a), v(b), v(x), c(k)]),
            SsaOp::DotMCSub(a, b, x, k) => (36, [v(a), v(b), v(x), c(k)]),
            SsaOp::DotCMSub(a, k, x, y) => (37, [v(a), c(k), v(x), v(y)]),
            SsaOp::MulMulCAddC(a, b, k1, k2) => (38, [v(a), v(b), c(k1), c(k2)]),
            SsaOp::SubMulMul(x, a, b, y) => (39, [v(x), v(a), v(b), v(y)]),
            SsaOp::SubMulCMul(x, a, k, b) => (40, [v(x), v(a), c(k), v(b)]),
        }
    }
}

/// The SSA program under construction: operations, their hash index (common
/// subexpressions) and, after [`Ssa::fuse`], which were absorbed into a later one.
#[derive(Default)]
struct Ssa {
    prog: Vec<SsaOp>,
    index: HashMap<Key, usize>,
    dead: Vec<bool>,
}

impl Ssa {
    /// The operation computing `v`, if it is the first result of one.
    fn def(&self, v: Val) -> Option<SsaOp> {
        match v {
            Val::Ssa(k, false) => self.prog.get(k).copied(),
            _ => None,
        }
    }

    /// Adds `op` (after the value-preserving rewrites of negations), or returns the value
    /// of an equal operation already there.
    fn emit(&mut self, op: SsaOp) -> Val {
        let neg_of = |s: &Ssa, v: Val| match s.def(v) {
            Some(SsaOp::Neg(x)) => Some(x),
            _ => None,
        };
        let op = match op {
            // a + (-b) = a - b; (-a) + b = b - a; a - (-b) = a + b.
            SsaOp::Bin(BinOp::Add, a, b) => match (neg_of(self, a), neg_of(self, b)) {
                (_, Some(y)) => SsaOp::Bin(BinOp::Sub, a, y),
                (Some(x), None) => SsaOp::Bin(BinOp::Sub, b, x),
                _ => op,
            },
            SsaOp::Bin(BinOp::Sub, a, b) => match neg_of(self, b) {
                Some(y) => SsaOp::Bin(BinOp::Add, a, y),
                None => op,
            },
            // a*(-b) = (-a)*b = -(a*b), and likewise for a quotient: the negation moves to
            // where a sum can absorb it (each product or quotient is the same number up to
            // its sign, also coefficient by coefficient).
            SsaOp::Bin(bin @ (BinOp::Mul | BinOp::Div), a, b) => match (neg_of(self, a), neg_of(self, b)) {
                (Some(x), Some(y)) => SsaOp::Bin(bin, x, y),
                (Some(x), None) => {
                    let p = self.push(SsaOp::Bin(bin, x, b));
                    SsaOp::Neg(p)
                }
                (None, Some(y)) => {
                    let p = self.push(SsaOp::Bin(bin, a, y));
                    SsaOp::Neg(p)
                }
                (None, None) => op,
            },
            // (-a)*k = a*(-k).
            SsaOp::MulC(a, k) => match neg_of(self, a) {
                Some(x) => SsaOp::MulC(x, -k),
                None => op,
            },
            // -(-a) = a; -(a*k) = a*(-k).
            SsaOp::Neg(a) => match self.def(a) {
                Some(SsaOp::Neg(x)) => return x,
                Some(SsaOp::MulC(x, k)) => SsaOp::MulC(x, -k),
                _ => op,
            },
            _ => op,
        };
        self.push(op)
    }

    fn push(&mut self, op: SsaOp) -> Val {
        let key = op.key();
        if let Some(&k) = self.index.get(&key) {
            return Val::Ssa(k, false);
        }
        let k = self.prog.len();
        self.prog.push(op);
        self.index.insert(key, k);
        Val::Ssa(k, false)
    }

    /// `(sin x, cos x)` from one operation.
    fn sin_cos(&mut self, x: Val) -> (Val, Val) {
        let Val::Ssa(k, _) = self.push(SsaOp::SinCos(x)) else { return (Val::Const(f64::NAN), Val::Const(f64::NAN)) };
        (Val::Ssa(k, false), Val::Ssa(k, true))
    }

    /// `x^m` as the products (and reciprocal) [`powi`] forms, in its order: the same value.
    fn powi(&mut self, x: Val, m: i32) -> Val {
        let e0 = m.unsigned_abs();
        if e0 > MAX_EXPANDED_POWER {
            return self.emit(SsaOp::PowI(x, m));
        }
        let mut e = e0;
        let mut base = x;
        let mut acc: Option<Val> = None;
        while e > 0 {
            if e & 1 == 1 {
                acc = Some(match acc {
                    None => base,
                    Some(a) => self.emit(SsaOp::Bin(BinOp::Mul, a, base)),
                });
            }
            e >>= 1;
            if e > 0 {
                base = self.emit(SsaOp::Bin(BinOp::Mul, base, base));
            }
        }
        let p = acc.unwrap_or(Val::Const(1.0));
        if m < 0 { self.emit(SsaOp::RDivC(1.0, p)) } else { p }
    }

    /// Fuses a product (`a*b` or `a*k`) into the one operation that uses it, when nothing
    /// else (no other operation, no output) reads it: the fused instruction rounds the
    /// product, then applies the operation, in the operands' original order.
    fn fuse(&mut self, outputs: &[Val]) {
        let np = self.prog.len();
        // Operations some output still needs (rewrites leave negations nobody reads).
        self.dead = vec![false; np];
        self.sweep(outputs);
        let uses = self.uses(outputs);
        for j in 0..np {
            if self.dead.get(j).copied().unwrap_or(true) {
                continue;
            }
            let Some(op) = self.prog.get(j).copied() else { continue };
            // `v` is a product used only here and not yet fused: its operands.
            let single = |s: &Ssa, v: Val| s.single_use(&uses, v);
            let mul = |s: &Ssa, v: Val| match single(s, v) {
                Some((k, SsaOp::Bin(BinOp::Mul, a, b))) => Some((k, a, b)),
                _ => None,
            };
            let mulc = |s: &Ssa, v: Val| match single(s, v) {
                Some((k, SsaOp::MulC(a, c))) => Some((k, a, c)),
                _ => None,
            };
            // A sum or difference of two such products: both fused.
            let two = match op {
                SsaOp::Bin(bin @ (BinOp::Add | BinOp::Sub), x, y) if x != y => {
                    let add = bin == BinOp::Add;
                    match (mul(self, x), mulc(self, x), mul(self, y), mulc(self, y)) {
                        (Some((i, a, b)), _, Some((k, c, d)), _) => {
                            Some((i, k, if add { SsaOp::DotAdd(a, b, c, d) } else { SsaOp::DotSub(a, b, c, d) }))
                        }
                        (_, Some((i, a, k1)), _, Some((k, c, k2))) => {
                            Some((i, k, if add { SsaOp::DotCAdd(a, k1, c, k2) } else { SsaOp::DotCSub(a, k1, c, k2) }))
                        }
                        (Some((i, a, b)), _, _, Some((k, c, q))) => {
                            Some((i, k, if add { SsaOp::DotMCAdd(a, b, c, q) } else { SsaOp::DotMCSub(a, b, c, q) }))
                        }
                        // `c*k + a*b` = `a*b + c*k`: a sum is symmetric bit for bit.
                        (_, Some((i, c, q)), Some((k, a, b)), _) => {
                            Some((i, k, if add { SsaOp::DotMCAdd(a, b, c, q) } else { SsaOp::DotCMSub(c, q, a, b) }))
                        }
                        _ => None,
                    }
                }
                _ => None,
            };
            if let Some((i, k, f)) = two {
                self.absorb(j, &[i, k], f);
                continue;
            }
            let fused = match op {
                SsaOp::Bin(BinOp::Add, x, y) => {
                    if let Some((k, a, b)) = mul(self, x) {
                        Some((k, SsaOp::MulAdd(a, b, y)))
                    } else if let Some((k, a, b)) = mul(self, y) {
                        // `x + a*b` = `a*b + x`: a sum is symmetric bit for bit.
                        Some((k, SsaOp::MulAdd(a, b, x)))
                    } else if let Some((k, a, c)) = mulc(self, x) {
                        Some((k, SsaOp::MulCAdd(a, c, y)))
                    } else {
                        mulc(self, y).map(|(k, a, c)| (k, SsaOp::MulCAdd(a, c, x)))
                    }
                }
                SsaOp::Bin(BinOp::Sub, x, y) => {
                    if let Some((k, a, b)) = mul(self, x) {
                        Some((k, SsaOp::MulSub(a, b, y)))
                    } else if let Some((k, a, b)) = mul(self, y) {
                        Some((k, SsaOp::SubMul(x, a, b)))
                    } else if let Some((k, a, c)) = mulc(self, x) {
                        Some((k, SsaOp::MulCSub(a, c, y)))
                    } else {
                        mulc(self, y).map(|(k, a, c)| (k, SsaOp::SubMulC(x, a, c)))
                    }
                }
                SsaOp::AddC(x, k2) => mulc(self, x).map(|(k, a, c)| (k, SsaOp::MulCAddC(a, c, k2))),
                // `x - k2` = `x + (-k2)`.
                SsaOp::SubC(x, k2) => mulc(self, x).map(|(k, a, c)| (k, SsaOp::MulCAddC(a, c, -k2))),
                SsaOp::Bin(BinOp::Mul, x, y) => {
                    if let Some((k, a, b)) = mul(self, x) {
                        Some((k, SsaOp::MulMul(a, b, y)))
                    } else {
                        mulc(self, x).map(|(k, a, c)| (k, SsaOp::MulCMul(a, c, y)))
                    }
                }
                _ => None,
            };
            if let Some((k, f)) = fused {
                self.absorb(j, &[k], f);
            }
        }
        self.sweep(outputs);
    }

    /// Operation `j` becomes the fused `f`, which computes the operations `absorbed` too: they
    /// are dead now.
    fn absorb(&mut self, j: usize, absorbed: &[usize], f: SsaOp) {
        for &k in absorbed {
            if let Some(d) = self.dead.get_mut(k) {
                *d = true;
            }
        }
        if let Some(slot) = self.prog.get_mut(j) {
            *slot = f;
        }
    }

    /// The live operation behind `v` (index, op) when `v` is its first result and read once
    /// (`uses` from [`Ssa::uses`]): a candidate to fuse into its reader.
    fn single_use(&self, uses: &[usize], v: Val) -> Option<(usize, SsaOp)> {
        let Val::Ssa(k, false) = v else { return None };
        if uses.get(k).copied() != Some(1) || self.dead.get(k).copied().unwrap_or(true) {
            return None;
        }
        self.prog.get(k).map(|&d| (k, d))
    }

    /// How often each operation's first result is read by live operations, outputs counted
    /// twice (never fused away: an output keeps its own register).
    fn uses(&self, outputs: &[Val]) -> Vec<usize> {
        let mut uses = vec![0usize; self.prog.len()];
        let mut count = |v: Val| {
            if let Val::Ssa(k, false) = v {
                if let Some(u) = uses.get_mut(k) {
                    *u += 1;
                }
            }
        };
        for (k, op) in self.prog.iter().enumerate() {
            if !self.dead.get(k).copied().unwrap_or(true) {
                for v in op.operands() {
                    count(v);
                }
            }
        }
        for &v in outputs {
            count(v);
            count(v);
        }
        uses
    }

    /// After [`Ssa::fuse`]: fuses a fused product chain into its one user, when nothing
    /// else reads it (`(a*b)*k1 + k2` from a square scaled and shifted, `c - (a*b)*d` and
    /// `c - (a*k)*b`), evaluated in the operations' original order: the same roundings.
    fn fuse_chains(&mut self, outputs: &[Val]) {
        let uses = self.uses(outputs);
        for j in 0..self.prog.len() {
            if self.dead.get(j).copied().unwrap_or(true) {
                continue;
            }
            let Some(op) = self.prog.get(j).copied() else { continue };
            let fused = match op {
                SsaOp::MulCAddC(x, k1, k2) => match self.single_use(&uses, x) {
                    Some((k, SsaOp::Bin(BinOp::Mul, a, b))) => Some((k, SsaOp::MulMulCAddC(a, b, k1, k2))),
                    _ => None,
                },
                SsaOp::Bin(BinOp::Sub, c, y) if c != y => match self.single_use(&uses, y) {
                    Some((k, SsaOp::MulMul(a, b, d))) => Some((k, SsaOp::SubMulMul(c, a, b, d))),
                    Some((k, SsaOp::MulCMul(a, q, b))) => Some((k, SsaOp::SubMulCMul(c, a, q, b))),
                    _ => None,
                },
                _ => None,
            };
            if let Some((k, f)) = fused {
                self.absorb(j, &[k], f);
            }
        }
    }

    /// Marks dead every operation no output depends on (through live operations).
    fn sweep(&mut self, outputs: &[Val]) {
        let np = self.prog.len();
        let mut needed = vec![false; np];
        for &v in outputs {
            if let Val::Ssa(k, _) = v {
                if let Some(n) = needed.get_mut(k) {
                    *n = true;
                }
            }
        }
        for k in (0..np).rev() {
            if !needed.get(k).copied().unwrap_or(false) || self.dead.get(k).copied().unwrap_or(true) {
                continue;
            }
            for v in self.prog.get(k).map(SsaOp::operands).unwrap_or_default() {
                if let Val::Ssa(i, _) = v {
                    if let Some(n) = needed.get_mut(i) {
                        *n = true;
                    }
                }
            }
        }
        for (d, n) in self.dead.iter_mut().zip(&needed) {
            *d |= !n;
        }
    }

    /// Linear-scan register allocation: the inputs in registers `0..n_inputs`, constants
    /// that must live in registers next, then a register per value, freed after the value's
    /// last use (outputs are never freed).
    fn allocate(&self, outputs: &[Val], n_inputs: usize) -> Result<Tape, TapeError> {
        let live_ops = || self.prog.iter().enumerate().filter(|(k, _)| !self.dead.get(*k).copied().unwrap_or(false));
        // Constants that must live in registers (operands of register-only shapes, outputs).
        let mut consts: Vec<f64> = Vec::new();
        let note = |v: Val, consts: &mut Vec<f64>| {
            if let Val::Const(c) = v {
                if !consts.iter().any(|x| x.to_bits() == c.to_bits()) {
                    consts.push(c);
                }
            }
        };
        for (_, op) in live_ops() {
            for v in op.operands() {
                note(v, &mut consts);
            }
        }
        for &v in outputs {
            note(v, &mut consts);
        }
        let nc = consts.len();
        let np = self.prog.len();
        // Value slots: constants 0..nc, SSA k (first) nc + 2k, (second) nc + 2k + 1.
        let slot = |v: Val| -> Option<usize> {
            match v {
                Val::Const(c) => consts.iter().position(|x| x.to_bits() == c.to_bits()),
                Val::In(_) => None,
                Val::Ssa(k, second) => Some(nc + 2 * k + usize::from(second)),
            }
        };
        let n_slots = nc + 2 * np;
        // Position of each slot's last use (instruction index; constants come first).
        let mut last = vec![0usize; n_slots];
        let mut is_output = vec![false; n_slots];
        for (k, op) in live_ops() {
            for v in op.operands() {
                if let Some(l) = slot(v).and_then(|s| last.get_mut(s)) {
                    *l = nc + k;
                }
            }
        }
        for &v in outputs {
            if let Some(o) = slot(v).and_then(|s| is_output.get_mut(s)) {
                *o = true;
            }
        }
        let mut reg_of = vec![u16::MAX; n_slots];
        let mut free: Vec<u16> = Vec::new();
        let mut n_regs = n_inputs;
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
        let mut instrs = Vec::with_capacity(np);
        let mut const_regs = Vec::with_capacity(nc);
        for (c_idx, &c) in consts.iter().enumerate() {
            let r = take(&mut free)?;
            if let Some(s) = reg_of.get_mut(c_idx) {
                *s = r;
            }
            const_regs.push((r, c));
        }
        let reg = |v: Val, reg_of: &Vec<u16>| match v {
            Val::In(k) => k,
            v => slot(v).and_then(|s| reg_of.get(s)).copied().unwrap_or(0),
        };
        for (k, op) in live_ops() {
            let pos = nc + k;
            let r = |v: Val| reg(v, &reg_of);
            let op2 = match *op {
                SsaOp::Bin(b, x, y) => {
                    let (x, y) = (r(x), r(y));
                    match b {
                        BinOp::Add => Op::Add(x, y),
                        BinOp::Sub => Op::Sub(x, y),
                        BinOp::Mul => Op::Mul(x, y),
                        BinOp::Div => Op::Div(x, y),
                        BinOp::Atan2 => Op::Atan2(x, y),
                    }
                }
                SsaOp::Neg(a) => Op::Neg(r(a)),
                SsaOp::AddC(a, c) => Op::AddC(r(a), c),
                SsaOp::SubC(a, c) => Op::SubC(r(a), c),
                SsaOp::RSubC(c, a) => Op::RSubC(c, r(a)),
                SsaOp::MulC(a, c) => Op::MulC(r(a), c),
                SsaOp::DivC(a, c) => Op::DivC(r(a), c),
                SsaOp::RDivC(c, a) => Op::RDivC(c, r(a)),
                SsaOp::PowI(a, m) => Op::PowI(r(a), m),
                SsaOp::PowC(a, p) => Op::PowC(r(a), p),
                SsaOp::Fn1(f, a) => Op::Fn1(f, r(a)),
                SsaOp::SinCos(a) => Op::SinCos(r(a)),
                SsaOp::Sel(a, b, t, f) => Op::Sel(r(a), r(b), r(t), r(f)),
                SsaOp::MulAdd(a, b, c) => Op::MulAdd(r(a), r(b), r(c)),
                SsaOp::MulSub(a, b, c) => Op::MulSub(r(a), r(b), r(c)),
                SsaOp::SubMul(c, a, b) => Op::SubMul(r(c), r(a), r(b)),
                SsaOp::MulCAdd(a, q, c) => Op::MulCAdd(r(a), q, r(c)),
                SsaOp::MulCSub(a, q, c) => Op::MulCSub(r(a), q, r(c)),
                SsaOp::SubMulC(c, a, q) => Op::SubMulC(r(c), r(a), q),
                SsaOp::MulCAddC(a, q1, q2) => Op::MulCAddC(r(a), q1, q2),
                SsaOp::MulMul(a, b, c) => Op::MulMul(r(a), r(b), r(c)),
                SsaOp::MulCMul(a, q, b) => Op::MulCMul(r(a), q, r(b)),
                SsaOp::DotAdd(a, b, c, d) => Op::DotAdd(r(a), r(b), r(c), r(d)),
                SsaOp::DotSub(a, b, c, d) => Op::DotSub(r(a), r(b), r(c), r(d)),
                SsaOp::DotCAdd(a, k1, c, k2) => Op::DotCAdd(r(a), k1, r(c), k2),
                SsaOp::DotCSub(a, k1, c, k2) => Op::DotCSub(r(a), k1, r(c), k2),
                SsaOp::DotMCAdd(a, b, c, k) => Op::DotMCAdd(r(a), r(b), r(c), k),
                SsaOp::DotMCSub(a, b, c, k) => Op::DotMCSub(r(a), r(b), r(c), k),
                SsaOp::DotCMSub(a, k, c, d) => Op::DotCMSub(r(a), k, r(c), r(d)),
                SsaOp::MulMulCAddC(a, b, k1, k2) => Op::MulMulCAddC(r(a), r(b), k1, k2),
                SsaOp::SubMulMul(c, a, b, d) => Op::SubMulMul(r(c), r(a), r(b), r(d)),
                SsaOp::SubMulCMul(c, a, k, b) => Op::SubMulCMul(r(c), r(a), k, r(b)),
            };
            // Free operands whose last use is here (before choosing the destination: an
            // instruction may overwrite its own operand, the evaluation reads them first).
            // SinCos writes two registers, the first after reading: a freed operand may be
            // reused for either.
            for v in op.operands() {
                let Some(s) = slot(v) else { continue };
                if last.get(s).copied() == Some(pos) && !is_output.get(s).copied().unwrap_or(true) {
                    if let Some(r) = reg_of.get(s).copied() {
                        if r != u16::MAX && !free.contains(&r) {
                            free.push(r);
                        }
                    }
                }
            }
            let two = matches!(op, SsaOp::SinCos(_));
            let dst = take(&mut free)?;
            let dst2 = if two { take(&mut free)? } else { dst };
            if let Some(s) = reg_of.get_mut(nc + 2 * k) {
                *s = dst;
            }
            if two {
                if let Some(s) = reg_of.get_mut(nc + 2 * k + 1) {
                    *s = dst2;
                }
            }
            instrs.push(Instr { op: op2, dst, dst2 });
            // A result nobody reads (and no output) frees its register at once.
            for (s, is_two) in [(nc + 2 * k, false), (nc + 2 * k + 1, true)] {
                if is_two && !two {
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
        let outputs = outputs.iter().map(|&v| reg(v, &reg_of)).collect();
        instrs.push(Instr { op: Op::End, dst: 0, dst2: 0 });
        Tape { consts: const_regs, instrs, n_regs, n_inputs, outputs, native: None }.validate()
    }
}

impl Tape {
    /// A tape from its parts, checked as [`Tape::compile`]'s output is: public only for the
    /// tests of that check (`tests/expr/tape.rs`), not part of the API.
    #[doc(hidden)]
    pub fn from_parts(
        consts: Vec<(u16, f64)>,
        instrs: Vec<Instr>,
        n_regs: usize,
        n_inputs: usize,
        outputs: Vec<u16>,
    ) -> Result<Tape, TapeError> {
        Tape { consts, instrs, n_regs, n_inputs, outputs, native: None }.validate()
    }
}
