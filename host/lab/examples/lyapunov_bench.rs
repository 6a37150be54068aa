//! Instruction counts of the time-series exponents (docs/decisions/0003): `lyapunov_bench rosenstein|kantz`
//! on a Lorenz x series of 20,000 samples embedded in 6 dimensions with the report's settings
//! (Rosenstein: 3000 references, curve of 450 steps; Kantz: 2000 references, 8 scales, 50
//! neighbours each), for `valgrind --tool=callgrind`. Prints a checksum of the curves.

use chaos::{DivergenceParams, delay_embed, kantz_curves, log_spaced, rosenstein_curve};

fn main() {
    let what = std::env::args().nth(1).unwrap_or_else(|| "rosenstein".into());
    let l = chaos::reference::Lorenz::default();
    let x: Vec<f64> = l.orbit(20_000, 0.01, 6, 1000).iter().map(|p| p[0]).collect();
    let pts = delay_embed(&x, 6, 4).expect("embedding");
    let p = DivergenceParams { theiler: 150, max_steps: 450, max_reference: 3000, dt: 0.06, ..Default::default() };
    let mut h = 0u64;
    let mut mix = |v: f64| h = h.rotate_left(5) ^ v.to_bits();
    if what == "rosenstein" {
        let c = rosenstein_curve(&pts, &p).expect("curve");
        c.mean_log_distance.iter().for_each(|v| mix(*v));
    } else {
        let eps = log_spaced(0.05, 5.0, 8).expect("scales");
        let p = DivergenceParams { max_reference: 2000, ..p };
        for (e, m, c) in kantz_curves(&pts, &eps, &p, 50).expect("curves") {
            mix(e);
            mix(m);
            if let Ok(c) = c {
                c.mean_log_distance.iter().for_each(|v| mix(*v));
            }
        }
    }
    println!("{h:016x}");
}
