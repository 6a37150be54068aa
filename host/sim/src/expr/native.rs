//! A tape's `f64` evaluation as native x86-64 code: the instructions straight-line, with no
//! dispatch, the first registers of the tape held in `xmm0..xmm13` for the whole run, and
//! the constants read from a pool after the code. The register file in memory is read for
//! the inputs and constants the tape reads and written for its outputs; around a call, only
//! the values it reads or that live past it go through memory.
//!
//! The code does the operations of the interpreter's loop in its order, with the same
//! roundings (SSE2 scalar arithmetic, as Rust's own `f64` code on x86-64; no fused
//! multiply-add), so every value is the interpreter's bit for bit (tests compare them on
//! every bundled scene and on random expressions). `sin_cos` calls `f64::sin` and `f64::cos`
//! (what `f64::sin_cos` is); the other operations that call a function (`tan`, `exp`,
//! `atan2`, `powf`, `min`/`max`, ...) are not inlined: the code hands the instruction to the
//! interpreter's own one-step function, so those values are the interpreter's by
//! construction.
//!
//! The machine code is assembled by `dynasmrt` into a buffer that is never writable and
//! executable at once.

use std::fmt;

use dynasmrt::x64::Assembler;
use dynasmrt::{DynamicLabel, DynasmApi, DynasmLabelApi, ExecutableBuffer, dynasm};

use super::tape::{Instr, Op, exec_f64};

/// Tape registers below this are held in `xmm0..` during the run.
const HELD: u16 = 14;
/// Scratch registers for values (constants are memory operands, read from a pool after
/// the code).
const S0: u8 = 15;
const S1: u8 = 14;

/// A compiled tape: `run` evaluates it on a register file of at least `n_regs` `f64`s.
pub(super) struct Native {
    code: ExecutableBuffer,
    /// The function in `code`.
    entry: extern "sysv64" fn(*mut f64),
    /// The tape's instructions, at addresses the code hands to the interpreter's one-step
    /// function: owned here (a boxed slice never moves its elements), so they live as long
    /// as the code.
    _instrs: Box<[Instr]>,
    n_regs: usize,
}

/// Tapes compare by their instructions, of which the code is a function.
impl PartialEq for Native {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl fmt::Debug for Native {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Native {{ {} bytes, {} registers }}", self.code.len(), self.n_regs)
    }
}

/// Where a tape register lives during the run.
#[derive(Clone, Copy)]
enum Loc {
    Xmm(u8),
    /// Byte offset from the register file's start.
    Mem(i32),
}

fn loc(r: u16) -> Loc {
    if r < HELD { Loc::Xmm(r as u8) } else { Loc::Mem(8 * i32::from(r)) }
}

#[derive(Clone, Copy)]
enum Arith {
    Add,
    Sub,
    Mul,
    Div,
}

/// The assembler and the facts the emitters need.
struct Emit {
    ops: Assembler,
    /// Held registers whose `xmm` differs from the register file (written since the last
    /// spill or load).
    dirty: Vec<bool>,
    /// The constants the code reads (their bits) and their labels in the pool.
    pool: Vec<(u64, DynamicLabel)>,
    /// The sign mask of `negate` (16 bytes, aligned), once a negation needs it.
    sign: Option<DynamicLabel>,
}

impl Emit {
    /// `xmm d = r`.
    fn load(&mut self, d: u8, r: u16) {
        match loc(r) {
            Loc::Xmm(s) if s == d => {}
            Loc::Xmm(s) => dynasm!(self.ops ; .arch x64 ; movapd Rx(d), Rx(s)),
            Loc::Mem(o) => dynasm!(self.ops ; .arch x64 ; movsd Rx(d), QWORD [rbx + o]),
        }
    }

    /// `r = xmm s`.
    fn store(&mut self, r: u16, s: u8) {
        match loc(r) {
            Loc::Xmm(d) if s == d => {}
            Loc::Xmm(d) => dynasm!(self.ops ; .arch x64 ; movapd Rx(d), Rx(s)),
            Loc::Mem(o) => dynasm!(self.ops ; .arch x64 ; movsd QWORD [rbx + o], Rx(s)),
        }
    }

    /// The pool label of `c` (one per distinct bit pattern).
    fn label(&mut self, c: f64) -> DynamicLabel {
        let bits = c.to_bits();
        if let Some(&(_, l)) = self.pool.iter().find(|(b, _)| *b == bits) {
            return l;
        }
        let l = self.ops.new_dynamic_label();
        self.pool.push((bits, l));
        l
    }

    /// `xmm d = c`.
    fn konst(&mut self, d: u8, c: f64) {
        let l = self.label(c);
        dynasm!(self.ops ; .arch x64 ; movsd Rx(d), QWORD [=>l]);
    }

    /// `xmm d = -xmm d` (the sign bit flipped, as Rust's `-x`).
    fn negate(&mut self, d: u8) {
        let l = *self.sign.get_or_insert_with(|| self.ops.new_dynamic_label());
        dynasm!(self.ops ; .arch x64 ; xorpd Rx(d), OWORD [=>l]);
    }

    /// The constants after the code: the sign mask first (16-byte aligned, as `xorpd`
    /// needs), then each constant (8-byte aligned).
    fn emit_pool(&mut self) {
        dynasm!(self.ops ; .arch x64 ; .align 16);
        if let Some(l) = self.sign {
            let (mask, zero) = ((-0.0f64).to_bits(), 0u64);
            dynasm!(self.ops ; .arch x64 ; =>l ; .u64 mask ; .u64 zero);
        }
        for (bits, l) in std::mem::take(&mut self.pool) {
            dynasm!(self.ops ; .arch x64 ; =>l ; .u64 bits);
        }
    }

    /// `xmm d = xmm d (op) xmm s`.
    fn arith_x(&mut self, op: Arith, d: u8, s: u8) {
        match op {
            Arith::Add => dynasm!(self.ops ; .arch x64 ; addsd Rx(d), Rx(s)),
            Arith::Sub => dynasm!(self.ops ; .arch x64 ; subsd Rx(d), Rx(s)),
            Arith::Mul => dynasm!(self.ops ; .arch x64 ; mulsd Rx(d), Rx(s)),
            Arith::Div => dynasm!(self.ops ; .arch x64 ; divsd Rx(d), Rx(s)),
        }
    }

    /// `xmm d = xmm d (op) r`.
    fn arith(&mut self, op: Arith, d: u8, r: u16) {
        match (op, loc(r)) {
            (op, Loc::Xmm(s)) => self.arith_x(op, d, s),
            (Arith::Add, Loc::Mem(o)) => dynasm!(self.ops ; .arch x64 ; addsd Rx(d), QWORD [rbx + o]),
            (Arith::Sub, Loc::Mem(o)) => dynasm!(self.ops ; .arch x64 ; subsd Rx(d), QWORD [rbx + o]),
            (Arith::Mul, Loc::Mem(o)) => dynasm!(self.ops ; .arch x64 ; mulsd Rx(d), QWORD [rbx + o]),
            (Arith::Div, Loc::Mem(o)) => dynasm!(self.ops ; .arch x64 ; divsd Rx(d), QWORD [rbx + o]),
        }
    }

    /// `xmm d = xmm d (op) c`.
    fn arith_c(&mut self, op: Arith, d: u8, c: f64) {
        let l = self.label(c);
        match op {
            Arith::Add => dynasm!(self.ops ; .arch x64 ; addsd Rx(d), QWORD [=>l]),
            Arith::Sub => dynasm!(self.ops ; .arch x64 ; subsd Rx(d), QWORD [=>l]),
            Arith::Mul => dynasm!(self.ops ; .arch x64 ; mulsd Rx(d), QWORD [=>l]),
            Arith::Div => dynasm!(self.ops ; .arch x64 ; divsd Rx(d), QWORD [=>l]),
        }
    }

    /// `xmm d = a * b`.
    fn product(&mut self, d: u8, a: u16, b: u16) {
        self.load(d, a);
        self.arith(Arith::Mul, d, b);
    }

    /// `xmm d = a * k`.
    fn scaled(&mut self, d: u8, a: u16, k: f64) {
        self.load(d, a);
        self.arith_c(Arith::Mul, d, k);
    }

    /// The held registers of `which` written since they were loaded, to the register file.
    fn spill(&mut self, which: &[bool]) {
        for r in 0..HELD {
            let k = usize::from(r);
            if which.get(k).copied().unwrap_or(false) && self.dirty.get(k).copied().unwrap_or(false) {
                let o = 8 * i32::from(r);
                dynasm!(self.ops ; .arch x64 ; movsd QWORD [rbx + o], Rx(r as u8));
                if let Some(d) = self.dirty.get_mut(k) {
                    *d = false;
                }
            }
        }
    }

    /// The held registers of `which` from the register file.
    fn reload(&mut self, which: &[bool]) {
        for r in 0..HELD {
            let k = usize::from(r);
            if which.get(k).copied().unwrap_or(false) {
                let o = 8 * i32::from(r);
                dynasm!(self.ops ; .arch x64 ; movsd Rx(r as u8), QWORD [rbx + o]);
                if let Some(d) = self.dirty.get_mut(k) {
                    *d = false;
                }
            }
        }
    }

    /// The instruction at `ins` run by the interpreter's [`step`] on the register file,
    /// which must hold what it reads (`live_in`); the registers live after it (`live_out`)
    /// are loaded again, since a call may clobber every `xmm`.
    fn call(&mut self, ins: *const Instr, n_regs: usize, live_in: &[bool], live_out: &[bool]) {
        self.spill(live_in);
        let step: extern "sysv64" fn(*mut f64, usize, *const Instr) = step;
        let (n, ins, step) = (n_regs as i64, ins as i64, step as usize as i64);
        dynasm!(self.ops
            ; .arch x64
            ; mov rdi, rbx
            ; mov rsi, QWORD n
            ; mov rdx, QWORD ins
            ; mov rax, QWORD step
            ; call rax
        );
        self.reload(live_out);
        self.forget();
    }

    /// `sin` and `cos` of `a` into `dst` and `dst2` by direct calls of `f64::sin` and
    /// `f64::cos` (what `f64::sin_cos`, and so the interpreter, computes), with the value in
    /// `xmm0`: the registers live through it kept as for [`Emit::call`].
    fn sin_cos(&mut self, a: u16, dst: u16, dst2: u16, live_in: &[bool], live_out: &[bool]) {
        self.spill(live_in);
        let oa = 8 * i32::from(a);
        // The result that overwrites the argument's register (if one does) computed last.
        let (sin, cos): (extern "sysv64" fn(f64) -> f64, extern "sysv64" fn(f64) -> f64) = (sin, cos);
        let order = if dst == a { [(cos, dst2), (sin, dst)] } else { [(sin, dst), (cos, dst2)] };
        for (f, d) in order {
            let (f, od) = (f as usize as i64, 8 * i32::from(d));
            dynasm!(self.ops
                ; .arch x64
                ; movsd xmm0, QWORD [rbx + oa]
                ; mov rax, QWORD f
                ; call rax
                ; movsd QWORD [rbx + od], xmm0
            );
        }
        self.reload(live_out);
        self.forget();
    }

    /// After a call: the registers that live on were loaded, and the others' `xmm` hold
    /// nothing that is read again, so none differs from the register file in a way that
    /// matters (a dead value must not be spilled over what the call wrote).
    fn forget(&mut self) {
        self.dirty.fill(false);
    }

    /// One instruction, computed by the code itself; `false` for one that calls a function
    /// ([`Emit::sin_cos`], [`Emit::call`]), for which nothing is emitted.
    fn instr(&mut self, ins: &Instr) -> bool {
        use Arith::*;
        // The result straight into its held register when the operation reads no register
        // it would overwrite on the way, else through the scratch register.
        let mut reads = Vec::new();
        ins.op.registers(&mut reads);
        let d = match loc(ins.dst) {
            Loc::Xmm(x) if !reads.contains(&ins.dst) => x,
            _ => S0,
        };
        let e = S1;
        match ins.op {
            Op::Add(a, b) => self.binary(Add, d, a, b),
            Op::Sub(a, b) => self.binary(Sub, d, a, b),
            Op::Mul(a, b) => self.binary(Mul, d, a, b),
            Op::Div(a, b) => self.binary(Div, d, a, b),
            Op::Neg(a) => {
                self.load(d, a);
                self.negate(d);
            }
            Op::AddC(a, c) => self.with_const(Add, d, a, c),
            Op::SubC(a, c) => self.with_const(Sub, d, a, c),
            Op::RSubC(c, a) => {
                // `-a + c`, as the interpreter computes it.
                self.load(d, a);
                self.negate(d);
                self.arith_c(Add, d, c);
            }
            Op::MulC(a, c) => self.with_const(Mul, d, a, c),
            Op::DivC(a, c) => self.with_const(Div, d, a, c),
            Op::RDivC(c, a) => {
                self.konst(d, c);
                self.arith(Div, d, a);
            }
            Op::MulAdd(a, b, c) | Op::MulSub(a, b, c) => {
                self.product(d, a, b);
                self.arith(if matches!(ins.op, Op::MulAdd(..)) { Add } else { Sub }, d, c);
            }
            Op::MulCAdd(a, k, c) | Op::MulCSub(a, k, c) => {
                self.scaled(d, a, k);
                self.arith(if matches!(ins.op, Op::MulCAdd(..)) { Add } else { Sub }, d, c);
            }
            // `c - a*b` and `c - a*k`: the product first, as the interpreter rounds it.
            Op::SubMul(c, a, b) => {
                self.product(e, a, b);
                self.load(d, c);
                self.arith_x(Sub, d, e);
            }
            Op::SubMulC(c, a, k) => {
                self.scaled(e, a, k);
                self.load(d, c);
                self.arith_x(Sub, d, e);
            }
            Op::MulCAddC(a, k1, k2) => {
                self.scaled(d, a, k1);
                self.arith_c(Add, d, k2);
            }
            Op::MulMul(a, b, c) => {
                self.product(d, a, b);
                self.arith(Mul, d, c);
            }
            Op::MulCMul(a, k, b) => {
                self.scaled(d, a, k);
                self.arith(Mul, d, b);
            }
            // Two products (each `a*b` or `a*k`) added or subtracted.
            Op::DotAdd(a, b, c, f) | Op::DotSub(a, b, c, f) => {
                self.product(d, a, b);
                self.product(e, c, f);
                self.arith_x(if matches!(ins.op, Op::DotAdd(..)) { Add } else { Sub }, d, e);
            }
            Op::DotCAdd(a, k1, c, k2) | Op::DotCSub(a, k1, c, k2) => {
                self.scaled(d, a, k1);
                self.scaled(e, c, k2);
                self.arith_x(if matches!(ins.op, Op::DotCAdd(..)) { Add } else { Sub }, d, e);
            }
            Op::DotMCAdd(a, b, c, k) | Op::DotMCSub(a, b, c, k) => {
                self.product(d, a, b);
                self.scaled(e, c, k);
                self.arith_x(if matches!(ins.op, Op::DotMCAdd(..)) { Add } else { Sub }, d, e);
            }
            Op::DotCMSub(a, k, c, f) => {
                self.scaled(d, a, k);
                self.product(e, c, f);
                self.arith_x(Sub, d, e);
            }
            Op::MulMulCAddC(a, b, k1, k2) => {
                self.product(d, a, b);
                self.arith_c(Mul, d, k1);
                self.arith_c(Add, d, k2);
            }
            Op::SubMulMul(c, a, b, f) => {
                self.product(e, a, b);
                self.arith(Mul, e, f);
                self.load(d, c);
                self.arith_x(Sub, d, e);
            }
            Op::SubMulCMul(c, a, k, b) => {
                self.scaled(e, a, k);
                self.arith(Mul, e, b);
                self.load(d, c);
                self.arith_x(Sub, d, e);
            }
            Op::PowI(..) | Op::PowC(..) | Op::Fn1(..) | Op::SinCos(_) | Op::Atan2(..) | Op::Sel(..) | Op::End => {
                return false;
            }
        }
        self.store(ins.dst, d);
        if let Some(w) = self.dirty.get_mut(usize::from(ins.dst)) {
            *w = true;
        }
        true
    }

    /// `xmm d = a (op) b`.
    fn binary(&mut self, op: Arith, d: u8, a: u16, b: u16) {
        self.load(d, a);
        self.arith(op, d, b);
    }

    /// `xmm d = a (op) c`.
    fn with_const(&mut self, op: Arith, d: u8, a: u16, c: f64) {
        self.load(d, a);
        self.arith_c(op, d, c);
    }
}

impl Native {
    /// Native code for `instrs` (a validated tape's, up to its closing `End`) over `n_regs`
    /// registers with the given output registers; `None` where executable memory cannot be
    /// had.
    pub(super) fn compile(instrs: &[Instr], n_regs: usize, outputs: &[u16]) -> Option<Native> {
        let owned: Box<[Instr]> = instrs.iter().take_while(|i| i.op != Op::End).copied().collect();
        let instrs = &*owned;
        let live = liveness(instrs, n_regs, outputs);
        let mut emit =
            Emit { ops: Assembler::new().ok()?, dirty: vec![false; usize::from(HELD)], pool: Vec::new(), sign: None };
        let entry = emit.ops.offset();
        // The register file's address stays in `rbx` (callee-saved); the push also aligns
        // the stack to 16 bytes for the calls.
        dynasm!(emit.ops ; .arch x64 ; push rbx ; mov rbx, rdi);
        emit.reload(live.first()?);
        for (k, ins) in instrs.iter().enumerate() {
            if let Op::SinCos(a) = ins.op {
                emit.sin_cos(a, ins.dst, ins.dst2, live.get(k)?, live.get(k + 1)?);
            } else if !emit.instr(ins) {
                emit.call(ins as *const Instr, n_regs, live.get(k)?, live.get(k + 1)?);
            }
        }
        emit.spill(live.last()?);
        dynasm!(emit.ops ; .arch x64 ; pop rbx ; ret);
        emit.emit_pool();
        let code = emit.ops.finalize().ok()?;
        // SAFETY: `entry` is the start of the function assembled above, of this signature
        // (it takes the register file's address in `rdi`); the pointer stays valid as long
        // as `code`, which `Native` owns.
        let entry: extern "sysv64" fn(*mut f64) = unsafe { std::mem::transmute(code.ptr(entry)) };
        Some(Native { code, entry, _instrs: owned, n_regs })
    }

    /// Evaluates on `regs` (inputs and constants loaded); `false`, with nothing done, when
    /// the file is shorter than the tape's registers.
    #[inline]
    pub(super) fn run(&self, regs: &mut [f64]) -> bool {
        if regs.len() < self.n_regs {
            return false;
        }
        // The function reads and writes registers `0..n_regs` of the file only (every
        // register index of a validated tape is below `n_regs`), and `regs` has at least
        // that many; its calls go to `step` with the same file and instructions owned by
        // `self`, or to `sin` and `cos`.
        (self.entry)(regs.as_mut_ptr());
        true
    }
}

/// One instruction of the interpreter over a register file of `n` `f64`s: what the code
/// calls for the operations it does not compute itself.
extern "sysv64" fn step(regs: *mut f64, n: usize, ins: *const Instr) {
    // SAFETY: the code passes the register file it runs on (`n` registers, the tape's
    // `n_regs`, checked against the file's length before the run) and an instruction that
    // `Native` owns.
    let (regs, ins) = unsafe { (std::slice::from_raw_parts_mut(regs, n), &*ins) };
    exec_f64(ins, regs);
}

extern "sysv64" fn sin(x: f64) -> f64 {
    x.sin()
}

extern "sysv64" fn cos(x: f64) -> f64 {
    x.cos()
}

/// `live[k][r]`: register `r` holds a value read later, before instruction `k` (`k` up to
/// `instrs.len()`, where the outputs are live).
fn liveness(instrs: &[Instr], n_regs: usize, outputs: &[u16]) -> Vec<Vec<bool>> {
    let mut live = vec![vec![false; n_regs]; instrs.len() + 1];
    let mut now = vec![false; n_regs];
    for &r in outputs {
        if let Some(l) = now.get_mut(usize::from(r)) {
            *l = true;
        }
    }
    let mut reads = Vec::new();
    for (k, ins) in instrs.iter().enumerate().rev() {
        if let Some(slot) = live.get_mut(k + 1) {
            slot.clone_from(&now);
        }
        for w in [ins.dst, ins.dst2] {
            if let Some(l) = now.get_mut(usize::from(w)) {
                *l = false;
            }
        }
        reads.clear();
        ins.op.registers(&mut reads);
        for &r in &reads {
            if let Some(l) = now.get_mut(usize::from(r)) {
                *l = true;
            }
        }
    }
    if let Some(slot) = live.first_mut() {
        *slot = now;
    }
    live
}
