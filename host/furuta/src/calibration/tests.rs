use super::*;

#[test]
fn print_calibration() {
    let rows = calibration_rows(&FLAG_SAMPLING, &[0.0, 1.0, 3.0], 4).unwrap();
    for r in &rows {
        println!(
            "{} {} dt {:.4} lag {} th {} exact {:.4}+-{:.4} per_lag {:.3} D2 {:?}+-{:?} noise {:.4} fitted {}/{} ratio {:?} sd {:?} {:?} {:?}",
            r.system, r.observable, r.dt, r.lag, r.theiler, r.exact, r.exact_err, r.per_lag, r.corr_dim, r.corr_dim_err, r.noise_rel, r.fitted, r.segments, r.ratio_mean, r.ratio_sd, r.ratios, r.notes
        );
    }
}
