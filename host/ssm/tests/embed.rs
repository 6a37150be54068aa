//! The tests of `ssm::embed`.

use ssm::data::{DataError, MultiSeries, TimeSeries};
use ssm::embed::*;

#[test]
fn over_embeds_every_observable() {
    // q = 2 observables a_n = n, b_n = 10 n; p = 3 copies, shift 2.
    let t: Vec<f64> = (0..7).map(|i| i as f64).collect();
    let x: Vec<f64> = (0..7).flat_map(|i| [i as f64, 10.0 * i as f64]).collect();
    let ms = MultiSeries::new("m", t, vec!["a".into(), "b".into()], x).unwrap();
    let y = delay_embed_multi(&ms, 3, 2, 1).unwrap();
    assert_eq!((y.nrows(), y.ncols()), (6, 3));
    // column 1 = [a1, b1, a3, b3, a5, b5]
    assert_eq!((0..6).map(|r| y[(r, 1)]).collect::<Vec<_>>(), [1.0, 10.0, 3.0, 30.0, 5.0, 50.0]);
    // One observable: the scalar embedding, entry for entry.
    let ts = TimeSeries::new("s", (0..9).map(|i| i as f64).collect(), (0..9).map(|i| (i * i) as f64 - 3.0).collect())
        .unwrap();
    let (a, b) = (delay_embed(&ts, 4, 2, 1).unwrap(), delay_embed_multi(&MultiSeries::from(&ts), 4, 2, 1).unwrap());
    assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()));
    assert!((0..a.nrows()).all(|r| (0..a.ncols()).all(|c| a[(r, c)] == b[(r, c)])));
    let e = delay_embed_multi(&ms, 3, 2, 4).unwrap_err();
    assert!(matches!(e, DataError::TooShort { have: 7, need: 8, .. }), "{e}");
}

#[test]
fn embeds_with_shift() {
    let ts =
        TimeSeries::new("a", (0..7).map(|i| i as f64).collect(), (0..7).map(|i| (i * i) as f64).collect()).unwrap();
    let y = delay_embed(&ts, 3, 2, 1).unwrap();
    assert_eq!((y.nrows(), y.ncols()), (3, 3));
    assert_eq!(embedded_len(7, 3, 2), Some(3));
    // column 1 = [x1, x3, x5]
    assert_eq!([y[(0, 1)], y[(1, 1)], y[(2, 1)]], [1.0, 9.0, 25.0]);
    let e = delay_embed(&ts, 3, 2, 4).unwrap_err();
    assert!(matches!(e, DataError::TooShort { have: 7, need: 8, .. }), "{e}");
}
