//! Histogram PDFs of each coordinate of two point sets (data and model) on a common grid,
//! and their divergence.
//!
//! Grid, per coordinate: `bins` equal bins over `[min, max]` of the union of both samples
//! (the last bin closed), so no sample falls outside. Bin-count rule ([`Bins`]):
//! - `FreedmanDiaconis { min, max }` (default 10..=200): width `2 IQR / n^(1/3)` where the IQR
//!   is that of the pooled samples and `n` is the SMALLER sample size (so the sparser
//!   sample is still resolved); count = `ceil(range / width)`, kept within `[min, max]`.
//!   When the IQR is zero (heavily repeated values, e.g. quantized data) the Rice count
//!   `ceil(2 n^(1/3))` is used, kept within the same limits.
//! - `Fixed(n)`.
//!
//! Divergence, per coordinate, on the bin masses `P`, `Q`:
//! - Jensen–Shannon divergence in bits, `JS = H(M) - (H(P) + H(Q))/2` with `M = (P+Q)/2`:
//!   symmetric, in `[0, 1]`, finite when a bin is empty on one side (1 = disjoint supports).
//! - L1 distance of the densities `sum |P_k - Q_k|`, in `[0, 2]`.

use crate::{ChaosError, Points, Result, at_least};

#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Bins {
    Fixed(usize),
    FreedmanDiaconis { min: usize, max: usize },
}

impl Default for Bins {
    fn default() -> Self {
        Bins::FreedmanDiaconis { min: 10, max: 200 }
    }
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct CoordinatePdf {
    pub coord: usize,
    /// `bins + 1` edges.
    pub edges: Vec<f64>,
    pub centers: Vec<f64>,
    /// Densities (integrate to 1 over the grid).
    pub data_density: Vec<f64>,
    pub model_density: Vec<f64>,
    pub js_bits: f64,
    pub l1: f64,
}

#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PdfComparison {
    pub coords: Vec<CoordinatePdf>,
    pub mean_js_bits: f64,
    pub max_js_bits: f64,
}

/// Jensen–Shannon divergence (bits) of two histograms (counts or masses; each is
/// normalized to sum 1). Errors on length mismatch, negative or non-finite entries, or an
/// all-zero histogram.
pub fn jensen_shannon_bits(p: &[f64], q: &[f64]) -> Result<f64> {
    if p.len() != q.len() {
        return Err(ChaosError::Shape { what: "histogram length", expected: p.len(), got: q.len() });
    }
    let norm = |h: &[f64], name: &'static str| -> Result<Vec<f64>> {
        if let Some(k) = h.iter().position(|v| !v.is_finite() || *v < 0.0) {
            return Err(ChaosError::BadParameter {
                name,
                value: h[k],
                reason: "histogram entries must be finite and >= 0",
            });
        }
        let s: f64 = h.iter().sum();
        if s <= 0.0 {
            return Err(ChaosError::BadParameter { name, value: s, reason: "histogram is empty" });
        }
        Ok(h.iter().map(|v| v / s).collect())
    };
    let (p, q) = (norm(p, "p")?, norm(q, "q")?);
    // sum over bins of  p/2 log2(2p/(p+q)) + q/2 log2(2q/(p+q)), empty terms dropped.
    let term = |a: f64, m: f64| if a > 0.0 { a * (a / m).log2() } else { 0.0 };
    let js: f64 = p
        .iter()
        .zip(&q)
        .map(|(&a, &b)| {
            let m = 0.5 * (a + b);
            0.5 * (term(a, m) + term(b, m))
        })
        .sum();
    Ok(js.clamp(0.0, 1.0))
}

fn quantile_sorted(v: &[f64], q: f64) -> f64 {
    let pos = q * (v.len() - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = pos.ceil() as usize;
    v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
}

fn bin_count(pooled: &mut [f64], n_small: usize, range: f64, rule: Bins) -> Result<usize> {
    match rule {
        Bins::Fixed(n) => {
            at_least("bins", n, 1)?;
            Ok(n)
        }
        Bins::FreedmanDiaconis { min, max } => {
            at_least("bins min", min, 1)?;
            if max < min {
                return Err(ChaosError::BadParameter { name: "bins max", value: max as f64, reason: "below bins min" });
            }
            pooled.sort_by(f64::total_cmp);
            let iqr = quantile_sorted(pooled, 0.75) - quantile_sorted(pooled, 0.25);
            let cube = (n_small as f64).cbrt();
            let n = if iqr > 0.0 { (range / (2.0 * iqr / cube)).ceil() } else { (2.0 * cube).ceil() };
            Ok((n as usize).clamp(min, max))
        }
    }
}

fn densities(x: &[f64], lo: f64, width: f64, bins: usize) -> Vec<f64> {
    let mut h = vec![0.0; bins];
    for &v in x {
        let k = (((v - lo) / width) as usize).min(bins - 1);
        h[k] += 1.0;
    }
    let norm = x.len() as f64 * width;
    h.iter_mut().for_each(|c| *c /= norm);
    h
}

/// Per-coordinate PDFs of `data` and `model` on common grids, and their divergences.
pub fn compare_pdfs(data: &Points, model: &Points, bins: Bins) -> Result<PdfComparison> {
    if data.dim() != model.dim() {
        return Err(ChaosError::Shape { what: "model dimension", expected: data.dim(), got: model.dim() });
    }
    for (name, p) in [("data", data), ("model", model)] {
        if p.len() < 2 {
            return Err(ChaosError::TooShort { param: name, have: p.len(), need: 2 });
        }
    }
    let mut coords = Vec::with_capacity(data.dim());
    for c in 0..data.dim() {
        let a = data.column(c);
        let b = model.column(c);
        let lo = a.iter().chain(&b).copied().fold(f64::INFINITY, f64::min);
        let hi = a.iter().chain(&b).copied().fold(f64::NEG_INFINITY, f64::max);
        if hi <= lo {
            return Err(ChaosError::ZeroVariance { coord: c, value: lo });
        }
        let mut pooled: Vec<f64> = a.iter().chain(&b).copied().collect();
        let n = bin_count(&mut pooled, a.len().min(b.len()), hi - lo, bins)?;
        let width = (hi - lo) / n as f64;
        let edges: Vec<f64> = (0..=n).map(|k| if k == n { hi } else { lo + k as f64 * width }).collect();
        let centers: Vec<f64> = (0..n).map(|k| lo + (k as f64 + 0.5) * width).collect();
        let pd = densities(&a, lo, width, n);
        let pm = densities(&b, lo, width, n);
        let js_bits = jensen_shannon_bits(&pd, &pm)?;
        let l1 = pd.iter().zip(&pm).map(|(x, y)| (x - y).abs() * width).sum();
        coords.push(CoordinatePdf { coord: c, edges, centers, data_density: pd, model_density: pm, js_bits, l1 });
    }
    let mean_js_bits = coords.iter().map(|c| c.js_bits).sum::<f64>() / coords.len() as f64;
    let max_js_bits = coords.iter().map(|c| c.js_bits).fold(0.0, f64::max);
    Ok(PdfComparison { coords, mean_js_bits, max_js_bits })
}
