//! The compiled tapes of the bundled equation scenes: each tape's instructions by shape,
//! and the most frequent pairs of consecutive shapes (where a fused shape would save a
//! dispatch). A profiling aid; prints, not a test.
//!
//! ```text
//! cargo run --release -p lab --example tape_shapes -- [--dump]
//! ```

use std::collections::BTreeMap;

use sim::closed_loop::{AnyPlant, build_plant};
use sim::expr::Tape;
use sim::scene::Scene;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

const SCENES: [&str; 6] =
    ["furuta-equations", "cartpole-pd", "pendulum-pd", "double-pendulum-cart", "duffing-chain", "duffing-chain4"];

/// The shape of an instruction: its `Debug` form up to the first parenthesis.
fn shape(t: &Tape, k: usize) -> String {
    t.instrs().get(k).map_or("?".into(), |i| format!("{:?}", i.op).split('(').next().unwrap_or("?").to_string())
}

fn main() -> Res<()> {
    let dump = std::env::args().any(|a| a == "--dump");
    let mut shapes: BTreeMap<String, usize> = BTreeMap::new();
    let mut pairs: BTreeMap<String, usize> = BTreeMap::new();
    for name in SCENES {
        let scene = Scene::load(name, &[])?;
        let plant = build_plant(&scene)?;
        let model = match &plant {
            AnyPlant::Equations1(p) => p.model(),
            AnyPlant::Equations2(p) => p.model(),
            AnyPlant::Equations3(p) => p.model(),
            AnyPlant::Equations4(p) => p.model(),
            _ => return Err(format!("{name} is not an equations scene").into()),
        };
        for (what, t) in [("value", Some(model.tape())), ("jacobian", model.jac_tape())] {
            let Some(t) = t else { continue };
            println!(
                "{name} {what}: {} instructions, {} registers, {} constants",
                t.len(),
                t.n_regs(),
                t.consts().len()
            );
            for k in 0..t.len() {
                if dump {
                    if let Some(i) = t.instrs().get(k) {
                        println!("  r{} <- {:?}", i.dst, i.op);
                    }
                }
                *shapes.entry(shape(t, k)).or_default() += 1;
                if k + 1 < t.len() {
                    *pairs.entry(format!("{} {}", shape(t, k), shape(t, k + 1))).or_default() += 1;
                }
            }
        }
    }
    let mut s: Vec<_> = shapes.into_iter().collect();
    s.sort_by(|a, b| b.1.cmp(&a.1));
    println!("shapes: {s:?}");
    let mut p: Vec<_> = pairs.into_iter().collect();
    p.sort_by(|a, b| b.1.cmp(&a.1));
    println!("pairs: {:?}", p.iter().take(25).collect::<Vec<_>>());
    Ok(())
}
