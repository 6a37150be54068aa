//! Cost of `Tps` products (profiling aid; prints a checksum, not a test).
//! `cargo run --release -p lab --example tps_mul_bench -- [reps]`: order 5, 7 and 9 series in
//! four variables, dense and odd-only (the Furuta jets), `reps` products each.
use sim::taylor::{Tps, TpsTable};

fn main() {
    let reps: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(2000);
    let mut seed = 0x9e3779b97f4a7c15u64;
    let mut rnd = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut h = 0xcbf29ce484222325u64;
    for order in [5, 7, 9] {
        let Some(t) = TpsTable::get(4, order) else { continue };
        for odd in [false, true] {
            let coef = |r: &mut dyn FnMut() -> f64| -> Vec<f64> {
                (0..t.len())
                    .map(|i| if odd && t.exponents()[i].iter().sum::<u32>() % 2 == 0 { 0.0 } else { r() })
                    .collect()
            };
            let a = Tps::from_coefficients(t, &coef(&mut rnd));
            let b = Tps::from_coefficients(t, &coef(&mut rnd));
            let mut p = a;
            for r in 0..reps {
                let q = if r % 2 == 0 { p.mul_ref(&b) } else { b.mul_ref(&p) };
                p = q.scaled(0.25);
                if r % 8 == 0 {
                    p = a;
                }
            }
            for v in p.coefficients() {
                h ^= v.to_bits();
                h = h.wrapping_mul(0x100000001b3);
            }
        }
    }
    println!("{h:016x}");
}
