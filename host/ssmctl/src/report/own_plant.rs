//! Report section "Your own plant": a plant written as equations in a scene, end to end. The
//! cart-pole's stability region over its pendulum gains (a local sweep of scene overrides:
//! exact ZOH multipliers at each grid point), its simulated response, and the equation-driven
//! SSM of the Duffing chain (`ssm-equations`).

use crate::plot::{self, Series};
use crate::report::Report;
use crate::report::prose::Prose;
use plotters::style::RGBColor;
use serde_json::{Value, json};
use sim::closed_loop;
use sim::scene::{Scene, SceneBuilder};
use sim::stability;
use std::error::Error;

/// The cart-pole scene and the ranges of its pendulum gains swept (`theta.p`, `theta.d`).
const CART_POLE: &str = "cartpole-pd";
const P_RANGE: (f64, f64) = (-90.0, -10.0);
const D_RANGE: (f64, f64) = (-30.0, 0.0);
/// The scene whose equation-driven SSM is tabulated, and its order.
const SSM_SCENE: &str = "duffing-chain";
const SSM_ORDER: u32 = 5;

type SendError = Box<dyn Error + Send + Sync>;

/// The largest modulus of the non-structural multipliers of `scene` with the pendulum gains
/// `(p, d)`.
fn spectral_radius(p: f64, d: f64) -> Result<f64, Box<dyn Error>> {
    let o = [format!("controller.gains.theta.p={p}"), format!("controller.gains.theta.d={d}")];
    let s = Scene::load(CART_POLE, &o)?;
    Ok(stability::dominant_pairs(&s)?.first().map_or(f64::NAN, |m| m.abs))
}

/// Per grid column `p`: the lowest and highest `d` of the grid where the loop is stable
/// (`None` when no grid point of the column is).
type Boundary = Vec<(f64, Option<(f64, f64)>)>;

fn stable_region(n: usize) -> Result<(Boundary, usize), Box<dyn Error>> {
    let at = |(a, b): (f64, f64), k: usize| a + (b - a) * k as f64 / (n - 1) as f64;
    let cols = crate::report::par_map(&(0..n).collect::<Vec<_>>(), |&i| -> Result<_, SendError> {
        let p = at(P_RANGE, i);
        let mut stable = Vec::new();
        for j in 0..n {
            let d = at(D_RANGE, j);
            if spectral_radius(p, d).map_err(|e| e.to_string())? < 1.0 {
                stable.push(d);
            }
        }
        Ok((p, stable))
    })
    .map_err(|e| e as Box<dyn Error>)?;
    let count = cols.iter().map(|(_, s)| s.len()).sum();
    let boundary = cols
        .into_iter()
        .map(|(p, s)| (p, s.first().copied().zip(s.last().copied()).map(|(lo, hi)| (lo.min(hi), lo.max(hi)))))
        .collect();
    Ok((boundary, count))
}

/// The section's text over its values (the summary entry `own_plant`): every number is a
/// placeholder.
const INTRO: &str = "A plant given by its mass matrix and forces in a scene (<code>kind = \"equations\"</code>) goes \
     through the same exact ZOH stability, simulation and equation-driven SSM as the built-in Furuta pendulum. \
     Stability region of the cart-pole (<code>{{ chart.scene }}</code>) over its pendulum gains, its simulated response \
     at the bundled gains, and the SSM of the Duffing chain (<code>{{ ssm.scene }}</code>) from its equations.";
const CHART_CAPTION: &str =
    "{{ chart.scene }}: stable d range per p ({{ chart.grid }} x {{ chart.grid }} grid, exact multipliers)";
const RESPONSE_CAPTION: &str = "{{ chart.scene }}: theta and x from theta = {{ response.initial_theta | num }} rad";
const RESPONSE: &str = "Bundled gains theta.p = {{ chart.own_gains[0] | num }}, theta.d = {{ chart.own_gains[1] | num }}: \
     largest multiplier modulus {{ chart.own_radius | num }}; {{ chart.stable_points }} of {{ chart.grid * chart.grid }} \
     grid points stable. Response over {{ response.periods }} periods: max |theta| over the second half \
     {{ response.max_abs_theta_late | num }} rad, max |x| {{ response.max_abs_x_late | num }} m.";
const SSM: &str = "Equation-driven SSM of {{ ssm.scene }} (order {{ ssm.order }}, amplitudes rho in m of x1): exact \
     rates ln|mu|/dt {{ ssm.exact_rates | nums }} 1/s at {{ ssm.exact_freqs_hz | nums }} Hz; the linear rows equal them.";

/// Computes the section's values (the summary entry `own_plant`) and draws its figures into
/// `dir`: `n` grid points per gain (fewer when `quick`), the response over 300 periods when
/// `quick`.
fn compute(dir: &std::path::Path, quick: bool) -> Result<Value, Box<dyn Error>> {
    let n = if quick { 17 } else { 41 };
    let (boundary, stable_points) = stable_region(n)?;
    let base = Scene::load(CART_POLE, &[])?;
    let gain = base.measured()?.into_iter().next().ok_or("cartpole-pd measures no coordinate")?;
    let own_radius = spectral_radius(gain.p, gain.d)?;
    let lower: Vec<(f64, f64)> = boundary.iter().filter_map(|(p, b)| b.map(|(lo, _)| (*p, lo))).collect();
    let upper: Vec<(f64, f64)> = boundary.iter().filter_map(|(p, b)| b.map(|(_, hi)| (*p, hi))).collect();
    // A cross at the bundled gains (a polyline through its arms).
    let (dp, dd) = (0.02 * (P_RANGE.1 - P_RANGE.0), 0.03 * (D_RANGE.1 - D_RANGE.0));
    let own =
        [(gain.p - dp, gain.d), (gain.p + dp, gain.d), (gain.p, gain.d), (gain.p, gain.d - dd), (gain.p, gain.d + dd)];
    let chart = "fig/own_plant_chart.png";
    plot::lines(
        &dir.join(chart),
        "cartpole-pd: stable region over the pendulum gains",
        "theta.p",
        "theta.d",
        &[
            Series { name: "lowest stable d", points: &lower, color: RGBColor(20, 60, 160) },
            Series { name: "highest stable d", points: &upper, color: RGBColor(200, 60, 20) },
            Series { name: "bundled gains", points: &own, color: RGBColor(0, 0, 0) },
        ],
        (640, 360),
    )?;
    let mut b = SceneBuilder::load(CART_POLE)?;
    if quick {
        b = b.periods(300);
    }
    let s = b.build()?;
    let tr = closed_loop::simulate(&s, None)?;
    let col = |k: usize| -> Vec<(f64, f64)> { (0..tr.rows()).map(|i| (tr.t[i], tr.state(i, k))).collect() };
    let (theta, x) = (col(0), col(2));
    let response = "fig/own_plant_response.png";
    plot::lines(
        &dir.join(response),
        "cartpole-pd: simulated response",
        "t [s]",
        "theta [rad], x [m]",
        &[
            Series { name: "theta", points: &theta, color: RGBColor(20, 60, 160) },
            Series { name: "x", points: &x, color: RGBColor(200, 60, 20) },
        ],
        (640, 300),
    )?;
    let late = |v: &[(f64, f64)]| v[v.len() / 2..].iter().fold(0.0f64, |m, p| m.max(p.1.abs()));
    let e = crate::equations_command::compute(&Scene::load(SSM_SCENE, &[])?, SSM_ORDER)?;
    let boundary_json: Vec<Value> =
        boundary.iter().map(|(p, b)| json!({"p": p, "d_stable": b.map(|(lo, hi)| [lo, hi])})).collect();
    Ok(json!({
        "chart": {"scene": CART_POLE, "grid": n, "p_range": P_RANGE, "d_range": D_RANGE,
                  "stable_points": stable_points, "columns": boundary_json,
                  "own_gains": [gain.p, gain.d], "own_radius": own_radius, "figure": chart},
        "response": {"periods": tr.rows() - 1, "initial_theta": tr.state(0, 0), "max_abs_theta_late": late(&theta),
                     "max_abs_x_late": late(&x), "figure": response},
        "ssm": {"scene": SSM_SCENE, "order": SSM_ORDER, "exact_rates": e.exact_rates,
                "exact_freqs_hz": e.exact_freqs_hz, "table": e.table.rows},
    }))
}

/// Writes the section's text, figures and table from its values `v` (see `compute`).
pub fn render(rep: &mut Report, v: &Value) -> Result<(), Box<dyn Error>> {
    let p = Prose::new();
    rep.section("own-plant", "Your own plant: plants written as equations", &p.html("own-plant/intro", INTRO, v)?);
    let fig = |key: &str| v[key]["figure"].as_str().ok_or_else(|| format!("own_plant.{key}.figure is not a string"));
    rep.figure(fig("chart")?, &p.text("own-plant/chart", CHART_CAPTION, v)?);
    rep.figure(fig("response")?, &p.text("own-plant/response-caption", RESPONSE_CAPTION, v)?);
    rep.para(&p.html("own-plant/response", RESPONSE, v)?);
    rep.para(&p.html("own-plant/ssm", SSM, v)?);
    let rows = v["ssm"]["table"].as_array().ok_or("own_plant.ssm.table is not a list")?;
    let cells = ["rho_{{ mode }}'", "{{ monomial }}", "{{ value | num }}"];
    let rows: Vec<Vec<String>> = rows
        .iter()
        .map(|r| cells.iter().map(|c| p.text("own-plant/ssm-row", c, r)).collect())
        .collect::<Result<_, String>>()?;
    rep.table(&["equation", "monomial", "coefficient"], &rows);
    Ok(())
}

/// Writes the section: computes its values, renders its text from them and stores them in the
/// summary as `own_plant`.
pub fn section(rep: &mut Report, quick: bool) -> Result<(), Box<dyn Error>> {
    let v = compute(rep.dir(), quick)?;
    render(rep, &v)?;
    rep.summary.insert("own_plant".into(), v);
    Ok(())
}
