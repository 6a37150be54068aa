//! The tests of `chaos_study::microchaos`.

use chaos::held_out::Context;
use chaos_study::Error;
use chaos_study::microchaos::*;
use sim::closed_loop::Trajectory;
use sim::scene::{Scene, SceneBuilder};
use ssm::{SsmModel, TimeSeries};

/// The runs [`analyse_held_out_runs`] returns are what the report drew before it shared
/// them: each model's fresh `predict` over the held-out series and `reduce_series` of it
/// under the first model, bit for bit.
#[test]
fn held_out_runs_equal_fresh_predictions_bit_for_bit() {
    let runs: Vec<TimeSeries> = [0.02, 0.035]
        .iter()
        .enumerate()
        .map(|(i, th)| simulate_quantized(2500, *th, &format!("quant #{i}")).unwrap())
        .collect();
    let o = ChaosOptions { centers: 60, ssm_dim: Some(4), ..ChaosOptions::default() };
    let (_, models, held) = analyse_held_out_runs(&runs[..1], Some(&runs[1]), &o).unwrap();
    assert_eq!(models.len(), 2);
    assert_eq!(held.len(), models.len());
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for ((kind, m), h) in models.iter().zip(&held) {
        let p = m.predict(&runs[1]).unwrap();
        assert_eq!(bits(&h.prediction.x), bits(&p.x), "{kind} x");
        assert_eq!(bits(&h.prediction.eta), bits(&p.eta), "{kind} eta");
        assert_eq!(bits(&h.prediction.t), bits(&p.t), "{kind} t");
        assert_eq!(h.prediction.stop.is_some(), p.stop.is_some(), "{kind} stop");
        assert_eq!(bits(&h.eta_data), bits(&reduce_series(m, &runs[1]).unwrap()), "{kind} eta_data");
    }
}

/// [`evaluate_kicked`] as it was (kept here): residuals by the plain step, the data's
/// reduced coordinates formed again.
fn evaluate_kicked_plain(
    m: &SsmModel,
    train: &[TimeSeries],
    data: &TimeSeries,
    ctx: &Context,
    seed: u64,
    name: &str,
) -> Result<KickedStats, Error> {
    use ssm::dynamics::StepScratch;
    let d = m.options.dim;
    let mut sc = StepScratch::default();
    let mut res = Vec::new();
    for ts in train {
        let e = reduce_series(m, ts)?;
        for k in 0..(e.len() / d).saturating_sub(1) {
            let mut x = e[k * d..(k + 1) * d].to_vec();
            m.dynamics.step(&mut x, m.dt, &mut sc);
            res.extend(e[(k + 1) * d..(k + 2) * d].iter().zip(&x).map(|(a, b)| a - b));
        }
    }
    let nres = res.len() / d;
    if nres == 0 {
        return Err(Error::BadInput {
            what: "kicked model",
            why: format!("{name}: no training pairs for the residuals"),
        });
    }
    let residual_rms = (res.iter().map(|v| v * v).sum::<f64>() / nres as f64).sqrt();
    let eta_data = reduce_series(m, data)?;
    let n = eta_data.len() / d;
    let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    let bound = chaos_study::lyapunov::model_bound(m);
    let mut eta = eta_data[..d].to_vec();
    let mut etas = Vec::with_capacity(n * d);
    let mut x = Vec::with_capacity(n);
    let mut lifted = vec![0.0; m.manifold.p];
    let mut ps = ssm::poly::PolyScratch::default();
    let mut notes = Vec::new();
    let (map, manifold) = (m.dynamics.prepare(), m.manifold.prepare());
    for step in 0..n {
        if !eta.iter().all(|v| v.is_finite() && v.abs() <= bound) {
            notes.push(format!("{name} kicked model left the bound {bound:.3e} at step {step}"));
            break;
        }
        etas.extend_from_slice(&eta);
        manifold.lift_into(&eta, &mut ps, &mut lifted);
        x.push(lifted[0]);
        map.step(&mut eta, m.dt, &mut sc);
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        let k = (state % nres as u64) as usize;
        for (e, r) in eta.iter_mut().zip(&res[k * d..(k + 1) * d]) {
            *e += r;
        }
    }
    let (lle_rosenstein, js) = series_statistics(
        ctx,
        d,
        &x,
        etas,
        eta_data,
        &format!("{name} kicked"),
        &format!("{name} kicked model"),
        &mut notes,
    );
    Ok(KickedStats { lle_rosenstein, js, residual_rms, notes })
}

/// The kicked statistics [`analyse_held_out_runs`] reports (residuals by the prepared
/// step, the data's reduced coordinates of the model's run) equal the plain evaluation's
/// bit for bit, RBF and polynomial, and so does [`evaluate_kicked`].
#[test]
fn kicked_runs_equal_the_plain_evaluation() {
    let runs: Vec<TimeSeries> = [0.02, 0.035]
        .iter()
        .enumerate()
        .map(|(i, th)| simulate_quantized(2500, *th, &format!("quant #{i}")).unwrap())
        .collect();
    let o = ChaosOptions { centers: 60, ssm_dim: Some(4), ..ChaosOptions::default() };
    let (s, models, _) = analyse_held_out_runs(&runs[..1], Some(&runs[1]), &o).unwrap();
    let ctx = Context::from_series(&runs[1].x, runs[1].dt().unwrap(), o.gp_embed).unwrap();
    let bits = |v: Option<f64>| v.map(f64::to_bits);
    assert_eq!(models.len(), 2);
    for (kind, m) in &models {
        let old = evaluate_kicked_plain(m, &runs[..1], &runs[1], &ctx, 1, kind).unwrap();
        let new = evaluate_kicked(m, &runs[..1], &runs[1], &ctx, 1, kind).unwrap();
        let (l, j) = if *kind == "rbf" {
            (s.lle_model_rbf_kicked, s.pdf_divergence_rbf_kicked)
        } else {
            (s.lle_model_poly_kicked, s.pdf_divergence_poly_kicked)
        };
        assert_eq!((bits(l), bits(j)), (bits(old.lle_rosenstein), bits(old.js)), "{kind}");
        assert_eq!(
            (bits(new.lle_rosenstein), bits(new.js), new.residual_rms.to_bits(), &new.notes),
            (bits(old.lle_rosenstein), bits(old.js), old.residual_rms.to_bits(), &old.notes),
            "{kind}"
        );
        assert!(old.lle_rosenstein.is_some() || old.js.is_some(), "{kind}: {:?}", old.notes);
    }
}

/// A run served by [`simulate_shared`] equals a plain `simulate` bit for bit: the same
/// length again (kept run), a shorter one (prefix of the kept run), and a longer one
/// (simulated afresh, then kept).
#[test]
fn shared_runs_equal_fresh_runs_bit_for_bit() {
    let scene = |periods: u64| {
        SceneBuilder::load("furuta-quant-dt25")
            .unwrap()
            .periods(periods)
            .initial_state(&[0.0312, 0.0, 0.0, 0.0])
            .build()
            .unwrap()
    };
    let same = |a: &Trajectory, b: &Trajectory| {
        assert_eq!(a.rows(), b.rows());
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&a.t), bits(&b.t));
        assert_eq!(bits(&a.states), bits(&b.states));
        assert_eq!(bits(&a.u), bits(&b.u));
        assert_eq!(a.codes, b.codes);
        assert_eq!((a.saturated_samples, &a.stopped), (b.saturated_samples, &b.stopped));
    };
    for periods in [600, 600, 250, 900, 400] {
        let fresh = sim::closed_loop::simulate(&scene(periods), None).unwrap();
        same(&simulate_shared(&scene(periods)).unwrap(), &fresh);
    }
    // A run that saturates (the quantized loop with the amplifier clipped at 0.3 V): the
    // prefix counts only its own clipped samples.
    let sat = |periods: u64| {
        let s = Scene::load("furuta-quant-dt25", &["effects.saturation.u_max=0.3".to_string()]).unwrap();
        s.builder().periods(periods).initial_state(&[0.0312, 0.0, 0.0, 0.0]).build().unwrap()
    };
    let long = simulate_shared(&sat(400)).unwrap();
    for periods in [400, 120, 60] {
        let fresh = sim::closed_loop::simulate(&sat(periods), None).unwrap();
        let shared = simulate_shared(&sat(periods)).unwrap();
        same(&shared, &fresh);
        assert_eq!(shared.saturated_rows, fresh.saturated_rows);
        assert_eq!(fresh.saturated_rows.len() as u64, fresh.saturated_samples);
        eprintln!(
            "furuta-saturation, {periods} periods: {} saturated samples (of {} in 400)",
            fresh.saturated_samples, long.saturated_samples
        );
    }
    let s120 = sim::closed_loop::simulate(&sat(120), None).unwrap().saturated_samples;
    assert!(s120 > 0 && s120 < long.saturated_samples, "{s120} of {}", long.saturated_samples);
}
