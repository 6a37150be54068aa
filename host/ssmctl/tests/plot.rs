use plotters::prelude::*;
use ssmctl::plot::*;

#[test]
fn bars_draw_and_refuse_bad_values() {
    let p = std::env::temp_dir().join(format!("ssmctl-bars-{}.png", std::process::id()));
    let blue = RGBColor(20, 60, 160);
    bars(&p, "t", "s", &[("a".into(), 1.5), ("b".into(), 0.0)], blue, (400, 160)).unwrap();
    assert!(p.metadata().unwrap().len() > 1000);
    assert!(bars(&p, "t", "s", &[], blue, (400, 160)).unwrap_err().to_string().contains("no bars"));
    let e = bars(&p, "t", "s", &[("c".into(), -1.0)], blue, (400, 160)).unwrap_err().to_string();
    assert!(e.contains("bar `c`"), "{e}");
    std::fs::remove_file(&p).unwrap();
}
