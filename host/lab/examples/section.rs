//! Runs one section of `ssmctl reproduce` alone, for profiling (docs/decisions/0003):
//! `cargo run --release -p lab --example section -- NAME OUT_DIR [--quick] [--data-dir DIR]`,
//! NAME one of accuracy-time-sim, chaos, chaos-scale, chaos-verdict, chaos-cost, or chain (the first
//! three in one process, as the report runs them).
//! Writes OUT_DIR/index.html and OUT_DIR/summary.json with that section only.

use std::error::Error;
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().ok_or("usage: section NAME OUT_DIR [--quick] [--data-dir DIR]")?.clone();
    let out = PathBuf::from(args.get(1).ok_or("missing OUT_DIR")?);
    let quick = args.iter().any(|a| a == "--quick");
    let data_dir = args
        .iter()
        .position(|a| a == "--data-dir")
        .and_then(|i| args.get(i + 1))
        .map_or_else(|| PathBuf::from("../shared/data"), PathBuf::from);
    ssm::ridge::set_memory_budget(ssmctl::report::reproduce::REGRESSION_MEMORY_MB << 20);
    let mut rep = ssmctl::report::Report::new(&out)?;
    std::fs::create_dir_all(out.join("fig"))?;
    if name == "bench-window" {
        // The simulation bench at a given timing window, as JSON rows (docs/decisions/0003: how short
        // can the windows be with the same ratios).
        let w: f64 = args.get(2).ok_or("missing window")?.parse()?;
        let (rows, _) = ssmctl::bench::bench_simulate_window(200, false, w, |_| {})?;
        println!("{}", serde_json::to_string(&rows)?);
        return Ok(());
    }
    if name == "chain" {
        // The report's chaos chain in one process (chaos, chaos-scale, chaos-verdict), so the
        // runs they share are shared as in `ssmctl reproduce`.
        let r = &mut rep;
        ssmctl::report::tasks::task("chaos", || ssmctl::report::chaos::section(r, &data_dir, quick))?;
        ssmctl::report::tasks::task("chaos-scale", || ssmctl::report::chaos::scale_section(r, &data_dir, quick))?;
        ssmctl::report::tasks::task("chaos-verdict", || ssmctl::report::verdict::microchaos_verdict_section(r, quick))?;
        rep.finish(&name)?;
        return Ok(());
    }
    let r = &mut rep;
    ssmctl::report::tasks::task(&name, || -> Result<(), Box<dyn Error>> {
        match name.as_str() {
            "accuracy-time-sim" => ssmctl::report::reproduce::bench_section(r, quick, true),
            "chaos" => ssmctl::report::chaos::section(r, &data_dir, quick),
            "chaos-scale" => ssmctl::report::chaos::scale_section(r, &data_dir, quick),
            "chaos-verdict" => ssmctl::report::verdict::microchaos_verdict_section(r, quick),
            "chaos-cost" => ssmctl::report::chaos::cost_section(r, &data_dir),
            _ => Err(format!("unknown section {name}").into()),
        }
    })?;
    rep.finish(&name)?;
    Ok(())
}
