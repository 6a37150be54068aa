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
