use serde_json::{Value, json};
use ssm::portrait::{Fate, PointKind};
use ssmctl::report::bifurcations::*;

#[test]
fn debug_text_writes_enums_as_rust_does() {
    use ssm::portrait::FateClass;
    for f in [
        FateClass::ConvergesTo(PointKind::LimitCycle { mode: 2 }),
        FateClass::LeavesBox,
        FateClass::ConvergesTo(PointKind::Torus2),
    ] {
        assert_eq!(debug_text(&serde_json::to_value(f).unwrap()), format!("{f:?}"));
    }
    let f = Fate::LeavesBox { at: (0.5, 0.25) };
    assert_eq!(debug_text(&serde_json::to_value(f).unwrap()), format!("{f:?}"));
}

/// The sensitivity section's values (full report only), made up, for
/// [`crate::report::pages`]'s checks.
pub(crate) fn sensitivity_values() -> Value {
    let row = |variant: &str, fit: Option<f64>| {
        json!({"variant": variant, "dts_ms": [30.5, 31.0], "max_theta": 0.2, "heteroclinic_dt_ms": 31.61,
               "torus_hopf_dt_ms": null, "small_start_switch_dt_ms": 31.33, "torus_30p8_rho": [0.09, 0.03],
               "fit_seconds": fit})
    };
    json!({
        "bifurcation_sensitivity": [row("default", None), row("more periods", Some(12.5))],
        "torus_full_vs_dt": [{"dt_ms": 30.8, "rho": [0.095, 0.028], "rho_spread": [0.001, 0.0005], "escaped": false},
                             {"dt_ms": 31.9, "escaped": true}],
        "page_bifsensitivity": {"max_rate_error": 0.0017, "torus_rho": TORUS_RHO, "torus_periods": TORUS_PERIODS,
                                "torus_tail_s": TORUS_TAIL_S, "torus_dt_ms": TORUS_DT_MS,
                                "escaped_why": [null, "left the box"]},
    })
}
