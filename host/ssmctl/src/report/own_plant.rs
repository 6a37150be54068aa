//! Report section "Your own plant": a plant written as equations in a scene, end to end. The
//! cart-pole's stability region over its pendulum gains (a local sweep of scene overrides:
//! exact ZOH multipliers at each grid point), its simulated response, and the equation-driven
//! SSM of the Duffing chain (`ssm-equations`).

use crate::plot::{self, Series};
use crate::report::{Report, num};
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

/// Writes the section: `n` grid points per gain (fewer when `quick`), the response over
/// 300 periods when `quick`.
pub fn section(rep: &mut Report, quick: bool) -> Result<(), Box<dyn Error>> {
    rep.section(
        "own-plant",
        "Your own plant: plants written as equations",
        "A plant given by its mass matrix and forces in a scene (<code>kind = \"equations\"</code>) goes through \
         the same exact ZOH stability, simulation and equation-driven SSM as the built-in Furuta pendulum. \
         Stability region of the cart-pole (<code>cartpole-pd</code>) over its pendulum gains, its simulated \
         response at the bundled gains, and the SSM of the Duffing chain (<code>duffing-chain</code>) from its \
         equations.",
    );
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
        &rep.dir().join(chart),
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
    rep.figure(chart, &format!("cartpole-pd: stable d range per p ({n} x {n} grid, exact multipliers)"));
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
        &rep.dir().join(response),
        "cartpole-pd: simulated response",
        "t [s]",
        "theta [rad], x [m]",
        &[
            Series { name: "theta", points: &theta, color: RGBColor(20, 60, 160) },
            Series { name: "x", points: &x, color: RGBColor(200, 60, 20) },
        ],
        (640, 300),
    )?;
    rep.figure(response, "cartpole-pd: theta and x from theta = 0.05 rad");
    let late = |v: &[(f64, f64)]| v[v.len() / 2..].iter().fold(0.0f64, |m, p| m.max(p.1.abs()));
    rep.para(&format!(
        "Bundled gains theta.p = {}, theta.d = {}: largest multiplier modulus {}; {stable_points} of {} grid points \
         stable. Response over {} periods: max |theta| over the second half {} rad, max |x| {} m.",
        gain.p,
        gain.d,
        num(own_radius),
        n * n,
        tr.rows() - 1,
        num(late(&theta)),
        num(late(&x)),
    ));
    let e = crate::equations_command::compute(&Scene::load(SSM_SCENE, &[])?, SSM_ORDER)?;
    let rows: Vec<Vec<String>> =
        e.table.rows.iter().map(|r| vec![format!("rho_{}'", r.mode), r.monomial.clone(), num(r.value)]).collect();
    rep.para(&format!(
        "Equation-driven SSM of {SSM_SCENE} (order {SSM_ORDER}, amplitudes rho in m of x1): exact rates ln|mu|/dt {} 1/s \
         at {} Hz; the linear rows equal them.",
        e.exact_rates.iter().map(|r| num(*r)).collect::<Vec<_>>().join(", "),
        e.exact_freqs_hz.iter().map(|f| num(*f)).collect::<Vec<_>>().join(", "),
    ));
    rep.table(&["equation", "monomial", "coefficient"], &rows);
    let boundary_json: Vec<Value> =
        boundary.iter().map(|(p, b)| json!({"p": p, "d_stable": b.map(|(lo, hi)| [lo, hi])})).collect();
    rep.summary.insert(
        "own_plant".into(),
        json!({
            "chart": {"scene": CART_POLE, "grid": n, "p_range": P_RANGE, "d_range": D_RANGE,
                      "stable_points": stable_points, "columns": boundary_json,
                      "own_gains": [gain.p, gain.d], "own_radius": own_radius, "figure": chart},
            "response": {"periods": tr.rows() - 1, "max_abs_theta_late": late(&theta), "max_abs_x_late": late(&x),
                         "figure": response},
            "ssm": {"scene": SSM_SCENE, "order": SSM_ORDER, "exact_rates": e.exact_rates,
                    "exact_freqs_hz": e.exact_freqs_hz, "table": e.table.rows},
        }),
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quick section: the bundled gains are stable and inside the swept region, the SSM
    /// table's linear rows are the exact rates, the figures exist.
    #[test]
    fn own_plant_section_quick() {
        let dir = std::env::temp_dir().join(format!("ssmctl-own-plant-{}", std::process::id()));
        let mut rep = Report::new(&dir).unwrap();
        crate::output::create_dir(&dir.join("fig")).unwrap();
        section(&mut rep, true).unwrap();
        let v = &rep.summary["own_plant"];
        eprintln!("{}", serde_json::to_string(&v["chart"]).unwrap());
        eprintln!("{}", serde_json::to_string(&v["response"]).unwrap());
        assert!(v["chart"]["own_radius"].as_f64().unwrap() < 1.0);
        let stable = v["chart"]["stable_points"].as_u64().unwrap();
        assert!(stable > 0 && stable < 17 * 17, "{stable}");
        let (p, d) = (v["chart"]["own_gains"][0].as_f64().unwrap(), v["chart"]["own_gains"][1].as_f64().unwrap());
        let col = v["chart"]["columns"]
            .as_array()
            .unwrap()
            .iter()
            .min_by(|a, b| (a["p"].as_f64().unwrap() - p).abs().total_cmp(&(b["p"].as_f64().unwrap() - p).abs()))
            .unwrap();
        let r = col["d_stable"].as_array().unwrap();
        let (lo, hi) = (r[0].as_f64().unwrap(), r[1].as_f64().unwrap());
        assert!(lo - 1.0 <= d && d <= hi + 1.0, "{d} outside [{lo}, {hi}] at p = {p}");
        let rates = v["ssm"]["exact_rates"].as_array().unwrap();
        let table = v["ssm"]["table"].as_array().unwrap();
        for (i, r) in rates.iter().enumerate() {
            let lin =
                table.iter().find(|row| row["mode"] == i + 1 && row["monomial"] == format!("rho_{}", i + 1)).unwrap();
            let (a, b) = (lin["value"].as_f64().unwrap(), r.as_f64().unwrap());
            assert!((a - b).abs() < 1e-9 * b.abs(), "{a} {b}");
        }
        assert!(dir.join("fig/own_plant_chart.png").is_file() && dir.join("fig/own_plant_response.png").is_file());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
