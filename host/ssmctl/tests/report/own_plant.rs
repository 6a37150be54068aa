use serde_json::Value;
use ssmctl::report::Report;
use ssmctl::report::own_plant::*;

/// The quick section: the bundled gains are stable and inside the swept region, the SSM
/// table's linear rows are the exact rates, the figures exist.
#[test]
fn own_plant_section_quick() {
    let dir = std::env::temp_dir().join(format!("ssmctl-own-plant-{}", std::process::id()));
    let mut rep = Report::new(&dir).unwrap();
    ssmctl::output::create_dir(&dir.join("fig")).unwrap();
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
        let lin = table.iter().find(|row| row["mode"] == i + 1 && row["monomial"] == format!("rho_{}", i + 1)).unwrap();
        let (a, b) = (lin["value"].as_f64().unwrap(), r.as_f64().unwrap());
        assert!((a - b).abs() < 1e-9 * b.abs(), "{a} {b}");
    }
    assert!(dir.join("fig/own_plant_chart.png").is_file() && dir.join("fig/own_plant_response.png").is_file());

    // The text follows the values: one value changed changes its number on the page, and
    // with every value moved, every number on the page moves.
    let body = |v: &Value| {
        let mut r = Report::new(&dir).unwrap();
        render(&mut r, v).unwrap();
        r.into_parts().0
    };
    let v = v.clone();
    let html = body(&v);
    let old = ssmctl::report::num(v["chart"]["own_radius"].as_f64().unwrap());
    assert!(html.contains(&format!("largest multiplier modulus {old};")), "{html}");
    let mut one = v.clone();
    one["chart"]["own_radius"] = serde_json::json!(0.8765);
    let changed = body(&one);
    assert!(changed.contains("largest multiplier modulus 0.8765;") && !changed.contains(&format!("modulus {old};")));
    let moved = ssmctl::report::prose::unmoved(&html, &body(&ssmctl::report::prose::perturbed(&v))).unwrap();
    assert!(moved.is_empty(), "numbers typed into the text, not from values: {moved:?}\n{html}");
    let _ = std::fs::remove_dir_all(&dir);
}
