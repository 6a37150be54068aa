use serde_json::json;
use ssmctl::report::prose::*;

#[test]
fn numbers_are_found_and_names_and_units_skipped() {
    let t = "rho_1^3 at 0.05 rad, -3.2e-4 1/s, x2 and 2D, 17 x 17 grid; 1.5e3. (12 %) furuta-dt25, degree-1 (-2), the 0-1 test, docs/decisions/0001";
    assert_eq!(numbers_in(t), ["0.05", "-3.2e-4", "17", "17", "1.5e3", "12", "-2"]);
}

#[test]
fn templates_fill_numbers_and_refuse_unknown_names() {
    let p = Prose::new();
    let v = json!({"a": 0.123456, "n": 17, "list": [1.0, 2.5e-7], "f": 0.25, "name": "<x>"});
    let t = "{{ a | num }} {{ n * n }} {{ list | nums }} {{ f | pct(1) }} % {{ a | sci(2) }} {{ name }}";
    assert_eq!(p.html("t", t, &v).unwrap(), "0.1235 289 1, 2.500e-7 25.0 % 1.23e-1 &lt;x&gt;");
    assert!(p.text("t", t, &v).unwrap().ends_with(" <x>"));
    let e = p.html("t", "{{ missing | num }}", &v).unwrap_err();
    assert!(e.contains("`t`") && e.contains("undefined"), "{e}");
    let e = p.text("t", "{{ name | num }}", &v).unwrap_err();
    assert!(e.contains("not a number"), "{e}");
}

#[test]
fn signed_and_plain_numbers_format_as_rust_does() {
    let p = Prose::new();
    let v = json!({"a": 0.5, "b": -2.5e-4, "d": 31.0, "e": 30.8, "n": 16000, "l": [31.0, 31.55]});
    let t = "{{ a | signed(2) }} {{ b | ssci(2) }} {{ d | plain }} {{ e | plain }} {{ n | plain }} {{ l | plain }} {{ l | plain(\" / \") }}";
    assert_eq!(p.text("t", t, &v).unwrap(), "+0.50 -2.50e-4 31 30.8 16000 31, 31.55 31 / 31.55");
}

#[test]
fn a_typed_number_does_not_move_with_the_values() {
    let p = Prose::new();
    let v = json!({"a": 0.5, "n": 3});
    let t = "{{ a | num }} within 10 % over {{ n }} runs";
    let (x, y) = (p.html("t", t, &v).unwrap(), p.html("t", t, &perturbed(&v)).unwrap());
    assert_eq!(unmoved(&x, &y).unwrap(), [(1, "10".to_string())]);
}
