//! Stability chart of the sampled-data delayed loop in the plane of the gains (KP, KD),
//! like the paper's figure 2.
//!
//! For each sampling period the chart
//! - classifies a grid of (KP, KD) points by the spectral radius of the non-structural
//!   closed-loop multipliers ([`crate::linear::ClosedLoopMap::dominant_multipliers`]) and
//!   shades the stable ones;
//! - draws the D-curves, where a multiplier lies on the unit circle: the static boundary
//!   (a real multiplier at +1), the flip boundary (a real multiplier at -1) and the dynamic
//!   boundary (a complex pair at `e^{+-i w}`). Because the gains enter the one-period map
//!   through a rank-one term, `det(M(KP, KD) - lambda I)` is affine in (KP, KD), so each
//!   curve point is the solution of a 2x2 (or, for lambda = +-1, 1x2) linear system;
//! - marks the base configuration's gains (the paper's point (15.5, 5.45)).
//!
//! Other gains (KphiD, KI), the delay and the plant come from the caller; this module
//! owns no plant and never simulates.

use std::time::Instant;

use nalgebra::{Complex, DMatrix, SMatrix, SVector};
use rayon::prelude::*;
use serde::Serialize;
use shared::ControllerConfig;

use crate::linear::{LinearError, LinearPlant, Zoh, eigenvalues};

/// The chart's steps (D-curves, clipping, crossing kinds, the gains setter), public only for the
/// crate's tests (`tests/chart.rs`): not part of the API.
#[doc(hidden)]
pub mod internals {
    pub use super::{affine_det, clip_polyline, d_curves, kind_of, set_primary};
}

/// Why a chart could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ChartError {
    #[error(transparent)]
    Linear(#[from] LinearError),
    #[error("{axis} axis: {reason}")]
    BadAxis { axis: String, reason: String },
    #[error("no sampling periods given")]
    NoPeriods,
    #[error("{0} sampling periods (panels); a chart has at most {MAX_PANELS}")]
    TooManyPanels(usize),
    #[error("sampling period {0} s must be finite and > 0")]
    BadPeriod(f64),
    #[error("panel at dt = {dt:e} s: {source}")]
    Period { dt: f64, source: LinearError },
}

/// Most panels (sampling periods) of one chart: each is a figure panel and a full grid.
pub const MAX_PANELS: usize = 64;

/// A grid axis: `n` points evenly from `lo` to `hi` inclusive.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
pub struct Axis {
    pub lo: f64,
    pub hi: f64,
    pub n: usize,
}

impl Axis {
    /// The axis if its bounds are finite and ordered and it has 2 ..= 4000 points; else an
    /// error naming `axis`.
    pub fn check(self, axis: &str) -> Result<Self, ChartError> {
        let bad = |reason: String| Err(ChartError::BadAxis { axis: axis.into(), reason });
        if !(self.lo.is_finite() && self.hi.is_finite()) {
            return bad(format!("bounds {} .. {} must be finite", self.lo, self.hi));
        }
        if self.lo >= self.hi {
            return bad(format!("lower bound {} must be below upper bound {}", self.lo, self.hi));
        }
        if !(2..=4000).contains(&self.n) {
            return bad(format!("{} points; need 2 ..= 4000", self.n));
        }
        Ok(self)
    }

    /// The j-th grid value.
    pub fn at(&self, j: usize) -> f64 {
        self.lo + (self.hi - self.lo) * j as f64 / (self.n - 1) as f64
    }

    /// Grid spacing.
    pub fn step(&self) -> f64 {
        (self.hi - self.lo) / (self.n - 1) as f64
    }
}

impl From<(f64, f64, usize)> for Axis {
    fn from((lo, hi, n): (f64, f64, usize)) -> Self {
        Self { lo, hi, n }
    }
}

/// How stability is lost across a boundary.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Crossing {
    /// A real multiplier through +1 (a real eigenvalue through 0 in continuous time).
    Static,
    /// A complex pair through the unit circle (Neimark-Sacker / Hopf).
    Dynamic,
    /// A real multiplier through -1 (period doubling).
    Flip,
}

/// A D-curve piece inside the chart window: gains where a multiplier is on the unit circle.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Curve {
    pub kind: Crossing,
    /// (KP, KD) points in order along the curve.
    pub points: Vec<(f64, f64)>,
    /// Frequency `arg(mu) / (2 pi dt)` of the multiplier on the circle at each point, Hz.
    pub freq_hz: Vec<f64>,
}

impl Curve {
    fn from_clipped(kind: Crossing, pts: Vec<(f64, f64, f64)>) -> Self {
        let (points, freq_hz) = pts.into_iter().map(|(x, y, f)| ((x, y), f)).unzip();
        Self { kind, points, freq_hz }
    }
}

/// Everything computed for one sampling period.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    pub dt_s: f64,
    /// Spectral radius of the non-structural multipliers at `(kp.at(j), kd.at(i))`,
    /// stored at `i * kp.n + j`.
    pub radius: Vec<f64>,
    /// How the largest multiplier outside the unit circle sits (None where stable).
    pub unstable_kind: Vec<Option<Crossing>>,
    pub curves: Vec<Curve>,
    pub summary: PanelSummary,
}

/// Numbers of one panel, for reports and tests.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PanelSummary {
    pub dt_s: f64,
    pub grid_points: usize,
    pub stable_points: usize,
    /// Stable points / grid points.
    pub stable_fraction: f64,
    /// Smallest and largest KP (V/rad) among stable grid points.
    pub kp_range: Option<(f64, f64)>,
    /// Smallest and largest KD (V s/rad) among stable grid points.
    pub kd_range: Option<(f64, f64)>,
    /// Grid point with the smallest spectral radius: (KP, KD, radius).
    pub most_stable: (f64, f64, f64),
    /// Spectral radius at the base configuration's gains (not necessarily a grid point).
    pub base_radius: f64,
    /// Stable grid points whose unstable 4-neighbour loses stability statically,
    /// dynamically, by flip.
    pub edge_static: usize,
    pub edge_dynamic: usize,
    pub edge_flip: usize,
}

/// A computed chart (all panels), ready to draw. `kp` and `kd` are the first and second
/// axis: the primary coordinate's P and D gains unless `names` says otherwise.
#[derive(Debug, Clone, PartialEq)]
pub struct Chart {
    pub kp: Axis,
    pub kd: Axis,
    pub base: ControllerConfig,
    pub panels: Vec<Panel>,
    /// The names of the two axes (`theta.p`, `plant.parameters.m`, ...); `None` for the
    /// classic (KP, KD) chart.
    pub names: Option<[String; 2]>,
    /// The scene's own values on the two axes (the marked point); `None`: the base
    /// configuration's shorthand (KP, KD).
    pub base_point: Option<(f64, f64)>,
}

/// Sets the two axis values in a controller configuration (gain axes only: the
/// closed-loop map is then affine in them, which the D-curves use).
pub type SetGains<'a> = &'a (dyn Fn(&mut ControllerConfig, f64, f64) + Sync);

#[doc(hidden)]
pub fn set_primary(c: &mut ControllerConfig, p: f64, d: f64) {
    *c = c.with_primary(p, d);
}

/// Number of frequency samples of the dynamic D-curve before adaptive refinement.
const CURVE_SAMPLES: usize = 1500;

/// Compute the chart: for each `dts_s`, the stability of every grid point and the
/// D-curves. The base configuration supplies KphiD, KI and the delay; its kp, kd, dt are
/// replaced by the grid values and each period in turn (its gains are the marked point).
pub fn compute_chart(
    plant: &LinearPlant,
    base: &ControllerConfig,
    dts_s: &[f64],
    kp: Axis,
    kd: Axis,
) -> Result<Chart, ChartError> {
    compute_chart_with(plant, base, dts_s, (kp, "KP"), (kd, "KD"), &set_primary)
}

/// [`compute_chart`] over any two gains: `set` puts the axis values into a configuration,
/// the names label errors.
pub fn compute_chart_with(
    plant: &LinearPlant,
    base: &ControllerConfig,
    dts_s: &[f64],
    (kp, x_name): (Axis, &str),
    (kd, y_name): (Axis, &str),
    set: SetGains<'_>,
) -> Result<Chart, ChartError> {
    let kp = kp.check(x_name)?;
    let kd = kd.check(y_name)?;
    if dts_s.is_empty() {
        return Err(ChartError::NoPeriods);
    }
    if dts_s.len() > MAX_PANELS {
        return Err(ChartError::TooManyPanels(dts_s.len()));
    }
    if let Some(&dt) = dts_s.iter().find(|dt| !(dt.is_finite() && **dt > 0.0)) {
        return Err(ChartError::BadPeriod(dt));
    }
    // Panels in parallel, collected in input order; the first error in that order wins.
    let panels: Vec<Result<Panel, ChartError>> =
        dts_s.par_iter().map(|&dt| compute_panel(plant, base, dt, kp, kd, set)).collect();
    let panels = panels.into_iter().collect::<Result<Vec<_>, _>>()?;
    Ok(Chart { kp, kd, base: *base, panels, names: None, base_point: None })
}

/// Spectral radius of the non-structural multipliers and, if it exceeds 1, the kind of
/// the largest one: one grid point of a chart.
pub fn classify(zoh: &Zoh, cfg: &ControllerConfig) -> Result<(f64, Option<Crossing>), LinearError> {
    let m = loop_matrix(zoh, cfg, true)?;
    let ev = eigenvalues(&m)?;
    let top = ev.iter().copied().max_by(|a, b| a.norm().total_cmp(&b.norm()));
    let Some(top) = top else { return Ok((0.0, None)) };
    let radius = top.norm();
    let kind = (radius >= 1.0).then(|| kind_of(top));
    Ok((radius, kind))
}

/// The closed-loop map without its structural multiplier 1 when `deflate` and the loop has
/// one (a cyclic, unstiffened secondary coordinate), else the whole map.
fn loop_matrix(zoh: &Zoh, cfg: &ControllerConfig, deflate: bool) -> Result<DMatrix<f64>, LinearError> {
    let map = zoh.closed_loop(cfg)?;
    if !deflate {
        return Ok(map.matrix.clone());
    }
    match map.deflated() {
        Err(LinearError::SecondaryCouples { .. } | LinearError::SecondaryControlled { .. }) => Ok(map.matrix.clone()),
        other => other,
    }
}

#[doc(hidden)]
pub fn kind_of(mu: Complex<f64>) -> Crossing {
    if mu.im.abs() > 1e-12 * mu.norm() {
        Crossing::Dynamic
    } else if mu.re > 0.0 {
        Crossing::Static
    } else {
        Crossing::Flip
    }
}

/// A panel from grid points computed elsewhere (a sharded sweep: `points[i * kp.n + j]` is
/// [`classify`] at `(kp.at(j), kd.at(i))`): the D-curves, the base radius and the summary
/// are computed here, as [`compute_chart`] computes them.
pub fn assemble_panel(
    plant: &LinearPlant,
    base: &ControllerConfig,
    dt: f64,
    kp: Axis,
    kd: Axis,
    points: &[(f64, Option<Crossing>)],
) -> Result<Panel, ChartError> {
    assemble_panel_with(plant, base, dt, (kp, "KP"), (kd, "KD"), points, &set_primary)
}

/// [`assemble_panel`] over any two gains: `set` puts the axis values into a configuration,
/// the names label errors.
pub fn assemble_panel_with(
    plant: &LinearPlant,
    base: &ControllerConfig,
    dt: f64,
    (kp, x_name): (Axis, &str),
    (kd, y_name): (Axis, &str),
    points: &[(f64, Option<Crossing>)],
    set: SetGains<'_>,
) -> Result<Panel, ChartError> {
    let kp = kp.check(x_name)?;
    let kd = kd.check(y_name)?;
    if !(dt.is_finite() && dt > 0.0) {
        return Err(ChartError::BadPeriod(dt));
    }
    if points.len() != kp.n * kd.n {
        return Err(ChartError::BadAxis {
            axis: format!("{x_name} x {y_name}"),
            reason: format!("{} points given for a {} x {} grid", points.len(), kp.n, kd.n),
        });
    }
    let zoh = plant.discretize(dt).map_err(|source| ChartError::Period { dt, source })?;
    let (radius, unstable_kind): (Vec<f64>, Vec<Option<Crossing>>) = points.iter().copied().unzip();
    let (base_radius, _) = classify(&zoh, &ControllerConfig { dt, ..*base })?;
    let curves = d_curves(&zoh, base, kp, kd, set)?;
    let summary = summarize(dt, kp, kd, &radius, &unstable_kind, base_radius);
    Ok(Panel { dt_s: dt, radius, unstable_kind, curves, summary })
}

fn compute_panel(
    plant: &LinearPlant,
    base: &ControllerConfig,
    dt: f64,
    kp: Axis,
    kd: Axis,
    set: SetGains<'_>,
) -> Result<Panel, ChartError> {
    let zoh = plant.discretize(dt).map_err(|source| ChartError::Period { dt, source })?;
    let n = kp.n * kd.n;
    // Grid rows (one KD each) in parallel with the D-curves; every point is computed
    // alone, and the rows are put together in order, so the result is the serial one.
    let row = |i: usize| -> Result<Vec<(f64, Option<Crossing>)>, LinearError> {
        (0..kp.n)
            .map(|j| {
                let mut c = ControllerConfig { dt, ..*base };
                set(&mut c, kp.at(j), kd.at(i));
                classify(&zoh, &c)
            })
            .collect()
    };
    let (rows, curves) =
        rayon::join(|| (0..kd.n).into_par_iter().map(row).collect::<Vec<_>>(), || d_curves(&zoh, base, kp, kd, set));
    let mut radius = Vec::with_capacity(n);
    let mut unstable_kind = Vec::with_capacity(n);
    for r in rows {
        for (r, k) in r? {
            radius.push(r);
            unstable_kind.push(k);
        }
    }
    let (base_radius, _) = classify(&zoh, &ControllerConfig { dt, ..*base })?;
    let curves = curves?;
    let summary = summarize(dt, kp, kd, &radius, &unstable_kind, base_radius);
    Ok(Panel { dt_s: dt, radius, unstable_kind, curves, summary })
}

pub(crate) fn summarize(
    dt: f64,
    kp: Axis,
    kd: Axis,
    radius: &[f64],
    kinds: &[Option<Crossing>],
    base_radius: f64,
) -> PanelSummary {
    let stable = |i: usize, j: usize| radius[i * kp.n + j] < 1.0;
    let mut s = PanelSummary {
        dt_s: dt,
        grid_points: radius.len(),
        stable_points: 0,
        stable_fraction: 0.0,
        kp_range: None,
        kd_range: None,
        most_stable: (kp.lo, kd.lo, f64::INFINITY),
        base_radius,
        edge_static: 0,
        edge_dynamic: 0,
        edge_flip: 0,
    };
    let widen = |r: Option<(f64, f64)>, v: f64| Some(r.map_or((v, v), |(a, b)| (a.min(v), b.max(v))));
    for i in 0..kd.n {
        for j in 0..kp.n {
            let r = radius[i * kp.n + j];
            if r < s.most_stable.2 {
                s.most_stable = (kp.at(j), kd.at(i), r);
            }
            if !stable(i, j) {
                continue;
            }
            s.stable_points += 1;
            s.kp_range = widen(s.kp_range, kp.at(j));
            s.kd_range = widen(s.kd_range, kd.at(i));
            let neighbours = [
                (i.checked_sub(1), Some(j)),
                ((i + 1 < kd.n).then_some(i + 1), Some(j)),
                (Some(i), j.checked_sub(1)),
                (Some(i), (j + 1 < kp.n).then_some(j + 1)),
            ];
            let mut seen = [false; 3];
            for (ni, nj) in neighbours {
                let (Some(ni), Some(nj)) = (ni, nj) else { continue };
                match kinds[ni * kp.n + nj] {
                    Some(Crossing::Static) => seen[0] = true,
                    Some(Crossing::Dynamic) => seen[1] = true,
                    Some(Crossing::Flip) => seen[2] = true,
                    None => {}
                }
            }
            s.edge_static += usize::from(seen[0]);
            s.edge_dynamic += usize::from(seen[1]);
            s.edge_flip += usize::from(seen[2]);
        }
    }
    s.stable_fraction = s.stable_points as f64 / radius.len() as f64;
    s
}

/// `det(R(kp, kd) - lambda I)` of the deflated map as the affine function
/// `f0 + fa*kp + fb*kd`: returns `(f0, fa, fb)`.
#[doc(hidden)]
pub fn affine_det(
    zoh: &Zoh,
    base: &ControllerConfig,
    lambda: Complex<f64>,
    kp_span: f64,
    kd_span: f64,
    set: SetGains<'_>,
    deflate: bool,
) -> Result<(Complex<f64>, Complex<f64>, Complex<f64>), LinearError> {
    let at = |kp: f64, kd: f64| gains_at(zoh, base, set, kp, kd);
    let det = |kp: f64, kd: f64| -> Result<Complex<f64>, LinearError> {
        let r = loop_matrix(zoh, &at(kp, kd), deflate)?;
        let n = r.nrows();
        let c = DMatrix::<Complex<f64>>::from_fn(n, n, |i, j| {
            Complex::new(r[(i, j)], 0.0) - if i == j { lambda } else { Complex::new(0.0, 0.0) }
        });
        Ok(c.determinant())
    };
    let f0 = det(0.0, 0.0)?;
    let fa = (det(kp_span, 0.0)? - f0) / kp_span;
    let fb = (det(0.0, kd_span)? - f0) / kd_span;
    Ok((f0, fa, fb))
}

fn gains_at(zoh: &Zoh, base: &ControllerConfig, set: SetGains<'_>, kp: f64, kd: f64) -> ControllerConfig {
    let mut c = ControllerConfig { dt: zoh.dt, ..*base };
    set(&mut c, kp, kd);
    c
}

/// The D-curves inside the window `kp x kd`.
#[doc(hidden)]
pub fn d_curves(
    zoh: &Zoh,
    base: &ControllerConfig,
    kp: Axis,
    kd: Axis,
    set: SetGains<'_>,
) -> Result<Vec<Curve>, LinearError> {
    let (w, h) = (kp.hi - kp.lo, kd.hi - kd.lo);
    let mut curves = Vec::new();
    // Deflate the maps at the three points of the affine fit all or none, so that their
    // determinants are of one affine family.
    let mut deflate = true;
    for (p, d) in [(0.0, 0.0), (w, 0.0), (0.0, h)] {
        match zoh.closed_loop(&gains_at(zoh, base, set, p, d))?.deflated() {
            Ok(_) => {}
            Err(LinearError::SecondaryCouples { .. } | LinearError::SecondaryControlled { .. }) => deflate = false,
            Err(e) => return Err(e),
        }
    }
    // Real multipliers +1 and -1: one real equation, a straight line.
    let nyquist = 0.5 / zoh.dt;
    for (lambda, kind, f) in [(1.0, Crossing::Static, 0.0), (-1.0, Crossing::Flip, nyquist)] {
        let (f0, fa, fb) = affine_det(zoh, base, Complex::new(lambda, 0.0), w, h, set, deflate)?;
        let (f0, fa, fb) = (f0.re, fa.re, fb.re);
        // Parametrize by the coordinate with the smaller coefficient (weighted by span).
        let line: Vec<(f64, f64, f64)> = if (fa * w).abs() >= (fb * h).abs() {
            if fa == 0.0 {
                continue;
            }
            (0..=200).map(|k| kd.lo - h + 3.0 * h * k as f64 / 200.0).map(|d| ((-f0 - fb * d) / fa, d, f)).collect()
        } else {
            (0..=200).map(|k| kp.lo - w + 3.0 * w * k as f64 / 200.0).map(|p| (p, (-f0 - fa * p) / fb, f)).collect()
        };
        curves.extend(clip_polyline(&line, kp, kd).into_iter().map(|pts| Curve::from_clipped(kind, pts)));
    }
    // Complex pair e^{+-iw}: two real equations.
    let solve = |omega: f64| -> Result<Option<(f64, f64)>, LinearError> {
        let (f0, fa, fb) = affine_det(zoh, base, Complex::from_polar(1.0, omega), w, h, set, deflate)?;
        let det = fa.re * fb.im - fb.re * fa.im;
        if det == 0.0 {
            return Ok(None);
        }
        let p = (-f0.re * fb.im + fb.re * f0.im) / det;
        let d = (-fa.re * f0.im + fa.im * f0.re) / det;
        Ok((p.is_finite() && d.is_finite()).then_some((p, d)))
    };
    let pi = std::f64::consts::PI;
    let mut samples: Vec<(f64, Option<(f64, f64)>)> = Vec::with_capacity(CURVE_SAMPLES);
    for k in 1..CURVE_SAMPLES {
        let omega = pi * k as f64 / CURVE_SAMPLES as f64;
        samples.push((omega, solve(omega)?));
    }
    // Refine where consecutive points inside the (extended) window are far apart.
    let near = |p: (f64, f64)| p.0 > kp.lo - w && p.0 < kp.hi + w && p.1 > kd.lo - h && p.1 < kd.hi + h;
    let far = |a: (f64, f64), b: (f64, f64)| ((a.0 - b.0) / w).hypot((a.1 - b.1) / h) > 0.004;
    for _ in 0..12 {
        let mut refined = Vec::with_capacity(samples.len());
        let mut changed = false;
        for pair in samples.windows(2) {
            refined.push(pair[0]);
            if let ((o0, Some(a)), (o1, Some(b))) = (pair[0], pair[1]) {
                if (near(a) || near(b)) && far(a, b) {
                    let om = 0.5 * (o0 + o1);
                    refined.push((om, solve(om)?));
                    changed = true;
                }
            }
        }
        if let Some(last) = samples.last() {
            refined.push(*last);
        }
        samples = refined;
        if !changed || samples.len() > 200_000 {
            break;
        }
    }
    // Split at gaps (unsolvable frequencies) and at jumps still left (poles).
    let hz = 1.0 / (2.0 * pi * zoh.dt);
    let mut piece: Vec<(f64, f64, f64)> = Vec::new();
    let mut pieces = Vec::new();
    for (omega, p) in samples {
        match p {
            Some(p) if piece.last().is_none_or(|&(qx, qy, _)| !far(p, (qx, qy)) || !(near(p) || near((qx, qy)))) => {
                piece.push((p.0, p.1, omega * hz))
            }
            Some(p) => pieces.push(std::mem::replace(&mut piece, vec![(p.0, p.1, omega * hz)])),
            None => pieces.push(std::mem::take(&mut piece)),
        }
    }
    pieces.push(piece);
    for piece in pieces {
        curves.extend(clip_polyline(&piece, kp, kd).into_iter().map(|pts| Curve::from_clipped(Crossing::Dynamic, pts)));
    }
    Ok(curves)
}

/// Clip a polyline `(KP, KD, attribute)` to the window; returns the pieces inside (each
/// with >= 2 points), the attribute interpolated linearly at cut points.
#[doc(hidden)]
pub fn clip_polyline(line: &[(f64, f64, f64)], kp: Axis, kd: Axis) -> Vec<Vec<(f64, f64, f64)>> {
    let mut out: Vec<Vec<(f64, f64, f64)>> = Vec::new();
    let mut cur: Vec<(f64, f64, f64)> = Vec::new();
    for seg in line.windows(2) {
        match clip_segment(seg[0], seg[1], kp, kd) {
            Some((a, b)) => {
                if cur.last() != Some(&a) {
                    if cur.len() >= 2 {
                        out.push(std::mem::take(&mut cur));
                    }
                    cur.clear();
                    cur.push(a);
                }
                cur.push(b);
            }
            None => {
                if cur.len() >= 2 {
                    out.push(std::mem::take(&mut cur));
                }
                cur.clear();
            }
        }
    }
    if cur.len() >= 2 {
        out.push(cur);
    }
    out
}

/// Liang-Barsky clipping of the segment a-b to the window.
type P3 = (f64, f64, f64);
fn clip_segment(a: P3, b: P3, kp: Axis, kd: Axis) -> Option<(P3, P3)> {
    let (dx, dy, dz) = (b.0 - a.0, b.1 - a.1, b.2 - a.2);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-dx, a.0 - kp.lo), (dx, kp.hi - a.0), (-dy, a.1 - kd.lo), (dy, kd.hi - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    let at = |t: f64| (a.0 + t * dx, a.1 + t * dy, a.2 + t * dz);
    (t0 <= t1).then(|| (at(t0), at(t1)))
}

/// Compute the chart for the plant `x' = A x + B u` (controller reads `x[primary]`,
/// `x[secondary]`): one panel per sampling period. Returns the chart and the wall time of
/// its computation in seconds.
#[allow(clippy::too_many_arguments)]
pub fn plant_chart<const N: usize>(
    a: &SMatrix<f64, N, N>,
    b: &SVector<f64, N>,
    primary: usize,
    secondary: usize,
    base: &ControllerConfig,
    dts_s: &[f64],
    kp: (f64, f64, usize),
    kd: (f64, f64, usize),
) -> Result<(Chart, f64), ChartError> {
    let plant = LinearPlant::new(a, b, primary, secondary)?;
    let t0 = Instant::now();
    let chart = compute_chart(&plant, base, dts_s, kp.into(), kd.into())?;
    Ok((chart, t0.elapsed().as_secs_f64()))
}
