//! Four ways to run the compiled tapes of `furuta-equations` in `f64`, against the tape's
//! own `match` loop (`Tape::eval_outputs` of a tape compiled without native code): the
//! tape's native code (what `f64` evaluations run on x86-64), the same instructions in the same order through
//! a `match` loop over renamed registers (every value its own register: the baseline of the
//! other two), threaded code (one function pointer per instruction, called in a loop), and
//! batches (the instructions scheduled by dependency level, a level's instructions of one
//! kind run as one batch: one dispatch, then a loop with that kind's body). Each form gives
//! the tape's outputs bit for bit (checked on every run); the program reports instructions
//! and indirect jumps per evaluation (valgrind cachegrind with branch simulation, the
//! difference of two run lengths) and CPU time per evaluation (interleaved rounds, the
//! median of each form's ratio to the tape). A profiling aid; prints, not a test.
//!
//! ```text
//! cargo run --release -p lab --example tape_dispatch
//! target/release/examples/tape_dispatch count FORM TAPE N   # what valgrind runs
//! ```
//! FORM is `tape`, `native`, `match`, `threaded` or `batched`; TAPE is `value` or `jacobian`.

use std::process::Command;
use std::time::Instant;

use sim::closed_loop::{AnyPlant, build_plant};
use sim::expr::{F1, Op, Tape};
use sim::scene::Scene;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

const FORMS: [&str; 5] = ["tape", "native", "match", "threaded", "batched"];
const TAPES: [&str; 2] = ["value", "jacobian"];

/// The inputs of the evaluations (theta, phi, their rates, u), near the bench run's.
const INPUTS: [f64; 5] = [0.05, 0.0166, 0.025, 0.0125, 0.3];

/// An instruction over renamed registers: each result its own register.
#[derive(Clone, Copy, Debug)]
struct Ins {
    op: Op,
    dst: usize,
    dst2: usize,
}

/// A tape's instructions with every register renamed (no register written twice), its
/// constants, register count and output registers.
struct Program {
    ins: Vec<Ins>,
    consts: Vec<(usize, f64)>,
    n_regs: usize,
    outputs: Vec<usize>,
}

/// The registers an operation reads, rewritten by `map`.
fn remap(op: Op, map: &mut dyn FnMut(u16) -> u16) -> Op {
    let mut m = |r: u16| map(r);
    match op {
        Op::Add(a, b) => Op::Add(m(a), m(b)),
        Op::Sub(a, b) => Op::Sub(m(a), m(b)),
        Op::Mul(a, b) => Op::Mul(m(a), m(b)),
        Op::Div(a, b) => Op::Div(m(a), m(b)),
        Op::Neg(a) => Op::Neg(m(a)),
        Op::AddC(a, c) => Op::AddC(m(a), c),
        Op::SubC(a, c) => Op::SubC(m(a), c),
        Op::RSubC(c, a) => Op::RSubC(c, m(a)),
        Op::MulC(a, c) => Op::MulC(m(a), c),
        Op::DivC(a, c) => Op::DivC(m(a), c),
        Op::RDivC(c, a) => Op::RDivC(c, m(a)),
        Op::PowI(a, k) => Op::PowI(m(a), k),
        Op::PowC(a, p) => Op::PowC(m(a), p),
        Op::Fn1(f, a) => Op::Fn1(f, m(a)),
        Op::SinCos(a) => Op::SinCos(m(a)),
        Op::Atan2(a, b) => Op::Atan2(m(a), m(b)),
        Op::Sel(a, b, c, d) => Op::Sel(m(a), m(b), m(c), m(d)),
        Op::MulAdd(a, b, c) => Op::MulAdd(m(a), m(b), m(c)),
        Op::MulSub(a, b, c) => Op::MulSub(m(a), m(b), m(c)),
        Op::SubMul(c, a, b) => Op::SubMul(m(c), m(a), m(b)),
        Op::MulCAdd(a, k, c) => Op::MulCAdd(m(a), k, m(c)),
        Op::MulCSub(a, k, c) => Op::MulCSub(m(a), k, m(c)),
        Op::SubMulC(c, a, k) => Op::SubMulC(m(c), m(a), k),
        Op::MulCAddC(a, k1, k2) => Op::MulCAddC(m(a), k1, k2),
        Op::MulMul(a, b, c) => Op::MulMul(m(a), m(b), m(c)),
        Op::MulCMul(a, k, b) => Op::MulCMul(m(a), k, m(b)),
        Op::DotAdd(a, b, c, d) => Op::DotAdd(m(a), m(b), m(c), m(d)),
        Op::DotSub(a, b, c, d) => Op::DotSub(m(a), m(b), m(c), m(d)),
        Op::DotCAdd(a, k1, c, k2) => Op::DotCAdd(m(a), k1, m(c), k2),
        Op::DotCSub(a, k1, c, k2) => Op::DotCSub(m(a), k1, m(c), k2),
        Op::DotMCAdd(a, b, c, k) => Op::DotMCAdd(m(a), m(b), m(c), k),
        Op::DotMCSub(a, b, c, k) => Op::DotMCSub(m(a), m(b), m(c), k),
        Op::DotCMSub(a, k, c, d) => Op::DotCMSub(m(a), k, m(c), m(d)),
        Op::MulMulCAddC(a, b, k1, k2) => Op::MulMulCAddC(m(a), m(b), k1, k2),
        Op::SubMulMul(c, a, b, d) => Op::SubMulMul(m(c), m(a), m(b), m(d)),
        Op::SubMulCMul(c, a, k, b) => Op::SubMulCMul(m(c), m(a), k, m(b)),
        Op::End => Op::End,
    }
}

/// The registers an operation reads.
fn reads(op: Op) -> Vec<u16> {
    let mut out = Vec::new();
    remap(op, &mut |r| {
        out.push(r);
        r
    });
    out
}

impl Program {
    /// `t` renamed: inputs keep registers `0..n_inputs`, then each constant and each
    /// result gets the next register.
    fn rename(t: &Tape) -> Program {
        let mut cur: Vec<u16> = (0..t.n_regs() as u16).collect();
        let mut next = t.n_inputs() as u16;
        let mut fresh = || {
            next += 1;
            next - 1
        };
        let mut consts = Vec::new();
        for &(r, c) in t.consts() {
            let n = fresh();
            cur[usize::from(r)] = n;
            consts.push((usize::from(n), c));
        }
        let mut ins = Vec::new();
        for i in t.instrs() {
            let op = remap(i.op, &mut |r| cur[usize::from(r)]);
            let dst = fresh();
            let dst2 = if matches!(i.op, Op::SinCos(_)) { fresh() } else { dst };
            cur[usize::from(i.dst)] = dst;
            cur[usize::from(i.dst2)] = dst2;
            ins.push(Ins { op, dst: usize::from(dst), dst2: usize::from(dst2) });
        }
        let outputs = t.outputs().iter().map(|&r| usize::from(cur[usize::from(r)])).collect();
        Program { ins, consts, n_regs: usize::from(next), outputs }
    }

    /// The instructions reordered by dependency level, a level's instructions grouped by
    /// kind; returns the batches as `(start, length)` into the reordered instructions.
    fn batched(&self) -> (Vec<Ins>, Vec<(usize, usize)>) {
        let mut level_of = vec![0usize; self.n_regs];
        let mut keyed: Vec<(usize, String, usize, Ins)> = Vec::new();
        for (k, i) in self.ins.iter().enumerate() {
            let l = reads(i.op).iter().map(|&r| level_of[usize::from(r)]).max().unwrap_or(0) + 1;
            level_of[i.dst] = l;
            level_of[i.dst2] = l;
            keyed.push((l, kind(i.op), k, *i));
        }
        keyed.sort_by(|a, b| (a.0, &a.1, a.2).cmp(&(b.0, &b.1, b.2)));
        let ins: Vec<Ins> = keyed.iter().map(|k| k.3).collect();
        let mut runs = Vec::new();
        let mut s = 0;
        while s < keyed.len() {
            let mut e = s + 1;
            while e < keyed.len() && keyed[e].0 == keyed[s].0 && keyed[e].1 == keyed[s].1 {
                e += 1;
            }
            runs.push((s, e - s));
            s = e;
        }
        (ins, runs)
    }
}

/// An operation's kind (its `Debug` name).
fn kind(op: Op) -> String {
    format!("{op:?}").split('(').next().unwrap_or("?").to_string()
}

/// One instruction's value (`f64` only; the operations the bundled tapes use), and for
/// `SinCos` the cosine into `dst2`.
#[inline(always)]
fn exec(op: Op, r: &mut [f64], dst2: usize) -> f64 {
    let g = |r: &[f64], i: u16| r[usize::from(i)];
    match op {
        Op::Add(a, b) => g(r, a) + g(r, b),
        Op::Sub(a, b) => g(r, a) - g(r, b),
        Op::Mul(a, b) => g(r, a) * g(r, b),
        Op::Div(a, b) => g(r, a) / g(r, b),
        Op::Neg(a) => -g(r, a),
        Op::AddC(a, c) => g(r, a) + c,
        Op::SubC(a, c) => g(r, a) - c,
        Op::RSubC(c, a) => -g(r, a) + c,
        Op::MulC(a, c) => g(r, a) * c,
        Op::DivC(a, c) => g(r, a) / c,
        Op::RDivC(c, a) => c / g(r, a),
        Op::Fn1(F1::Sin, a) => g(r, a).sin(),
        Op::Fn1(F1::Cos, a) => g(r, a).cos(),
        Op::SinCos(a) => {
            let (s, c) = g(r, a).sin_cos();
            r[dst2] = c;
            s
        }
        Op::MulAdd(a, b, c) => g(r, a) * g(r, b) + g(r, c),
        Op::MulSub(a, b, c) => g(r, a) * g(r, b) - g(r, c),
        Op::SubMul(c, a, b) => g(r, c) - g(r, a) * g(r, b),
        Op::MulCAdd(a, k, c) => g(r, a) * k + g(r, c),
        Op::MulCSub(a, k, c) => g(r, a) * k - g(r, c),
        Op::SubMulC(c, a, k) => g(r, c) - g(r, a) * k,
        Op::MulCAddC(a, k1, k2) => g(r, a) * k1 + k2,
        Op::MulMul(a, b, c) => g(r, a) * g(r, b) * g(r, c),
        Op::MulCMul(a, k, b) => g(r, a) * k * g(r, b),
        Op::DotAdd(a, b, c, d) => g(r, a) * g(r, b) + g(r, c) * g(r, d),
        Op::DotSub(a, b, c, d) => g(r, a) * g(r, b) - g(r, c) * g(r, d),
        Op::DotCAdd(a, k1, c, k2) => g(r, a) * k1 + g(r, c) * k2,
        Op::DotCSub(a, k1, c, k2) => g(r, a) * k1 - g(r, c) * k2,
        Op::DotMCAdd(a, b, c, k) => g(r, a) * g(r, b) + g(r, c) * k,
        Op::DotMCSub(a, b, c, k) => g(r, a) * g(r, b) - g(r, c) * k,
        Op::DotCMSub(a, k, c, d) => g(r, a) * k - g(r, c) * g(r, d),
        Op::MulMulCAddC(a, b, k1, k2) => g(r, a) * g(r, b) * k1 + k2,
        Op::SubMulMul(c, a, b, d) => g(r, c) - g(r, a) * g(r, b) * g(r, d),
        Op::SubMulCMul(c, a, k, b) => g(r, c) - g(r, a) * k * g(r, b),
        _ => f64::NAN,
    }
}

/// Whether [`exec`] covers every instruction of `p`.
fn covered(p: &Program) -> bool {
    p.ins.iter().all(|i| !matches!(i.op, Op::PowI(..) | Op::PowC(..) | Op::Atan2(..) | Op::Sel(..) | Op::End))
        && p.ins.iter().all(|i| !matches!(i.op, Op::Fn1(f, _) if !matches!(f, F1::Sin | F1::Cos)))
}

const R: usize = 64;

fn load(p: &Program, inputs: &[f64], regs: &mut [f64; R]) {
    regs[..inputs.len()].copy_from_slice(inputs);
    for &(r, c) in &p.consts {
        regs[r] = c;
    }
}

/// The same instructions in a `match` loop.
fn run_match(p: &Program, inputs: &[f64], out: &mut [f64]) {
    let mut regs = [0.0; R];
    load(p, inputs, &mut regs);
    for i in &p.ins {
        regs[i.dst] = exec(i.op, &mut regs, i.dst2);
    }
    for (o, &r) in out.iter_mut().zip(&p.outputs) {
        *o = regs[r];
    }
}

type Handler = fn(&Ins, &mut [f64; R]);

/// One handler per kind: `exec` specialized by the match arm the handler was taken from.
macro_rules! handler {
    ($pat:pat) => {{
        fn h(i: &Ins, r: &mut [f64; R]) {
            if let op @ $pat = i.op {
                r[i.dst] = exec(op, r, i.dst2);
            }
        }
        h as Handler
    }};
}

fn handler_of(op: Op) -> Handler {
    match op {
        Op::Add(..) => handler!(Op::Add(..)),
        Op::Sub(..) => handler!(Op::Sub(..)),
        Op::Mul(..) => handler!(Op::Mul(..)),
        Op::Div(..) => handler!(Op::Div(..)),
        Op::Neg(..) => handler!(Op::Neg(..)),
        Op::AddC(..) => handler!(Op::AddC(..)),
        Op::SubC(..) => handler!(Op::SubC(..)),
        Op::RSubC(..) => handler!(Op::RSubC(..)),
        Op::MulC(..) => handler!(Op::MulC(..)),
        Op::DivC(..) => handler!(Op::DivC(..)),
        Op::RDivC(..) => handler!(Op::RDivC(..)),
        Op::Fn1(..) => handler!(Op::Fn1(..)),
        Op::SinCos(..) => handler!(Op::SinCos(..)),
        Op::MulAdd(..) => handler!(Op::MulAdd(..)),
        Op::MulSub(..) => handler!(Op::MulSub(..)),
        Op::SubMul(..) => handler!(Op::SubMul(..)),
        Op::MulCAdd(..) => handler!(Op::MulCAdd(..)),
        Op::MulCSub(..) => handler!(Op::MulCSub(..)),
        Op::SubMulC(..) => handler!(Op::SubMulC(..)),
        Op::MulCAddC(..) => handler!(Op::MulCAddC(..)),
        Op::MulMul(..) => handler!(Op::MulMul(..)),
        Op::MulCMul(..) => handler!(Op::MulCMul(..)),
        Op::DotAdd(..) => handler!(Op::DotAdd(..)),
        Op::DotSub(..) => handler!(Op::DotSub(..)),
        Op::DotCAdd(..) => handler!(Op::DotCAdd(..)),
        Op::DotCSub(..) => handler!(Op::DotCSub(..)),
        Op::DotMCAdd(..) => handler!(Op::DotMCAdd(..)),
        Op::DotMCSub(..) => handler!(Op::DotMCSub(..)),
        Op::DotCMSub(..) => handler!(Op::DotCMSub(..)),
        Op::MulMulCAddC(..) => handler!(Op::MulMulCAddC(..)),
        Op::SubMulMul(..) => handler!(Op::SubMulMul(..)),
        Op::SubMulCMul(..) => handler!(Op::SubMulCMul(..)),
        _ => handler!(Op::End),
    }
}

/// Threaded code: a function pointer per instruction.
fn run_threaded(p: &Program, code: &[(Handler, Ins)], inputs: &[f64], out: &mut [f64]) {
    let mut regs = [0.0; R];
    load(p, inputs, &mut regs);
    for (h, i) in code {
        h(i, &mut regs);
    }
    for (o, &r) in out.iter_mut().zip(&p.outputs) {
        *o = regs[r];
    }
}

/// A batch: one `match` on its kind, then that kind's body in a loop.
macro_rules! batch {
    ($run:expr, $regs:expr, $($pat:pat),*) => {
        match $run.first().map(|i| i.op) {
            $(Some($pat) => {
                for i in $run {
                    if let op @ $pat = i.op {
                        $regs[i.dst] = exec(op, $regs, i.dst2);
                    }
                }
            })*
            _ => {
                for i in $run {
                    $regs[i.dst] = exec(i.op, $regs, i.dst2);
                }
            }
        }
    };
}

fn run_batched(p: &Program, ins: &[Ins], runs: &[(usize, usize)], inputs: &[f64], out: &mut [f64]) {
    let mut regs = [0.0; R];
    load(p, inputs, &mut regs);
    for &(s, n) in runs {
        let run = &ins[s..s + n];
        let regs = &mut regs;
        batch!(
            run,
            regs,
            Op::Add(..),
            Op::Sub(..),
            Op::Mul(..),
            Op::Neg(..),
            Op::SubC(..),
            Op::RSubC(..),
            Op::MulC(..),
            Op::SinCos(..),
            Op::SubMul(..),
            Op::MulCAdd(..),
            Op::SubMulC(..),
            Op::MulCAddC(..),
            Op::MulMul(..),
            Op::MulCMul(..),
            Op::DotCSub(..),
            Op::DotMCAdd(..),
            Op::DotMCSub(..),
            Op::MulMulCAddC(..),
            Op::SubMulMul(..),
            Op::SubMulCMul(..)
        );
    }
    for (o, &r) in out.iter_mut().zip(&p.outputs) {
        *o = regs[r];
    }
}

/// The Furuta's tapes (value, Jacobian), interpreted or with native code.
fn tapes(native: bool) -> Res<(Tape, Tape)> {
    let scene = Scene::load("furuta-equations", &[])?;
    let plant = if native { build_plant(&scene)? } else { sim::expr::interpreted(|| build_plant(&scene))? };
    let AnyPlant::Equations2(p) = plant else { return Err("furuta-equations has two coordinates".into()) };
    let jt = p.model().jac_tape().ok_or("no Jacobian tape")?.clone();
    Ok((p.model().tape().clone(), jt))
}

/// A form ready to run on one tape: its evaluation into `out`.
struct Forms {
    tape: Tape,
    native: Tape,
    prog: Program,
    code: Vec<(Handler, Ins)>,
    batched: (Vec<Ins>, Vec<(usize, usize)>),
}

impl Forms {
    fn new(tape: Tape, native: Tape) -> Res<Forms> {
        let prog = Program::rename(&tape);
        if !covered(&prog) || prog.n_regs > R {
            return Err("the tape uses operations or registers this program does not cover".into());
        }
        let code = prog.ins.iter().map(|i| (handler_of(i.op), *i)).collect();
        let batched = prog.batched();
        Ok(Forms { tape, native, prog, code, batched })
    }

    #[inline(never)]
    fn run(&self, form: &str, inputs: &[f64], out: &mut [f64]) {
        match form {
            "tape" => self.tape.eval_outputs(inputs, out),
            "native" => self.native.eval_outputs(inputs, out),
            "match" => run_match(&self.prog, inputs, out),
            "threaded" => run_threaded(&self.prog, &self.code, inputs, out),
            _ => run_batched(&self.prog, &self.batched.0, &self.batched.1, inputs, out),
        }
    }
}

fn count(form: &str, which: &str, n: u64) -> Res<()> {
    let ((v, j), (nv, nj)) = (tapes(false)?, tapes(true)?);
    let f = if which == "value" { Forms::new(v, nv)? } else { Forms::new(j, nj)? };
    let mut out = vec![0.0; f.prog.outputs.len()];
    for _ in 0..n {
        f.run(std::hint::black_box(form), std::hint::black_box(&INPUTS), &mut out);
        std::hint::black_box(&out);
    }
    Ok(())
}

/// Instructions and indirect jumps of `self count form tape n` under cachegrind.
fn counts(form: &str, which: &str, n: u64) -> Res<(u64, u64)> {
    let out = Command::new("valgrind")
        .args(["--tool=cachegrind", "--cache-sim=no", "--branch-sim=yes", "--cachegrind-out-file=/dev/null"])
        .arg(std::env::current_exe()?)
        .args(["count", form, which, &n.to_string()])
        .output()?;
    let text = String::from_utf8_lossy(&out.stderr);
    if !out.status.success() {
        return Err(format!("valgrind {form} {which} failed: {text}").into());
    }
    let num = |key: &str| -> Res<u64> {
        let line = text.lines().find(|l| l.contains(key)).ok_or(format!("no `{key}` line"))?;
        let field = line.split(':').nth(1).unwrap_or("").split('(').next().unwrap_or("");
        Ok(field.chars().filter(char::is_ascii_digit).collect::<String>().parse()?)
    };
    Ok((num("I   refs")?, indirect(&text)?))
}

/// Indirect jumps: the `ind` part of the `Branches:` line.
fn indirect(text: &str) -> Res<u64> {
    let line = text.lines().find(|l| l.contains("Branches:")).ok_or("no `Branches:` line")?;
    let ind = line.split('+').nth(1).ok_or("no indirect count")?;
    Ok(ind.chars().take_while(|c| *c != 'i').filter(char::is_ascii_digit).collect::<String>().parse()?)
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("count") {
        let n: u64 = args.get(3).ok_or("count FORM TAPE N")?.parse()?;
        return count(args.get(1).ok_or("FORM")?, args.get(2).ok_or("TAPE")?, n);
    }
    let ((v, j), (nv, nj)) = (tapes(false)?, tapes(true)?);
    let forms = [Forms::new(v, nv)?, Forms::new(j, nj)?];
    // Every form gives the tape's outputs bit for bit, at the bench point and beyond.
    for (which, f) in TAPES.iter().zip(&forms) {
        for k in 0..200 {
            let x: Vec<f64> = INPUTS.iter().enumerate().map(|(i, v)| v + 0.37 * (k * (i + 1)) as f64 - 20.0).collect();
            let mut want = vec![0.0; f.prog.outputs.len()];
            f.run("tape", &x, &mut want);
            for form in FORMS {
                let mut got = vec![0.0; want.len()];
                f.run(form, &x, &mut got);
                let same = want.iter().zip(&got).all(|(a, b)| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan()));
                if !same {
                    return Err(format!("{form} on the {which} tape differs at {x:?}: {got:?} vs {want:?}").into());
                }
            }
        }
        let (ins, runs) = &f.batched;
        println!(
            "{which} tape: {} instructions; {} batches ({} of them longer than one)",
            ins.len(),
            runs.len(),
            runs.iter().filter(|r| r.1 > 1).count()
        );
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("load average before: {}", load.split_whitespace().next().unwrap_or("-"));
    println!("| tape | form | instructions / eval | indirect jumps / eval | CPU ns / eval | x tape [range] |");
    println!("|---|---|---|---|---|---|");
    let (n1, n2) = (10_000u64, 110_000u64);
    let rounds = 15;
    let reps = 200_000;
    for (which, f) in TAPES.iter().zip(&forms) {
        let mut times: Vec<Vec<f64>> = vec![Vec::new(); FORMS.len()];
        let mut out = vec![0.0; f.prog.outputs.len()];
        for _ in 0..rounds {
            for (k, form) in FORMS.iter().enumerate() {
                let t = Instant::now();
                for _ in 0..reps {
                    f.run(std::hint::black_box(form), std::hint::black_box(&INPUTS), &mut out);
                    std::hint::black_box(&out);
                }
                times[k].push(t.elapsed().as_secs_f64() / reps as f64);
            }
        }
        for (k, form) in FORMS.iter().enumerate() {
            let (i1, b1) = counts(form, which, n1)?;
            let (i2, b2) = counts(form, which, n2)?;
            let per = |a: u64, b: u64| (b as f64 - a as f64) / (n2 - n1) as f64;
            let mut ratios: Vec<f64> = times[k].iter().zip(&times[0]).map(|(a, b)| a / b).collect();
            let (lo, hi) = ratios.iter().fold((f64::MAX, 0.0f64), |(l, h), r| (l.min(*r), h.max(*r)));
            let r = median(&mut ratios);
            let ns = 1e9 * median(&mut times[k].clone());
            println!(
                "| {which} | {form} | {:.0} | {:.1} | {ns:.1} | {r:.2} [{lo:.2}, {hi:.2}] |",
                per(i1, i2),
                per(b1, b2)
            );
        }
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("load average after: {}", load.split_whitespace().next().unwrap_or("-"));
    Ok(())
}
