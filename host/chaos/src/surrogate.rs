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
pub(crate) struct IaaftWork {
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
    pub(crate) s: Vec<f64>,
}

impl IaaftWork {
    pub(crate) fn new(n: usize) -> Self {
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
    pub(crate) fn amplitudes(&mut self, x: &[f64]) -> Vec<f64> {
        self.forward_real(x);
        self.re.iter().zip(&self.im).map(|(a, b)| a.hypot(*b)).collect()
    }

    /// One IAAFT surrogate (into `self.s`) from the data's sorted values and Fourier
    /// amplitudes; returns the iterations used. Bit for bit the plain iteration (the test
    /// module's `iaaft_plain`).
    pub(crate) fn iaaft(&mut self, sorted: &[f64], amp: &[f64], max_iter: usize, rng: &mut SplitMix) -> usize {
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
fn total_order_key(x: f64) -> u64 {
    let b = x.to_bits() as i64;
    ((b ^ (((b >> 63) as u64) >> 1) as i64) as u64) ^ (1 << 63)
}

/// Stable sort by the key: insertion sort on a copy while it moves fewer than `8 n` entries
/// (the IAAFT order changes little once the iteration settles), else [`radix_sort`].
fn stable_sort_keyed(v: &mut Vec<(u64, u32)>, tmp: &mut Vec<(u64, u32)>) {
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
fn radix_sort(v: &mut Vec<(u64, u32)>, tmp: &mut Vec<(u64, u32)>) {
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
fn prediction_sse_scan(
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
fn prediction_sse_sorted(
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reference::Henon;

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
        thread_local! {
            static TWIDDLES: std::cell::RefCell<[(usize, Vec<(f64, f64)>); 2]> = const { std::cell::RefCell::new([(0, Vec::new()), (0, Vec::new())]) };
        }
        TWIDDLES.with(|t| {
            let mut t = t.borrow_mut();
            let slot = &mut t[usize::from(inverse)];
            if slot.0 != n {
                let sign = if inverse { 1.0 } else { -1.0 };
                slot.1 =
                    (0..n / 2).map(|k| (sign * 2.0 * std::f64::consts::PI * k as f64 / n as f64).sin_cos()).collect();
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
        let vals =
            [0.0, -0.0, 1.0, -1.0, f64::MIN_POSITIVE, -f64::MIN_POSITIVE, 5e-324, -5e-324, 1e300, -1e300, 0.5, -0.5];
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
        assert!(
            he.statistic_data < 0.5 * he.statistic_surrogates.iter().copied().fold(f64::INFINITY, f64::min),
            "{he:?}"
        );
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
}
