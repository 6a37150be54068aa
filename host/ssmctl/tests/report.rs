//! The unit tests of `ssmctl::report`, a module per source module.

mod auto_table;
mod bifurcations;
mod cache;
mod chaos;
mod global;
mod normal_form;
mod own_plant;
mod pages;
mod prose;
mod reproduce;
mod sloshing;
mod verdict;

use serde_json::Value;
use ssmctl::report::*;

/// Parts built apart are appended in order; a summary key written twice is refused; the
/// timing section and its contents entry sit between the markers.
#[test]
fn parts_append_in_order_and_timings_are_marked() {
    let dir = std::env::temp_dir().join(format!("ssmctl-report-parts-{}", std::process::id()));
    let mut rep = Report::new(&dir).unwrap();
    let (mut a, mut b) = (rep.part(), rep.part());
    b.section("b", "B", "second");
    b.summary.insert("b".into(), Value::from(2));
    a.section("a", "A", "first");
    a.summary.insert("a".into(), Value::from(1));
    rep.append(a).unwrap();
    rep.append(b).unwrap();
    let mut dup = rep.part();
    dup.summary.insert("a".into(), Value::from(3));
    assert!(rep.append(dup).unwrap_err().contains("`a`"));
    rep.timings_section("timings", "Where the time goes", "wall");
    rep.para("1.0 s");
    rep.end_timings();
    rep.finish("t").unwrap();
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    let (ia, ib) = (html.find("<h2 id=\"a\"").unwrap(), html.find("<h2 id=\"b\"").unwrap());
    assert!(ia < ib);
    assert!(
        html.contains(&format!("{TIMINGS_BEGIN}<li><a href=\"#timings\">Where the time goes</a></li>{TIMINGS_END}"))
    );
    assert!(
        html.contains(&format!("{TIMINGS_BEGIN}\n<h2 id=\"timings\">"))
            && html.contains(&format!("<p>1.0 s</p>\n{TIMINGS_END}\n"))
    );
    assert_eq!(rep.summary["a"], 1);
    std::fs::remove_dir_all(&dir).unwrap();
}
