//! Prints the microchaos verdict (`chaos_study::verdict`) with the quick or full settings:
//! `cargo run --release -p lab --example microchaos_verdict [full]`. An exploration, not a test.

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let full = std::env::args().nth(1).is_some_and(|a| a == "full");
    let o =
        if full { chaos_study::verdict::VerdictOptions::full() } else { chaos_study::verdict::VerdictOptions::quick() };
    let t0 = std::time::Instant::now();
    let v = chaos_study::verdict::microchaos_verdict(None, &o)?;
    println!("{}", serde_json::to_string_pretty(&v)?);
    eprintln!("{:.1} s", t0.elapsed().as_secs_f64());
    Ok(())
}
