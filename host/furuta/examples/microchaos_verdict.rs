//! Prints the microchaos verdict (`furuta::verdict`) with the quick or full settings:
//! `cargo run --release -p furuta --example microchaos_verdict [full]`. An exploration, not a test.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let full = std::env::args().nth(1).is_some_and(|a| a == "full");
    let o = if full { furuta::verdict::VerdictOptions::full() } else { furuta::verdict::VerdictOptions::quick() };
    let t0 = std::time::Instant::now();
    let v = furuta::verdict::microchaos_verdict(None, &o)?;
    println!("{}", serde_json::to_string_pretty(&v)?);
    eprintln!("{:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}
