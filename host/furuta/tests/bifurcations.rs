//! The tests of `furuta::bifurcations`.

use furuta::Error;
use furuta::bifurcations::*;

/// Known answer: the rotation-and-growth map `z -> lambda(dt) e^{0.3 i} z`, `lambda = 1 +
/// 0.01 (dt - 31.3)`, from |z| = 1e-3 for N = 1000 steps escapes |z| > 1 exactly when
/// `lambda^N > 1000`, i.e. above `dt* = 31.3 + 100 (1000^{1/N} - 1)` = 31.99316 ms. The
/// grid-and-bisection switch must bracket dt* to the tolerance; a second start at 1e-4
/// (escapes later) changes nothing, the escape count on the grid is monotone.
#[test]
fn switch_of_a_map_with_a_known_escape_threshold() {
    let n_steps = 1000u64;
    let want = 31.3 + 100.0 * (1000f64.powf(1.0 / n_steps as f64) - 1.0);
    let escapes = |dt: f64| -> Result<Vec<bool>, Error> {
        let lam = 1.0 + 0.01 * (dt - 31.3);
        let (c, s) = (lam * 0.3f64.cos(), lam * 0.3f64.sin());
        Ok([1e-3, 1e-4]
            .iter()
            .map(|&r0| {
                let step = |e: &mut [f64]| {
                    let (x, y) = (e[0], e[1]);
                    e[0] = c * x - s * y;
                    e[1] = s * x + c * y;
                };
                !iterate_outcome(step, |e: &[f64]| e[0].hypot(e[1]), &[r0, 0.0], n_steps, 0.0, 0.01, 1.0).bounded()
            })
            .collect())
    };
    let sw = first_escape_switch(escapes, 31.0, 32.0, 11, 0.005).unwrap();
    let (a, b) = sw.bracket.unwrap();
    eprintln!("{sw:?}, want {want}");
    assert!(a < want && want <= b && b - a <= 0.005, "{a} {b} vs {want}");
    assert!(sw.monotone);
    assert_eq!(sw.grid.iter().map(|g| g.1).collect::<Vec<_>>(), vec![0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1]);
    // Nothing escapes below 31.9: no bracket; errors for a bad range.
    assert!(first_escape_switch(escapes, 31.0, 31.9, 5, 0.005).unwrap().bracket.is_none());
    assert!(matches!(first_escape_switch(escapes, 32.0, 31.0, 5, 0.005), Err(Error::BadInput { .. })));
    assert!(matches!(first_escape_switch(escapes, 31.0, 32.0, 5, 0.0), Err(Error::BadInput { .. })));
}

/// Escape time and maximum of a direct iteration; a non-finite state counts as escape.
#[test]
fn iterate_outcome_classifies() {
    // x -> 2x from 0.1: 0.1, 0.2, 0.4, 0.8, 1.6 -> escape at sample 4, t = 1 + 4 * 0.5.
    let o = iterate_outcome(|e| e[0] *= 2.0, |e| e[0], &[0.1], 10, 1.0, 0.5, 1.0);
    assert_eq!(o.escape_t, Some(3.0));
    assert_eq!(o.max_theta, 1.6);
    // Bounded for 3 steps (0.8 at the end).
    let o = iterate_outcome(|e| e[0] *= 2.0, |e| e[0], &[0.1], 3, 0.0, 0.5, 1.0);
    assert!(o.bounded() && o.max_theta == 0.8);
    let o = iterate_outcome(|e| e[0] = f64::NAN, |e| 0.0 * e[0], &[0.1], 3, 0.0, 0.5, 1.0);
    assert_eq!(o.escape_t, Some(0.5));
}
