use super::*;

fn two_tone(n: usize, dt: f64, a1: impl Fn(f64) -> f64, a2: impl Fn(f64) -> f64, f: [f64; 2]) -> Vec<f64> {
    (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            0.01 + a1(t) * (TAU * f[0] * t + 0.3).cos() + a2(t) * (TAU * f[1] * t + 1.1).cos()
        })
        .collect()
}

/// Constant amplitudes lie in the fitted span: recovered to round-off in every window.
/// Linearly varying amplitudes: the fit is a phase-dependent weighted mean of the envelope
/// over the window (`tau sin(w tau)` is even and leaks into the cosine term), so the error is
/// first order in the slope: |error| <= 0.1 |A'| W (measured 0.049 and 0.042 of |A'| W).
/// Curved envelopes (a 30 %
/// modulation at 0.02 Hz; a growth at 0.05 1/s) are biased by the curvature across the
/// window: |error| <= 0.3 max|A''| W^2 (the quadratic term's projection, ~W^2/12, amplified
/// by the near-collinearity of the constant and a 1.1-cycle slow tone; measured 0.22 and
/// 0.09 of max|A''| W^2).
fn envelope_errors(a1: impl Fn(f64) -> f64 + Copy, a2: impl Fn(f64) -> f64 + Copy) -> [f64; 2] {
    let (dt, f) = (0.0315, [0.44, 8.4]);
    let x = two_tone(3000, dt, a1, a2, f);
    let a = mode_amplitudes(&x, dt, f, 2.5).unwrap();
    let mut worst = [0.0f64; 2];
    for (t, r) in &a {
        worst[0] = worst[0].max((r[0] - a1(*t)).abs());
        worst[1] = worst[1].max((r[1] - a2(*t)).abs());
    }
    worst
}

#[test]
fn mode_amplitudes_recovers_known_envelopes() {
    let (dt, f) = (0.0315, [0.44, 8.4]);
    let x = two_tone(3000, dt, |_| 0.08, |_| 0.03, f);
    let a = mode_amplitudes(&x, dt, f, 2.5).unwrap();
    let w = (2.5f64 / dt).round() as usize;
    assert_eq!(a.len(), 3000 - w + 1);
    for (_, r) in &a {
        assert!((r[0] - 0.08).abs() < 1e-10 && (r[1] - 0.03).abs() < 1e-10, "{r:?}");
    }
    let lin = envelope_errors(|t| 0.08 + 5e-4 * t, |t| 0.03 - 2e-4 * t);
    eprintln!("linear envelopes: worst absolute errors {lin:?}, ratios {:?}", [lin[0] / (5e-4 * 2.5), lin[1] / (2e-4 * 2.5)]);
    assert!(lin[0] < 0.1 * 5e-4 * 2.5 && lin[1] < 0.1 * 2e-4 * 2.5, "{lin:?}");
    let om = TAU * 0.02;
    let curved = envelope_errors(|t| 0.08 * (1.0 + 0.3 * (om * t).sin()), |t| 0.03 * (0.05 * (t - 50.0)).exp());
    let w2 = 2.5f64 * 2.5;
    let max_curv = [0.08 * 0.3 * om * om, 0.03 * 0.0025 * (0.05f64 * (3000.0 * dt - 50.0)).exp()];
    eprintln!("curved envelopes: worst absolute errors {curved:?}, ratios {:?}", [curved[0] / (max_curv[0] * w2), curved[1] / (max_curv[1] * w2)]);
    assert!(curved[0] < 0.3 * max_curv[0] * w2 && curved[1] < 0.3 * max_curv[1] * w2, "{curved:?}");
    // Bad inputs are named, not clamped.
    assert!(mode_amplitudes(&x, dt, [0.44, 20.0], 2.5).is_err());
    assert!(mode_amplitudes(&x, dt, [0.44, 0.44], 2.5).is_err());
    assert!(mode_amplitudes(&x, dt, f, 0.1).is_err());
    assert!(mode_amplitudes(&x[..10], dt, f, 2.5).unwrap().is_empty());
}

/// Off-bin tones: the log-quadratic interpolation of the zero-padded Hann spectrum reads
/// frequency and amplitude; a 40 % amplitude modulation at 0.03 Hz shows as sidebands whose
/// spacing is the modulation frequency. The sidebands must be resolved: 0.03 Hz is 5.7 bins
/// of the 6000-sample series (at 2.8 bins, 3000 samples, the carrier's Hann lobe biases the
/// sideband amplitude by 6 % and the spacing by 6 %).
#[test]
fn spectral_peaks_read_tones_and_sidebands() {
    let (n, dt) = (3000, 0.0315);
    let bin = 1.0 / (n as f64 * dt);
    let f = [0.4937, 8.2467];
    let x = two_tone(n, dt, |_| 0.07, |_| 0.02, f);
    let p = spectral_peaks(&x, dt, PEAK_REL_THRESHOLD).unwrap();
    eprintln!("{p:?} (bin {bin:.5} Hz)");
    assert_eq!(p.len(), 2, "{p:?}");
    for (q, (fr, am)) in p.iter().zip([(f[0], 0.07), (f[1], 0.02)]) {
        assert!((q.freq_hz - fr).abs() < 0.02 * bin, "{q:?} vs {fr}");
        assert!((q.amplitude - am).abs() < 0.01 * am, "{q:?} vs {am}");
    }
    let n = 6000;
    let bin = 1.0 / (n as f64 * dt);
    let x = two_tone(n, dt, |t| 0.07 * (1.0 + 0.4 * (TAU * 0.03 * t).cos()), |_| 0.02, f);
    let p = spectral_peaks(&x, dt, PEAK_REL_THRESHOLD).unwrap();
    eprintln!("{p:?}");
    assert_eq!(p.len(), 4, "{p:?}");
    assert!((p[0].amplitude - 0.014).abs() < 0.02 * 0.014 && (p[2].amplitude - 0.014).abs() < 0.02 * 0.014, "{p:?}");
    let s = sideband_spacing(&p, 2.0).unwrap();
    assert!((s - 0.03).abs() < 0.05 * bin, "spacing {s}");
}

/// Known facts (MODEL.md): small starts stay bounded at 31.2 ms and escape within tens of
/// seconds at 31.6 ms; in between, the pure fast-mode start of 1e-3 rad escapes at 31.38 ms
/// (measured: after 93 s) while the plain 0.05 rad start does not within 3000 periods.
#[test]
fn switch_scan_brackets_the_switch() {
    let (x, h) = mode_start(31.38, None, Some((1e-3, 0.0))).unwrap();
    let ics: Vec<Start> = vec![([0.05, 0.0, 0.0, 0.0], None), (x, Some(h))];
    let s = switch_scan(&[31.2, 31.38, 31.6], &ics, 3000, ESCAPE_THETA).unwrap();
    eprintln!("{}cost {:.2} s for {} runs", s.to_text(), s.wall_seconds, s.runs);
    assert!(s.outcomes[0].iter().all(Outcome::bounded));
    assert!(s.outcomes[0].iter().all(|o| o.max_theta < 0.3), "{:?}", s.outcomes[0]);
    assert_eq!(s.bracket(), Some((31.2, 31.38)));
    assert_eq!(s.all_escape_from(), Some(31.6));
    assert!(s.monotone());
    assert!(s.outcomes[1][0].bounded());
    let t = s.outcomes[1][1].escape_t.unwrap();
    assert!((80.0..100.0).contains(&t), "escape at {t}");
    for o in &s.outcomes[2] {
        let t = o.escape_t.unwrap();
        assert!((10.0..100.0).contains(&t), "escape at {t}");
    }
    assert!(switch_scan(&[31.4, 31.3], &ics, 10, 1.0).is_err());
    assert!(switch_scan(&[31.4], &[], 10, 1.0).is_err());
}

/// The stable 2-torus at 30.8 ms from theta0 = 0.05: bounded, the fast frequency within 1 %
/// of the exact linear one, the slow one shifted up by the amplitude (measured +13.7 %,
/// 0.501 vs 0.4405 Hz), amplitude about a tenth of a radian and consistent with the mode
/// amplitudes (max |theta| of two tones <= rho_1 + rho_2, reached on a long tail).
#[test]
fn torus_at_30_8_ms() {
    let tf = torus_full(30.8, &([0.05, 0.0, 0.0, 0.0], None), 8000, 80.0).unwrap();
    eprintln!("{tf:?}");
    let lin = tf.linear_freqs_hz;
    assert!(((tf.freqs_hz[1] - lin[1]) / lin[1]).abs() < 0.01, "{tf:?}");
    let shift = (tf.freqs_hz[0] - lin[0]) / lin[0];
    assert!((0.08..0.20).contains(&shift), "slow shift {shift}");
    assert!((0.08..0.2).contains(&tf.amplitude_theta), "{tf:?}");
    let sum = tf.rho[0] + tf.rho[1];
    assert!(tf.amplitude_theta < 1.05 * sum && tf.amplitude_theta > 0.9 * sum, "{tf:?}");
    assert!(tf.rho[0] > 2.0 * tf.rho[1], "slow component dominates: {:?}", tf.rho);
}

/// Domain of attraction at 31.6 ms (paper fig. 5): a start near the 2-torus stays, one
/// inside it (small slow amplitude) and one outside it escape.
#[test]
fn fates_at_31_6_ms() {
    let inside = fate_from(31.6, [0.08, 0.03], [0.0, 0.0], 6000).unwrap();
    let low = fate_from(31.6, [0.02, 0.03], [0.0, 0.0], 6000).unwrap();
    let high = fate_from(31.6, [0.14, 0.055], [0.0, 0.0], 6000).unwrap();
    eprintln!("inside {:?} {:?}; low {:?}; high {:?}", inside.bounded, inside.freqs_hz, low.escape_t, high.escape_t);
    assert!(inside.bounded && inside.escape_t.is_none());
    assert!(!low.bounded && !high.bounded);
    assert!((15.0..40.0).contains(&low.escape_t.unwrap()), "{:?}", low.escape_t);
    assert!(high.escape_t.unwrap() < 10.0, "{:?}", high.escape_t);
    // The first window reads the requested amplitudes (linear start, 1.25 s in).
    let r = inside.amps[0].1;
    assert!((r[0] - 0.08).abs() < 0.1 * 0.08 && (r[1] - 0.03).abs() < 0.15 * 0.03, "{r:?}");
    // Bounded run: the amplitudes stay near the torus.
    let tail = &inside.amps[inside.amps.len() / 2..];
    assert!(tail.iter().all(|a| (0.05..0.13).contains(&a.1[0]) && a.1[1] < 0.06), "amplitudes left the torus");
    assert!(fate_from(31.6, [0.0, 0.0], [0.0, 0.0], 10).is_err());
}

/// Near the 3-torus at 31.5 ms: the 150 s transient has the slow and fast peaks plus
/// sidebands; their spacing is the frequency of the slow amplitude's own oscillation
/// (measured 0.02097 vs 0.02092 Hz), two independent readings of the third frequency.
#[test]
fn transient_near_three_torus_shows_third_frequency() {
    let (x, h) = start_from_rho(31.5, [0.02, 0.035], [0.0, 0.0]).unwrap();
    let a = transient_analysis(31.5, &(x, Some(h)), 150.0).unwrap();
    eprintln!("{a:?}");
    assert!(a.peaks.len() >= 3, "{:?}", a.peaks);
    let (s, e) = (a.sideband_spacing_hz.unwrap(), a.envelope_freq_hz.unwrap());
    assert!((s - e).abs() < 0.02 * e, "sideband {s} vs envelope {e}");
    assert!((0.01..0.05).contains(&e), "{e}");
    let lin = exact_modes(31.5).unwrap().freqs_hz;
    assert!(((a.fast.freq_hz - lin[1]) / lin[1]).abs() < 0.03 && ((a.slow.freq_hz - lin[0]) / lin[0]).abs() < 0.2, "{a:?}");
}

/// Exploration, prints only: `FC_WHAT` selects the experiment.
#[test]
#[ignore = "exploration, prints only"]
fn furcheck_explore() {
    let what = std::env::var("FC_WHAT").unwrap_or_default();
    let envf = |k: &str, d: f64| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok()).unwrap_or(d);
    match what.as_str() {
        "torus" => {
            let dt = envf("FC_DT", 30.8);
            let t0 = Instant::now();
            let tf = torus_full(dt, &([0.05, 0.0, 0.0, 0.0], None), envf("FC_P", 3000.0) as u64, envf("FC_TAIL", 40.0)).unwrap();
            eprintln!("{tf:?} in {:.2} s", t0.elapsed().as_secs_f64());
        }
        "scan" => {
            let t0 = Instant::now();
            let s = default_switch_scan(envf("FC_P", 3000.0) as u64).unwrap();
            eprintln!("{}", s.to_text());
            eprintln!("bracket {:?} monotone {} runs {} wall {:.1} s ({:.1})", s.bracket(), s.monotone(), s.runs, s.wall_seconds, t0.elapsed().as_secs_f64());
        }
        "fate" => {
            let dt = envf("FC_DT", 31.5);
            let rho = [envf("FC_R1", 0.05), envf("FC_R2", 0.02)];
            let f = fate_from(dt, rho, [envf("FC_P1", 0.0), envf("FC_P2", 0.0)], envf("FC_P", 3000.0) as u64).unwrap();
            eprintln!("bounded {} escape {:?}", f.bounded, f.escape_t);
            for a in f.amps.iter().step_by(64) {
                eprintln!("  t {:7.2}  rho {:.4} {:.4}", a.0, a.1[0], a.1[1]);
            }
        }
        "spec" => {
            let dt = envf("FC_DT", 31.5);
            let rho = [envf("FC_R1", 0.05), envf("FC_R2", 0.02)];
            let (x, h) = start_from_rho(dt, rho, [envf("FC_P1", 0.0), envf("FC_P2", 0.0)]).unwrap();
            let a = transient_analysis(dt, &(x, Some(h)), envf("FC_S", 60.0)).unwrap();
            for q in &a.peaks {
                eprintln!("  {:.4} Hz  {:.5}", q.freq_hz, q.amplitude);
            }
            eprintln!("analysed {:.1} s escape {:?} slow {:?} fast {:?} sideband {:?} envelope {:?}", a.analysed_s, a.escape_t, a.slow, a.fast, a.sideband_spacing_hz, a.envelope_freq_hz);
        }
        "one" => {
            let p = envf("FC_P", 20000.0) as u64;
            let k = envf("FC_K", 2.0) as usize;
            for dt in std::env::var("FC_DTS").unwrap().split(',').map(|v| v.parse::<f64>().unwrap()) {
                let ic = default_ics(dt).unwrap().swap_remove(k);
                let tr = run(dt, &ic, p, ESCAPE_THETA).unwrap();
                let o = outcome_of(&tr);
                let fr = exact_modes(dt).unwrap().freqs_hz;
                let am = mode_amplitudes(&tr.primary(), tr.dt, fr, AMP_WINDOW_S).unwrap();
                let pts: Vec<String> = am.iter().step_by(320).map(|a| format!("{:.0}:({:.3},{:.3})", a.0, a.1[0], a.1[1])).collect();
                eprintln!("dt {dt} ic {k}: {o:?}\n   {}", pts.join(" "));
            }
        }
        "grid" => {
            let dt = envf("FC_DT", 31.45);
            let p = envf("FC_P", 6000.0) as u64;
            let r1s: Vec<f64> = (0..10).map(|i| 0.02 + 0.015 * i as f64).collect();
            let r2s: Vec<f64> = (0..7).map(|i| 0.005 + 0.01 * i as f64).collect();
            for &r2 in r2s.iter().rev() {
                let mut line = format!("r2 {r2:.3}: ");
                for &r1 in &r1s {
                    let (x, h) = start_from_rho(dt, [r1, r2], [0.0, 0.0]).unwrap();
                    let o = outcome_of(&run(dt, &(x, Some(h)), p, ESCAPE_THETA).unwrap());
                    line.push_str(&match o.escape_t { None => "   B  ".to_string(), Some(t) => format!("{t:5.0} ") });
                }
                eprintln!("{line}");
            }
            eprintln!("r1 = {r1s:?}");
        }
        _ => eprintln!("set FC_WHAT"),
    }
}

/// `mode_start` on the fast mode alone: theta's envelope grows at the exact fast rate
/// (`ln|mu|/dt`, +0.27 1/s) and its first sample is the requested amplitude times
/// cos(phase); the mixed start's theta is the sum of the two single-mode starts (linear).
#[test]
fn mode_start_excites_the_fast_mode() {
    let dt_ms = 31.0;
    let e = exact_modes(dt_ms).unwrap();
    let (x, h) = mode_start(dt_ms, None, Some((1e-4, 0.4))).unwrap();
    assert!((x[0] - 1e-4 * 0.4f64.cos()).abs() < 1e-12, "{x:?}");
    let tr = run(dt_ms, &(x, Some(h)), 640, ESCAPE_THETA).unwrap();
    let th = tr.primary();
    let per = 32; // ~1 s chunks, 8 fast periods each
    let peaks: Vec<f64> = th.chunks(per).take(20).map(|c| c.iter().fold(0.0f64, |m, v| m.max(v.abs()))).collect();
    let rate = (peaks[18] / peaks[2]).ln() / (16.0 * per as f64 * tr.dt);
    eprintln!("fast envelope rate {rate:+.5} vs exact {:+.5}", e.rates[1]);
    assert!(((rate - e.rates[1]) / e.rates[1]).abs() < 0.05, "{rate} vs {}", e.rates[1]);
    let (s, hs) = mode_start(dt_ms, Some((2e-3, 1.0)), None).unwrap();
    let (f, hf) = mode_start(dt_ms, None, Some((1e-3, -0.5))).unwrap();
    let (m, hm) = mode_start(dt_ms, Some((2e-3, 1.0)), Some((1e-3, -0.5))).unwrap();
    for k in 0..4 {
        assert!((m[k] - s[k] - f[k]).abs() < 1e-12 * (1.0 + m[k].abs()), "{k}");
    }
    for ((a, b), c) in hs.iter().zip(&hf).zip(&hm) {
        assert!((c[0] - a[0] - b[0]).abs() < 1e-14 && (c[1] - a[1] - b[1]).abs() < 1e-14);
    }
    assert!(mode_start(dt_ms, None, None).is_err());
    assert!(mode_start(dt_ms, Some((-1e-3, 0.0)), None).is_err());
}

/// Exploration: the full system's fast-mode cycle (start on the fast mode only, tiny slow
/// part) against the model's fast saddle cycle; prints the amplitude history.
#[test]
#[ignore = "exploration, prints only"]
fn fast_cycle_explore() {
    for dt in [30.8, 31.2, 31.4, 31.6] {
        let f = fate_from(dt, [1e-7, 0.005], [0.0, 0.0], 6000).unwrap();
        let pick: Vec<String> = f.amps.iter().step_by((f.amps.len() / 16).max(1)).map(|(t, r)| format!("{t:.0}:({:.4},{:.4})", r[0], r[1])).collect();
        eprintln!("FAST dt {dt}: bounded {} escape {:?}: {}", f.bounded, f.escape_t, pick.join(" "));
    }
}
