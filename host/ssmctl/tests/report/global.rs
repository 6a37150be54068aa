use serde_json::{Value, json};
use ssmctl::report::global::*;
use ssmctl::report::prose::Prose;

/// The quick report's values with made-up training variants of the fitted map (the full
/// report's table), for [`crate::report::pages`]'s checks.
pub(crate) fn map_variant_values() -> Value {
    let mut s = crate::report::pages::snapshot_summary();
    let spread = |x: f64| json!({"found": 2, "of": 2, "min": 31.5, "max": 31.5 + x, "spread_ms": x});
    let torus = json!({"lost_between": [31.7, 31.75], "lost_at_first_dt": false, "first_dt_ms": 31.3,
                       "growth_onset": 31.72});
    let first = json!({"lost_between": null, "lost_at_first_dt": true, "first_dt_ms": 31.3, "growth_onset": null});
    s["map_sensitivity"] = json!({
        "variants": [{"variant": "default (paper's periods, cut 0.2 rad)",
                      "connection": {"linear": {"bracket": [31.61, 31.62], "monotone": true},
                                     "spline": {"error": "no escape on the grid"}},
                      "torus": {"linear": torus, "spline": first}}],
        "spreads": {"connection_linear": spread(0.03), "connection_spline": spread(0.04),
                    "torus_onset_linear": spread(0.05), "torus_onset_spline": spread(0.06),
                    "torus_lost_linear": spread(0.07), "torus_lost_spline": spread(0.08)},
    });
    s
}

/// The equation section's paragraphs over made-up values: every number follows them.
#[test]
fn equation_paragraphs_follow_their_values() {
    use ssmctl::report::prose::{perturbed, unmoved};
    let p = Prose::new();
    let spread = |x: f64| json!({"found": 3, "of": 5, "min": 31.5, "max": 31.5 + x, "spread_ms": x});
    let cases = [
        (INVARIANCE, json!({"order": 9, "orders": [3, 5, 7, 9], "radii": [0.05, 0.1]})),
        (
            CUBIC,
            json!({"target": CUBIC_TARGET, "robust": CHART_ROBUST, "order": 7, "dyn_order": 7, "low_degree": 3,
                   "low_knee": 0.1, "knee": 0.2}),
        ),
        (
            WHERE_THE_NORMAL_FORM_ERRS,
            json!({"order": 7, "target": MAP_TARGET_MS, "graph": [{"order": 5, "at": 31.61}, {"order": 7, "at": null}],
                   "polar": [{"order": 7, "at": 31.82}], "full_error": null, "full": 31.55, "nf_conn": 31.7,
                   "nf_onset": 31.66, "gaps": [0.12, null, 0.031, 0.02, 0.05, 0.07]}),
        ),
        (
            MAP_VARIANTS,
            json!({"spreads": {"connection_linear": spread(0.03), "connection_spline": spread(0.04),
                               "torus_onset_linear": spread(0.05), "torus_onset_spline": spread(0.06),
                               "torus_lost_linear": spread(0.07), "torus_lost_spline": spread(0.08)},
                   "target": SPREAD_TARGET_MS, "low_degree": 3, "low_knee": 0.1}),
        ),
    ];
    for (t, v) in cases {
        let a = p.html("t", t, &v).unwrap();
        let b = p.html("t", t, &perturbed(&v)).unwrap();
        assert_eq!(unmoved(&a, &b).unwrap(), [], "{a}");
    }
}

/// The main figure carries the fitted map's verdict (its differing cells marked) over the
/// full system's basin with the normal forms' separatrices; the normal forms' marks are on
/// the second figure; the legend band overlaps no panel.
#[test]
fn the_main_basin_figure_shows_the_fitted_map_verdict() {
    let (r1, r2) = ([0.1, 0.2], [0.01, 0.02, 0.03]);
    let panel = |k: usize| BasinPanel {
        caption: format!("dt {k}"),
        full: vec![true, true, false, true, false, false],
        map_differs: vec![false, false, true, false, false, false],
        nf_differs: [vec![true; 6], vec![false, true, true, true, true, false]],
        separatrices: [vec![vec![(0.1, 0.01), (0.2, 0.02)]], vec![]],
    };
    let panels = [panel(0), panel(1), panel(2)];
    let main = overlay_panels(&panels, &r1, &r2, Verdicts::FittedMap);
    for (m, p) in main.iter().zip(&panels) {
        assert_eq!(m.marks.len(), 1);
        assert!(m.marks[0].0.contains("fitted map"), "{}", m.marks[0].0);
        assert_eq!(m.marks[0].2, p.map_differs);
        assert_eq!(m.bounded, p.full.as_slice());
        assert_eq!(m.curves.len(), 2);
    }
    let nf = overlay_panels(&panels, &r1, &r2, Verdicts::NormalForms);
    assert!(nf.iter().all(|p| p.marks.len() == 2 && p.marks.iter().all(|m| m.0.contains("normal form"))));
    for (l, mark) in [
        (ssmctl::draw::basin::overlay_layout(&main), "fitted map differs"),
        (ssmctl::draw::basin::overlay_layout(&nf), "normal form differs"),
    ] {
        assert!(l.panels.iter().all(|r| !r.overlaps(&l.legend)), "{l:?}");
        assert!(l.entries.iter().any(|e| e.0.contains(mark)), "{mark}: {:?}", l.entries);
    }
}

#[test]
fn value_spread_counts_the_values_found_and_spans_them() {
    let v = value_spread(&[Some(31.3156), None, Some(31.4), Some(31.3281)]);
    assert_eq!(v["found"], 3);
    assert_eq!(v["of"], 4);
    assert_eq!(v["min"], 31.3156);
    assert_eq!(v["max"], 31.4);
    assert!((v["spread_ms"].as_f64().unwrap() - 0.0844).abs() < 1e-12, "{v}");
    let none = value_spread(&[None, None]);
    assert_eq!(none["found"], 0);
    assert!(none["spread_ms"].is_null() && none["min"].is_null(), "{none}");
}
