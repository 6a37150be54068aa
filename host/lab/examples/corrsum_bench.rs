//! Times chaos's correlation sum and Rosenstein curve on a quasi-periodic series like the
//! report's (29,000 samples, embedding 6): `cargo run --release -p lab --example corrsum_bench`.
//! Prints a hash of the results (bit for bit checks across versions).
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n = 29_000;
    let x: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 * 0.025;
            (1.3 * t).sin() + 0.4 * (3.7 * t).sin() + 0.05 * ((i * 7919 % 1000) as f64 / 1000.0 - 0.5)
        })
        .collect();
    let pts = chaos::delay_embed(&x, 6, 10)?;
    let what = std::env::args().nth(1).unwrap_or_else(|| "corr".into());
    let t0 = std::time::Instant::now();
    let mut h: u64 = 0;
    for _ in 0..3 {
        if what == "corr" {
            let c = chaos::correlation_sum(&pts, &chaos::CorrSumParams { theiler: 200, ..Default::default() })?;
            h = c.count.iter().fold(h, |h, &k| h.wrapping_mul(31).wrapping_add(k)) ^ c.diameter.to_bits();
        } else {
            let c = chaos::rosenstein_curve(
                &pts,
                &chaos::DivergenceParams {
                    theiler: 200,
                    max_steps: 600,
                    max_reference: 3000,
                    dt: 0.025,
                    ..Default::default()
                },
            )?;
            h = c.mean_log_distance.iter().fold(h, |h, v| h.wrapping_mul(31).wrapping_add(v.to_bits()));
        }
    }
    println!("{what} hash {h:x} {:.2} s", t0.elapsed().as_secs_f64());
    Ok(())
}
