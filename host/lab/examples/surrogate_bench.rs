//! Times the IAAFT surrogate test on a quasi-periodic series like the verdict's (4096 samples
//! used, 19 surrogates, prediction error and time reversal):
//! `cargo run --release -p lab --example surrogate_bench [surrogates]`. Prints a hash of
//! the results (bit for bit checks across versions) and the mean IAAFT iterations.
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let surrogates: usize = std::env::args().nth(1).map_or(Ok(19), |s| s.parse())?;
    let n = 5000;
    let x: Vec<f64> = (0..n)
        .map(|i| {
            let t = i as f64 * 0.025;
            0.01 * ((1.3 * t).sin() + 0.4 * (3.7 * t).sin()) + 0.0005 * ((i * 7919 % 1000) as f64 / 1000.0 - 0.5)
        })
        .collect();
    let sp = chaos::SurrogateParams { surrogates, max_len: 4096, max_iter: 100, seed: 1, ..Default::default() };
    let pe = chaos::Statistic::PredictionError { m: 6, tau: 10, horizon: 10, neighbours: 5, theiler: 40, refs: 500 };
    let t0 = std::time::Instant::now();
    let r = chaos::surrogate_tests(&x, &[pe, chaos::Statistic::TimeReversal { lag: 10 }], &sp)?;
    let h = r
        .iter()
        .flat_map(|t| t.statistic_surrogates.iter().chain([&t.statistic_data, &t.p_value]))
        .fold(0u64, |h, v| h.wrapping_mul(31).wrapping_add(v.to_bits()));
    println!("hash {h:016x} iterations {:.1} {:.2} s", r[0].mean_iterations, t0.elapsed().as_secs_f64());
    Ok(())
}
