//! Surrogate-data tests for determinism (Theiler et al. 1992; iterative amplitude-adjusted
//! Fourier-transform surrogates of Schreiber & Schmitz 1996).
//!
//! Null hypothesis: the series is a stationary linear Gaussian process seen through a
//! static, monotone measurement function. IAAFT surrogates keep the series' amplitude
//! distribution exactly and its power spectrum approximately (alternate projections: impose
//! the data's Fourier amplitudes, then rank-order remap onto the data's values). A
//! discriminating statistic is computed on the data and on every surrogate, and the rank of
//! the data among them gives the p-value: with `M` surrogates the smallest attainable
//! one-sided p is `1 / (M + 1)`.
//!
//! Statistics: the nonlinear prediction error (zeroth-order local-average predictor in a delay
//! embedding; deterministic data predict better than their surrogates, one-sided) and the
//! time-reversal asymmetry `<(x_{n+l} - x_n)^3> / <(x_{n+l} - x_n)^2>^{3/2}` (two-sided).
//!
//! The series is cut to the longest power of two (radix-2 FFT), at the offset whose segment
//! ends match best (value and slope), so the periodic continuation the FFT assumes does not
//! add a jump that only the data have.

use crate::rng::SplitMix;
use crate::{ChaosError, Result, at_least, check_finite, strided};

/// The discriminating statistic.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub enum Statistic {
    /// RMS error of predicting `horizon` samples ahead from the `neighbours` nearest delay
    /// vectors (`m`, `tau`), outside a Theiler window, over at most `refs` reference points,
    /// divided by the standard deviation. Smaller = more deterministic (one-sided test).
    PredictionError { m: usize, tau: usize, horizon: usize, neighbours: usize, theiler: usize, refs: usize },
    /// Time-reversal asymmetry at lag `lag` (two-sided test on its absolute value).
    TimeReversal { lag: usize },
}

/// Settings of [`surrogate_test`].
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SurrogateParams {
    pub statistic: Statistic,
    /// Number of surrogates (19: p >= 0.05; 39: p >= 0.025; 99: p >= 0.01).
    pub surrogates: usize,
    /// IAAFT iterations at most (stops earlier when the rank order no longer changes).
    pub max_iter: usize,
    pub seed: u64,
    /// Use at most this many samples (the largest power of two not above it and the length).
    pub max_len: usize,
}

impl Default for SurrogateParams {
    fn default() -> Self {
        Self {
            statistic: Statistic::PredictionError { m: 4, tau: 1, horizon: 1, neighbours: 5, theiler: 10, refs: 500 },
            surrogates: 39,
            max_iter: 200,
            seed: 1,
            max_len: 4096,
        }
    }
}

/// What [`surrogate_test`] found.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct SurrogateResult {
    pub statistic_data: f64,
    pub statistic_surrogates: Vec<f64>,
    /// Rank-based p-value of the null hypothesis (linear Gaussian process).
    pub p_value: f64,
    /// Samples used (power of two) and where the segment starts.
    pub len: usize,
    pub offset: usize,
    /// Mean IAAFT iterations per surrogate.
    pub mean_iterations: f64,
}

/// Shortest segment the test accepts.
pub const MIN_LEN: usize = 64;

/// Runs the surrogate test on `x` (see the module doc).
pub fn surrogate_test(x: &[f64], p: &SurrogateParams) -> Result<SurrogateResult> {
    surrogate_tests(x, &[p.statistic], p)?.pop().ok_or(ChaosError::TooShort {
        param: "surrogate statistics",
        have: 0,
        need: 1,
    })
}

/// [`surrogate_test`] for several statistics on the same surrogates (`p.statistic` is not
/// used): one result per statistic, in order.
pub fn surrogate_tests(x: &[f64], stats: &[Statistic], p: &SurrogateParams) -> Result<Vec<SurrogateResult>> {
    check_finite(x, 1)?;
    at_least("surrogates", p.surrogates, 1)?;
    at_least("max_iter (IAAFT)", p.max_iter, 1)?;
    at_least("statistics", stats.len(), 1)?;
    let cap = x.len().min(p.max_len);
    if cap < MIN_LEN {
        return Err(ChaosError::TooShort { param: "surrogate test", have: cap, need: MIN_LEN });
    }
    let len = 1usize << (usize::BITS - 1 - cap.leading_zeros());
    let offset = best_offset(x, len);
    let seg = &x[offset..offset + len];
    if seg.iter().all(|&v| v == seg[0]) {
        return Err(ChaosError::ZeroVariance { coord: 0, value: seg[0] });
    }
    let data: Vec<f64> = stats.iter().map(|s| statistic(seg, s)).collect::<Result<_>>()?;
    let mut sorted = seg.to_vec();
    sorted.sort_by(f64::total_cmp);
    let mut work = IaaftWork::new(len);
    let amp = work.amplitudes(seg);
    let mut rng = SplitMix::new(p.seed);
    let mut surr: Vec<Vec<f64>> = vec![Vec::with_capacity(p.surrogates); stats.len()];
    let mut iters = 0usize;
    for _ in 0..p.surrogates {
        iters += work.iaaft(&sorted, &amp, p.max_iter, &mut rng);
        for (v, st) in surr.iter_mut().zip(stats) {
            v.push(statistic(&work.s, st)?);
        }
    }
    let m = p.surrogates as f64;
    Ok(stats
        .iter()
        .zip(data)
        .zip(surr)
        .map(|((st, statistic_data), statistic_surrogates)| {
            let as_extreme = match st {
                Statistic::PredictionError { .. } => {
                    statistic_surrogates.iter().filter(|&&s| s <= statistic_data).count()
                }
                Statistic::TimeReversal { .. } => {
                    statistic_surrogates.iter().filter(|&&s| s.abs() >= statistic_data.abs()).count()
                }
            };
            SurrogateResult {
                statistic_data,
                statistic_surrogates,
                p_value: (1.0 + as_extreme as f64) / (m + 1.0),
                len,
                offset,
                mean_iterations: iters as f64 / m,
            }
        })
        .collect())
}

/// The IAAFT iteration's transform tables and work arrays for one length `n` (a power of
/// two), built once per test and reused by every surrogate and iteration (nothing is
/// allocated inside the iteration). The transforms are the radix-2 FFT's operations in its
/// order, bit for bit: the bit-reversal permutation as a gather, each stage's twiddles in a
/// contiguous table (the entries `k n / len` of the largest stage's), so a stage's butterflies
/// run over contiguous slices.
#[doc(hidden)]
pub struct IaaftWork {
    /// `rev[i]`: `i` with its `log2 n` bits reversed.
    rev: Vec<usize>,
    /// Stage twiddles (cosines, sines; forward, inverse): the stage of half-length `h`
    /// (`h = 1, 2, 4, .., n/2`) at offsets `h - 1 .. 2h - 1`.
    fwd: (Vec<f64>, Vec<f64>),
    inv: (Vec<f64>, Vec<f64>),
    re: Vec<f64>,
    im: Vec<f64>,
    re2: Vec<f64>,
    im2: Vec<f64>,
    /// (total-order key of the inverse transform's value, index), in the last rank order.
    keyed: Vec<(u64, u32)>,
    keyed_tmp: Vec<(u64, u32)>,
    rank: Vec<usize>,
    /// The current surrogate.
    pub s: Vec<f64>,
}

impl IaaftWork {
    pub fn new(n: usize) -> Self {
        let bits = n.trailing_zeros();
        let rev: Vec<usize> =
            (0..n).map(|i| if n > 1 { i.reverse_bits() >> (usize::BITS - bits) } else { 0 }).collect();
        let tables = |sign: f64| {
            let tw: Vec<(f64, f64)> =
                (0..n / 2).map(|k| (sign * 2.0 * std::f64::consts::PI * k as f64 / n as f64).sin_cos()).collect();
            let (mut c, mut s) = (Vec::with_capacity(n), Vec::with_capacity(n));
            let mut h = 1;
            while h < n {
                let stride = n / (2 * h);
                for k in 0..h {
                    let (sk, ck) = tw[k * stride];
                    c.push(ck);
                    s.push(sk);
                }
                h <<= 1;
            }
            (c, s)
        };
        Self {
            rev,
            fwd: tables(-1.0),
            inv: tables(1.0),
            re: vec![0.0; n],
            im: vec![0.0; n],
            re2: vec![0.0; n],
            im2: vec![0.0; n],
            keyed: Vec::with_capacity(n),
            keyed_tmp: vec![(0, 0); n],
            rank: vec![0; n],
            s: vec![0.0; n],
        }
    }

    /// Forward transform of the real `x` into `re`, `im`.
    fn forward_real(&mut self, x: &[f64]) {
        for ((r, i), &k) in self.re.iter_mut().zip(self.im.iter_mut()).zip(&self.rev) {
            *r = x[k];
            *i = 0.0;
        }
        stages(&mut self.re, &mut self.im, &self.fwd.0, &self.fwd.1);
    }

    /// The Fourier amplitudes of `x` (length `n`).
    pub fn amplitudes(&mut self, x: &[f64]) -> Vec<f64> {
        self.forward_real(x);
        self.re.iter().zip(&self.im).map(|(a, b)| a.hypot(*b)).collect()
    }

    /// One IAAFT surrogate (into `self.s`) from the data's sorted values and Fourier
    /// amplitudes; returns the iterations used. Bit for bit the plain iteration (the test
    /// module's `iaaft_plain`).
    pub fn iaaft(&mut self, sorted: &[f64], amp: &[f64], max_iter: usize, rng: &mut SplitMix) -> usize {
        let n = sorted.len();
        // Start from a random permutation of the values.
        self.s.copy_from_slice(sorted);
        for i in (1..n).rev() {
            self.s.swap(i, rng.below(i + 1));
        }
        self.rank.iter_mut().for_each(|r| *r = 0);
        self.keyed.clear();
        self.keyed.extend((0..n as u32).map(|i| (0, i)));
        let scale = 1.0 / n as f64;
        for it in 1..=max_iter {
            // Impose the Fourier amplitudes, keep the phases; the result goes to the inverse
            // transform's bit-reversed order directly.
            let s = std::mem::take(&mut self.s);
            self.forward_real(&s);
            self.s = s;
            for ((r2, i2), &k) in self.re2.iter_mut().zip(self.im2.iter_mut()).zip(&self.rev) {
                let (re, im) = (self.re[k], self.im[k]);
                let a = re.hypot(im);
                let (c, si) = if a > 0.0 { (re / a, im / a) } else { (1.0, 0.0) };
                *r2 = amp[k] * c;
                *i2 = amp[k] * si;
            }
            stages(&mut self.re2, &mut self.im2, &self.inv.0, &self.inv.1);
            // Rank-order remap onto the data's values: a stable sort of the last order by
            // the values (scaled by 1/n as the inverse transform's; the imaginary part is
            // not used), as a radix sort of their total-order keys.
            for e in self.keyed.iter_mut() {
                e.0 = total_order_key(self.re2[e.1 as usize] * scale);
            }
            stable_sort_keyed(&mut self.keyed, &mut self.keyed_tmp);
            let mut changed = false;
            for (r, &(_, i)) in self.keyed.iter().enumerate() {
                let i = i as usize;
                if self.rank[i] != r {
                    changed = true;
                    self.rank[i] = r;
                }
                self.s[i] = sorted[r];
            }
            if !changed && it > 1 {
                return it;
            }
        }
        max_iter
    }
}

/// The radix-2 stages on bit-reversed `re`, `im` with the stage twiddles `c`, `s` of
/// [`IaaftWork`]: per butterfly `t = x_b w`, `x_b = x_a - t`, `x_a += t`.
fn stages(re: &mut [f64], im: &mut [f64], c: &[f64], s: &[f64]) {
    let n = re.len();
    // The short stages with their length fixed (unrolled, no per-block slice set-up).
    let mut h = 1;
    while h < n && h <= 8 {
        match h {
            1 => stage_fixed::<1, 2>(re, im, c, s),
            2 => stage_fixed::<2, 4>(re, im, c, s),
            4 => stage_fixed::<4, 8>(re, im, c, s),
            _ => stage_fixed::<8, 16>(re, im, c, s),
        }
        h <<= 1;
    }
    while h < n {
        let (tc, ts) = (&c[h - 1..2 * h - 1], &s[h - 1..2 * h - 1]);
        for (rblk, iblk) in re.chunks_exact_mut(2 * h).zip(im.chunks_exact_mut(2 * h)) {
            let (ra, rb) = rblk.split_at_mut(h);
            let (ia, ib) = iblk.split_at_mut(h);
            for (((((ra, rb), ia), ib), &c), &s) in
                ra.iter_mut().zip(rb.iter_mut()).zip(ia.iter_mut()).zip(ib.iter_mut()).zip(tc).zip(ts)
            {
                let (tr, ti) = (*rb * c - *ib * s, *rb * s + *ib * c);
                *rb = *ra - tr;
                *ib = *ia - ti;
                *ra += tr;
                *ia += ti;
            }
        }
        h <<= 1;
    }
}

/// The stage of half-length `H` (`L = 2H`) of [`stages`], the same operations in the same order.
#[inline(always)]
fn stage_fixed<const H: usize, const L: usize>(re: &mut [f64], im: &mut [f64], c: &[f64], s: &[f64]) {
    let (Ok(tc), Ok(ts)) = (<&[f64; H]>::try_from(&c[H - 1..2 * H - 1]), <&[f64; H]>::try_from(&s[H - 1..2 * H - 1]))
    else {
        return;
    };
    for (rb, ib) in re.chunks_exact_mut(L).zip(im.chunks_exact_mut(L)) {
        let (Ok(rb), Ok(ib)) = (<&mut [f64; L]>::try_from(rb), <&mut [f64; L]>::try_from(ib)) else { return };
        for k in 0..H {
            let (c, s) = (tc[k], ts[k]);
            let (xr, xi) = (rb[k + H], ib[k + H]);
            let (tr, ti) = (xr * c - xi * s, xr * s + xi * c);
            rb[k + H] = rb[k] - tr;
            ib[k + H] = ib[k] - ti;
            rb[k] += tr;
            ib[k] += ti;
        }
    }
}

/// `x`'s position in `f64::total_cmp`'s order as an unsigned key.
#[inline]
#[doc(hidden)]
pub fn total_order_key(x: f64) -> u64 {
    let b = x.to_bits() as i64;
    ((b ^ (((b >> 63) as u64) >> 1) as i64) as u64) ^ (1 << 63)
}

/// Stable sort by the key: insertion sort on a copy while it moves fewer than `8 n` entries
/// (the IAAFT order changes little once the iteration settles), else [`radix_sort`].
#[doc(hidden)]
pub fn stable_sort_keyed(v: &mut Vec<(u64, u32)>, tmp: &mut Vec<(u64, u32)>) {
    let n = v.len();
    tmp.clear();
    tmp.extend_from_slice(v);
    let mut budget = 8 * n;
    for i in 1..n {
        let e = tmp[i];
        let mut j = i;
        while j > 0 && tmp[j - 1].0 > e.0 {
            tmp[j] = tmp[j - 1];
            j -= 1;
        }
        tmp[j] = e;
        let moved = i - j;
        if moved > budget {
            radix_sort(v, tmp);
            return;
        }
        budget -= moved;
    }
    std::mem::swap(v, tmp);
}

/// Stable LSD radix sort by the key (bytes; a byte equal in every key is skipped).
#[doc(hidden)]
pub fn radix_sort(v: &mut Vec<(u64, u32)>, tmp: &mut Vec<(u64, u32)>) {
    let n = v.len();
    tmp.resize(n, (0, 0));
    let mut counts = [[0u32; 256]; 8];
    for &(k, _) in v.iter() {
        for (d, c) in counts.iter_mut().enumerate() {
            c[((k >> (8 * d)) & 255) as usize] += 1;
        }
    }
    for (d, c) in counts.iter().enumerate() {
        if c.iter().any(|&m| m as usize == n) {
            continue;
        }
        let mut pos = [0usize; 256];
        let mut acc = 0usize;
        for (p, &m) in pos.iter_mut().zip(c) {
            *p = acc;
            acc += m as usize;
        }
        for &e in v.iter() {
            let b = ((e.0 >> (8 * d)) & 255) as usize;
            tmp[pos[b]] = e;
            pos[b] += 1;
        }
        std::mem::swap(v, tmp);
    }
}

/// Offset of the length-`len` segment whose ends match best: squared jump between the last
/// and the first value plus squared slope mismatch, over at most 2000 candidate offsets.
fn best_offset(x: &[f64], len: usize) -> usize {
    let last = x.len() - len;
    let cost = |s: usize| {
        let (a, b) = (x[s], x[s + len - 1]);
        let slope = if len > 2 { (x[s + 1] - a) - (b - x[s + len - 2]) } else { 0.0 };
        (b - a) * (b - a) + slope * slope
    };
    strided(last + 1, 2000).into_iter().min_by(|&a, &b| cost(a).total_cmp(&cost(b))).unwrap_or(0)
}

/// The statistic of series `x`.
pub fn statistic(x: &[f64], s: &Statistic) -> Result<f64> {
    match *s {
        Statistic::TimeReversal { lag } => {
            at_least("lag (time reversal)", lag, 1)?;
            if x.len() <= lag + 1 {
                return Err(ChaosError::TooShort { param: "time-reversal lag", have: x.len(), need: lag + 2 });
            }
            let (mut s2, mut s3) = (0.0, 0.0);
            for w in x.windows(lag + 1) {
                let d = w[lag] - w[0];
                s2 += d * d;
                s3 += d * d * d;
            }
            let n = (x.len() - lag) as f64;
            let v = s2 / n;
            Ok(if v > 0.0 { s3 / n / v.powf(1.5) } else { 0.0 })
        }
        Statistic::PredictionError { m, tau, horizon, neighbours, theiler, refs } => {
            prediction_error(x, m, tau, horizon, neighbours, theiler, refs)
        }
    }
}

/// Zeroth-order nonlinear prediction error (see [`Statistic::PredictionError`]).
pub fn prediction_error(
    x: &[f64],
    m: usize,
    tau: usize,
    horizon: usize,
    neighbours: usize,
    theiler: usize,
    refs: usize,
) -> Result<f64> {
    at_least("m (prediction embedding)", m, 1)?;
    at_least("tau (prediction lag)", tau, 1)?;
    at_least("horizon (prediction)", horizon, 1)?;
    at_least("neighbours (prediction)", neighbours, 1)?;
    at_least("refs (prediction)", refs, 1)?;
    let w = (m - 1) * tau;
    // Delay vectors i = 0..nv (first sample x[i], last x[i + w]) with a target x[i + w + horizon].
    let need = w + horizon + 2 * theiler + neighbours + 2;
    if x.len() < need {
        return Err(ChaosError::TooShort {
            param: "prediction error (embedding window + horizon + Theiler)",
            have: x.len(),
            need,
        });
    }
    let nv = x.len() - w - horizon;
    let (mean, sd) = crate::mean_std(x);
    let _ = mean;
    if sd <= 0.0 {
        return Err(ChaosError::ZeroVariance { coord: 0, value: x[0] });
    }
    let refs = strided(nv, refs);
    let sse_count = if x.iter().all(|v| v.is_finite()) {
        prediction_sse_sorted(x, m, tau, horizon, neighbours, theiler, nv, &refs)
    } else {
        prediction_sse_scan(x, m, tau, horizon, neighbours, theiler, nv, &refs)
    };
    let (sse, count) = sse_count;
    if count == 0 {
        return Err(ChaosError::TooShort { param: "prediction error references", have: 0, need: 1 });
    }
    Ok((sse / count as f64).sqrt() / sd)
}

/// Squared distance of the delay vectors starting at `i` and `j` (components in order).
#[inline]
fn delay_dist2(x: &[f64], i: usize, j: usize, m: usize, tau: usize) -> f64 {
    let mut d2 = 0.0;
    for k in 0..m {
        let e = x[i + k * tau] - x[j + k * tau];
        d2 += e * e;
    }
    d2
}

/// The prediction error's sum of squares and count by the plain scan: for each reference,
/// every delay vector `j` in index order outside the Theiler window, the `neighbours`
/// nearest kept sorted by distance (the smaller index first among equal distances).
#[allow(clippy::too_many_arguments)]
#[doc(hidden)]
pub fn prediction_sse_scan(
    x: &[f64],
    m: usize,
    tau: usize,
    horizon: usize,
    neighbours: usize,
    theiler: usize,
    nv: usize,
    refs: &[usize],
) -> (f64, usize) {
    let w = (m - 1) * tau;
    let mut best: Vec<(f64, usize)> = Vec::with_capacity(neighbours + 1);
    let mut sse = 0.0;
    let mut count = 0usize;
    for &i in refs {
        best.clear();
        for j in 0..nv {
            if j.abs_diff(i) <= theiler {
                continue;
            }
            let d2 = delay_dist2(x, i, j, m, tau);
            if best.len() < neighbours || d2 < best[best.len() - 1].0 {
                let pos = best.partition_point(|b| b.0 <= d2);
                best.insert(pos, (d2, j));
                best.truncate(neighbours);
            }
        }
        if let Some(e) = forecast_error(&best, x, i + w + horizon, w + horizon) {
            sse += e * e;
            count += 1;
        }
    }
    (sse, count)
}

/// The mean of the neighbours' values `ahead` samples after their start, minus the reference's
/// value `target` (None without neighbours): the prediction error of one reference point.
fn forecast_error(best: &[(f64, usize)], x: &[f64], target: usize, ahead: usize) -> Option<f64> {
    if best.is_empty() {
        return None;
    }
    let pred = best.iter().map(|&(_, j)| x[j + ahead]).sum::<f64>() / best.len() as f64;
    Some(pred - x[target])
}

/// [`prediction_sse_scan`] bit for bit on finite data, by a walk over the delay vectors
/// sorted by their first component (ties by index), outward from the reference on both
/// sides; a side ends at the first vector whose first-component gap alone exceeds the
/// current `neighbours`-th distance (its rounded square is part of every later distance on
/// that side, and rounding is monotone). The kept set is the `neighbours` smallest
/// `(distance, index)` pairs, which is what the scan keeps (it sees indices in increasing
/// order, so an equal distance never displaces an earlier index), in the same order, so
/// the prediction sums the same values in the same order.
#[allow(clippy::too_many_arguments)]
#[doc(hidden)]
pub fn prediction_sse_sorted(
    x: &[f64],
    m: usize,
    tau: usize,
    horizon: usize,
    neighbours: usize,
    theiler: usize,
    nv: usize,
    refs: &[usize],
) -> (f64, usize) {
    // The distance with its length fixed for the usual embeddings (the same sum in the same
    // order as `delay_dist2`).
    macro_rules! fixed {
        ($($m:literal)*) => {
            match m {
                $($m => prediction_sse_sorted_by(x, m, tau, horizon, neighbours, theiler, nv, refs, |i, j| delay_dist2_fixed::<$m>(x, i, j, tau)),)*
                _ => prediction_sse_sorted_by(x, m, tau, horizon, neighbours, theiler, nv, refs, |i, j| delay_dist2(x, i, j, m, tau)),
            }
        };
    }
    fixed!(2 3 4 5 6 7 8)
}

/// [`delay_dist2`] for `M` components.
#[inline(always)]
fn delay_dist2_fixed<const M: usize>(x: &[f64], i: usize, j: usize, tau: usize) -> f64 {
    let w = (M - 1) * tau;
    let (a, b) = (&x[i..=i + w], &x[j..=j + w]);
    let mut d2 = 0.0;
    for k in 0..M {
        let e = a[k * tau] - b[k * tau];
        d2 += e * e;
    }
    d2
}

/// [`prediction_sse_sorted`] with the squared distance `dist(i, j)`.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn prediction_sse_sorted_by(
    x: &[f64],
    m: usize,
    tau: usize,
    horizon: usize,
    neighbours: usize,
    theiler: usize,
    nv: usize,
    refs: &[usize],
    dist: impl Fn(usize, usize) -> f64,
) -> (f64, usize) {
    let w = (m - 1) * tau;
    let mut order: Vec<usize> = (0..nv).collect();
    order.sort_unstable_by(|&a, &b| x[a].total_cmp(&x[b]).then(a.cmp(&b)));
    let mut rank = vec![0; nv];
    for (r, &j) in order.iter().enumerate() {
        rank[j] = r;
    }
    let mut best: Vec<(f64, usize)> = Vec::with_capacity(neighbours + 1);
    let mut sse = 0.0;
    let mut count = 0usize;
    for &i in refs {
        best.clear();
        let x0 = x[i];
        let consider = |j: usize, best: &mut Vec<(f64, usize)>| {
            if j.abs_diff(i) <= theiler {
                return;
            }
            let d2 = dist(i, j);
            // `b` comes before `(d2, j)`; `j` is new, so never equal.
            let before = |b: &(f64, usize)| b.0 < d2 || (b.0 == d2 && b.1 < j);
            if best.len() < neighbours || !before(&best[best.len() - 1]) {
                let pos = best.partition_point(before);
                best.insert(pos, (d2, j));
                best.truncate(neighbours);
            }
        };
        let r = rank[i];
        let (mut lo, mut hi) = (r, r);
        let (mut lo_open, mut hi_open) = (true, true);
        // The reference itself (rank r) is inside its own Theiler window; start beside it.
        while lo_open || hi_open {
            if lo_open {
                if lo == 0 {
                    lo_open = false;
                } else {
                    lo -= 1;
                    let j = order[lo];
                    let t = x0 - x[j];
                    if best.len() == neighbours && t * t > best[neighbours - 1].0 {
                        lo_open = false;
                    } else {
                        consider(j, &mut best);
                    }
                }
            }
            if hi_open {
                hi += 1;
                if hi >= nv {
                    hi_open = false;
                } else {
                    let j = order[hi];
                    let t = x0 - x[j];
                    if best.len() == neighbours && t * t > best[neighbours - 1].0 {
                        hi_open = false;
                    } else {
                        consider(j, &mut best);
                    }
                }
            }
        }
        if let Some(e) = forecast_error(&best, x, i + w + horizon, w + horizon) {
            sse += e * e;
            count += 1;
        }
    }
    (sse, count)
}
