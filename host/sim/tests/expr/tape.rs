use sim::expr::{Instr, Op, Tape, TapeError};

/// A tape of two inputs from its parts, checked ([`Tape::from_parts`]).
fn tape(instrs: Vec<Instr>, consts: Vec<(u16, f64)>, n_regs: usize, outputs: Vec<u16>) -> Result<Tape, TapeError> {
    Tape::from_parts(consts, instrs, n_regs, 2, outputs)
}

fn ins(op: Op, dst: u16) -> Instr {
    Instr { op, dst, dst2: dst }
}

const END: Instr = Instr { op: Op::End, dst: 0, dst2: 0 };

/// The invariants the unchecked evaluation relies on are checked: a register past
/// `n_regs` anywhere (operand, destination, second destination, constant, output,
/// inputs) and a tape without its one closing `End` are refused.
#[test]
fn validation_refuses_every_out_of_range_register() {
    let good = || tape(vec![ins(Op::MulAdd(0, 1, 2), 3), END], vec![(2, 1.5)], 4, vec![3]);
    assert!(good().is_ok());
    let mut bad = vec![
        tape(vec![ins(Op::MulAdd(0, 4, 2), 3), END], vec![(2, 1.5)], 4, vec![3]),
        tape(vec![ins(Op::MulAdd(0, 1, 2), 4), END], vec![(2, 1.5)], 4, vec![3]),
        tape(vec![Instr { op: Op::SinCos(0), dst: 2, dst2: 9 }, END], vec![], 4, vec![2]),
        tape(vec![ins(Op::MulAdd(0, 1, 2), 3), END], vec![(7, 1.5)], 4, vec![3]),
        tape(vec![ins(Op::MulAdd(0, 1, 2), 3), END], vec![(2, 1.5)], 4, vec![5]),
        tape(vec![ins(Op::DotCMSub(0, 2.0, 1, 8), 3), END], vec![], 4, vec![3]),
        tape(vec![ins(Op::Sel(0, 1, 2, 300), 3), END], vec![], 4, vec![3]),
        // No `End`, or one before the last instruction.
        tape(vec![ins(Op::Add(0, 1), 3)], vec![], 4, vec![3]),
        tape(vec![END, ins(Op::Add(0, 1), 3), END], vec![], 4, vec![3]),
        tape(vec![], vec![], 4, vec![]),
    ];
    // The good tape with more inputs than registers.
    bad.push(Tape::from_parts(vec![(2, 1.5)], vec![ins(Op::MulAdd(0, 1, 2), 3), END], 4, 5, vec![3]));
    for (k, t) in bad.into_iter().enumerate() {
        assert!(t.is_err(), "case {k} passed");
    }
}

/// The outputs read in place ([`sim::expr::Evaluated::outputs_fixed`]) are the outputs one by
/// one, NaN past `K`; more than the tape has gives `None`.
#[test]
fn outputs_read_in_place_equal_the_outputs() {
    let t = tape(vec![ins(Op::MulAdd(0, 1, 2), 3), ins(Op::Sub(3, 0), 2), END], vec![(2, 1.5)], 4, vec![2, 3, 0])
        .unwrap_or_else(|e| panic!("{e}"));
    let (fixed, one_by_one, too_many) = t.eval_with(&[2.0, -3.0], |e| {
        let fixed = e.outputs_fixed::<3>().map(|o| [o.get(0), o.get(1), o.get(2), o.get(3)]);
        let one_by_one = [e.output(0), e.output(1), e.output(2)];
        (fixed, one_by_one, e.outputs_fixed::<4>().is_none())
    });
    let fixed = fixed.unwrap_or_else(|| panic!("three outputs"));
    assert_eq!(one_by_one, [-6.5, -4.5, 2.0]);
    assert_eq!(fixed[..3], one_by_one[..]);
    assert!(fixed[3].is_nan());
    assert!(too_many);
}
