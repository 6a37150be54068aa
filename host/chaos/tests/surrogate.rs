//! The tests of `chaos::surrogate`.

use chaos::ChaosError;
use chaos::internals::{
    IaaftWork, prediction_sse_scan, prediction_sse_sorted, radix_sort, stable_sort_keyed, strided, total_order_key,
};
use chaos::reference::Henon;
use chaos::rng::SplitMix;
use chaos::surrogate::*;

// ---- The plain transform and iteration, the reference for bit equality. ----

fn fft_amplitudes(x: &[f64]) -> Vec<f64> {
    let mut re = x.to_vec();
    let mut im = vec![0.0; x.len()];
    fft(&mut re, &mut im, false);
    re.iter().zip(&im).map(|(a, b)| a.hypot(*b)).collect()
}

/// The bit-reversal permutation of the radix-2 FFT, in place on both parts.
fn bit_reverse(re: &mut [f64], im: &mut [f64]) {
    let n = re.len();
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
}

/// In-place iterative radix-2 FFT (length a power of two); `inverse` divides by n.
fn fft(re: &mut [f64], im: &mut [f64], inverse: bool) {
    let n = re.len();
    bit_reverse(re, im);
    // Twiddles of the largest stage; stage `len` reads every (n / len)-th. IAAFT transforms
    // the same length back and forth hundreds of times: the tables of the last length (both
    // directions) are kept per thread, the same values as computed afresh.
    /// (length, twiddles) of the last transform, forward and inverse.
    type Tables = [(usize, Vec<(f64, f64)>); 2];
    thread_local! {
        static TWIDDLES: std::cell::RefCell<Tables> = const { std::cell::RefCell::new([(0, Vec::new()), (0, Vec::new())]) };
    }
    TWIDDLES.with(|t| {
        let mut t = t.borrow_mut();
        let slot = &mut t[usize::from(inverse)];
        if slot.0 != n {
            let sign = if inverse { 1.0 } else { -1.0 };
            slot.1 = (0..n / 2).map(|k| (sign * 2.0 * std::f64::consts::PI * k as f64 / n as f64).sin_cos()).collect();
            slot.0 = n;
        }
        butterflies(re, im, &slot.1);
    });
    if inverse {
        let f = 1.0 / n as f64;
        re.iter_mut().chain(im.iter_mut()).for_each(|v| *v *= f);
    }
}

/// The radix-2 stages of [`fft`] on bit-reversed `re`, `im` with the twiddles `tw` of length n.
fn butterflies(re: &mut [f64], im: &mut [f64], tw: &[(f64, f64)]) {
    let n = re.len();
    let mut len = 2;
    while len <= n {
        let stride = n / len;
        for start in (0..n).step_by(len) {
            for k in 0..len / 2 {
                let (s, c) = tw[k * stride];
                let (a, b) = (start + k, start + k + len / 2);
                let (tr, ti) = (re[b] * c - im[b] * s, re[b] * s + im[b] * c);
                re[b] = re[a] - tr;
                im[b] = im[a] - ti;
                re[a] += tr;
                im[a] += ti;
            }
        }
        len <<= 1;
    }
}

/// One IAAFT surrogate from the data's sorted values and Fourier amplitudes; returns it and
/// the iterations used.
fn iaaft_plain(sorted: &[f64], amp: &[f64], max_iter: usize, rng: &mut SplitMix) -> (Vec<f64>, usize) {
    let n = sorted.len();
    // Start from a random permutation of the values.
    let mut s = sorted.to_vec();
    for i in (1..n).rev() {
        s.swap(i, rng.below(i + 1));
    }
    let mut rank: Vec<usize> = vec![0; n];
    let mut order: Vec<usize> = (0..n).collect();
    let mut re = vec![0.0; n];
    let mut im = vec![0.0; n];
    for it in 1..=max_iter {
        // Impose the Fourier amplitudes, keep the phases.
        re.copy_from_slice(&s);
        im.iter_mut().for_each(|v| *v = 0.0);
        fft(&mut re, &mut im, false);
        for k in 0..n {
            let a = re[k].hypot(im[k]);
            let (c, si) = if a > 0.0 { (re[k] / a, im[k] / a) } else { (1.0, 0.0) };
            re[k] = amp[k] * c;
            im[k] = amp[k] * si;
        }
        fft(&mut re, &mut im, true);
        // Rank-order remap onto the data's values.
        order.sort_by(|&a, &b| re[a].total_cmp(&re[b]));
        let mut changed = false;
        for (r, &i) in order.iter().enumerate() {
            if rank[i] != r {
                changed = true;
                rank[i] = r;
            }
            s[i] = sorted[r];
        }
        if !changed && it > 1 {
            return (s, it);
        }
    }
    (s, max_iter)
}

fn ar2(n: usize, seed: u64) -> Vec<f64> {
    let mut rng = SplitMix::new(seed);
    let (mut a, mut b) = (0.0, 0.0);
    (0..n + 500)
        .map(|_| {
            let x = 1.6 * a - 0.8 * b + rng.normal();
            b = a;
            a = x;
            x
        })
        .skip(500)
        .collect()
}

/// The kept twiddle tables give the transform computed with fresh ones, bit for bit,
/// when lengths and directions alternate.
#[test]
fn kept_twiddles_give_the_fresh_transform() {
    let fresh = |re: &mut Vec<f64>, im: &mut Vec<f64>, inverse: bool| {
        let n = re.len();
        bit_reverse(re, im);
        let sign = if inverse { 1.0 } else { -1.0 };
        let tw: Vec<(f64, f64)> =
            (0..n / 2).map(|k| (sign * 2.0 * std::f64::consts::PI * k as f64 / n as f64).sin_cos()).collect();
        butterflies(re, im, &tw);
        if inverse {
            let f = 1.0 / n as f64;
            re.iter_mut().chain(im.iter_mut()).for_each(|v| *v *= f);
        }
    };
    for (n, inverse) in [(64, false), (64, true), (256, false), (64, false), (256, true), (256, true), (8, false)] {
        let x: Vec<f64> = (0..n).map(|k| ((k * 37 % 11) as f64 - 5.0) * 0.3 + (k as f64 * 0.2).sin()).collect();
        let (mut a, mut ai) = (x.clone(), x.iter().map(|v| v * 0.5).collect::<Vec<_>>());
        let (mut b, mut bi) = (a.clone(), ai.clone());
        fft(&mut a, &mut ai, inverse);
        fresh(&mut b, &mut bi, inverse);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!((bits(&a), bits(&ai)), (bits(&b), bits(&bi)), "n {n} inverse {inverse}");
    }
}

/// The IAAFT work path (stage tables, gathers, radix-sorted ranks) against the plain
/// transform and iteration above, bit for bit: amplitudes, surrogates and iteration counts
/// for lengths 2..4096, on data with exact ties, signed zeros, a constant stretch and
/// values of both signs, several runs per work (reuse), including runs that converge
/// before `max_iter`.
#[test]
fn iaaft_work_matches_the_plain_iteration() {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for n in [2usize, 4, 8, 64, 256, 1024, 4096] {
        let ar = ar2(n, n as u64);
        let cases: Vec<Vec<f64>> = vec![
            ar.clone(),
            ar.iter().map(|v| v.powi(3)).collect(),
            ar.iter().map(|v| (v * 2.0).round() / 2.0).collect(),
            ar.iter()
                .enumerate()
                .map(|(i, v)| {
                    if i % 5 == 0 {
                        0.0
                    } else if i % 7 == 0 {
                        -0.0
                    } else if i < n / 8 {
                        1.5
                    } else {
                        *v
                    }
                })
                .collect(),
            (0..n).map(|i| (i as f64 * 0.37).sin() * 1e-3 + 2.0).collect(),
        ];
        let mut work = IaaftWork::new(n);
        for (c, x) in cases.iter().enumerate() {
            let amp = fft_amplitudes(x);
            assert_eq!(bits(&work.amplitudes(x)), bits(&amp), "n {n} case {c} amplitudes");
            let mut sorted = x.clone();
            sorted.sort_by(f64::total_cmp);
            for (seed, max_iter) in [(1u64, 100usize), (7, 3), (11, 1), (5, 1000)] {
                let (mut r1, mut r2) = (SplitMix::new(seed), SplitMix::new(seed));
                let (s, it) = iaaft_plain(&sorted, &amp, max_iter, &mut r1);
                let it2 = work.iaaft(&sorted, &amp, max_iter, &mut r2);
                assert_eq!((bits(&work.s), it2), (bits(&s), it), "n {n} case {c} seed {seed} max_iter {max_iter}");
                assert_eq!(r1.next_u64(), r2.next_u64());
            }
        }
    }
    // The radix sort is the stable comparison sort by total order.
    let mut rng = SplitMix::new(3);
    let vals = [0.0, -0.0, 1.0, -1.0, f64::MIN_POSITIVE, -f64::MIN_POSITIVE, 5e-324, -5e-324, 1e300, -1e300, 0.5, -0.5];
    for len in [1usize, 2, 17, 300, 5000] {
        let x: Vec<f64> = (0..len)
            .map(|i| {
                if i % 3 == 0 {
                    vals[rng.below(vals.len())]
                } else {
                    rng.normal() * 10f64.powi(rng.below(20) as i32 - 10)
                }
            })
            .collect();
        let mut order: Vec<usize> = (0..len).rev().collect();
        let mut keyed: Vec<(u64, u32)> = order.iter().map(|&i| (total_order_key(x[i]), i as u32)).collect();
        order.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
        let mut k2 = keyed.clone();
        radix_sort(&mut keyed, &mut Vec::new());
        assert_eq!(keyed.iter().map(|e| e.1 as usize).collect::<Vec<_>>(), order, "len {len}");
        stable_sort_keyed(&mut k2, &mut Vec::new());
        assert_eq!(k2, keyed, "len {len}");
        // Nearly sorted (the insertion path): a few entries moved.
        let mut k3 = keyed.clone();
        for t in 0..len / 50 {
            k3.swap((t * 37) % len, (t * 101 + 7) % len);
        }
        let mut k4 = k3.clone();
        k3.sort_by_key(|e| e.0);
        stable_sort_keyed(&mut k4, &mut Vec::new());
        assert_eq!(k4, k3, "len {len}");
    }
}

#[test]
fn fft_round_trip_and_known_transform() {
    let x: Vec<f64> = (0..16).map(|k| (2.0 * std::f64::consts::PI * 3.0 * k as f64 / 16.0).cos()).collect();
    let (mut re, mut im) = (x.clone(), vec![0.0; 16]);
    fft(&mut re, &mut im, false);
    for k in 0..16 {
        let want = if k == 3 || k == 13 { 8.0 } else { 0.0 };
        assert!((re[k].hypot(im[k]) - want).abs() < 1e-12, "{k}");
    }
    fft(&mut re, &mut im, true);
    for k in 0..16 {
        assert!((re[k] - x[k]).abs() < 1e-14 && im[k].abs() < 1e-14);
    }
}

/// IAAFT keeps the values exactly and the spectrum within a few per cent.
#[test]
fn iaaft_keeps_distribution_and_spectrum() {
    let x: Vec<f64> = ar2(1024, 5).iter().map(|v| v.powi(3)).collect(); // non-Gaussian values
    let mut sorted = x.clone();
    sorted.sort_by(f64::total_cmp);
    let mut work = IaaftWork::new(x.len());
    let amp = work.amplitudes(&x);
    work.iaaft(&sorted, &amp, 200, &mut SplitMix::new(1));
    let s = work.s.clone();
    let mut ss = s.clone();
    ss.sort_by(f64::total_cmp);
    assert_eq!(ss, sorted);
    assert_ne!(s, x);
    let a2 = fft_amplitudes(&s);
    let num: f64 = amp.iter().zip(&a2).map(|(a, b)| (a - b) * (a - b)).sum();
    let den: f64 = amp.iter().map(|a| a * a).sum();
    assert!((num / den).sqrt() < 0.15, "{}", (num / den).sqrt());
    // A plain shuffle (the start of the iteration) loses the spectrum.
    let mut sh = x.clone();
    let mut rng = SplitMix::new(2);
    for i in (1..sh.len()).rev() {
        sh.swap(i, rng.below(i + 1));
    }
    let a3 = fft_amplitudes(&sh);
    let num3: f64 = amp.iter().zip(&a3).map(|(a, b)| (a - b) * (a - b)).sum();
    assert!((num3 / den).sqrt() > 0.5, "{}", (num3 / den).sqrt());
}

/// Known answers: a linear Gaussian AR(2) process is not rejected (by either statistic);
/// the Henon map's x series is rejected at the smallest attainable p.
#[test]
fn ar_not_rejected_henon_rejected() {
    let p = SurrogateParams { surrogates: 19, max_len: 2048, ..Default::default() };
    let ar = surrogate_test(&ar2(2048, 11), &p).unwrap();
    assert!(ar.p_value > 0.1, "{ar:?}");
    let tr = SurrogateParams { statistic: Statistic::TimeReversal { lag: 1 }, ..p };
    let ar_t = surrogate_test(&ar2(2048, 12), &tr).unwrap();
    assert!(ar_t.p_value > 0.1, "{ar_t:?}");
    let h: Vec<f64> = Henon::default().orbit(2048, 1000).iter().map(|v| v[0]).collect();
    let he = surrogate_test(&h, &p).unwrap();
    assert_eq!(he.p_value, 0.05, "{he:?}");
    assert!(he.statistic_data < 0.5 * he.statistic_surrogates.iter().copied().fold(f64::INFINITY, f64::min), "{he:?}");
    let he_t = surrogate_test(&h, &tr).unwrap();
    assert_eq!(he_t.p_value, 0.05, "{he_t:?}");
    // Both statistics on one set of surrogates: the same numbers as one at a time.
    let both = surrogate_tests(&h, &[p.statistic, tr.statistic], &p).unwrap();
    assert_eq!(both, vec![he, he_t]);
}

/// The sorted walk against the plain scan: the same sum of squares and count bit for bit,
/// on quantized Henon data (many exact ties and zero distances), an AR(2) series and an
/// IAAFT surrogate of it, for several embeddings, horizons, neighbour counts and Theiler
/// windows; `PE_BENCH=sorted` / `PE_BENCH=scan` time one of them on 4096 samples.
#[test]
fn sorted_prediction_search_equals_the_scan() {
    let h: Vec<f64> = Henon::default().orbit(1500, 100).iter().map(|v| (v[0] * 20.0).round() / 20.0).collect();
    let ar = ar2(2048, 3);
    let mut sorted = ar.clone();
    sorted.sort_by(f64::total_cmp);
    let (surr, _) = iaaft_plain(&sorted, &fft_amplitudes(&ar), 50, &mut SplitMix::new(4));
    for (name, x) in [("henon", &h), ("ar2", &ar), ("iaaft", &surr)] {
        for (m, tau, horizon, neighbours, theiler, refs) in [
            (4, 1, 1, 5, 10, 500),
            (2, 3, 2, 1, 0, 300),
            (5, 2, 4, 8, 3, 2000),
            (1, 1, 1, 3, 20, 100),
            (6, 10, 10, 5, 40, 500),
            (3, 4, 1, 2, 5, 200),
            (7, 2, 3, 5, 10, 300),
            (8, 1, 2, 4, 6, 300),
            (9, 2, 1, 5, 10, 200),
        ] {
            let w = (m - 1) * tau;
            let nv = x.len() - w - horizon;
            let refs = strided(nv, refs);
            let a = prediction_sse_sorted(x, m, tau, horizon, neighbours, theiler, nv, &refs);
            let b = prediction_sse_scan(x, m, tau, horizon, neighbours, theiler, nv, &refs);
            assert_eq!(
                (a.0.to_bits(), a.1),
                (b.0.to_bits(), b.1),
                "{name} m={m} tau={tau} h={horizon} k={neighbours} theiler={theiler}"
            );
        }
    }
    if let Ok(kind) = std::env::var("PE_BENCH") {
        let x = ar2(4096, 9);
        let nv = x.len() - 3 - 1;
        let refs = strided(nv, 500);
        let mut acc = 0.0;
        for _ in 0..40 {
            acc += if kind == "sorted" {
                prediction_sse_sorted(&x, 4, 1, 1, 5, 10, nv, &refs)
            } else {
                prediction_sse_scan(&x, 4, 1, 1, 5, 10, nv, &refs)
            }
            .0;
        }
        eprintln!("40 {kind} prediction errors ({acc:.3e})");
    }
}

#[test]
fn bad_inputs_are_named() {
    let p = SurrogateParams::default();
    assert!(matches!(surrogate_test(&[1.0; 40], &p), Err(ChaosError::TooShort { .. })));
    assert!(matches!(surrogate_test(&[1.0; 100], &p), Err(ChaosError::ZeroVariance { .. })));
    assert!(matches!(
        surrogate_test(&ar2(100, 1), &SurrogateParams { surrogates: 0, ..p }),
        Err(ChaosError::BadParameter { .. })
    ));
    let mut x = ar2(100, 1);
    x[7] = f64::INFINITY;
    assert!(matches!(surrogate_test(&x, &p), Err(ChaosError::NonFinite { index: 7, .. })));
}
