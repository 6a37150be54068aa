//! The tests of `ssm::data`.

use ssm::data::*;

fn parse(text: &str) -> Result<TimeSeries, DataError> {
    parse_csv("mem.csv", "mem".into(), text)
}

#[test]
fn parses_valid_file() {
    let ts = parse("t_s,x\n0,1\n0.5,2\n1.0,-3.5\n").unwrap();
    assert_eq!(ts.t, vec![0.0, 0.5, 1.0]);
    assert_eq!(ts.x, vec![1.0, 2.0, -3.5]);
    assert!((ts.dt().unwrap() - 0.5).abs() < 1e-15);
}

#[test]
fn errors_name_the_line_or_row() {
    let e = parse("t,x\n0,1\n0.5,abc\n").unwrap_err();
    assert!(matches!(&e, DataError::Parse { line: 3, column, .. } if column == "x"), "{e}");
    assert!(e.to_string().contains("mem.csv: line 3"), "{e}");

    let e = parse("t,x\n0,1\n0.5\n").unwrap_err();
    assert!(matches!(e, DataError::Columns { line: 3, found: 1, .. }), "{e}");

    let e = parse("t,x\n0,1\n0.5,NaN\n1,2\n").unwrap_err();
    assert!(matches!(&e, DataError::NonFinite { row: 2, column, .. } if column == "x"), "{e}");

    let e = parse("t,x\n0,1\n0.5,2\n0.5,3\n").unwrap_err();
    assert!(matches!(e, DataError::NonIncreasing { row: 3, .. }), "{e}");

    let e = parse("t,x\n0,1\n0.5,2\n1.0,3\n1.6,4\n2.0,5\n").unwrap_err();
    assert!(matches!(e, DataError::UnevenSampling { row: 4, .. }), "{e}");

    let e = parse("t,x\n0,2\n1,2\n2,2\n").unwrap_err();
    assert!(matches!(e, DataError::Constant { .. }), "{e}");

    let e = parse("").unwrap_err();
    assert!(matches!(e, DataError::NoHeader { .. }), "{e}");

    let e = parse("t,x\n0,1\n").unwrap_err();
    assert!(matches!(e, DataError::TooShort { have: 1, need: 2, .. }), "{e}");
}

#[test]
fn named_column_of_a_wider_file() {
    let text = "t,theta,w,u\n0,0.1,5,1\n0.5,0.2,6,1\n1.0,-0.1,7,1\n";
    let ts = parse_csv_column("sim.csv", "sim".into(), text, Some("theta")).unwrap();
    assert_eq!((ts.t.clone(), ts.x.clone()), (vec![0.0, 0.5, 1.0], vec![0.1, 0.2, -0.1]));
    let ts = parse_csv_column("sim.csv", "sim".into(), text, Some("w")).unwrap();
    assert_eq!(ts.x, vec![5.0, 6.0, 7.0]);
    // Without a name a wide file is an error that says what to do.
    let e = parse_csv_column("sim.csv", "sim".into(), text, None).unwrap_err();
    assert!(matches!(e, DataError::ManyColumns { found: 4, .. }) && e.to_string().contains("--column"), "{e}");
    // Unknown names (and the time column itself) list the available ones.
    for bad in ["phi", "t"] {
        let e = parse_csv_column("sim.csv", "sim".into(), text, Some(bad)).unwrap_err();
        assert!(matches!(e, DataError::UnknownColumn { .. }) && e.to_string().contains("theta, w, u"), "{e}");
    }
    // A short row is reported against the header's width; a bad entry of the chosen column by line.
    let e = parse_csv_column("sim.csv", "sim".into(), "t,theta,w\n0,1,2\n1,2\n", Some("theta")).unwrap_err();
    assert!(matches!(e, DataError::Columns { line: 3, expected: 3, found: 2, .. }), "{e}");
    let e = parse_csv_column("sim.csv", "sim".into(), "t,theta,w\n0,1,2\n1,x,2\n", Some("theta")).unwrap_err();
    assert!(matches!(&e, DataError::Parse { line: 3, column, .. } if column == "x"), "{e}");
}

#[test]
fn sampling_tolerance_is_relative_to_mean_step() {
    // A step off by 1e-5 relative (rounded time stamps) passes, 1e-3 relative fails.
    let ok = TimeSeries::new("a", vec![0.0, 1.0, 2.0 + 1e-5, 3.0], vec![0.0, 1.0, 0.0, 1.0]);
    assert!(ok.is_ok());
    let bad = TimeSeries::new("b", vec![0.0, 1.0, 2.0 + 1e-3, 3.0], vec![0.0, 1.0, 0.0, 1.0]);
    assert!(matches!(bad, Err(DataError::UnevenSampling { row: 3, .. })));
}

/// Regression: a file without a header line lost its first sample silently.
#[test]
fn a_file_without_a_header_is_an_error_naming_the_file() {
    for text in ["0,1\n0.5,2\n1.0,3\n", "0, 1e-3\n1,2\n2,3\n", "-1.5,2\n"] {
        let e = parse(text).unwrap_err();
        assert!(matches!(e, DataError::NumericHeader { .. }), "{text:?}: {e}");
        let m = e.to_string();
        assert!(m.starts_with("mem.csv: line 1") && m.contains("header line"), "{m}");
    }
    // Also with a named column.
    let e = parse_csv_column("sim.csv", "sim".into(), "0,0.1,2\n1,0.2,3\n", Some("theta")).unwrap_err();
    assert!(matches!(e, DataError::NumericHeader { .. }), "{e}");
    // Column names that merely contain digits are a header.
    assert!(parse("t1,x2\n0,1\n1,2\n").is_ok());
}

/// Regression: one missing sample in a long series was reported at row 2 (every step
/// differed from the mean step); it is the row where the step changes.
#[test]
fn a_missing_sample_is_reported_where_the_step_changes() {
    let mut t: Vec<f64> = (0..100).map(|i| f64::from(i) * 0.01).collect();
    t.remove(57); // data rows are 1-based: row 58 now holds t = 0.58
    let x: Vec<f64> = t.iter().map(|v| v.sin()).collect();
    let e = TimeSeries::new("gap", t, x).unwrap_err();
    match &e {
        DataError::UnevenSampling { row, step, typical, .. } => {
            assert_eq!(*row, 58, "{e}");
            assert!((step - 0.02).abs() < 1e-12 && (typical - 0.01).abs() < 1e-12, "{e}");
        }
        _ => panic!("{e}"),
    }
    assert!(e.to_string().contains("row 58"), "{e}");
    // A repeated sample: reported where it sits, too.
    let e = parse("t,x\n0,1\n1,2\n2,3\n3,4\n3.5,5\n4.5,6\n5.5,7\n").unwrap_err();
    assert!(matches!(e, DataError::UnevenSampling { row: 5, .. }), "{e}");
}

/// Regression: data scaled by 1e-300 were fitted with subnormal arithmetic and scored
/// `inf`: signals outside the magnitudes double precision can square are refused.
#[test]
fn signals_too_small_or_large_to_square_are_refused() {
    for s in [1e-300, 1e-120, 1e120, 1e300] {
        let e = TimeSeries::new("s", vec![0.0, 1.0, 2.0], vec![s, -s, 0.5 * s]).unwrap_err();
        assert!(matches!(e, DataError::Magnitude { .. }) && e.to_string().contains("rescale the data"), "{s}: {e}");
    }
    for s in [1e-90, 1.0, 1e90] {
        assert!(TimeSeries::new("s", vec![0.0, 1.0, 2.0], vec![s, -s, 0.5 * s]).is_ok(), "{s}");
    }
}

#[test]
fn missing_file_is_reported() {
    let e = load_csv("/nonexistent/definitely/missing.csv").unwrap_err();
    assert!(e.to_string().contains("missing.csv"), "{e}");
}

/// The tests of `ssm::data::multi`.
mod multi {
    use ssm::data::multi::*;
    use ssm::data::{DataError, TimeSeries};

    fn series() -> MultiSeries {
        let t: Vec<f64> = (0..11).map(|i| i as f64 * 0.5).collect();
        let x: Vec<f64> = (0..11).flat_map(|i| [i as f64, (i * i) as f64]).collect();
        MultiSeries::new("m", t, vec!["a".into(), "b".into()], x).unwrap()
    }

    #[test]
    fn csv_with_several_observables() {
        let text = "t,a,b,c\n0,1,5,9\n0.5,2,6,8\n1.0,3,7,9\n";
        let all = parse_csv_observables("f.csv", "f".into(), text, None).unwrap();
        assert_eq!(all.observables, ["a", "b", "c"]);
        assert_eq!(all.x, [1.0, 5.0, 9.0, 2.0, 6.0, 8.0, 3.0, 7.0, 9.0]);
        let picked = parse_csv_observables("f.csv", "f".into(), text, Some(&["c".into(), "a".into()])).unwrap();
        assert_eq!(
            (picked.observables.clone(), picked.x.clone()),
            (vec!["c".to_string(), "a".into()], vec![9.0, 1.0, 8.0, 2.0, 9.0, 3.0])
        );
        assert_eq!(picked.observable(1).unwrap().x, [1.0, 2.0, 3.0]);
        let e = parse_csv_observables("f.csv", "f".into(), text, Some(&["d".into()])).unwrap_err();
        assert!(matches!(e, DataError::UnknownColumn { .. }) && e.to_string().contains("a, b, c"), "{e}");
        let e = parse_csv_observables("f.csv", "f".into(), "t,a,b\n0,1,2\n1,2,x\n", None).unwrap_err();
        assert!(e.to_string().contains("line 3") && e.to_string().contains("b value"), "{e}");
        // A constant observable is named.
        let e = parse_csv_observables("f.csv", "f".into(), "t,a,b\n0,1,2\n1,2,2\n2,3,2\n", None).unwrap_err();
        assert!(matches!(&e, DataError::ConstantObservable { observable, .. } if observable == "b"), "{e}");
        let e = parse_csv_observables("f.csv", "f".into(), "t\n0\n1\n", None).unwrap_err();
        assert!(matches!(e, DataError::NoObservables { .. }), "{e}");
    }

    #[test]
    fn windows_cut_and_name_what_is_wrong() {
        let s = series();
        let w = s.window(Some(1.0), Some(2.0)).unwrap();
        assert_eq!(w.t, [1.0, 1.5, 2.0]);
        assert_eq!(w.x, [2.0, 4.0, 3.0, 9.0, 4.0, 16.0]);
        assert_eq!(s.window(Some(4.2), None).unwrap().t, [4.5, 5.0]);
        assert_eq!(s.window(None, Some(0.5)).unwrap().t, [0.0, 0.5]);
        assert_eq!(s.window(None, None).unwrap().x, s.x);
        for (from, to, why) in [
            (Some(6.0), None, "outside"),
            (None, Some(-1.0), "outside"),
            (Some(2.0), Some(1.0), "below"),
            (Some(f64::NAN), None, "finite"),
        ] {
            let e = s.window(from, to).unwrap_err();
            let msg = e.to_string();
            assert!(
                matches!(e, DataError::Window { .. })
                    && msg.contains(why)
                    && msg.contains("m:")
                    && msg.contains("0 .. 5"),
                "{msg}"
            );
        }
        // Inside the span but holding a single sample.
        let e = s.window(Some(4.9), None).unwrap_err();
        assert!(matches!(e, DataError::TooShort { have: 1, .. }), "{e}");
    }

    #[test]
    fn observable_counts_must_agree() {
        let a = series();
        let mut b = series();
        b.name = "second".into();
        b.observables = vec!["a".into()];
        b.x = (0..11).map(|i| i as f64).collect();
        let e = check_same_observables(&[a.clone(), b], false).unwrap_err();
        assert!(matches!(&e, DataError::ObservableMismatch { name, .. } if name == "second"), "{e}");
        assert!(check_same_observables(&[a.clone(), a], true).is_ok());
    }

    #[test]
    fn scalar_series_converts() {
        let ts = TimeSeries::new("s", vec![0.0, 1.0, 2.0], vec![1.0, -1.0, 0.5]).unwrap();
        let m = MultiSeries::from(&ts);
        assert_eq!((m.dim(), m.x.clone(), m.t.clone()), (1, ts.x.clone(), ts.t.clone()));
        assert!(m.validate().is_ok());
    }
}
