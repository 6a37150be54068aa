//! Phase portraits of the polar amplitude equations of a two-mode normal form (paper section
//! 3.1, figure "phasePortraits1"): fixed points, their stability, the invariant manifolds of
//! saddles, periodic orbits, and the two bifurcations the paper reads off the portraits as
//! the sampling time `dt` varies (the heteroclinic connection of the saddle cycles and the
//! Hopf bifurcation of the 2-torus).
//!
//! # The amplitude system
//!
//! [`PolarNormalForm`] with `modes = 2` gives `rho_i' = rho_i g_i(P)`, `P_j = rho_j^2`,
//! `g_i(P) = sum_k amp[i][k] P^pexps[k]`, and `theta_i' = Omega_i(P)`. The quadrant
//! `rho_1, rho_2 >= 0` is invariant, so are both axes. In the full system
//! * the origin is the equilibrium ([`PointKind::Equilibrium`]),
//! * a fixed point `(rho_1*, 0)` or `(0, rho_2*)` is a limit cycle of mode 1 or 2
//!   ([`PointKind::LimitCycle`]),
//! * an interior fixed point is a 2-torus ([`PointKind::Torus2`]),
//! * a periodic orbit of the amplitude system is a 3-torus ([`PeriodicOrbit`]).
//!
//! The Jacobian is analytic: `J_ij = delta_ij g_i + 2 rho_i rho_j dg_i/dP_j`. On an axis it
//! is diagonal, so the invariant manifolds of axis saddles start exactly along the axes.
//!
//! # Algorithm
//!
//! * Fixed points ([`fixed_points`]): the origin; on axis `i` the roots of
//!   `r -> g_i(P_i = r^2, P_other = 0)` on `(0, rho_max_i]`, bracketed on a uniform grid of
//!   [`PortraitOptions::axis_samples`] points and refined by bisection to machine precision
//!   (a root where `g_i` only touches zero, a non-hyperbolic double root, is not bracketed
//!   and therefore not reported); interior points by damped Newton on `g(P) = 0` in
//!   `P`-space from a `grid x grid` lattice of starts in the box, deduplicated at
//!   [`PortraitOptions::dedup_tol`]. Points on the box edge are kept (relative slack 1e-9).
//! * Manifolds of saddles ([`Portrait::manifolds`]): from `p +- eps v` (`v` the unit
//!   eigenvector, `eps` = [`PortraitOptions::manifold_eps`]) integrated forward (unstable)
//!   or backward (stable) with an adaptive Dormand-Prince 5(4) scheme. A start outside the
//!   quadrant is skipped (that half-branch does not exist for amplitudes). Each branch ends
//!   with a [`Fate`]: within `converge_tol` of a non-saddle fixed point (converges), of a
//!   saddle (approaches it: a connection along an axis, or a near-heteroclinic passage),
//!   leaving the box (the polyline is cut at the box edge), or the time/step limit.
//! * Periodic orbits: for every interior non-saddle fixed point `c` the return map on the
//!   ray from `c` straight down to the `rho_1` axis (it is bounded by invariant axes, so it
//!   cuts every periodic orbit that encircles `c`). A return is the first time the unwrapped
//!   polar angle around `c` reaches `+-2 pi`; the crossing is located inside the step by
//!   bisection on a re-integrated Dormand-Prince step. `D(s) = R(s) - s` is sampled on
//!   [`PortraitOptions::ray_samples`] uniform points plus geometric refinements towards both
//!   ends of the ray (`1 - 10^-k`, `k = 3..=12`, and `10^-k`, `k = 3..=6`, of its length);
//!   every sign change between two points with a defined return, or between a point with a
//!   return and the edge of the returning set next to it (bisection on "returns"), is
//!   refined by bisection. The multiplier `R'(s*)` (central difference)
//!   gives the stability of the orbit.

// Index loops mirror the 2x2 formulas.
#![allow(clippy::needless_range_loop)]

use std::f64::consts::{PI, TAU};

use serde::{Deserialize, Serialize};
use thiserror::Error;

use super::normal_form::PolarNormalForm;

/// Errors of the portrait analysis and the bifurcation scans.
#[derive(Debug, Error)]
pub enum PortraitError {
    #[error("phase portrait needs a 2-mode normal form, got {0} modes")]
    Modes(usize),
    #[error("normal form shape: {0}")]
    Shape(String),
    #[error("normal form coefficient {what} is not finite ({value})")]
    NonFinite { what: String, value: f64 },
    #[error("bad box rho_max = [{0}, {1}]: extents must be finite and positive")]
    BadBox(f64, f64),
    #[error("bad option {name} = {value}: {why}")]
    BadOption { name: &'static str, value: f64, why: &'static str },
    #[error("bad parameter range [{lo}, {hi}] ms: {why}")]
    BadRange { lo: f64, hi: f64, why: &'static str },
    #[error("normal form at dt = {dt} ms: {message}")]
    NormalForm { dt: f64, message: String },
    #[error("no interior fixed point (2-torus) in the box at dt = {dt} ms")]
    NoTorus { dt: f64 },
    #[error("no saddle-type limit cycle with an interior unstable branch in the box at dt = {dt} ms")]
    NoSaddle { dt: f64 },
}

/// Options of [`portrait`] (and of the scans, through [`ScanOptions::portrait`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PortraitOptions {
    /// The box `[0, rho_max[0]] x [0, rho_max[1]]` (amplitudes of mode 1 and mode 2).
    pub rho_max: [f64; 2],
    /// Grid of the 1D root bracketing on each axis.
    pub axis_samples: usize,
    /// Newton starts per direction for interior fixed points (`grid x grid`).
    pub grid: usize,
    /// Two fixed points closer than this (in rho) are the same.
    pub dedup_tol: f64,
    /// Offset of manifold starts from the saddle, along the unit eigenvector.
    pub manifold_eps: f64,
    /// Distance to a fixed point counted as reaching it (must be below `manifold_eps`).
    pub converge_tol: f64,
    /// Time limit of one integration (s).
    pub t_max: f64,
    /// Time limit of the grey sample trajectories (s).
    pub t_flow: f64,
    /// Relative and absolute tolerances of the adaptive integrator.
    pub rtol: f64,
    pub atol: f64,
    /// Largest step (s); also the resolution of the stored polylines.
    pub max_step: f64,
    /// Step cap of one integration.
    pub max_steps: usize,
    /// Sample points of the Poincare return map on the ray (0 disables the orbit search).
    pub ray_samples: usize,
    /// Sample trajectories per direction for the plot (`flow_grid x flow_grid`).
    pub flow_grid: usize,
}

impl Default for PortraitOptions {
    fn default() -> Self {
        PortraitOptions {
            rho_max: [1.0, 1.0],
            axis_samples: 4000,
            grid: 24,
            dedup_tol: 1e-7,
            manifold_eps: 1e-6,
            converge_tol: 1e-8,
            t_max: 5000.0,
            t_flow: 300.0,
            rtol: 1e-10,
            atol: 1e-13,
            max_step: 0.5,
            max_steps: 200_000,
            ray_samples: 48,
            flow_grid: 5,
        }
    }
}

/// What a fixed point of the amplitude system is in the full system.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum PointKind {
    /// The origin: the equilibrium of the full system.
    Equilibrium,
    /// A point on the axis of `mode` (1-based): a limit cycle of that mode.
    LimitCycle { mode: usize },
    /// An interior point: a 2-torus.
    Torus2,
}

/// Linear stability of a fixed point of the amplitude system.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Stability {
    StableNode,
    StableFocus,
    UnstableNode,
    UnstableFocus,
    Saddle,
    /// An eigenvalue with zero real part (within `1e-12` of the Jacobian's scale).
    NonHyperbolic,
}

impl Stability {
    pub fn is_stable(self) -> bool {
        matches!(self, Stability::StableNode | Stability::StableFocus)
    }
}

/// One fixed point of the amplitude equations.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FixedPoint {
    pub rho: [f64; 2],
    pub kind: PointKind,
    /// `J[i][j] = d rho_i' / d rho_j`.
    pub jacobian: [[f64; 2]; 2],
    /// Eigenvalues `(re, im)`; real ones in increasing order, a complex pair with `im > 0` first.
    pub eigenvalues: [(f64, f64); 2],
    /// Unit eigenvectors of the real eigenvalues (same order), `None` for a complex pair.
    pub eigenvectors: Option<[[f64; 2]; 2]>,
    pub stability: Stability,
    /// `theta_i' / (2 pi)` at the point (Hz).
    pub freqs_hz: [f64; 2],
}

/// Which invariant manifold a branch belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Direction {
    Stable,
    Unstable,
}

/// How an integrated branch ends.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Fate {
    /// Came within `converge_tol` of the (non-saddle) fixed point with this index.
    Converges { point: usize },
    /// Came within `converge_tol` of the saddle with this index (a connection).
    ApproachesSaddle { point: usize },
    /// Crossed the box edge at this point.
    LeavesBox { at: (f64, f64) },
    /// Ran for `t_max` seconds.
    TimeLimit,
    /// Hit `max_steps` or a step-size underflow.
    StepLimit,
}

/// A parameter-independent label of a fate (fixed points are named by kind, not index).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum FateClass {
    ConvergesTo(PointKind),
    ApproachesSaddle(PointKind),
    LeavesBox,
    TimeLimit,
    StepLimit,
}

/// One half-branch of a saddle's stable or unstable manifold.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ManifoldBranch {
    /// Index of the saddle in [`Portrait::fixed_points`].
    pub saddle: usize,
    pub direction: Direction,
    /// Unit direction of the start offset from the saddle.
    pub start_dir: [f64; 2],
    /// The branch lies on an invariant axis.
    pub on_axis: bool,
    pub points: Vec<(f64, f64)>,
    pub fate: Fate,
    /// Integration time spent (s, positive also for backward branches).
    pub duration: f64,
    /// Closest approach to each fixed point (same indexing), excluding the first
    /// `10 * manifold_eps` of the own saddle's neighbourhood.
    pub min_distance: Vec<f64>,
}

/// A periodic orbit of the amplitude equations (a 3-torus of the full system).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PeriodicOrbit {
    /// Index of the encircled fixed point.
    pub center: usize,
    /// The crossing of the section ray.
    pub section_point: [f64; 2],
    /// Period (s) of the amplitude oscillation.
    pub period: f64,
    /// `[min, max]` of `rho_1` and of `rho_2` along the orbit.
    pub rho_range: [[f64; 2]; 2],
    /// Derivative of the return map at the fixed point.
    pub multiplier: f64,
    pub stable: bool,
    pub points: Vec<(f64, f64)>,
}

/// A phase portrait.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Portrait {
    pub rho_max: [f64; 2],
    pub fixed_points: Vec<FixedPoint>,
    pub manifolds: Vec<ManifoldBranch>,
    pub orbits: Vec<PeriodicOrbit>,
    /// Sample trajectories from a grid of starts (for the plot).
    pub flow: Vec<Vec<(f64, f64)>>,
}

impl Portrait {
    /// Indices of the fixed points of `kind`.
    pub fn of_kind(&self, kind: PointKind) -> Vec<usize> {
        (0..self.fixed_points.len()).filter(|&i| self.fixed_points[i].kind == kind).collect()
    }

    /// The class of a fate of this portrait.
    pub fn fate_class(&self, fate: &Fate) -> FateClass {
        match *fate {
            Fate::Converges { point } => FateClass::ConvergesTo(self.fixed_points[point].kind),
            Fate::ApproachesSaddle { point } => FateClass::ApproachesSaddle(self.fixed_points[point].kind),
            Fate::LeavesBox { .. } => FateClass::LeavesBox,
            Fate::TimeLimit => FateClass::TimeLimit,
            Fate::StepLimit => FateClass::StepLimit,
        }
    }
}

// ------------------------------------------------------------------------- the field

/// The amplitude field, validated.
#[derive(Clone, Debug)]
#[doc(hidden)]
pub struct Field {
    #[doc(hidden)]
    pub pexps: Vec<[i32; 2]>,
    #[doc(hidden)]
    pub amp: [Vec<f64>; 2],
    #[doc(hidden)]
    pub phase: [Vec<f64>; 2],
    /// The largest exponent of each `P_j` in `pexps` (at most 64).
    top: [usize; 2],
}

/// `P_j^k` for `k = 0..=top[j]` (by `powi`, the value a monomial takes; entries above
/// `top[j]` are unused).
type Powers = [[f64; 65]; 2];

impl Field {
    #[doc(hidden)]
    pub fn new(nf: &PolarNormalForm) -> Result<Self, PortraitError> {
        if nf.modes != 2 {
            return Err(PortraitError::Modes(nf.modes));
        }
        let n = nf.pexps.len();
        if n == 0 {
            return Err(PortraitError::Shape("no monomials (pexps is empty)".into()));
        }
        let mut pexps = Vec::with_capacity(n);
        for (k, e) in nf.pexps.iter().enumerate() {
            if e.len() != 2 {
                return Err(PortraitError::Shape(format!("pexps[{k}] has {} exponents, need 2", e.len())));
            }
            if e.iter().any(|&x| x > 64) {
                return Err(PortraitError::Shape(format!("pexps[{k}] = {e:?}: exponent above 64")));
            }
            pexps.push([e[0] as i32, e[1] as i32]);
        }
        for (name, rows) in [("amp", &nf.amp), ("phase", &nf.phase)] {
            if rows.len() != 2 {
                return Err(PortraitError::Shape(format!("{name} has {} rows, need 2", rows.len())));
            }
            for (i, r) in rows.iter().enumerate() {
                if r.len() != n {
                    return Err(PortraitError::Shape(format!("{name}[{i}] has {} entries, pexps has {n}", r.len())));
                }
                for (k, &v) in r.iter().enumerate() {
                    if !v.is_finite() {
                        return Err(PortraitError::NonFinite {
                            what: format!("{name}[{i}][{k}] (P^{:?})", nf.pexps[k]),
                            value: v,
                        });
                    }
                }
            }
        }
        let top = [0, 1].map(|j| pexps.iter().map(|e: &[i32; 2]| e[j] as usize).max().unwrap_or(0));
        Ok(Field {
            pexps,
            amp: [nf.amp[0].clone(), nf.amp[1].clone()],
            phase: [nf.phase[0].clone(), nf.phase[1].clone()],
            top,
        })
    }

    /// The powers of `P` the monomials use, each computed once (`powi` per monomial gave
    /// the same values: the same call with the same arguments).
    fn powers(&self, p: [f64; 2]) -> Powers {
        let mut pw = [[0.0; 65]; 2];
        for j in 0..2 {
            for (k, v) in pw[j][..=self.top[j]].iter_mut().enumerate() {
                *v = p[j].powi(k as i32);
            }
        }
        pw
    }

    #[doc(hidden)]
    pub fn monos(&self, p: [f64; 2]) -> impl Iterator<Item = f64> + '_ {
        let pw = self.powers(p);
        self.pexps.iter().map(move |e| pw[0][e[0] as usize] * pw[1][e[1] as usize])
    }

    #[doc(hidden)]
    pub fn g(&self, p: [f64; 2]) -> [f64; 2] {
        let mut out = [0.0; 2];
        for (k, m) in self.monos(p).enumerate() {
            out[0] += self.amp[0][k] * m;
            out[1] += self.amp[1][k] * m;
        }
        out
    }

    /// `g` and `dg_i/dP_j`.
    #[doc(hidden)]
    pub fn g_grad(&self, p: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
        let mut g = [0.0; 2];
        let mut d = [[0.0; 2]; 2];
        let pw = self.powers(p);
        for (k, e) in self.pexps.iter().enumerate() {
            let (e0, e1) = (e[0] as usize, e[1] as usize);
            let m = pw[0][e0] * pw[1][e1];
            let d0 = if e0 > 0 { e[0] as f64 * pw[0][e0 - 1] * pw[1][e1] } else { 0.0 };
            let d1 = if e1 > 0 { e[1] as f64 * pw[0][e0] * pw[1][e1 - 1] } else { 0.0 };
            for i in 0..2 {
                g[i] += self.amp[i][k] * m;
                d[i][0] += self.amp[i][k] * d0;
                d[i][1] += self.amp[i][k] * d1;
            }
        }
        (g, d)
    }

    /// Sum of `|amp[i][k] P^k|`: the scale of `g_i` at `P` (for residual tests).
    #[doc(hidden)]
    pub fn g_scale(&self, p: [f64; 2]) -> [f64; 2] {
        let mut out = [0.0; 2];
        for (k, m) in self.monos(p).enumerate() {
            out[0] += (self.amp[0][k] * m).abs();
            out[1] += (self.amp[1][k] * m).abs();
        }
        out
    }

    #[doc(hidden)]
    pub fn f(&self, x: [f64; 2]) -> [f64; 2] {
        let g = self.g([x[0] * x[0], x[1] * x[1]]);
        [x[0] * g[0], x[1] * g[1]]
    }

    #[doc(hidden)]
    pub fn jac(&self, x: [f64; 2]) -> [[f64; 2]; 2] {
        let (g, d) = self.g_grad([x[0] * x[0], x[1] * x[1]]);
        let mut j = [[0.0; 2]; 2];
        for i in 0..2 {
            for k in 0..2 {
                j[i][k] = 2.0 * x[i] * x[k] * d[i][k] + if i == k { g[i] } else { 0.0 };
            }
        }
        j
    }

    #[doc(hidden)]
    pub fn freqs_hz(&self, x: [f64; 2]) -> [f64; 2] {
        let mut out = [0.0; 2];
        for (k, m) in self.monos([x[0] * x[0], x[1] * x[1]]).enumerate() {
            out[0] += self.phase[0][k] * m;
            out[1] += self.phase[1][k] * m;
        }
        [out[0] / TAU, out[1] / TAU]
    }
}

fn check_opts(o: &PortraitOptions) -> Result<(), PortraitError> {
    if !o.rho_max.iter().all(|r| r.is_finite() && *r > 0.0) {
        return Err(PortraitError::BadBox(o.rho_max[0], o.rho_max[1]));
    }
    let pos = |name: &'static str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(PortraitError::BadOption { name, value: v, why: "must be finite and positive" })
        }
    };
    pos("dedup_tol", o.dedup_tol)?;
    pos("manifold_eps", o.manifold_eps)?;
    pos("converge_tol", o.converge_tol)?;
    pos("t_max", o.t_max)?;
    pos("t_flow", o.t_flow)?;
    pos("rtol", o.rtol)?;
    pos("atol", o.atol)?;
    pos("max_step", o.max_step)?;
    if o.converge_tol >= o.manifold_eps {
        return Err(PortraitError::BadOption {
            name: "converge_tol",
            value: o.converge_tol,
            why: "must be below manifold_eps",
        });
    }
    if o.axis_samples < 2 {
        return Err(PortraitError::BadOption {
            name: "axis_samples",
            value: o.axis_samples as f64,
            why: "need at least 2",
        });
    }
    if o.grid < 1 {
        return Err(PortraitError::BadOption { name: "grid", value: 0.0, why: "need at least 1" });
    }
    if o.max_steps < 1 {
        return Err(PortraitError::BadOption { name: "max_steps", value: 0.0, why: "need at least 1" });
    }
    if o.ray_samples == 1 {
        return Err(PortraitError::BadOption { name: "ray_samples", value: 1.0, why: "need 0 (off) or at least 2" });
    }
    Ok(())
}

// -------------------------------------------------------------------- fixed points

/// Eigenvalues, eigenvectors (real case) and stability of a 2x2 Jacobian.
type Classified = ([(f64, f64); 2], Option<[[f64; 2]; 2]>, Stability);

fn classify(j: [[f64; 2]; 2]) -> Classified {
    let (a, b, c, d) = (j[0][0], j[0][1], j[1][0], j[1][1]);
    let tr = a + d;
    let det = a * d - b * c;
    let half = 0.5 * tr;
    // Discriminant written without cancellation for the diagonal-dominant case.
    let disc = 0.25 * (a - d) * (a - d) + b * c;
    let scale = a.abs().max(b.abs()).max(c.abs()).max(d.abs());
    let zero = 1e-12 * scale;
    if disc < 0.0 {
        let im = (-disc).sqrt();
        let st = if half < -zero {
            Stability::StableFocus
        } else if half > zero {
            Stability::UnstableFocus
        } else {
            Stability::NonHyperbolic
        };
        return ([(half, im), (half, -im)], None, st);
    }
    let s = disc.sqrt();
    // Stable product form for the smaller-magnitude root.
    let (l1, l2) = if half >= 0.0 {
        let big = half + s;
        (if big != 0.0 { det / big } else { 0.0 }, big)
    } else {
        let big = half - s;
        (big, if big != 0.0 { det / big } else { 0.0 })
    };
    let (l1, l2) = if l1 <= l2 { (l1, l2) } else { (l2, l1) };
    let vec_for = |l: f64| -> [f64; 2] {
        let u = [b, l - a];
        let w = [l - d, c];
        let nu = u[0].hypot(u[1]);
        let nw = w[0].hypot(w[1]);
        let (v, n) = if nu >= nw { (u, nu) } else { (w, nw) };
        if n == 0.0 {
            return [1.0, 0.0];
        }
        let mut v = [v[0] / n, v[1] / n];
        // Orientation: first nonzero component positive.
        if v[0] < 0.0 || (v[0] == 0.0 && v[1] < 0.0) {
            v = [-v[0], -v[1]];
        }
        v
    };
    let mut v1 = vec_for(l1);
    let v2 = vec_for(l2);
    if l1 == l2 && (v1[0] * v2[1] - v1[1] * v2[0]).abs() < 1e-12 {
        // Repeated eigenvalue of a scalar matrix: any basis.
        v1 = if v2[0].abs() > 0.5 { [0.0, 1.0] } else { [1.0, 0.0] };
    }
    let st = if l1.abs() <= zero || l2.abs() <= zero {
        Stability::NonHyperbolic
    } else if l2 < 0.0 {
        Stability::StableNode
    } else if l1 > 0.0 {
        Stability::UnstableNode
    } else {
        Stability::Saddle
    };
    ([(l1, 0.0), (l2, 0.0)], Some([v1, v2]), st)
}

fn make_point(field: &Field, rho: [f64; 2], kind: PointKind) -> FixedPoint {
    let jacobian = field.jac(rho);
    let (eigenvalues, eigenvectors, stability) = classify(jacobian);
    FixedPoint { rho, kind, jacobian, eigenvalues, eigenvectors, stability, freqs_hz: field.freqs_hz(rho) }
}

fn axis_roots(field: &Field, axis: usize, rmax: f64, n: usize) -> Vec<f64> {
    let h = |r: f64| {
        let mut p = [0.0; 2];
        p[axis] = r * r;
        field.g(p)[axis]
    };
    let mut roots = Vec::new();
    let rs: Vec<f64> = (1..=n).map(|k| rmax * k as f64 / n as f64).collect();
    let hs: Vec<f64> = rs.iter().map(|&r| h(r)).collect();
    for k in 0..n {
        if hs[k] == 0.0 {
            roots.push(rs[k]);
            continue;
        }
        if k + 1 < n && hs[k] * hs[k + 1] < 0.0 {
            let (mut lo, mut hi, mut hlo) = (rs[k], rs[k + 1], hs[k]);
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if mid <= lo || mid >= hi {
                    break;
                }
                let hm = h(mid);
                if hm == 0.0 {
                    lo = mid;
                    hi = mid;
                    break;
                }
                if hm * hlo < 0.0 {
                    hi = mid;
                } else {
                    lo = mid;
                    hlo = hm;
                }
            }
            roots.push(0.5 * (lo + hi));
        }
    }
    // The segment (0, r_1]: a sign change between r -> 0 and the first sample.
    let h0 = field.g([0.0, 0.0])[axis];
    if h0 * hs[0] < 0.0 {
        let (mut lo, mut hi) = (0.0, rs[0]);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if h(mid) * h0 < 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        roots.insert(0, 0.5 * (lo + hi));
    }
    roots
}

fn newton_interior(field: &Field, p0: [f64; 2]) -> Option<[f64; 2]> {
    let mut p = p0;
    let norm = |g: [f64; 2]| g[0].hypot(g[1]);
    let (mut g, mut d) = field.g_grad(p);
    for _ in 0..80 {
        let det = d[0][0] * d[1][1] - d[0][1] * d[1][0];
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let dp = [(d[1][1] * g[0] - d[0][1] * g[1]) / det, (-d[1][0] * g[0] + d[0][0] * g[1]) / det];
        let g_norm = norm(g);
        let mut lam = 1.0;
        let mut accepted = false;
        for _ in 0..40 {
            let q = [p[0] - lam * dp[0], p[1] - lam * dp[1]];
            let gq = field.g(q);
            if norm(gq).is_finite() && norm(gq) < g_norm.max(1e-300) {
                p = q;
                accepted = true;
                break;
            }
            lam *= 0.5;
        }
        let (gn, dn) = field.g_grad(p);
        g = gn;
        d = dn;
        let step = lam * dp[0].hypot(dp[1]);
        if !accepted || step <= 1e-15 * (1.0 + p[0].abs() + p[1].abs()) {
            break;
        }
    }
    let sc = field.g_scale(p);
    let ok = (0..2).all(|i| g[i].abs() <= 1e-9 * sc[i].max(1e-300));
    if ok && p.iter().all(|x| x.is_finite()) { Some(p) } else { None }
}

/// All fixed points of the amplitude equations in the box (origin, axis points ordered by
/// amplitude, mode 1 first, then interior points ordered by `rho_1`).
pub fn fixed_points(nf: &PolarNormalForm, opts: &PortraitOptions) -> Result<Vec<FixedPoint>, PortraitError> {
    check_opts(opts)?;
    let field = Field::new(nf)?;
    Ok(fixed_points_field(&field, opts))
}

fn fixed_points_field(field: &Field, opts: &PortraitOptions) -> Vec<FixedPoint> {
    let mut out = vec![make_point(field, [0.0, 0.0], PointKind::Equilibrium)];
    for axis in 0..2 {
        for r in axis_roots(field, axis, opts.rho_max[axis], opts.axis_samples) {
            let mut rho = [0.0; 2];
            rho[axis] = r;
            out.push(make_point(field, rho, PointKind::LimitCycle { mode: axis + 1 }));
        }
    }
    let slack = 1.0 + 1e-9;
    let mut interior: Vec<[f64; 2]> = Vec::new();
    let n = opts.grid;
    for a in 0..n {
        for b in 0..n {
            let r = [opts.rho_max[0] * (a as f64 + 0.5) / n as f64, opts.rho_max[1] * (b as f64 + 0.5) / n as f64];
            let Some(p) = newton_interior(field, [r[0] * r[0], r[1] * r[1]]) else { continue };
            if !(p[0] > 0.0 && p[1] > 0.0) {
                continue;
            }
            let rho = [p[0].sqrt(), p[1].sqrt()];
            if rho[0] > opts.rho_max[0] * slack || rho[1] > opts.rho_max[1] * slack {
                continue;
            }
            if interior.iter().any(|q| (q[0] - rho[0]).hypot(q[1] - rho[1]) < opts.dedup_tol) {
                continue;
            }
            interior.push(rho);
        }
    }
    interior.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    out.extend(interior.into_iter().map(|rho| make_point(field, rho, PointKind::Torus2)));
    out
}

// ---------------------------------------------------------------------- integrator

/// One Dormand-Prince 5(4) step of `x' = sign f(x)`: (5th-order solution, error estimate).
fn dp_step(field: &Field, sign: f64, x: [f64; 2], h: f64) -> ([f64; 2], [f64; 2]) {
    let f = |y: [f64; 2]| {
        let v = field.f(y);
        [sign * v[0], sign * v[1]]
    };
    let add = |coef: &[f64], ks: &[[f64; 2]]| -> [f64; 2] {
        let mut y = x;
        for (c, k) in coef.iter().zip(ks) {
            y[0] += h * c * k[0];
            y[1] += h * c * k[1];
        }
        y
    };
    let k1 = f(x);
    let k2 = f(add(&[1.0 / 5.0], &[k1]));
    let k3 = f(add(&[3.0 / 40.0, 9.0 / 40.0], &[k1, k2]));
    let k4 = f(add(&[44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0], &[k1, k2, k3]));
    let k5 = f(add(&[19372.0 / 6561.0, -25360.0 / 2187.0, 64448.0 / 6561.0, -212.0 / 729.0], &[k1, k2, k3, k4]));
    let k6 = f(add(
        &[9017.0 / 3168.0, -355.0 / 33.0, 46732.0 / 5247.0, 49.0 / 176.0, -5103.0 / 18656.0],
        &[k1, k2, k3, k4, k5],
    ));
    let b = [35.0 / 384.0, 0.0, 500.0 / 1113.0, 125.0 / 192.0, -2187.0 / 6784.0, 11.0 / 84.0];
    let y = add(&b, &[k1, k2, k3, k4, k5, k6]);
    let k7 = f(y);
    let e = [71.0 / 57600.0, 0.0, -71.0 / 16695.0, 71.0 / 1920.0, -17253.0 / 339200.0, 22.0 / 525.0, -1.0 / 40.0];
    let ks = [k1, k2, k3, k4, k5, k6, k7];
    let mut err = [0.0; 2];
    for (c, k) in e.iter().zip(&ks) {
        err[0] += h * c * k[0];
        err[1] += h * c * k[1];
    }
    (y, err)
}

enum End {
    Fate(Fate),
    /// The step callback asked to stop, with a located point and time.
    Event([f64; 2], f64),
}

struct Traj {
    points: Vec<(f64, f64)>,
    t: f64,
    end: End,
    min_distance: Vec<f64>,
}

/// What the step callback decides.
enum Step {
    Go,
    Stop([f64; 2], f64),
}

/// Integrates `x' = sign f(x)` from `x0` for at most `t_max`. Stops at fixed points, the box
/// edge, the limits, or when `on_step(x_a, x_b, t_a, h)` says so. Coordinates that are
/// exactly zero stay zero (the axes are invariant; `f_i = rho_i g_i` keeps them so).
#[allow(clippy::too_many_arguments)]
fn integrate(
    field: &Field,
    x0: [f64; 2],
    sign: f64,
    t_max: f64,
    fps: &[FixedPoint],
    skip_near: Option<(usize, f64)>,
    opts: &PortraitOptions,
    on_step: &mut dyn FnMut([f64; 2], [f64; 2], f64, f64) -> Step,
) -> Traj {
    let mut x = x0;
    let mut t = 0.0;
    let mut h = opts.max_step.min(t_max) * 0.01;
    let mut points = vec![(x[0], x[1])];
    let mut min_distance = vec![f64::INFINITY; fps.len()];
    let bound = [opts.rho_max[0] * (1.0 + 1e-9), opts.rho_max[1] * (1.0 + 1e-9)];
    let mut steps = 0usize;
    let mut armed = skip_near.is_none();
    let end = loop {
        if t >= t_max {
            break End::Fate(Fate::TimeLimit);
        }
        if steps >= opts.max_steps {
            break End::Fate(Fate::StepLimit);
        }
        let hh = h.min(t_max - t).min(opts.max_step);
        let (y, e) = dp_step(field, sign, x, hh);
        let mut err = 0.0;
        for i in 0..2 {
            let sc = opts.atol + opts.rtol * x[i].abs().max(y[i].abs());
            err += (e[i] / sc).powi(2);
        }
        let err = (0.5 * err).sqrt();
        if !err.is_finite() || err > 1.0 {
            h = hh * if err.is_finite() { (0.9 * err.powf(-0.2)).max(0.1) } else { 0.1 };
            if h < 1e-12 * (1.0 + t) {
                break End::Fate(Fate::StepLimit);
            }
            continue;
        }
        steps += 1;
        let xa = x;
        x = y;
        for i in 0..2 {
            if x0[i] == 0.0 {
                x[i] = 0.0;
            }
        }
        let ta = t;
        t += hh;
        h = hh * (0.9 * err.max(1e-10).powf(-0.2)).min(5.0);
        // Box exit (cut the polyline at the edge).
        let out_hi = (0..2).any(|i| x[i] > bound[i]);
        let out_lo = (0..2).any(|i| x[i] < 0.0);
        if out_hi || out_lo {
            let mut lam: f64 = 1.0;
            for i in 0..2 {
                let d = x[i] - xa[i];
                if x[i] > bound[i] && d != 0.0 {
                    lam = lam.min((opts.rho_max[i] - xa[i]) / d);
                }
                if x[i] < 0.0 && d != 0.0 {
                    lam = lam.min(-xa[i] / d);
                }
            }
            let lam = lam.clamp(0.0, 1.0);
            let at = (xa[0] + lam * (x[0] - xa[0]), xa[1] + lam * (x[1] - xa[1]));
            points.push(at);
            break End::Fate(Fate::LeavesBox { at });
        }
        points.push((x[0], x[1]));
        if let Step::Stop(p, te) = on_step(xa, x, ta, hh) {
            break End::Event(p, te);
        }
        let mut hit = None;
        for (k, fp) in fps.iter().enumerate() {
            let dist = (x[0] - fp.rho[0]).hypot(x[1] - fp.rho[1]);
            if let Some((own, r)) = skip_near
                && own == k
                && !armed
            {
                if dist > r {
                    armed = true;
                } else {
                    continue;
                }
            }
            min_distance[k] = min_distance[k].min(dist);
            if dist < opts.converge_tol && hit.is_none() {
                hit = Some(k);
            }
        }
        if let Some(k) = hit {
            break End::Fate(if fps[k].stability == Stability::Saddle {
                Fate::ApproachesSaddle { point: k }
            } else {
                Fate::Converges { point: k }
            });
        }
    };
    Traj { points, t, end, min_distance }
}

/// The forward trajectory of the amplitude equations from `rho0` for at most `t_max` s, and
/// its fate (reaches a fixed point within `converge_tol`, leaves the box, or a limit).
pub fn trajectory(
    nf: &PolarNormalForm,
    rho0: [f64; 2],
    t_max: f64,
    opts: &PortraitOptions,
) -> Result<(Vec<(f64, f64)>, Fate), PortraitError> {
    check_opts(opts)?;
    check_start(rho0, t_max)?;
    PreparedField::new(nf, opts)?.trajectory(rho0, t_max)
}

fn check_start(rho0: [f64; 2], t_max: f64) -> Result<(), PortraitError> {
    for (name, v) in [("rho0[0]", rho0[0]), ("rho0[1]", rho0[1])] {
        if !(v.is_finite() && v >= 0.0) {
            return Err(PortraitError::BadOption { name, value: v, why: "must be finite and non-negative" });
        }
    }
    if !(t_max.is_finite() && t_max > 0.0) {
        return Err(PortraitError::BadOption { name: "t_max", value: t_max, why: "must be finite and positive" });
    }
    Ok(())
}

/// The amplitude equations of one normal form and their fixed points, computed once for
/// many [`PreparedField::trajectory`] calls (a basin grid: [`trajectory`] finds the fixed
/// points afresh each time, most of a short run's cost). Bit-identical to [`trajectory`] with
/// the same options.
pub struct PreparedField {
    field: Field,
    fps: Vec<FixedPoint>,
    opts: PortraitOptions,
}

impl PreparedField {
    /// The field of `nf` and its fixed points in the box of `opts` ([`fixed_points`]).
    pub fn new(nf: &PolarNormalForm, opts: &PortraitOptions) -> Result<Self, PortraitError> {
        check_opts(opts)?;
        let field = Field::new(nf)?;
        let fps = fixed_points_field(&field, opts);
        Ok(PreparedField { field, fps, opts: opts.clone() })
    }

    /// The fixed points, as [`fixed_points`] returns them (the numbering of the fates).
    pub fn fixed_points(&self) -> &[FixedPoint] {
        &self.fps
    }

    /// [`trajectory`] from `rho0` for at most `t_max` s.
    pub fn trajectory(&self, rho0: [f64; 2], t_max: f64) -> Result<(Vec<(f64, f64)>, Fate), PortraitError> {
        check_start(rho0, t_max)?;
        let tr = integrate(&self.field, rho0, 1.0, t_max, &self.fps, None, &self.opts, &mut |_, _, _, _| Step::Go);
        Ok((tr.points, fate_of(&tr.end)))
    }
}

fn fate_of(end: &End) -> Fate {
    match end {
        End::Fate(f) => *f,
        End::Event(..) => Fate::TimeLimit,
    }
}

// ------------------------------------------------------------------------ manifolds

fn saddle_branches(
    field: &Field,
    fps: &[FixedPoint],
    s: usize,
    opts: &PortraitOptions,
    only: Option<Direction>,
) -> Vec<ManifoldBranch> {
    let fp = &fps[s];
    let Some(vecs) = fp.eigenvectors else { return Vec::new() };
    let mut out = Vec::new();
    // eigenvalues are ordered: [stable (negative), unstable (positive)] for a saddle.
    for (idx, dir) in [(0usize, Direction::Stable), (1usize, Direction::Unstable)] {
        if only.is_some_and(|o| o != dir) {
            continue;
        }
        let v = vecs[idx];
        for sgn in [1.0, -1.0] {
            let d = [sgn * v[0], sgn * v[1]];
            let mut x0 = [fp.rho[0] + opts.manifold_eps * d[0], fp.rho[1] + opts.manifold_eps * d[1]];
            // Coordinates on an invariant axis stay exactly on it.
            let mut on_axis = false;
            for i in 0..2 {
                if fp.rho[i] == 0.0 && d[i].abs() < 1e-14 {
                    x0[i] = 0.0;
                    on_axis = true;
                }
            }
            if x0.iter().any(|c| *c < 0.0) {
                continue; // this half-branch lies outside the amplitude quadrant
            }
            let sign = if dir == Direction::Unstable { 1.0 } else { -1.0 };
            let tr = integrate(
                field,
                x0,
                sign,
                opts.t_max,
                fps,
                Some((s, 10.0 * opts.manifold_eps)),
                opts,
                &mut |_, _, _, _| Step::Go,
            );
            let mut points = vec![(fp.rho[0], fp.rho[1])];
            points.extend(tr.points);
            out.push(ManifoldBranch {
                saddle: s,
                direction: dir,
                start_dir: d,
                on_axis,
                points,
                fate: fate_of(&tr.end),
                duration: tr.t,
                min_distance: tr.min_distance,
            });
        }
    }
    out
}

// ------------------------------------------------------------------ periodic orbits

/// Return along the downward ray from `c`: `Some((s_return, period, polyline))`.
/// `(s_return, period, polyline)` of one return to the section ray.
type Return = (f64, f64, Vec<(f64, f64)>);

fn ray_return(field: &Field, c: [f64; 2], s: f64, fps: &[FixedPoint], opts: &PortraitOptions) -> Option<Return> {
    let x0 = [c[0], c[1] - s];
    let ang = |x: [f64; 2]| (x[1] - c[1]).atan2(x[0] - c[0]);
    let mut phi = 0.0;
    let tr = integrate(field, x0, 1.0, opts.t_max, fps, None, opts, &mut |xa, xb, ta, h| {
        let mut dphi = ang(xb) - ang(xa);
        if dphi > PI {
            dphi -= TAU;
        } else if dphi < -PI {
            dphi += TAU;
        }
        let before = phi;
        phi += dphi;
        if phi.abs() >= TAU && before.abs() < TAU {
            // Locate the crossing of the ray inside the step: cross product with the ray
            // direction (0, -1) is -(x - c_x); it changes sign over the step.
            let side = |x: [f64; 2]| x[0] - c[0];
            let (mut lo, mut hi) = (0.0, h);
            let slo = side(xa);
            let mut p = xb;
            for _ in 0..80 {
                let mid = 0.5 * (lo + hi);
                let (xm, _) = dp_step(field, 1.0, xa, mid);
                if side(xm) * slo > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                    p = xm;
                }
            }
            return Step::Stop(p, ta + hi);
        }
        Step::Go
    });
    match tr.end {
        End::Event(p, te) if p[1] < c[1] => {
            let mut pts = tr.points;
            pts.pop();
            pts.push((p[0], p[1]));
            Some((c[1] - p[1], te, pts))
        }
        _ => None,
    }
}

fn find_orbits(field: &Field, fps: &[FixedPoint], opts: &PortraitOptions) -> Vec<PeriodicOrbit> {
    let mut out: Vec<PeriodicOrbit> = Vec::new();
    if opts.ray_samples < 2 {
        return out;
    }
    for (ci, fp) in fps.iter().enumerate() {
        if fp.kind != PointKind::Torus2 || fp.stability == Stability::Saddle {
            continue;
        }
        let c = fp.rho;
        let len = c[1];
        let n = opts.ray_samples;
        let mut ss: Vec<f64> = (0..n).map(|k| len * (0.002 + 0.996 * k as f64 / (n - 1) as f64)).collect();
        // Geometric refinement towards both ends: orbits born in a heteroclinic bifurcation
        // pass exponentially close to the axis, small ones (near a Hopf point) hug the centre.
        ss.extend((3..=12).map(|k| len * (1.0 - 10f64.powi(-k))));
        ss.extend((3..=6).map(|k| len * 10f64.powi(-k)));
        ss.sort_by(f64::total_cmp);
        ss.dedup();
        let n = ss.len();
        let ds: Vec<Option<f64>> =
            ss.iter().map(|&s| ray_return(field, c, s, fps, opts).map(|(r, _, _)| r - s)).collect();
        // Brackets of sign changes of D: between neighbouring samples with a return, and
        // between a sample with a return and the edge of the returning set next to it
        // (located by bisection on "returns": an unstable orbit next to an escape region has
        // a thin layer of once-returning points with the other sign just outside it).
        let mut brackets: Vec<(f64, f64, f64)> = Vec::new();
        for k in 0..n - 1 {
            match (ds[k], ds[k + 1]) {
                (Some(da), Some(db)) if da * db <= 0.0 => brackets.push((ss[k], ss[k + 1], da)),
                (Some(da), None) | (None, Some(da)) => {
                    let (s_def, s_undef) = if ds[k].is_some() { (ss[k], ss[k + 1]) } else { (ss[k + 1], ss[k]) };
                    let (mut a, mut b, mut d_edge) = (s_def, s_undef, da);
                    for _ in 0..50 {
                        let mid = 0.5 * (a + b);
                        match ray_return(field, c, mid, fps, opts) {
                            Some((r, _, _)) => {
                                a = mid;
                                d_edge = r - mid;
                            }
                            None => b = mid,
                        }
                    }
                    if d_edge * da < 0.0 {
                        let (lo, hi) = if s_def < a { (s_def, a) } else { (a, s_def) };
                        let dlo = if s_def < a { da } else { d_edge };
                        brackets.push((lo, hi, dlo));
                    }
                }
                _ => {}
            }
        }
        for (blo, bhi, bd) in brackets {
            let (mut lo, mut hi, mut dlo) = (blo, bhi, bd);
            let mut failed = false;
            for _ in 0..60 {
                if hi - lo <= 1e-11 * len {
                    break;
                }
                let mid = 0.5 * (lo + hi);
                let Some((r, _, _)) = ray_return(field, c, mid, fps, opts) else {
                    failed = true;
                    break;
                };
                let dm = r - mid;
                if dm * dlo > 0.0 {
                    lo = mid;
                    dlo = dm;
                } else {
                    hi = mid;
                }
            }
            if failed {
                continue;
            }
            let s = 0.5 * (lo + hi);
            let Some((_, period, pts)) = ray_return(field, c, s, fps, opts) else { continue };
            let hstep = 1e-4 * len;
            let multiplier =
                match (ray_return(field, c, s + hstep, fps, opts), ray_return(field, c, s - hstep, fps, opts)) {
                    (Some((rp, _, _)), Some((rm, _, _))) => (rp - rm) / (2.0 * hstep),
                    _ => f64::NAN,
                };
            if !multiplier.is_finite() {
                continue;
            }
            let mut range = [[f64::INFINITY, f64::NEG_INFINITY]; 2];
            for p in &pts {
                range[0] = [range[0][0].min(p.0), range[0][1].max(p.0)];
                range[1] = [range[1][0].min(p.1), range[1][1].max(p.1)];
            }
            out.push(PeriodicOrbit {
                center: ci,
                section_point: [c[0], c[1] - s],
                period,
                rho_range: range,
                multiplier,
                stable: multiplier.abs() < 1.0,
                points: pts,
            });
        }
    }
    out
}

// ------------------------------------------------------------------------- portrait

/// Full phase portrait: fixed points, manifolds of every saddle, periodic orbits around
/// interior non-saddle points, and sample trajectories for the plot.
pub fn portrait(nf: &PolarNormalForm, opts: &PortraitOptions) -> Result<Portrait, PortraitError> {
    check_opts(opts)?;
    let field = Field::new(nf)?;
    let fps = fixed_points_field(&field, opts);
    let mut manifolds = Vec::new();
    for s in 0..fps.len() {
        if fps[s].stability == Stability::Saddle {
            manifolds.extend(saddle_branches(&field, &fps, s, opts, None));
        }
    }
    let orbits = find_orbits(&field, &fps, opts);
    let mut flow = Vec::new();
    let n = opts.flow_grid;
    for a in 0..n {
        for b in 0..n {
            let x0 = [opts.rho_max[0] * (a as f64 + 0.5) / n as f64, opts.rho_max[1] * (b as f64 + 0.5) / n as f64];
            let tr = integrate(&field, x0, 1.0, opts.t_flow, &fps, None, opts, &mut |_, _, _, _| Step::Go);
            flow.push(tr.points);
        }
    }
    Ok(Portrait { rho_max: opts.rho_max, fixed_points: fps, manifolds, orbits, flow })
}

// ---------------------------------------------------------------- bifurcation scans

/// Options of the `dt` scans.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ScanOptions {
    pub portrait: PortraitOptions,
    /// Number of grid points over `[lo, hi]` (at least 2).
    pub grid: usize,
    /// Bisection stops when the bracket is at most this wide (ms).
    pub tol: f64,
}

impl Default for ScanOptions {
    fn default() -> Self {
        ScanOptions {
            portrait: PortraitOptions { ray_samples: 0, flow_grid: 0, ..PortraitOptions::default() },
            grid: 41,
            tol: 1e-4,
        }
    }
}

/// A heteroclinic bifurcation found by [`heteroclinic_dt`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeteroclinicEvent {
    /// Midpoint of the final bracket (ms).
    pub dt: f64,
    pub bracket: (f64, f64),
    /// The saddle whose interior unstable branch switches fate.
    pub saddle: PointKind,
    /// Fate class of that branch at the low and the high end of the bracket.
    pub fate_below: FateClass,
    pub fate_above: FateClass,
    /// The other saddle passed closest at the bracket ends, and that distance (the smaller of
    /// the two ends); it shrinks to zero at the connection.
    pub nearest_saddle: Option<(PointKind, f64)>,
    /// A bisection midpoint gave a third outcome (the branch reached another saddle within
    /// `converge_tol`, or the time limit): the connection is at that midpoint (`dt`).
    pub exact_hit: bool,
}

/// A change of stability of the 2-torus found by [`torus_hopf_dt`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HopfEvent {
    pub dt: f64,
    pub bracket: (f64, f64),
    /// Torus position and eigenvalues at `dt`.
    pub rho: [f64; 2],
    pub eigenvalues: [(f64, f64); 2],
    /// True when the crossing eigenvalues are a complex pair (a Hopf bifurcation of the
    /// amplitude system, a torus bifurcation of the full system); false when a real
    /// eigenvalue crosses zero.
    pub complex_pair: bool,
    /// `|Im lambda| / (2 pi)` at `dt` (Hz): the frequency of the 3-torus being born.
    pub frequency_hz: f64,
    /// True when the torus is stable below and unstable above.
    pub loses_stability: bool,
}

fn check_range(lo: f64, hi: f64, s: &ScanOptions) -> Result<(), PortraitError> {
    if !(lo.is_finite() && hi.is_finite() && lo < hi) {
        return Err(PortraitError::BadRange { lo, hi, why: "need finite lo < hi" });
    }
    if s.grid < 2 {
        return Err(PortraitError::BadOption {
            name: "grid",
            value: s.grid as f64,
            why: "scan needs at least 2 points",
        });
    }
    if !(s.tol.is_finite() && s.tol > 0.0) {
        return Err(PortraitError::BadOption { name: "tol", value: s.tol, why: "must be finite and positive" });
    }
    check_opts(&s.portrait)
}

fn field_at<E: std::fmt::Display>(
    nf_at: &impl Fn(f64) -> Result<PolarNormalForm, E>,
    dt: f64,
) -> Result<Field, PortraitError> {
    let nf = nf_at(dt).map_err(|e| PortraitError::NormalForm { dt, message: e.to_string() })?;
    Field::new(&nf)
}

/// The interior unstable branches of the saddle cycles at one `dt`, keyed by
/// `(mode, ordinal of the saddle on its axis)`.
struct BranchInfo {
    key: (usize, usize),
    class: FateClass,
    /// `(kind, distance)` of the closest other saddle.
    nearest: Option<(PointKind, f64)>,
}

fn interior_unstable(field: &Field, opts: &PortraitOptions) -> Vec<BranchInfo> {
    let fps = fixed_points_field(field, opts);
    let mut out = Vec::new();
    let mut ordinal = [0usize; 3];
    for s in 0..fps.len() {
        let PointKind::LimitCycle { mode } = fps[s].kind else { continue };
        let ord = ordinal[mode];
        ordinal[mode] += 1;
        if fps[s].stability != Stability::Saddle {
            continue;
        }
        for b in saddle_branches(field, &fps, s, opts, Some(Direction::Unstable)) {
            if b.on_axis {
                continue;
            }
            let class = match b.fate {
                Fate::Converges { point } => FateClass::ConvergesTo(fps[point].kind),
                Fate::ApproachesSaddle { point } => FateClass::ApproachesSaddle(fps[point].kind),
                Fate::LeavesBox { .. } => FateClass::LeavesBox,
                Fate::TimeLimit => FateClass::TimeLimit,
                Fate::StepLimit => FateClass::StepLimit,
            };
            let nearest = (0..fps.len())
                .filter(|&k| k != s && fps[k].stability == Stability::Saddle && fps[k].kind != PointKind::Equilibrium)
                .map(|k| (fps[k].kind, b.min_distance[k]))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            out.push(BranchInfo { key: (mode, ord), class, nearest });
        }
    }
    out
}

fn decisive(c: FateClass) -> bool {
    matches!(c, FateClass::ConvergesTo(_) | FateClass::LeavesBox)
}

/// Heteroclinic bifurcation of the saddle cycles in `[lo, hi]` (ms).
///
/// Rule: on `grid` equally spaced values of `dt`, take every interior (off-axis) unstable
/// branch of a saddle-type limit cycle (keyed by its mode and position along the axis) and
/// its fate class: converges to a fixed point of a given kind, or leaves the box. The first
/// grid interval (from `lo`) where the same branch has two different decisive classes
/// brackets the event. Between them the branch must cross the stable manifold of another
/// saddle (a heteroclinic connection), so the bracket is bisected, keeping a class at each
/// end, until it is at most `opts.tol` wide; `dt` is its midpoint. A midpoint whose outcome
/// is neither class (the branch reaches a saddle within `converge_tol`, or a limit) ends the
/// bisection there (`exact_hit`). Grid points whose outcome is not decisive are skipped.
/// `Ok(None)` when no branch switches on the grid; [`PortraitError::NoSaddle`] when no grid
/// point has such a branch at all.
pub fn heteroclinic_dt<E: std::fmt::Display>(
    nf_at: impl Fn(f64) -> Result<PolarNormalForm, E>,
    lo: f64,
    hi: f64,
    opts: &ScanOptions,
) -> Result<Option<HeteroclinicEvent>, PortraitError> {
    check_range(lo, hi, opts)?;
    let po = &opts.portrait;
    let dts: Vec<f64> = (0..opts.grid).map(|k| lo + (hi - lo) * k as f64 / (opts.grid - 1) as f64).collect();
    let mut any = false;
    // Last decisive observation per key: (dt, class).
    let mut last: Vec<((usize, usize), f64, FateClass)> = Vec::new();
    let mut found = None;
    'scan: for &dt in &dts {
        let infos = interior_unstable(&field_at(&nf_at, dt)?, po);
        any |= !infos.is_empty();
        for inf in infos {
            if !decisive(inf.class) {
                continue;
            }
            match last.iter_mut().find(|e| e.0 == inf.key) {
                Some(e) if e.2 != inf.class => {
                    found = Some((inf.key, e.1, e.2, dt, inf.class));
                    break 'scan;
                }
                Some(e) => {
                    e.1 = dt;
                }
                None => last.push((inf.key, dt, inf.class)),
            }
        }
    }
    if !any {
        return Err(PortraitError::NoSaddle { dt: lo });
    }
    let Some((key, mut a, ca, mut b, cb)) = found else { return Ok(None) };
    let info_at = |dt: f64| -> Result<BranchInfo, PortraitError> {
        interior_unstable(&field_at(&nf_at, dt)?, po)
            .into_iter()
            .find(|i| i.key == key)
            .ok_or(PortraitError::NoSaddle { dt })
    };
    let mut near_a = info_at(a)?.nearest;
    let mut near_b = info_at(b)?.nearest;
    let mut exact_hit = false;
    while b - a > opts.tol {
        let mid = 0.5 * (a + b);
        let inf = info_at(mid)?;
        if inf.class == ca {
            a = mid;
            near_a = inf.nearest;
        } else if inf.class == cb {
            b = mid;
            near_b = inf.nearest;
        } else {
            exact_hit = true;
            a = mid;
            b = mid;
            near_a = inf.nearest;
            near_b = inf.nearest;
            break;
        }
    }
    let nearest = match (near_a, near_b) {
        (Some(x), Some(y)) => Some(if x.1 <= y.1 { x } else { y }),
        (x, y) => x.or(y),
    };
    Ok(Some(HeteroclinicEvent {
        dt: 0.5 * (a + b),
        bracket: (a, b),
        saddle: PointKind::LimitCycle { mode: key.0 },
        fate_below: ca,
        fate_above: cb,
        nearest_saddle: nearest,
        exact_hit,
    }))
}

/// The torus followed along the scan: the interior fixed point nearest to `prev` (the first
/// interior point when `prev` is `None`).
fn torus_at(
    field: &Field,
    opts: &PortraitOptions,
    prev: Option<[f64; 2]>,
    dt: f64,
) -> Result<FixedPoint, PortraitError> {
    let fps = fixed_points_field(field, opts);
    let mut tori: Vec<FixedPoint> = fps.into_iter().filter(|p| p.kind == PointKind::Torus2).collect();
    if tori.is_empty() {
        return Err(PortraitError::NoTorus { dt });
    }
    let idx = match prev {
        None => 0,
        Some(q) => {
            let d = |p: &FixedPoint| (p.rho[0] - q[0]).hypot(p.rho[1] - q[1]);
            (0..tori.len()).min_by(|&i, &j| d(&tori[i]).total_cmp(&d(&tori[j]))).unwrap_or(0)
        }
    };
    Ok(tori.swap_remove(idx))
}

fn max_re(p: &FixedPoint) -> f64 {
    p.eigenvalues[0].0.max(p.eigenvalues[1].0)
}

/// Change of stability of the 2-torus in `[lo, hi]` (ms).
///
/// Rule: on `grid` equally spaced values of `dt` follow the interior fixed point (the one
/// nearest the previous position; the first one at `lo`) and its largest eigenvalue real
/// part `m(dt)`. The first grid interval where `m` changes sign (strictly) is bisected on the
/// sign of `m` until at most `opts.tol` wide. At the midpoint a complex pair
/// (`complex_pair`) means a Hopf bifurcation of the amplitude equations; otherwise a real
/// eigenvalue crosses zero. [`PortraitError::NoTorus`] when a visited `dt` has no interior
/// fixed point in the box; `Ok(None)` when `m` keeps its sign on the grid.
pub fn torus_hopf_dt<E: std::fmt::Display>(
    nf_at: impl Fn(f64) -> Result<PolarNormalForm, E>,
    lo: f64,
    hi: f64,
    opts: &ScanOptions,
) -> Result<Option<HopfEvent>, PortraitError> {
    check_range(lo, hi, opts)?;
    let po = &opts.portrait;
    let mut prev: Option<(f64, FixedPoint)> = None;
    let mut bracket = None;
    for k in 0..opts.grid {
        let dt = lo + (hi - lo) * k as f64 / (opts.grid - 1) as f64;
        let t = torus_at(&field_at(&nf_at, dt)?, po, prev.as_ref().map(|p| p.1.rho), dt)?;
        if let Some((dp, p)) = &prev
            && max_re(p) * max_re(&t) < 0.0
        {
            bracket = Some((*dp, p.clone(), dt, t));
            break;
        }
        prev = Some((dt, t));
    }
    let Some((mut a, mut ta, mut b, mut tb)) = bracket else { return Ok(None) };
    let loses = max_re(&ta) < 0.0;
    while b - a > opts.tol {
        let mid = 0.5 * (a + b);
        let guess = [0.5 * (ta.rho[0] + tb.rho[0]), 0.5 * (ta.rho[1] + tb.rho[1])];
        let tm = torus_at(&field_at(&nf_at, mid)?, po, Some(guess), mid)?;
        let m = max_re(&tm);
        if m == 0.0 {
            a = mid;
            b = mid;
            ta = tm.clone();
            tb = tm;
            break;
        }
        if (m < 0.0) == (max_re(&ta) < 0.0) {
            a = mid;
            ta = tm;
        } else {
            b = mid;
            tb = tm;
        }
    }
    let dt = 0.5 * (a + b);
    let guess = [0.5 * (ta.rho[0] + tb.rho[0]), 0.5 * (ta.rho[1] + tb.rho[1])];
    let t = torus_at(&field_at(&nf_at, dt)?, po, Some(guess), dt)?;
    let complex_pair = t.eigenvalues[0].1 != 0.0;
    Ok(Some(HopfEvent {
        dt,
        bracket: (a, b),
        rho: t.rho,
        eigenvalues: t.eigenvalues,
        complex_pair,
        frequency_hz: t.eigenvalues[0].1.abs() / TAU,
        loses_stability: loses,
    }))
}
