//! The tests of `ssm::ridge`.
#![allow(clippy::single_range_in_vec_init)]

use faer::{Mat, MatRef};
use ssm::error::FitError;
use ssm::internals::{Budget, qr_first, u_blocks};
use ssm::ridge::*;
use std::sync::atomic::Ordering;

#[test]
fn exact_solution_without_ridge() {
    // a = [[1,0],[0,2],[1,1]], x = [3, -1] -> b exactly representable.
    let a = faer::mat![[1.0, 0.0], [0.0, 2.0], [1.0, 1.0]];
    let b = faer::mat![[3.0], [-2.0], [2.0]];
    let (x, c) = fit(a.as_ref(), b.as_ref(), &[0..3], Ridge::Fixed(0.0), "t").unwrap();
    assert!((x[(0, 0)] - 3.0).abs() < 1e-13 && (x[(1, 0)] + 1.0).abs() < 1e-13);
    assert!(c.rel_residual < 1e-14);
    assert!(c.cond > 1.0 && c.cond.is_finite());
}

#[test]
fn ridge_matches_normal_equations() {
    // Independent reference: (A^T A + l I) x = A^T b solved by hand for a 2x2 system.
    let a = faer::mat![[1.0, 2.0], [3.0, 4.0], [5.0, 7.0]];
    let b = faer::mat![[1.0], [0.0], [2.0]];
    let alpha = 1e-2;
    let ls = RidgeLs::new(a.as_ref(), "t").unwrap();
    let x = ls.solve(b.as_ref(), alpha);
    let smax2 = ls.s[0] * ls.s[0];
    let l = alpha * smax2;
    let ata = a.transpose() * &a;
    let atb = a.transpose() * &b;
    let (p, q, r, s) = (ata[(0, 0)] + l, ata[(0, 1)], ata[(1, 0)], ata[(1, 1)] + l);
    let det = p * s - q * r;
    let x0 = (s * atb[(0, 0)] - q * atb[(1, 0)]) / det;
    let x1 = (-r * atb[(0, 0)] + p * atb[(1, 0)]) / det;
    assert!((x[(0, 0)] - x0).abs() < 1e-12 && (x[(1, 0)] - x1).abs() < 1e-12);
}

/// `a x ~ b` solved through faer's own thin SVD, as before the factored path: `U^T b`
/// with the whole `U`.
fn solve_by_thin_svd(a: MatRef<'_, f64>, b: MatRef<'_, f64>, alpha: f64) -> Mat<f64> {
    let svd = a.thin_svd().unwrap();
    let s: Vec<f64> = (0..a.ncols()).map(|i| svd.S()[i]).collect();
    let ls = RidgeLs::from_parts(svd.U().to_owned(), s, svd.V().to_owned(), a.nrows());
    ls.solve(b, alpha)
}

/// The factorization in place (QR, SVD of R, `U = Q [U_R; 0]`) gives the same bits as
/// faer's thin SVD, on tall matrices of several shapes (QR block sizes), with and without
/// ridge; so does `fit_owned` against `fit`.
#[test]
fn factored_solve_is_bit_identical_to_thin_svd() {
    let mut r = ssm::testing::lcg_centered(7);
    for (m, n, q) in [(400, 30, 3), (3000, 35, 21), (4000, 200, 4), (2500, 330, 4)] {
        let a = Mat::from_fn(m, n, |_, _| r());
        let b = Mat::from_fn(m, q, |_, _| r());
        assert!(qr_first(m, n));
        for alpha in [0.0, 1e-8] {
            let want = solve_by_thin_svd(a.as_ref(), b.as_ref(), alpha);
            let owned = RidgeLs::from_owned(a.clone(), "t").unwrap().solve(b.as_ref(), alpha);
            for i in 0..n {
                for j in 0..q {
                    assert_eq!(owned[(i, j)].to_bits(), want[(i, j)].to_bits(), "{m}x{n} alpha {alpha}: x[{i},{j}]");
                }
            }
        }
        let (x, c) = fit(a.as_ref(), b.as_ref(), &[0..m], Ridge::Fixed(0.0), "t").unwrap();
        let (xo, co) = fit_owned(a.clone(), b.as_ref(), &[0..m], Ridge::Fixed(0.0), "t", || a.clone()).unwrap();
        assert!(x == xo && c == co, "{m}x{n}: fit_owned differs from fit");
    }
}

/// `solve_owned` (`U` a block of columns at a time, only `U^T b` kept) gives the same
/// bits as `from_owned(a).solve(b)`, on shapes whose last block is narrow, wide or joined
/// to the one before; the blocks cover the columns once, each wider than 48.
#[test]
fn blockwise_u_solve_is_bit_identical() {
    for n in [97, 193, 241, 290, 330, 505, 1000] {
        let blocks = u_blocks(n);
        assert_eq!(blocks.first().map(|r| r.start), Some(0));
        assert_eq!(blocks.last().map(|r| r.end), Some(n));
        assert!(blocks.windows(2).all(|w| w[0].end == w[1].start && w[0].len() == U_BLOCK), "{n}: {blocks:?}");
        assert!(blocks.iter().all(|r| r.len() > 48 && r.len() <= U_BLOCK + U_BLOCK / 2), "{n}: {blocks:?}");
    }
    let mut r = ssm::testing::lcg_centered(11);
    for (m, n, q) in [(2600, 241, 4), (2000, 290, 4), (3000, 505, 6), (1200, 193, 1)] {
        let a = Mat::from_fn(m, n, |_, _| r());
        let b = Mat::from_fn(m, q, |_, _| r());
        assert!(qr_first(m, n) && n > 2 * U_BLOCK);
        for alpha in [0.0, 1e-8] {
            let ls = RidgeLs::from_owned(a.clone(), "t").unwrap();
            let want = ls.solve(b.as_ref(), alpha);
            let (got, s) = RidgeLs::solve_owned(a.clone(), b.as_ref(), alpha, "t").unwrap();
            assert_eq!(
                s.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                ls.s.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "{m}x{n}: singular values"
            );
            for i in 0..n {
                for j in 0..q {
                    assert_eq!(got[(i, j)].to_bits(), want[(i, j)].to_bits(), "{m}x{n} alpha {alpha}: x[{i},{j}]");
                }
            }
        }
    }
    let a = Mat::from_fn(300, 200, |_, _| r());
    assert!(matches!(
        RidgeLs::solve_owned(a, Mat::<f64>::zeros(299, 1).as_ref(), 0.0, "t"),
        Err(FitError::BadOption { .. })
    ));
}

/// `solve_owned_qtb` (`U^T b` as `U_R^T (Q^T b)`, no `U`): the singular values of
/// `solve_owned` bit for bit and the solution within 1e-13 relative (max-norm over the
/// solution, printed per shape; the column-scaled shape with cond ~1e6 included),
/// with and without ridge; not tall enough for the
/// QR-first SVD: `solve_owned` itself; bad right-hand side refused.
#[test]
fn qtb_solve_matches_the_u_solve_to_rounding() {
    let mut r = ssm::testing::lcg_centered(5);
    for (m, n, q, graded) in [(2600, 241, 4, false), (4000, 120, 3, false), (3000, 200, 4, true), (60, 40, 2, false)] {
        // graded: column j scaled by 10^(-6 j / n), condition number ~1e6.
        let a = Mat::from_fn(m, n, |_, j| r() * if graded { 10f64.powf(-6.0 * j as f64 / n as f64) } else { 1.0 });
        let b = Mat::from_fn(m, q, |_, _| r());
        for alpha in [0.0, 1e-8] {
            let (want, sw) = RidgeLs::solve_owned(a.clone(), b.as_ref(), alpha, "t").unwrap();
            let (got, sg) = RidgeLs::solve_owned_qtb(a.clone(), b.as_ref(), alpha, "t").unwrap();
            assert_eq!(
                sg.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                sw.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                "{m}x{n}: singular values"
            );
            let top =
                (0..n).flat_map(|i| (0..q).map(move |j| (i, j))).map(|(i, j)| want[(i, j)].abs()).fold(0.0, f64::max);
            let diff = (0..n)
                .flat_map(|i| (0..q).map(move |j| (i, j)))
                .map(|(i, j)| (got[(i, j)] - want[(i, j)]).abs())
                .fold(0.0, f64::max);
            eprintln!("{m}x{n} q {q} graded {graded} alpha {alpha}: max |x_qtb - x_u| / max |x| = {:.1e}", diff / top);
            assert!(diff <= 1e-13 * top, "{m}x{n} alpha {alpha}: {diff} vs {top}");
            if !qr_first(m, n) {
                assert!(got == want, "{m}x{n}: not tall, the U solve itself");
            }
        }
    }
    let a = Mat::from_fn(300, 20, |_, _| r());
    assert!(matches!(
        RidgeLs::solve_owned_qtb(a, Mat::<f64>::zeros(299, 1).as_ref(), 0.0, "t"),
        Err(FitError::BadOption { .. })
    ));
}

/// Reservations beyond the budget take turns; one alone goes ahead whatever its size;
/// small ones are not counted.
#[test]
fn reservations_beyond_the_budget_take_turns() {
    use std::sync::mpsc;
    use std::time::Duration;
    static B: Budget = Budget::new();
    B.limit.store(1000, Ordering::Relaxed);
    let first = B.reserve(800);
    let small = B.reserve(50);
    let (tx, rx) = mpsc::channel();
    let h = std::thread::spawn(move || {
        let _r = B.reserve(800);
        tx.send(()).unwrap();
    });
    assert!(rx.recv_timeout(Duration::from_millis(300)).is_err(), "the second reservation went ahead");
    drop(first);
    rx.recv_timeout(Duration::from_secs(10)).unwrap();
    h.join().unwrap();
    drop(small);
    assert_eq!(*B.used.lock().unwrap(), 0);
    drop(B.reserve(5000));
    assert_eq!(*B.used.lock().unwrap(), 0);
}

#[test]
fn rank_deficient_is_reported_not_divided() {
    let a = faer::mat![[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]];
    let b = faer::mat![[1.0], [2.0], [3.0]];
    let (x, c) = fit(a.as_ref(), b.as_ref(), &[0..3], Ridge::Fixed(0.0), "t").unwrap();
    assert!(x[(0, 0)].is_finite() && (x[(0, 0)] - 0.5).abs() < 1e-12);
    assert!(c.cond > 1e12, "cond {}", c.cond);
}
