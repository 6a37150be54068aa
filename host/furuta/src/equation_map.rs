//! The equation-driven reduced MAP (docs/decisions/0001): the SSM of the loop's exact one-period map
//! ([`crate::equation_ssm`]) iterated as a map, no polar normal form, in the form of a fitted
//! model so that [`crate::map_global`]'s rules read it exactly as they read the fitted map.
//!
//! The reduced map is the graph-style one ([`crate::equation_ssm::furuta_graph_ssm`]): every
//! term of `R` kept to the order (no normal-form removal of the non-resonant, phase-dependent
//! terms), the parametrization's nonlinear part `W_{>=2}` in the complementary spectral
//! subspace. That is the faithful map: the normal-form style keeps in `R` only the structural
//! terms `z_j |z_1|^{2a} |z_2|^{2b}`, so its iterate is rotation-equivariant and its amplitudes
//! obey the polar amplitude map whatever the phases (the polar normal form up to the
//! map-to-flow conversion): it cannot show what the phase averaging leaves out (the fast pair
//! turns 93.7 degrees per period, near the 1:4 resonance). The graph-style `R` is the order-K
//! Taylor polynomial of `F` restricted to the manifold, in the reduced coordinates
//! `z = U^T s` (exact: `U^T W_m = 0` for every `m` of degree >= 2), the form of the data-driven
//! map (a polynomial map over the tangent space).
//!
//! As a [`ssm::fit::SsmModel`]: reduced coordinates `eta = (Re z_1, Im z_1, Re z_2, Im z_2)`
//! (`z_j` the master coordinates, `c . v_j = 1/2` for the theta row `c`: theta is `Re z_1 + Re
//! z_2` at linear order), dynamics `ReducedDynamics::Map` with the increment `R(z(eta)) - eta`,
//! and a one-coordinate "embedding" `p = 1`: the observable theta itself, `c . W(z(eta))`
//! (`v1` its linear part `(1, 0, 1, 0)`, `nonlinear` its degrees 2..=K). The fit records
//! (`singular_values`, `conditioning`, `n_points`, `eta_range`) describe no regression and
//! are empty or zero; `manifold.reduce` is not the reduced coordinates of a delay vector
//! (there is none): starts are given in `eta` ([`torus_start`]).
//!
//! The ignored tests `measure_equation_map_by_order` and `measure_polar_vs_map` print, at
//! orders 5, 7 and 9 (9 nodes 30.5..32.5 ms, spline), the saddle connection and the torus
//! growth onset and loss of the graph map, of the normal-form map of the same SSM and of the
//! polar flow, to set beside the full system's (the report's bifurcation table). What they
//! show: the graph map is converged in order at the full system's values; the normal-form map
//! stays close to the polar flow (the map-to-flow step is small) and carries its
//! non-convergence: the equation-driven model's disagreement is the normal form's truncation
//! (the phase-dependent terms removed by the near-identity change of coordinates to order K,
//! which the torus at rho ~ 0.1 rad near the 1:4 resonance does not tolerate), not the SSM. The
//! fast saddle cycle's theta amplitude and the 2-torus agree among the graph map, the
//! normal-form map, the polar form and the full system.
//!
//! The small-start switch ([`equation_map_switch`]) uses the fitted map's rules from the full
//! system's starts, projected onto the reduced coordinates by [`StartProjection`] (`z = U^T s`,
//! the start's state and pre-history in the period map's deflated coordinates);
//! `measure_equation_map_switch` prints its bracket by order. The switch is the pure
//! slow-mode start of 1e-3 rad (it first grows the fast mode from round-off) in both systems;
//! its escape times (`measure_switch_starts`) agree above the threshold and part at it, which
//! places the map's switch just above the full system's, inside the full system's coarse
//! grid bracket.
//!
//! [`EquationMapFamily`] interpolates the node maps' coefficients in dt like
//! `SharedParametricModel::model_at` (`ssm::interp::mix_models`, `V1` mixed too; the
//! coordinates mean the same at every node: the eigenvector scaling `c . v_j = 1/2` fixes
//! modulus and phase).

use serde::Serialize;
use ssm::dynamics::ReducedDynamics;
use ssm::fit::{FitOptions, SsmModel};
use ssm::interp::{Interp, MixError, V1Mix, interp_weights, mix_models};
use ssm::manifold::Manifold;
use ssm::map_ssm::MapSsm;
use ssm::poly::Poly;
use ssm::{Conditioning, Dynamics, Ridge};

use crate::Error;
use crate::basin::TorusContinuation;
use crate::equation_ssm::furuta_graph_ssm;
use crate::map_global::{Connection, ConnectionOptions, map_connection, map_torus_continuation_from};

/// The graph-style SSM `s` as a model (see the module docs); `observable` is the row the SSM
/// was normalized by (theta), `dt` the map's step (s).
pub fn model_of_ssm(s: &MapSsm, observable: &[f64]) -> Result<SsmModel, Error> {
    let (increment, obs) = s.real_form(observable).map_err(|e| Error::from(ssm::Error::from(e)))?;
    let d = increment.dim_in;
    let linear = |e: &[u32]| e.iter().sum::<u32>() == 1;
    let mut v1 = vec![0.0; d];
    for (e, c) in obs.exps.iter().zip(&obs.coef) {
        if linear(e)
            && let Some(j) = e.iter().position(|&k| k == 1)
        {
            v1[j] = *c;
        }
    }
    let keep: Vec<usize> = (0..obs.exps.len()).filter(|&k| !linear(&obs.exps[k])).collect();
    let nonlinear = (!keep.is_empty()).then(|| Poly {
        dim_in: d,
        dim_out: 1,
        scale: vec![1.0; d],
        exps: keep.iter().map(|&k| obs.exps[k].clone()).collect(),
        coef: keep.iter().map(|&k| obs.coef[k]).collect(),
    });
    let no_regression = Conditioning::NONE;
    let dynamics = ReducedDynamics::Map { increment, dt: s.dt, conditioning: no_regression };
    let eigenvalues_ct = dynamics.eigenvalues_ct()?;
    Ok(SsmModel {
        options: FitOptions {
            dim: d,
            embed: 1,
            shift: 1,
            manifold_order: s.order,
            dyn_order: s.order,
            dynamics: Dynamics::Map,
            ridge: Ridge::Fixed(0.0),
            linear_anchor: None,
            anchor_joint: false,
        },
        dt: s.dt,
        manifold: Manifold {
            dim: d,
            p: 1,
            v1,
            singular_values: Vec::new(),
            eta_scale: vec![1.0; d],
            nonlinear,
            conditioning: None,
        },
        dynamics,
        eigenvalues_ct,
        eta_range: vec![0.0; d],
        n_points: 0,
        observables: 1,
    })
}

/// Which reduced map of the SSM is iterated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum MapStyle {
    /// Every term of `R` kept, `W`'s nonlinear part in the complement (the faithful map; see
    /// the module docs).
    Graph,
    /// The model's normal-form style (`crate::equation_ssm`'s, whose polar form is the
    /// equation-driven model): `R` keeps only the structural terms, so its iterate is
    /// rotation-equivariant (the phases averaged out at every order up to `K`). For the
    /// measurement that separates the normal form's truncation from the map-to-flow step.
    /// Its reduced coordinates of a state are `U^T s` only at linear order.
    NormalForm,
}

/// The equation-driven reduced map of the paper's loop at `dt_ms` and `order` (3..=9).
pub fn furuta_equation_map(dt_ms: f64, order: u32) -> Result<SsmModel, Error> {
    furuta_equation_map_styled(dt_ms, order, MapStyle::Graph)
}

/// [`furuta_equation_map`] in the style `style`.
pub fn furuta_equation_map_styled(dt_ms: f64, order: u32, style: MapStyle) -> Result<SsmModel, Error> {
    let (pm, s) = match style {
        MapStyle::Graph => furuta_graph_ssm(dt_ms, order)?,
        MapStyle::NormalForm => crate::equation_ssm::furuta_normal_form_ssm(dt_ms, order)?,
    };
    let mut c = vec![0.0; pm.dim()];
    c[pm.primary] = 1.0;
    model_of_ssm(&s, &c)
}

/// The reduced coordinates of the full system's start on the linear modes with theta
/// amplitudes `rho` and phases 0 ([`crate::full_system::start_from_rho`]): the master
/// coordinates `z = U^T s` of that start are `z_j = rho_j` exactly (theta = `Re z_1 + Re z_2`
/// at linear order), so `eta = (rho_1, 0, rho_2, 0)`.
pub fn torus_start(rho: [f64; 2]) -> Vec<f64> {
    vec![rho[0], 0.0, rho[1], 0.0]
}

/// The projection of a full-system start onto the equation map's reduced coordinates at one
/// sampling period: the start (plant state and controller pre-history) in the period map's
/// deflated coordinates `s` ([`crate::map_global::deflated_of_start`]; as in
/// `sim::taylor::PeriodMap`: the plant states but `phi`, the samples `y[i-1] .. y[i-1-r]`,
/// then `z[i-1-k] - phi` for `k = 0..=r`), then `z_j = u_j^T s` with the
/// left eigenvectors `u_j` of the exact linear one-period map at that dt (the ZOH
/// discretization, deflated), normalized as the graph-style SSM's (`c . v_j = 1/2`,
/// `u_j^T v_l = delta_jl`; `ssm::map_ssm` itself computes them, at order 1). In graph style
/// `U^T W(z) = z` exactly, so `U^T s` is the manifold point the start projects to along the
/// complementary spectral subspace (the start's part in the other modes decays with their
/// multipliers); that part is dropped, as the fitted map drops what
/// its tangent space does not see.
#[derive(Clone, Debug)]
pub struct StartProjection {
    pub dt_ms: f64,
    /// Controller delay `r` (samples).
    pub delay: usize,
    /// Rows `Re u_1, Im u_1, Re u_2, Im u_2` over the deflated state (`eta = rows . s`).
    pub rows: [Vec<f64>; 4],
}

impl StartProjection {
    /// The projection of the paper's loop (the `furuta-dt30.5` scene) at `dt_ms`.
    pub fn furuta(dt_ms: f64) -> Result<StartProjection, Error> {
        let scene = crate::full_system::scene_at(dt_ms)?;
        let cfg = scene.controller_config();
        let lin = sim::stability::linear_plant(&scene)?;
        if lin.dim() != 4 || lin.primary() != 0 || lin.secondary() != 2 {
            return Err(Error::BadInput {
                what: "plant",
                why: "the start projection needs the 4-state Furuta plant [theta, w_theta, phi, w_phi]".into(),
            });
        }
        let a = lin.closed_loop(&cfg)?.deflated()?;
        let d = a.nrows();
        let map = ssm::map_ssm::PolynomialMap {
            dim: d,
            linear: (0..d * d).map(|k| a[(k / d, k % d)]).collect(),
            nproj: 1,
            proj: vec![0.0; d],
            exps: Vec::new(),
            coef: vec![Vec::new(); d],
        };
        let mut observable = vec![0.0; d];
        observable[0] = 1.0;
        let opts = ssm::map_ssm::MapSsmOptions {
            order: 1,
            pairs: 2,
            resonance_tol: 0.0,
            observable,
            dt: cfg.dt,
            amplitude: ssm::map_ssm::Amplitude::Spectral,
        };
        let s = ssm::map_ssm::map_ssm(&map, &opts).map_err(|e| Error::from(ssm::Error::from(e)))?;
        let (u1, u2) = match (s.left.first(), s.left.get(2)) {
            (Some(u1), Some(u2)) if u1.len() == d && u2.len() == d => (u1, u2),
            _ => {
                return Err(Error::BadInput {
                    what: "linear map",
                    why: format!("expected 2 left eigenvectors of length {d}"),
                });
            }
        };
        let part = |u: &[(f64, f64)], im: bool| u.iter().map(|&(re, i)| if im { i } else { re }).collect::<Vec<f64>>();
        Ok(StartProjection {
            dt_ms,
            delay: cfg.delay as usize,
            rows: [part(u1, false), part(u1, true), part(u2, false), part(u2, true)],
        })
    }

    /// The start in deflated coordinates (length `3 + 2 (delay + 1)`). A start without
    /// pre-history has the plant at rest at its initial angles before t = 0, as the
    /// simulator takes it.
    pub fn deflated(&self, start: &crate::full_system::Start) -> Result<Vec<f64>, Error> {
        crate::map_global::deflated_of_start(start, self.delay)
    }

    /// The reduced coordinates `eta = (Re z_1, Im z_1, Re z_2, Im z_2)` of `start`.
    pub fn eta(&self, start: &crate::full_system::Start) -> Result<Vec<f64>, Error> {
        let s = self.deflated(start)?;
        if let Some(row) = self.rows.iter().find(|row| row.len() != s.len()) {
            return Err(Error::Shape { expected: row.len(), got: s.len() });
        }
        Ok(self.rows.iter().map(|row| row.iter().zip(&s).map(|(a, b)| a * b).sum()).collect())
    }
}

/// The equation map's fate of one full-system start by the full system's rules: the start
/// projected to `eta0` ([`StartProjection::eta`], `proj` at the map's dt), the map iterated
/// for `periods` periods (samples `0..=periods`, as a full-system run of `periods` periods),
/// theta read from `W(z(eta))` (the model's observable); escape at the first sample with
/// |theta| > `escape_theta` ([`crate::bifurcations::iterate_outcome`]).
pub fn equation_map_outcome(
    model: &SsmModel,
    proj: &StartProjection,
    start: &crate::full_system::Start,
    periods: u64,
    escape_theta: f64,
) -> Result<crate::full_system::Outcome, Error> {
    use ssm::dynamics::StepScratch;
    let dt = model.dynamics.map_dt().ok_or(Error::NotAMap)?;
    if (dt - sim::units::ms_to_s(proj.dt_ms)).abs() > 1e-9 * dt {
        return Err(Error::BadInput {
            what: "projection",
            why: format!("built at {} ms, but the map steps {} ms", proj.dt_ms, dt * 1e3),
        });
    }
    if model.manifold.p != 1 || model.manifold.dim != 4 {
        return Err(Error::BadInput {
            what: "model",
            why: format!(
                "needs the equation map's form (4 reduced coordinates, theta alone), got dim {} p {}",
                model.manifold.dim, model.manifold.p
            ),
        });
    }
    let eta0 = proj.eta(start)?;
    let mut scratch = StepScratch::default();
    // Map and lift prepared once for the run; theta is the one lifted coordinate
    // (`lift_one(.., 0)` is `lift_into`'s only entry, the same bits).
    let (map, manifold) = (model.dynamics.prepare(), model.manifold.prepare());
    let lift = std::cell::RefCell::new(ssm::poly::PolyScratch::default());
    let obs = |e: &[f64]| manifold.lift_one(e, &mut lift.borrow_mut(), 0);
    Ok(crate::bifurcations::iterate_outcome(
        |e| map.step(e, dt, &mut scratch),
        obs,
        &eta0,
        periods,
        0.0,
        dt,
        escape_theta,
    ))
}

/// The equation map's small-start switch by the fitted map's and the full system's rules
/// ([`crate::bifurcations::map_small_start_switch`]): at each dt the family's map (interpolated
/// by `interp`) is iterated from the full system's starts `ics_at(dt)` (e.g.
/// [`crate::full_system::default_ics`]) projected onto its reduced coordinates
/// ([`equation_map_outcome`]) for `periods` periods; the switch is the first dt with an escape
/// (|theta| > [`crate::full_system::ESCAPE_THETA`]), grid `n` on `[lo, hi]`, bisection to `tol` ms.
pub fn equation_map_switch(
    family: &EquationMapFamily,
    interp: Interp,
    ics_at: impl Fn(f64) -> Result<Vec<crate::full_system::Start>, Error> + Sync,
    (lo, hi, n, tol): (f64, f64, usize, f64),
    periods: u64,
) -> Result<crate::bifurcations::MapSwitch, Error> {
    if family.style != MapStyle::Graph {
        return Err(Error::BadInput {
            what: "family",
            why: "the start projection U^T s gives the reduced coordinates of the graph-style map only".into(),
        });
    }
    let escapes = |dt: f64| -> Result<Vec<bool>, Error> {
        let m = family.model_at(dt, interp)?;
        let proj = StartProjection::furuta(dt)?;
        let ics = ics_at(dt)?;
        let outs =
            crate::par_map(&ics, |ic| equation_map_outcome(&m, &proj, ic, periods, crate::full_system::ESCAPE_THETA))?;
        Ok(outs.iter().map(|o| !o.bounded()).collect())
    };
    crate::bifurcations::first_escape_switch(escapes, lo, hi, n, tol)
}

/// The equation-driven reduced maps at a few sampling periods (nodes), interpolated in dt.
#[derive(Clone, Debug, Serialize)]
pub struct EquationMapFamily {
    pub order: u32,
    pub style: MapStyle,
    /// Strictly increasing sampling periods (ms).
    pub nodes_ms: Vec<f64>,
    #[serde(skip)]
    pub maps: Vec<SsmModel>,
}

impl EquationMapFamily {
    /// The maps of the paper's loop at `nodes_ms` (at least 2, strictly increasing) and
    /// `order`, on the rayon pool.
    pub fn furuta(nodes_ms: &[f64], order: u32) -> Result<EquationMapFamily, Error> {
        Self::furuta_styled(nodes_ms, order, MapStyle::Graph)
    }

    /// [`EquationMapFamily::furuta`] in the style `style`.
    pub fn furuta_styled(nodes_ms: &[f64], order: u32, style: MapStyle) -> Result<EquationMapFamily, Error> {
        if nodes_ms.len() < 2 || nodes_ms.iter().any(|x| !x.is_finite()) || nodes_ms.windows(2).any(|w| w[1] <= w[0]) {
            return Err(Error::BadOption {
                what: "nodes_ms",
                why: format!("need at least 2 finite, strictly increasing periods, got {nodes_ms:?}"),
            });
        }
        let maps = crate::par_map(nodes_ms, |&dt| furuta_equation_map_styled(dt, order, style))?;
        Ok(EquationMapFamily { order, style, nodes_ms: nodes_ms.to_vec(), maps })
    }

    /// The map at `dt_ms` (inside the nodes): every coefficient of the increment and of the
    /// observable interpolated by `interp`, the step `dt_ms`.
    pub fn model_at(&self, dt_ms: f64, interp: Interp) -> Result<SsmModel, Error> {
        let w = interp_weights(&self.nodes_ms, dt_ms, interp)?;
        let maps: Vec<&SsmModel> = self.maps.iter().collect();
        mix_models(&maps, &w, 0, V1Mix::Mixed, sim::units::ms_to_s(dt_ms)).map_err(|e| match e {
            ssm::Error::Mix(MixError::Mismatch { index, part, .. }) => Error::BadInput {
                what: "equation map family",
                why: format!(
                    "node {} ms has other monomials than node {} ms ({part})",
                    self.nodes_ms[index], self.nodes_ms[0]
                ),
            },
            ssm::Error::Mix(MixError::NotAMap { .. }) => Error::NotAMap,
            e => e.into(),
        })
    }
}

/// The equation-driven map's global bifurcations by [`crate::map_global`]'s rules (those of
/// the fitted map and the full system): the saddle connection ([`map_connection`] on
/// `[lo, hi]`, grid `n`, bisection to `tol` ms) and the 2-torus continuation over `torus_dts`
/// ([`map_torus_continuation_from`] from [`torus_start`] of `start_rho`, `periods` each),
/// both on the family interpolated by `interp`, the two on the rayon pool.
#[derive(Clone, Debug, Serialize)]
pub struct EquationMapGlobal {
    pub order: u32,
    pub style: MapStyle,
    pub nodes_ms: Vec<f64>,
    pub interp: Interp,
    pub connection: Result<Connection, String>,
    pub torus: Result<TorusContinuation, String>,
}

/// See [`EquationMapGlobal`].
#[allow(clippy::too_many_arguments)]
pub fn equation_map_global(
    family: &EquationMapFamily,
    interp: Interp,
    (lo, hi, n, tol): (f64, f64, usize, f64),
    co: &ConnectionOptions,
    torus_dts: &[f64],
    start_rho: [f64; 2],
    periods: u64,
) -> EquationMapGlobal {
    let at = |dt: f64| family.model_at(dt, interp);
    let (connection, torus) = rayon::join(
        || map_connection(at, lo, hi, n, tol, co).map_err(|e| format!("not found ({e})")),
        || {
            map_torus_continuation_from(at, torus_dts, start_rho, torus_start(start_rho), periods)
                .map_err(|e| e.to_string())
        },
    );
    EquationMapGlobal {
        order: family.order,
        style: family.style,
        nodes_ms: family.nodes_ms.clone(),
        interp,
        connection,
        torus,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Complex;
    use ssm::dynamics::StepScratch;
    use ssm::poly::PolyScratch;

    /// Pinned values of [`golden_order5_connection_and_torus`] (ms, printed by it): the
    /// connection bracket's midpoint and the torus growth onset, against regressions.
    const GOLDEN_CONNECTION: f64 = 31.3234;
    const GOLDEN_ONSET: f64 = 31.7072;
    /// Pinned value of [`golden_order5_small_start_switch`] (ms, printed by it): the
    /// bracket's midpoint, inside the full system's bracket.
    const GOLDEN_SWITCH: f64 = 31.3359;

    fn theta(m: &SsmModel, eta: &[f64]) -> f64 {
        let mut out = vec![0.0; 1];
        m.manifold.lift_into(eta, &mut PolyScratch::default(), &mut out);
        out[0]
    }

    /// The model's step is the graph-style SSM's `R` and its observable is `c . W`, to
    /// rounding; one step of the model and one of the exact period-map expansion `F` agree in
    /// theta to the invariance error `F(W(z)) - W(R(z))` on that radius (graph style: `U^T W(z)
    /// = z`, so the reduced coordinates of `W(z)` are `z`).
    #[test]
    fn equation_map_is_the_reduced_map() {
        let (pm, s) = furuta_graph_ssm(31.0, 5).unwrap();
        let m = furuta_equation_map(31.0, 5).unwrap();
        assert_eq!((m.manifold.dim, m.manifold.p), (4, 1));
        assert_eq!(
            m.manifold.v1.iter().map(|x| (x * 1e12).round() / 1e12).collect::<Vec<_>>(),
            vec![1.0, 0.0, 1.0, 0.0]
        );
        // Graph style: no term removed, U^T W_m = 0.
        assert!(s.min_divisor.is_infinite());
        let map = crate::equation_ssm::polynomial_map(&pm);
        let inv = s.invariance_error(&map, 5, 0.02, 8);
        eprintln!("graph-style invariance error at r = 0.02: {:.3e} (rel {:.3e})", inv.abs, inv.rel);
        let dt = m.dynamics.map_dt().unwrap();
        for (k, eta) in [[0.012, 0.005, 0.01, -0.004], [-0.003, 0.014, 0.006, 0.009]].iter().enumerate() {
            let z: Vec<Complex<f64>> = [Complex::new(eta[0], eta[1]), Complex::new(eta[2], eta[3])]
                .iter()
                .flat_map(|z| [*z, z.conj()])
                .collect();
            let w: Vec<f64> = s.manifold_at(&z, 5).iter().map(|x| x.re).collect();
            let rz = s.reduced_at(&z, 5);
            let mut e = eta.to_vec();
            m.dynamics.step(&mut e, dt, &mut StepScratch::default());
            let want = [rz[0].re, rz[0].im, rz[2].re, rz[2].im];
            for i in 0..4 {
                assert!((e[i] - want[i]).abs() < 1e-14, "{k} {i}: {} vs {}", e[i], want[i]);
            }
            assert!((theta(&m, eta) - w[pm.primary]).abs() < 1e-15);
            let fw = pm.eval(&w).unwrap();
            let d = (theta(&m, &e) - fw[pm.primary]).abs();
            eprintln!("start {k}: |theta(R) - theta(F(W))| = {d:.3e}");
            assert!(d <= inv.abs, "{d} vs {}", inv.abs);
        }
    }

    /// Known answers of the start projection at 31.0 ms: (a) a start on the linear modes
    /// with amplitudes `rho` and phases `p` ([`crate::full_system::start_from_rho`]) has `z_j =
    /// rho_j e^{i p_j}` (theta = `Re z_1 + Re z_2` at linear order, mode 1 slow); (b) the left
    /// eigenvectors from the exact linear map equal the order-5 graph SSM's own to 1e-9
    /// (relative); (c) a start exactly on the manifold, `s = W(z0)` given as a plant state and
    /// pre-history, projects to `z0`, and the map's theta series from there equals that of
    /// the period map's expansion `F` iterated from `s` and that of the full system run from
    /// the start (the layout of the deflated coordinates) over 100 periods, to the stated
    /// tolerance 1e-7 rad (the differences, printed, are the order-5 truncation; a wrong
    /// layout of the pre-history moves theta by O(rho) = 1e-2).
    #[test]
    fn start_projection_known_answers() {
        let dt = 31.0;
        let proj = StartProjection::furuta(dt).unwrap();
        assert_eq!(proj.delay, 1);
        for (rho, ph) in [([0.03, 0.01], [0.0, 0.0]), ([0.02, 0.005], [0.7, -1.2]), ([0.0, 0.02], [0.0, 2.0])] {
            let (x, h) = crate::full_system::start_from_rho(dt, rho, ph).unwrap();
            let eta = proj.eta(&(x, Some(h))).unwrap();
            let want = [rho[0] * ph[0].cos(), rho[0] * ph[0].sin(), rho[1] * ph[1].cos(), rho[1] * ph[1].sin()];
            let err = eta.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            eprintln!("mode start rho {rho:?} phases {ph:?}: eta {eta:?}, error {err:.2e}");
            assert!(err < 1e-12, "{eta:?} vs {want:?}");
        }
        let (pm, s) = furuta_graph_ssm(dt, 5).unwrap();
        let unorm = s.left.iter().flatten().fold(0.0f64, |m, &(a, b)| m.max(a.hypot(b)));
        let du = [0usize, 2]
            .iter()
            .flat_map(|&j| s.left[j].iter().enumerate().map(move |(k, &(a, b))| (j, k, a, b)))
            .fold(0.0f64, |m, (j, k, a, b)| {
                let r = &proj.rows[j];
                m.max((r[k] - a).abs()).max((proj.rows[j + 1][k] - b).abs())
            });
        eprintln!("left eigenvectors: exact linear map vs the SSM's: {:.2e} (relative)", du / unorm);
        assert!(du / unorm < 1e-9);
        // A point on the manifold as a full-system start (phi = 0.3 rad, any: phi is cyclic).
        let z0 = [Complex::new(0.02, 0.008), Complex::new(0.012, -0.006)];
        let z: Vec<Complex<f64>> = z0.iter().flat_map(|z| [*z, z.conj()]).collect();
        let w: Vec<f64> = s.manifold_at(&z, 5).iter().map(|x| x.re).collect();
        assert_eq!(pm.names, ["x0", "x1", "x3", "y[i-1]", "y[i-2]", "z[i-1]-x2", "z[i-2]-x2"]);
        let phi = 0.3;
        let start: crate::full_system::Start =
            ([w[0], w[1], phi, w[2]], Some(vec![[w[4], w[6] + phi], [w[3], w[5] + phi]]));
        let back = proj.deflated(&start).unwrap();
        assert!(back.iter().zip(&w).all(|(a, b)| (a - b).abs() < 1e-15), "{back:?} vs {w:?}");
        assert_eq!(proj.deflated(&crate::map_global::start_of_deflated(&w).unwrap()).unwrap(), w);
        let eta = proj.eta(&start).unwrap();
        let want = [z0[0].re, z0[0].im, z0[1].re, z0[1].im];
        let err = eta.iter().zip(&want).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        eprintln!("manifold start: eta error {err:.2e}");
        assert!(err < 1e-10, "{eta:?} vs {want:?}");
        let m = furuta_equation_map(dt, 5).unwrap();
        let n = 100;
        let step = m.dynamics.map_dt().unwrap();
        let mut e = eta.clone();
        let mut sf = w.clone();
        let full = crate::full_system::run(dt, &start, n, 10.0).unwrap().primary();
        let (mut d_f, mut d_full, mut amp) = (0.0f64, 0.0f64, 0.0f64);
        for k in 0..=n as usize {
            let th = theta(&m, &e);
            d_f = d_f.max((th - sf[0]).abs());
            d_full = d_full.max((th - full[k]).abs());
            amp = amp.max(th.abs());
            m.dynamics.step(&mut e, step, &mut StepScratch::default());
            sf = pm.eval(&sf).unwrap();
        }
        eprintln!("theta over {n} periods (max |theta| {amp:.4}): map vs F {d_f:.2e}, map vs full system {d_full:.2e}");
        assert!(d_f < 1e-7 && d_full < 1e-7, "{d_f} {d_full}");
        // Refused: a start with the wrong pre-history length; a map at another dt.
        assert!(matches!(
            proj.eta(&([0.01, 0.0, 0.0, 0.0], Some(vec![[0.0, 0.0]]))),
            Err(Error::BadInput { what: "start", .. })
        ));
        let other = furuta_equation_map(31.5, 5).unwrap();
        assert!(matches!(
            equation_map_outcome(&other, &proj, &start, 10, 1.0),
            Err(Error::BadInput { what: "projection", .. })
        ));
    }

    /// Golden value, order 5 on 5 nodes (spline), the fitted map's settings (the full
    /// system's starts, 8000 periods, grid of 11 on [31.0, 32.0] ms, bisection to 0.005 ms):
    /// the equation map's small-start switch ([`GOLDEN_SWITCH`], within 0.005 ms); the
    /// normal-form-style family is refused (its reduced coordinates are not `U^T s`).
    #[test]
    fn golden_order5_small_start_switch() {
        let fam = EquationMapFamily::furuta(&[30.5, 31.0, 31.5, 32.0, 32.5], 5).unwrap();
        let t0 = std::time::Instant::now();
        let sw = equation_map_switch(
            &fam,
            Interp::Spline,
            crate::full_system::default_ics,
            (31.0, 32.0, 11, 0.005),
            crate::full_system::DEFAULT_SCAN_PERIODS,
        )
        .unwrap();
        eprintln!("order 5 switch: {sw:?} ({:.1} s)", t0.elapsed().as_secs_f64());
        let (a, b) = sw.bracket.unwrap();
        assert!(b - a <= 0.005 + 1e-12);
        assert!((0.5 * (a + b) - GOLDEN_SWITCH).abs() < 0.005, "{a} {b}");
        assert!(sw.monotone);
        let nf = EquationMapFamily::furuta_styled(&[30.5, 31.0], 5, MapStyle::NormalForm).unwrap();
        assert!(matches!(
            equation_map_switch(&nf, Interp::Spline, crate::full_system::default_ics, (30.5, 31.0, 3, 0.005), 10),
            Err(Error::BadInput { what: "family", .. })
        ));
    }

    /// Measurement (not a check): the equation map's small-start switch at orders 5, 7, 9
    /// with the full report's nodes (9, 30.5..32.5 ms, spline) and the fitted map's settings;
    /// per start, the first escaping grid dt.
    #[test]
    #[ignore]
    fn measure_equation_map_switch() {
        let nodes: Vec<f64> = (0..=8).map(|k| 30.5 + 0.25 * k as f64).collect();
        let orders: Vec<u32> = std::env::var("EQMAP_ORDERS")
            .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
            .unwrap_or(vec![5, 7, 9]);
        for order in orders {
            let t0 = std::time::Instant::now();
            let fam = EquationMapFamily::furuta(&nodes, order).unwrap();
            let sw = equation_map_switch(
                &fam,
                Interp::Spline,
                crate::full_system::default_ics,
                (31.0, 32.0, 11, 0.005),
                crate::full_system::DEFAULT_SCAN_PERIODS,
            )
            .unwrap();
            eprintln!("order {order}: {sw:?} ({:.1} s)", t0.elapsed().as_secs_f64());
        }
    }

    /// Measurement (not a check): per start, the escape time (s) of the full system and of the
    /// order-`EQMAP_ORDER` (default 7) equation map (9 nodes, spline) at dt in `EQMAP_DTS`
    /// (default 31.33..31.36 ms), 8000 periods: which start switches first and how its escape
    /// time differs, to place the full system's switch inside its coarse grid bracket.
    #[test]
    #[ignore]
    fn measure_switch_starts() {
        let nodes: Vec<f64> = (0..=8).map(|k| 30.5 + 0.25 * k as f64).collect();
        let order: u32 = std::env::var("EQMAP_ORDER").map(|s| s.parse().unwrap()).unwrap_or(7);
        let dts: Vec<f64> = std::env::var("EQMAP_DTS")
            .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
            .unwrap_or(vec![31.33, 31.335, 31.34, 31.3425, 31.345, 31.35, 31.36]);
        let fam = EquationMapFamily::furuta(&nodes, order).unwrap();
        let periods = crate::full_system::DEFAULT_SCAN_PERIODS;
        for &dt in &dts {
            let ics = crate::full_system::default_ics(dt).unwrap();
            let m = fam.model_at(dt, Interp::Spline).unwrap();
            let proj = StartProjection::furuta(dt).unwrap();
            let full = crate::full_system::switch_scan(&[dt], &ics, periods, crate::full_system::ESCAPE_THETA).unwrap();
            let map: Vec<_> = ics
                .iter()
                .map(|ic| equation_map_outcome(&m, &proj, ic, periods, crate::full_system::ESCAPE_THETA).unwrap())
                .collect();
            let t = |e: Option<f64>| e.map_or("-".to_string(), |t| format!("{t:.1}"));
            eprintln!(
                "dt {dt}: escape t full [{}], map [{}]",
                full.outcomes[0].iter().map(|o| t(o.escape_t)).collect::<Vec<_>>().join(", "),
                map.iter().map(|o| t(o.escape_t)).collect::<Vec<_>>().join(", ")
            );
        }
    }

    /// At a node the interpolated family is that node's map (to 1e-12, spline and linear);
    /// between nodes the step stays within 1e-3 relative of the map computed there.
    #[test]
    fn family_interpolates_the_node_maps() {
        let fam = EquationMapFamily::furuta(&[30.5, 31.0, 31.5, 32.0], 5).unwrap();
        let inc = |m: &SsmModel| match &m.dynamics {
            ReducedDynamics::Map { increment, .. } => increment.coef.clone(),
            _ => panic!("not a map"),
        };
        for interp in [Interp::Linear, Interp::Spline] {
            let at = fam.model_at(31.0, interp).unwrap();
            let node = &fam.maps[1];
            let err = inc(&at).iter().zip(inc(node)).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
            let err_obs = at
                .manifold
                .nonlinear
                .as_ref()
                .unwrap()
                .coef
                .iter()
                .zip(&node.manifold.nonlinear.as_ref().unwrap().coef)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(err < 1e-12 && err_obs < 1e-12, "{interp:?}: {err} {err_obs}");
            assert_eq!(at.dynamics.map_dt(), node.dynamics.map_dt());
        }
        let direct = furuta_equation_map(31.25, 5).unwrap();
        let mid = fam.model_at(31.25, Interp::Spline).unwrap();
        let eta = [0.05, 0.02, 0.02, -0.01];
        let dt = mid.dynamics.map_dt().unwrap();
        let (mut a, mut b) = (eta.to_vec(), eta.to_vec());
        mid.dynamics.step(&mut a, dt, &mut StepScratch::default());
        direct.dynamics.step(&mut b, dt, &mut StepScratch::default());
        let rel = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max) / 0.05;
        eprintln!("spline step at 31.25 ms vs direct: {rel:.2e}");
        assert!(rel < 1e-3, "{rel}");
        assert!(matches!(fam.model_at(33.0, Interp::Linear), Err(_)));
        assert!(matches!(EquationMapFamily::furuta(&[31.0], 5), Err(Error::BadOption { what: "nodes_ms", .. })));
    }

    /// Golden values, order 5 on 5 nodes (spline): the graph-style map's saddle connection
    /// by the fitted map's rule falls in the full system's bracket region (the full report's
    /// bifurcation table) and its torus growth onset near the full system's; the
    /// normal-form-style map of the same SSM (phases averaged) connects more than 0.1 ms away
    /// (the normal form's truncation, not the map). The values are printed.
    #[test]
    fn golden_order5_connection_and_torus() {
        let nodes = [30.5, 31.0, 31.5, 32.0, 32.5];
        let co = ConnectionOptions::default();
        let torus_dts: Vec<f64> = (0..=6).map(|k| ((31.6 + 0.05 * k as f64) * 1e4).round() / 1e4).collect();
        let graph = EquationMapFamily::furuta(&nodes, 5).unwrap();
        let g = equation_map_global(
            &graph,
            Interp::Spline,
            (31.2, 31.6, 3, 0.005),
            &co,
            &torus_dts,
            [0.097, 0.0277],
            16_000,
        );
        let nf = EquationMapFamily::furuta_styled(&nodes, 5, MapStyle::NormalForm).unwrap();
        let n = map_connection(|dt| nf.model_at(dt, Interp::Spline), 31.0, 31.4, 3, 0.005, &co).unwrap();
        let gb = g.connection.as_ref().unwrap().switch.bracket.unwrap();
        let t = g.torus.as_ref().unwrap();
        let nb = n.switch.bracket.unwrap();
        eprintln!(
            "graph: connection {gb:?}, torus lost {:?}, onset {:?}; normal-form map: connection {nb:?}",
            t.lost_between, t.growth_onset
        );
        assert!(gb.1 - gb.0 <= 0.005 + 1e-12);
        assert!((0.5 * (gb.0 + gb.1) - GOLDEN_CONNECTION).abs() < 0.01, "{gb:?}");
        assert_eq!(t.lost_between, Some((31.8, 31.85)));
        assert!((t.growth_onset.unwrap() - GOLDEN_ONSET).abs() < 0.01, "{:?}", t.growth_onset);
        assert!((0.5 * (nb.0 + nb.1) - 0.5 * (gb.0 + gb.1)).abs() > 0.1, "{nb:?} {gb:?}");
    }

    /// Measurement (not a check): the equation map's connection and torus loss at orders
    /// 5, 7, 9 with the full report's settings (9 nodes 30.5..32.5 ms, spline).
    #[test]
    #[ignore]
    fn measure_equation_map_by_order() {
        let nodes: Vec<f64> = (0..=8).map(|k| 30.5 + 0.25 * k as f64).collect();
        let torus_dts: Vec<f64> = (0..=14).map(|k| ((31.3 + 0.05 * k as f64) * 1e4).round() / 1e4).collect();
        let orders: Vec<u32> = std::env::var("EQMAP_ORDERS")
            .map(|s| s.split(',').map(|x| x.parse().unwrap()).collect())
            .unwrap_or(vec![5, 7, 9]);
        for order in orders {
            let t0 = std::time::Instant::now();
            let fam = EquationMapFamily::furuta(&nodes, order).unwrap();
            let t1 = t0.elapsed().as_secs_f64();
            let g = equation_map_global(
                &fam,
                Interp::Spline,
                (31.0, 32.0, 6, 0.005),
                &ConnectionOptions::default(),
                &torus_dts,
                [0.097, 0.0277],
                16_000,
            );
            let c = g.connection.as_ref().map(|c| (c.switch.bracket, c.switch.grid.clone()));
            let t = g.torus.as_ref().map(|t| {
                (
                    t.lost_between,
                    t.growth_onset,
                    t.steps.iter().map(|s| (s.dt_ms, s.rho, s.growth_rate, s.lost)).collect::<Vec<_>>(),
                )
            });
            eprintln!(
                "order {order}: family {t1:.1} s, total {:.1} s\n connection {c:?}\n torus {t:?}",
                t0.elapsed().as_secs_f64()
            );
        }
    }

    /// Measurement (not a check): at order 7, what separates the polar normal form from the
    /// map. (a) The normal-form-style reduced map iterated (same SSM as the polar form, phases
    /// averaged at every order, no map-to-flow step) by the same rules; (b) at a few dt: the
    /// fast saddle cycle's theta amplitude of the graph map, of the normal-form map, of the
    /// polar form (`saddle_cycles`' equation row) and of the full system.
    #[test]
    #[ignore]
    fn measure_polar_vs_map() {
        use crate::map_global::map_fast_circle;
        let nodes: Vec<f64> = (0..=8).map(|k| 30.5 + 0.25 * k as f64).collect();
        let torus_dts: Vec<f64> = (0..=14).map(|k| ((31.3 + 0.05 * k as f64) * 1e4).round() / 1e4).collect();
        let order: u32 = std::env::var("EQMAP_ORDER").map(|s| s.parse().unwrap()).unwrap_or(7);
        let co = ConnectionOptions::default();
        let nf = EquationMapFamily::furuta_styled(&nodes, order, MapStyle::NormalForm).unwrap();
        let graph = EquationMapFamily::furuta(&nodes, order).unwrap();
        for dt in [31.0, 31.3, 31.45] {
            let g = map_fast_circle(&graph.model_at(dt, Interp::Spline).unwrap(), &co).unwrap();
            let n = map_fast_circle(&nf.model_at(dt, Interp::Spline).unwrap(), &co).unwrap();
            let rows = crate::saddle_cycles::saddle_cycles(&[dt], 2, &[order], &co.circle).unwrap();
            let eq = &rows[0].equation[0];
            let full = rows[0].full.as_ref().map(|c| c.theta_amplitude);
            eprintln!(
                "dt {dt}: fast cycle theta amplitude: graph map {:.6} ({:.4} Hz), normal-form map {:.6} ({:.4} Hz), polar form rho {:?} theta {:?} ({:?} Hz), full {full:?}",
                g.theta_amplitude, g.freq_hz, n.theta_amplitude, n.freq_hz, eq.rho, eq.theta_amplitude, eq.freq_hz
            );
            let pf = crate::equation_ssm::furuta_equation_polar(dt, order).unwrap();
            let popts = ssm::portrait::PortraitOptions {
                rho_max: crate::bifurcations::RHO_MAX,
                ..ssm::portrait::PortraitOptions::default()
            };
            let fps = ssm::portrait::fixed_points(&pf, &popts).unwrap();
            eprintln!("  polar fixed points: {:?}", fps.iter().map(|f| (f.kind, f.rho)).collect::<Vec<_>>());
        }
        let g =
            equation_map_global(&nf, Interp::Spline, (31.0, 32.0, 6, 0.005), &co, &torus_dts, [0.097, 0.0277], 16_000);
        let c = g.connection.as_ref().map(|c| (c.switch.bracket, c.switch.grid.clone()));
        let t = g.torus.as_ref().map(|t| {
            (
                t.lost_between,
                t.growth_onset,
                t.steps.iter().map(|s| (s.dt_ms, s.rho, s.growth_rate, s.lost)).collect::<Vec<_>>(),
            )
        });
        eprintln!("normal-form map, order {order}:\n connection {c:?}\n torus {t:?}");
    }
}
