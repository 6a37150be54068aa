//! The tests of `chaos::lyapunov`.

use chaos::internals::{SortedAxis, check_params, finish_curve, strided};
use chaos::lyapunov::*;
use chaos::{ChaosError, Norm, Points, Result};

fn curve(y: &[f64]) -> DivergenceCurve {
    DivergenceCurve {
        time: (0..y.len()).map(|k| k as f64 * 0.5).collect(),
        mean_log_distance: y.to_vec(),
        n_terms: vec![1; y.len()],
        n_reference: 1,
        zero_distances: 0,
    }
}

#[test]
fn window_rule_on_a_ramp_with_plateau() {
    // Steep start (1 per sample up to k = 2), then 0.25 per sample up to y = 6, then
    // flat: rise 6; candidates end before y >= 4.2 (first at k = 11, y = 4.25), so
    // k <= 10; centred local slopes equal 0.25 per sample from k = 3 -> window 3..=10,
    // slope 0.25 / 0.5 s = 0.5 per unit time.
    let y: Vec<f64> = (0..30).map(|k| if k <= 2 { k as f64 } else { (2.0 + 0.25 * (k - 2) as f64).min(6.0) }).collect();
    let f = fit_divergence(&curve(&y), &FitRule::default()).unwrap();
    assert_eq!(f.window, (3, 10));
    assert!((f.exponent - 0.5).abs() < 1e-12, "{}", f.exponent);
    assert!(f.grew);
}

#[test]
fn flat_curve_fits_everything() {
    let y: Vec<f64> = (0..20).map(|k| -3.0 + 0.01 * (k as f64).sin()).collect();
    let f = fit_divergence(&curve(&y), &FitRule::default()).unwrap();
    assert!(!f.grew);
    assert_eq!(f.window, (0, 19));
    assert!(f.exponent.abs() < 0.01);
}

#[test]
fn rejects_short_series_naming_the_parameter() {
    let x: Vec<f64> = (0..50).map(|i| (i as f64 * 0.3).sin()).collect();
    let p = Points::from_series(&x).unwrap();
    let e = rosenstein_curve(&p, &DivergenceParams { max_steps: 40, theiler: 5, ..Default::default() }).unwrap_err();
    assert_eq!(e, ChaosError::TooShort { param: "max_steps + 2*(theiler+1)", have: 50, need: 53 });
    assert!(matches!(
        rosenstein_curve(&p, &DivergenceParams { dt: 0.0, ..Default::default() }),
        Err(ChaosError::BadParameter { name: "dt", .. })
    ));
}

/// The sorted-axis search against the plain scan over all points in index order
/// (Rosenstein: nearest non-zero distance, smallest index on ties): the same picks on a
/// quantized Henon-like embedding (many exact ties and zero distances) in both norms and
/// embedding dimensions 1 to 9.
#[test]
fn sorted_axis_search_equals_the_full_scan() {
    let (mut a, mut b) = (0.1_f64, 0.0_f64);
    let mut x = Vec::new();
    for _ in 0..1500 {
        (a, b) = (1.0 - 1.4 * a * a + b, 0.3 * a);
        x.push((a * 20.0).round() / 20.0);
    }
    // Embedding dimensions 1..9: the fixed-length distance loops (2..8) and the slice loop.
    for (m, norm) in (1..=9).flat_map(|m| [(m, Norm::Euclidean), (m, Norm::Max)]) {
        let pts = chaos::delay_embed(&x, m, 1).unwrap();
        let p = DivergenceParams { theiler: 3, max_steps: 10, norm, ..Default::default() };
        let nc = pts.len() - p.max_steps;
        let axis = SortedAxis::new(&pts, nc);
        for i in 0..nc {
            let mut best: Option<(usize, f64)> = None;
            for j in (0..nc).filter(|&j| j.abs_diff(i) > p.theiler) {
                let d2 = p.norm.dist2(pts.point(i), pts.point(j));
                if d2 > 0.0 && best.is_none_or(|(_, b)| d2 < b) {
                    best = Some((j, d2));
                }
            }
            assert_eq!(axis.nearest(&pts, i, &p), best.map(|(j, _)| j), "reference {i}, m {m}, {norm:?}");
        }
    }
}

/// Rosenstein's curve as it was before the fixed-length distances (kept here).
fn rosenstein_plain(points: &Points, p: &DivergenceParams) -> Result<DivergenceCurve> {
    let nc = check_params(points, p)?;
    let k_len = p.max_steps + 1;
    let mut sum = vec![0.0; k_len];
    let mut n_terms = vec![0usize; k_len];
    let mut zero = 0usize;
    let mut n_ref = 0usize;
    let axis = SortedAxis::new(points, nc);
    for i in strided(nc, p.max_reference) {
        let Some(j) = axis.nearest(points, i, p) else { continue };
        n_ref += 1;
        for k in 0..k_len {
            let d2 = p.norm.dist2(points.point(i + k), points.point(j + k));
            if d2 > 0.0 {
                sum[k] += 0.5 * d2.ln();
                n_terms[k] += 1;
            } else {
                zero += 1;
            }
        }
    }
    finish_curve(sum, n_terms, n_ref, zero, p.dt)
}

/// Kantz's curves as they were before the sorted walk and the shared distances (kept
/// here): the candidates by a scan over all points, each scale's distances apart.
#[allow(clippy::type_complexity)]
fn kantz_plain(
    points: &Points,
    eps: &[f64],
    p: &DivergenceParams,
    max_neighbours: usize,
) -> Result<Vec<(f64, f64, std::result::Result<DivergenceCurve, String>)>> {
    let nc = check_params(points, p)?;
    let eps_max = eps.iter().copied().fold(0.0, f64::max);
    let k_len = p.max_steps + 1;
    let ne = eps.len();
    let mut sum = vec![vec![0.0; k_len]; ne];
    let mut n_terms = vec![vec![0usize; k_len]; ne];
    let mut zero = vec![0usize; ne];
    let mut n_ref = vec![0usize; ne];
    let mut neigh_total = vec![0usize; ne];
    let mut cand: Vec<(usize, f64)> = Vec::new();
    let mut chosen: Vec<usize> = Vec::new();
    for i in strided(nc, p.max_reference) {
        let pi = points.point(i);
        cand.clear();
        for j in (0..nc).filter(|&j| j.abs_diff(i) > p.theiler) {
            let d2 = p.norm.dist2(pi, points.point(j));
            if d2 < eps_max * eps_max {
                cand.push((j, d2));
            }
        }
        for (e, &eps_e) in eps.iter().enumerate() {
            chosen.clear();
            chosen.extend(cand.iter().filter(|(_, d2)| *d2 < eps_e * eps_e).map(|(j, _)| *j));
            if chosen.is_empty() {
                continue;
            }
            if chosen.len() > max_neighbours {
                let keep: Vec<usize> = strided(chosen.len(), max_neighbours).into_iter().map(|q| chosen[q]).collect();
                chosen.clear();
                chosen.extend(keep);
            }
            n_ref[e] += 1;
            neigh_total[e] += chosen.len();
            for k in 0..k_len {
                let a = points.point(i + k);
                let mean_d = chosen.iter().map(|&j| p.norm.dist2(a, points.point(j + k)).sqrt()).sum::<f64>()
                    / chosen.len() as f64;
                if mean_d > 0.0 {
                    sum[e][k] += mean_d.ln();
                    n_terms[e][k] += 1;
                } else {
                    zero[e] += 1;
                }
            }
        }
    }
    let mut out = Vec::with_capacity(ne);
    for e in 0..ne {
        let mean_neigh = if n_ref[e] > 0 { neigh_total[e] as f64 / n_ref[e] as f64 } else { 0.0 };
        let curve = if n_ref[e] == 0 {
            Err(format!("no reference point has a neighbour within eps = {:.4e}", eps[e]))
        } else {
            finish_curve(std::mem::take(&mut sum[e]), std::mem::take(&mut n_terms[e]), n_ref[e], zero[e], p.dt)
                .map_err(|err| err.to_string())
        };
        out.push((eps[e], mean_neigh, curve));
    }
    Ok(out)
}

/// Rosenstein (fixed-length distances) and Kantz (candidates by the sorted walk, one
/// distance per neighbour and step for all scales) equal the plain versions bit for bit
/// (curves, counts, failures) on a Henon series, a quantized one (ties, zero distances,
/// signed zeros after the shift) and a Lorenz-like flow sample, both norms, embedding
/// dimensions 1..9, scales from none to all neighbours, caps that stride.
#[test]
fn kantz_and_rosenstein_equal_the_plain_versions() {
    let (mut a, mut b) = (0.1_f64, 0.0_f64);
    let mut henon = Vec::new();
    for _ in 0..700 {
        (a, b) = (1.0 - 1.4 * a * a + b, 0.3 * a);
        henon.push(a);
    }
    let quant: Vec<f64> = henon.iter().map(|v| (v * 8.0).round() / 8.0 - 0.125).collect();
    let flow: Vec<f64> =
        (0..800).map(|k| (0.05 * k as f64).sin() + 0.3 * (0.131 * k as f64).sin() * (0.017 * k as f64).cos()).collect();
    let mut n_cases = 0;
    for (name, x) in [("henon", &henon), ("quantized", &quant), ("flow", &flow)] {
        for (m, norm) in (1..=9).flat_map(|m| [(m, Norm::Euclidean), (m, Norm::Max)]) {
            let pts = chaos::delay_embed(x, m, 2).unwrap();
            let p = DivergenceParams { theiler: 4, max_steps: 25, max_reference: 150, dt: 0.1, norm };
            let bits = |c: &DivergenceCurve| {
                (
                    c.mean_log_distance.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                    c.n_terms.clone(),
                    c.n_reference,
                    c.zero_distances,
                )
            };
            match (rosenstein_curve(&pts, &p), rosenstein_plain(&pts, &p)) {
                (Ok(a), Ok(b)) => assert_eq!(bits(&a), bits(&b), "{name} m {m} {norm:?}"),
                (a, b) => assert_eq!(a.map(|c| bits(&c)), b.map(|c| bits(&c)), "{name} m {m} {norm:?}"),
            }
            let eps = log_spaced(1e-3, 3.0, 9).unwrap();
            for cap in [1, 7, 50, 10_000] {
                let new = kantz_curves(&pts, &eps, &p, cap).unwrap();
                let old = kantz_plain(&pts, &eps, &p, cap).unwrap();
                assert_eq!(new.len(), old.len());
                for (u, v) in new.iter().zip(&old) {
                    assert_eq!(
                        (u.0.to_bits(), u.1.to_bits()),
                        (v.0.to_bits(), v.1.to_bits()),
                        "{name} m {m} {norm:?} cap {cap}"
                    );
                    match (&u.2, &v.2) {
                        (Ok(a), Ok(b)) => {
                            assert_eq!(bits(a), bits(b), "{name} m {m} {norm:?} cap {cap} eps {}", u.0)
                        }
                        (a, b) => assert_eq!(a.as_ref().err(), b.as_ref().err(), "{name} m {m} {norm:?} cap {cap}"),
                    }
                    n_cases += 1;
                }
            }
        }
    }
    assert_eq!(n_cases, 3 * 18 * 4 * 9);
}
