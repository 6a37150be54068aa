//! Convergence of the equation-driven SSM where the global bifurcations live (docs/decisions/0001):
//! the SSM and its reduced map, truncated at orders 3, 5, ..., checked against the *exact*
//! one-period map of the unquantized loop (the plant integrated in `f64`, no Taylor
//! truncation), on spheres of normal-form amplitude up to the saddle cycles' 0.15-0.2 rad.
//!
//! Two errors per (radius, order), maxima over sample points `z` on the sphere (amplitude
//! directions including both axes, phases on a grid):
//! * invariance: `F(W(z)) - W(R(z))` (inf norm over the state, and its theta component);
//! * reduced dynamics: the exact image `F(W(z))` pulled back to parametrization coordinates
//!   `z'` (`ssm::map_ssm::MapSsm::master_coordinates`), its amplitudes `|z'_j|` against the
//!   reduced map's `|R(z)_j|`, expressed as a rate error `||z'_j| - |R_j(z)|| / (r dt)` (1/s,
//!   comparable with the linear rates -0.1 and 0.27 1/s that the cubic and quintic terms
//!   balance at a saddle cycle).
//!
//! A root test on consecutive orders, `r (e_k / e_{k+2})^{1/2}`, estimates the radius of
//! convergence of the series (`e_k ~ (r/R)^k`).

use nalgebra::Complex;
use serde::{Deserialize, Serialize};
use sim::closed_loop::{AnyPlant, build_plant};
use sim::ode::Method;
use sim::scene::Scene;
use sim::taylor::{FlowOptions, PeriodMap};
use ssm::map_ssm::{Amplitude, MapSsm, MapSsmOptions, map_ssm};

use crate::Error;
use crate::equation_ssm::{RESONANCE_TOL, polynomial_map, scene_period_map};

type C = Complex<f64>;

/// Radii (rad, `sqrt(rho_1^2 + rho_2^2)`) of [`furuta_convergence`]'s table: from half the
/// 2-torus amplitude to beyond the slow saddle cycle (rho_1 ~ 0.17-0.18 rad).
pub const CONVERGENCE_RADII: [f64; 5] = [0.05, 0.1, 0.15, 0.18, 0.2];

/// The integrator of the exact period map: adaptive RODAS4 at tolerances far below every
/// error measured with it.
pub const EXACT_METHOD: Method = Method::Rodas { rtol: 1e-12, atol: 1e-14 };

/// The exact (integrated, untruncated) one-period map of a scene's unquantized,
/// unsaturated loop, in the deflated coordinates of its Taylor expansion.
pub struct ExactMap {
    pub pm: PeriodMap,
    plant: AnyPlant,
    pub method: Method,
}

impl ExactMap {
    /// The exact map of `scene` next to its expansion to `order`.
    pub fn new(scene: &Scene, order: u32) -> Result<ExactMap, Error> {
        let pm = scene_period_map(scene, order, &FlowOptions::default())?;
        Ok(ExactMap { pm, plant: build_plant(scene)?, method: EXACT_METHOD })
    }

    /// State dimension.
    pub fn dim(&self) -> usize {
        self.pm.dim()
    }

    /// `F(s)` integrated.
    pub fn eval(&self, s: &[f64]) -> Result<Vec<f64>, Error> {
        let r = self.pm.exact_any(&self.plant, s, self.method);
        r.map_err(|e| Error::from(sim::Error::from(e)))
    }
}

/// Errors of one truncation order on one sphere.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ConvergenceRow {
    /// Sphere radius, rad.
    pub radius: f64,
    pub order: u32,
    /// `max ||F(W(z)) - W(R(z))||_inf` (state units: rad, rad/s).
    pub invariance: f64,
    /// The same, theta component only (rad).
    pub invariance_theta: f64,
    /// `invariance / max ||W(z)||_inf`.
    pub invariance_rel: f64,
    /// Rate error of the reduced map per mode, `max ||z'_j| - |R_j(z)|| / (r dt)` (1/s).
    pub rate_error: [f64; 2],
    /// `invariance` per amplitude direction `alpha = 0, 22.5, 45, 67.5, 90` deg
    /// (`rho_1 = r cos alpha`, `rho_2 = r sin alpha`: slow axis first, fast axis last).
    pub invariance_by_direction: [f64; 5],
    /// Sample points whose exact image could not be pulled back (Newton failed).
    pub unresolved: usize,
    pub points: usize,
}

/// The convergence table of one sampling period.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Convergence {
    pub dt_ms: f64,
    pub max_order: u32,
    /// Radius-major, orders 3, 5, ..., `max_order`.
    pub rows: Vec<ConvergenceRow>,
    /// Root-test estimates of the radius of convergence (rad) from the invariance errors at
    /// orders `k` and `k + 2` on each sphere: `(radius, k, r sqrt(e_k / e_{k+2}))`.
    pub radius_estimates: Vec<(f64, u32, f64)>,
    /// Largest radius whose invariance error still falls from order `max_order - 2` to
    /// `max_order` (NaN when none does).
    pub validity_radius: f64,
    /// Coefficient growth of `W` along each mode's axis (no integration): per odd order `k`,
    /// `(k, a_1(k), a_2(k))` with `a_j(k)` the largest `|W_m|` (over state components) of the
    /// degree-`k` monomials in `z_j, conj z_j` alone.
    pub axis_growth: Vec<(u32, f64, f64)>,
    /// Root-test radius along each axis from the last two orders, `sqrt(a_j(k-2) / a_j(k))`
    /// (rad): which mode's direction limits the convergence.
    pub axis_radius: [f64; 2],
}

/// Largest `|W_m|` per odd order on each mode's axis.
pub fn axis_growth(s: &MapSsm) -> Vec<(u32, f64, f64)> {
    (3..=s.order)
        .step_by(2)
        .map(|k| {
            let mut a = [0.0f64; 2];
            for (q, e) in s.exps.iter().enumerate() {
                if e.iter().sum::<u32>() != k {
                    continue;
                }
                let size = s.w.iter().fold(0.0f64, |m, row| m.max(C::new(row[q].0, row[q].1).norm()));
                if e[2] + e[3] == 0 {
                    a[0] = a[0].max(size);
                } else if e[0] + e[1] == 0 {
                    a[1] = a[1].max(size);
                }
            }
            (k, a[0], a[1])
        })
        .collect()
}

/// Sample points on the sphere of radius `r`: amplitude directions `alpha = k pi/8`
/// (k = 0..=4, both axes included), `phases` phases per excited mode.
fn sphere_points(r: f64, phases: usize) -> Vec<(usize, [C; 4])> {
    let mut out = Vec::new();
    for a in 0..=4 {
        let alpha = a as f64 * std::f64::consts::PI / 8.0;
        let (r1, r2) = (r * alpha.cos(), r * alpha.sin());
        let n1 = if r1 > 1e-12 * r { phases } else { 1 };
        let n2 = if r2 > 1e-12 * r { phases } else { 1 };
        for p in 0..n1 * n2 {
            let t1 = (p % n1) as f64 / n1 as f64 * std::f64::consts::TAU;
            let t2 = (p / n1) as f64 / n2 as f64 * std::f64::consts::TAU + 0.3;
            let z1 = C::from_polar(if r1 > 1e-12 * r { r1 } else { 0.0 }, t1);
            let z2 = C::from_polar(if r2 > 1e-12 * r { r2 } else { 0.0 }, t2);
            out.push((a, [z1, z1.conj(), z2, z2.conj()]));
        }
    }
    out
}

/// Per point: (inf error, theta error, |W|_inf, rate errors or None).
type PointErrors = (f64, f64, f64, Option<[f64; 2]>);

fn point_errors(ex: &ExactMap, s: &MapSsm, z: &[C; 4], order: u32, r: f64) -> Result<PointErrors, Error> {
    let w: Vec<f64> = s.manifold_at(z, order).iter().map(|c| c.re).collect();
    let fw = ex.eval(&w)?;
    let rz = s.reduced_at(z, order);
    let wr: Vec<f64> = s.manifold_at(&rz, order).iter().map(|c| c.re).collect();
    let inf = fw.iter().zip(&wr).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    let p = ex.pm.primary;
    let th = (fw[p] - wr[p]).abs();
    let size = w.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    let rate = s.master_coordinates(&fw, order, 1e-13).map(|zp| {
        let dt = ex.pm.dt;
        [(zp[0].norm() - rz[0].norm()).abs() / (r * dt), (zp[2].norm() - rz[2].norm()).abs() / (r * dt)]
    });
    Ok((inf, th, size, rate))
}

/// The convergence table of `scene`'s equation-driven SSM (orders 3, 5, ..., `order`
/// (3..=9), spheres `radii`, `phases` phases per excited mode), against the exact period
/// map. Points are evaluated on the rayon pool (results independent of the pool size).
pub fn convergence(scene: &Scene, order: u32, radii: &[f64], phases: usize) -> Result<Convergence, Error> {
    if !(3..=ssm::map_ssm::MAX_ORDER).contains(&order) {
        return Err(Error::BadOption {
            what: "order",
            why: format!("must be 3..={}, got {order}", ssm::map_ssm::MAX_ORDER),
        });
    }
    if radii.is_empty() || radii.iter().any(|r| !(r.is_finite() && *r > 0.0)) {
        return Err(Error::BadOption { what: "radii", why: format!("need finite radii > 0, got {radii:?}") });
    }
    if !(2..=64).contains(&phases) {
        return Err(Error::BadOption { what: "phases", why: format!("must be 2..=64, got {phases}") });
    }
    let ex = ExactMap::new(scene, order)?;
    let map = polynomial_map(&ex.pm);
    let mut observable = vec![0.0; ex.dim()];
    observable[ex.pm.primary] = 1.0;
    let s = map_ssm(
        &map,
        &MapSsmOptions {
            order,
            pairs: 2,
            resonance_tol: RESONANCE_TOL,
            observable,
            dt: ex.pm.dt,
            amplitude: Amplitude::Observable,
        },
    )
    .map_err(|e| Error::from(ssm::Error::from(e)))?;
    let orders: Vec<u32> = (3..=order).step_by(2).collect();
    let mut rows = Vec::new();
    for &r in radii {
        let pts = sphere_points(r, phases);
        for &k in &orders {
            let errs = crate::par_map(&pts, |(_, z)| point_errors(&ex, &s, z, k, r))?;
            let mut row = ConvergenceRow {
                radius: r,
                order: k,
                invariance: 0.0,
                invariance_theta: 0.0,
                invariance_rel: 0.0,
                rate_error: [0.0; 2],
                invariance_by_direction: [0.0; 5],
                unresolved: 0,
                points: pts.len(),
            };
            let mut size = 0.0f64;
            for ((a, _), (inf, th, sz, rate)) in pts.iter().zip(errs) {
                row.invariance = row.invariance.max(inf);
                row.invariance_by_direction[*a] = row.invariance_by_direction[*a].max(inf);
                row.invariance_theta = row.invariance_theta.max(th);
                size = size.max(sz);
                match rate {
                    Some(q) => {
                        row.rate_error[0] = row.rate_error[0].max(q[0]);
                        row.rate_error[1] = row.rate_error[1].max(q[1]);
                    }
                    None => row.unresolved += 1,
                }
            }
            row.invariance_rel = row.invariance / size.max(1e-300);
            rows.push(row);
        }
    }
    let mut radius_estimates = Vec::new();
    let mut validity_radius = f64::NAN;
    for chunk in rows.chunks(orders.len()) {
        for w in chunk.windows(2) {
            radius_estimates.push((w[0].radius, w[0].order, w[0].radius * (w[0].invariance / w[1].invariance).sqrt()));
        }
        if let [.., a, b] = chunk
            && b.invariance < a.invariance
            && !(validity_radius >= b.radius)
        {
            validity_radius = b.radius;
        }
    }
    let axis_growth = axis_growth(&s);
    let axis_radius = match axis_growth.as_slice() {
        [.., a, b] => [(a.1 / b.1).sqrt(), (a.2 / b.2).sqrt()],
        _ => [f64::NAN; 2],
    };
    Ok(Convergence {
        dt_ms: scene.controller.dt_ms,
        max_order: order,
        rows,
        radius_estimates,
        validity_radius,
        axis_growth,
        axis_radius,
    })
}

/// [`convergence`] of the paper's Furuta loop at `dt_ms` on [`CONVERGENCE_RADII`], 6 phases
/// per excited mode (120 points per sphere).
pub fn furuta_convergence(dt_ms: f64, order: u32) -> Result<Convergence, Error> {
    let scene = crate::full_system::scene_at(dt_ms)?;
    convergence(&scene, order, &CONVERGENCE_RADII, 6)
}

impl Convergence {
    /// Plain-text table, one line per (radius, order).
    pub fn to_text(&self) -> String {
        let mut out =
            format!("dt = {} ms: invariance and reduced-dynamics errors against the exact period map\n", self.dt_ms);
        out.push_str("radius order  |F(W)-W(R)|_inf   theta      rel        rate err mode1  mode2 (1/s)  unresolved  by direction 0/22.5/45/67.5/90 deg\n");
        for r in &self.rows {
            let dirs: Vec<String> = r.invariance_by_direction.iter().map(|x| format!("{x:.1e}")).collect();
            out.push_str(&format!(
                "{:<6} {:<5}  {:>12.3e}  {:>10.3e} {:>10.3e}  {:>10.3e}  {:>10.3e}  {}/{}  {}\n",
                r.radius,
                r.order,
                r.invariance,
                r.invariance_theta,
                r.invariance_rel,
                r.rate_error[0],
                r.rate_error[1],
                r.unresolved,
                r.points,
                dirs.join(" ")
            ));
        }
        for (r, k, est) in &self.radius_estimates {
            out.push_str(&format!(
                "root test at r = {r}, orders {k}/{}: radius of convergence ~ {est:.3} rad\n",
                k + 2
            ));
        }
        out.push_str(&format!(
            "invariance error still falls at the top order up to r = {} rad\n",
            self.validity_radius
        ));
        for (k, a1, a2) in &self.axis_growth {
            out.push_str(&format!("order {k}: max |W_m| on the mode-1 axis {a1:.3e}, mode-2 axis {a2:.3e}\n"));
        }
        out.push_str(&format!(
            "axis root test (last two orders): mode 1 {:.3} rad, mode 2 {:.3} rad\n",
            self.axis_radius[0], self.axis_radius[1]
        ));
        out
    }
}
