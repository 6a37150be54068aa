//! The estimators on a real chaotic recording (inverted flag, SSMLearn examples, 12,922
//! samples at 30 Hz), with timings. Only sanity is asserted: the true values are unknown.
//! Run with `--nocapture` (and `--release` for timings) to see the numbers.

use chaos::{
    Bins, CorrSumParams, DivergenceParams, FitRule, Points, ScalingRule, compare_pdfs, correlation_dimension,
    delay_embed, dominant_period, first_zero_crossing, kantz, log_spaced, rosenstein, ssm_dimension,
};
use std::time::Instant;

const FILE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/inverted_flag_chaotic/traj_9.csv");

fn read_column_2(path: &str) -> Option<(f64, Vec<f64>)> {
    let text = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) => {
            println!("SKIP: real data not available at {path} ({e}); the shared data folder is absent");
            return None;
        }
    };
    let mut t = Vec::new();
    let mut x = Vec::new();
    for (k, line) in text.lines().enumerate().skip(1) {
        let mut it = line.split(',');
        let (a, b) = (it.next(), it.next());
        let parse = |s: Option<&str>| s.and_then(|v| v.trim().parse::<f64>().ok());
        match (parse(a), parse(b)) {
            (Some(a), Some(b)) => {
                t.push(a);
                x.push(b);
            }
            _ => panic!("{path}: line {} is not two numbers: {line:?}", k + 1),
        }
    }
    let dt = (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64;
    Some((dt, x))
}

#[test]
fn inverted_flag_statistics_and_timing() {
    let Some((dt, x)) = read_column_2(FILE) else { return };
    println!("inverted flag traj_9: {} samples, dt = {dt:.5} s", x.len());
    let tau = first_zero_crossing(&x, 500).unwrap();
    let period = dominant_period(&x, 500).unwrap();
    println!(
        "autocorrelation: first zero at {tau} samples, dominant period {period} samples ({:.2} s)",
        period as f64 * dt
    );

    // Correlation dimension against the embedding dimension.
    let cprm = CorrSumParams { theiler: period, max_reference: 3000, ..Default::default() };
    let mut chosen = None;
    for m in [2, 3, 4, 5, 6, 7, 8] {
        let p = delay_embed(&x, m, tau).unwrap();
        let t0 = Instant::now();
        let d = correlation_dimension(&p, &cprm, &ScalingRule::default());
        let el = t0.elapsed().as_secs_f64();
        match &d {
            Ok(d) => println!(
                "  m = {m}: D2 = {:.3} +- {:.3} (fit se {:.3}) over r = {:.3e}..{:.3e} ({} radii), {:.3} s",
                d.dimension,
                d.slope_std,
                d.fit_stderr,
                d.r_range.0,
                d.r_range.1,
                d.index_range.1 - d.index_range.0 + 1,
                el
            ),
            Err(e) => println!("  m = {m}: {e} ({el:.3} s)"),
        }
        if m == 6 {
            chosen = Some(d);
        }
    }
    let d = chosen.unwrap().expect("a scaling range at m = 6");
    assert!(d.dimension.is_finite() && (1.0..5.0).contains(&d.dimension), "D2 = {}", d.dimension);
    println!("  SSM dimension (smallest even > D2 at m = 6): {}", ssm_dimension(d.dimension).unwrap());

    // Largest exponent: Rosenstein and Kantz at m = 6, curve over 5 dominant periods.
    let p = delay_embed(&x, 6, tau).unwrap();
    let lp = DivergenceParams { theiler: period, max_steps: 5 * period, max_reference: 3000, dt, ..Default::default() };
    let t0 = Instant::now();
    let r = rosenstein(&p, &lp, &FitRule::default()).unwrap();
    println!(
        "Rosenstein m = 6: {:.3} 1/s (fit se {:.3}, local-slope sd {:.3}) window {:.2}..{:.2} s, rise {:.2} nats, {:.3} s",
        r.fit.exponent,
        r.fit.fit_stderr,
        r.fit.slope_std,
        r.fit.window_time.0,
        r.fit.window_time.1,
        r.fit.rise,
        t0.elapsed().as_secs_f64()
    );
    assert!(r.fit.exponent.is_finite() && r.fit.exponent > 0.0);

    let sd = {
        let m = x.iter().sum::<f64>() / x.len() as f64;
        (x.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (x.len() - 1) as f64).sqrt()
    };
    let eps = log_spaced(0.05 * sd, 1.0 * sd, 5).unwrap();
    let t0 = Instant::now();
    let k = kantz(&p, &eps, &DivergenceParams { max_reference: 2000, ..lp }, 50, &FitRule::default()).unwrap();
    println!(
        "Kantz m = 6 ({:.3} s for {} scales), eps in units of the series' sd {sd:.4}:",
        t0.elapsed().as_secs_f64(),
        eps.len()
    );
    for e in &k {
        match &e.fit {
            Some(f) => println!(
                "  eps = {:.3} sd: {:.3} 1/s window {:.2}..{:.2} s, mean neighbours {:.1}",
                e.eps / sd,
                f.exponent,
                f.window_time.0,
                f.window_time.1,
                e.mean_neighbours
            ),
            None => println!("  eps = {:.3} sd: no fit ({:?})", e.eps / sd, e.failure),
        }
        if let Some(f) = &e.fit {
            assert!(f.exponent.is_finite());
        }
    }

    // PDFs: first half of the recording against the second half (a stationarity check and
    // the data-vs-model comparison's cost), on delay coordinates (m = 3).
    let p3 = delay_embed(&x, 3, tau).unwrap();
    let half = p3.len() / 2;
    let a = Points::from_flat(3, p3.as_flat()[..half * 3].to_vec()).unwrap();
    let b = Points::from_flat(3, p3.as_flat()[half * 3..].to_vec()).unwrap();
    let t0 = Instant::now();
    let cmp = compare_pdfs(&a, &b, Bins::default()).unwrap();
    println!(
        "PDFs first vs second half ({:.4} s): JS bits per coordinate {:?}, L1 {:?}, bins {}",
        t0.elapsed().as_secs_f64(),
        cmp.coords.iter().map(|c| (c.js_bits * 1e4).round() / 1e4).collect::<Vec<_>>(),
        cmp.coords.iter().map(|c| (c.l1 * 1e3).round() / 1e3).collect::<Vec<_>>(),
        cmp.coords[0].centers.len()
    );
    assert!(cmp.max_js_bits.is_finite() && cmp.max_js_bits < 0.2);
}
