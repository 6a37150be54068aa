//! The tests of `chaos::density`.

use chaos::density::*;
use chaos::{ChaosError, Points};

#[test]
fn js_known_values() {
    assert_eq!(jensen_shannon_bits(&[1.0, 0.0], &[0.0, 3.0]).unwrap(), 1.0);
    assert!(jensen_shannon_bits(&[2.0, 3.0, 5.0], &[4.0, 6.0, 10.0]).unwrap().abs() < 1e-15);
    // P = (1/2, 1/2), Q = (1, 0): M = (3/4, 1/4);
    // JS = 1/2 [1/2 log2(2/3) + 1/2 log2(2)] + 1/2 [log2(4/3)] = 0.311278...
    let v = jensen_shannon_bits(&[1.0, 1.0], &[1.0, 0.0]).unwrap();
    let exact = 0.5 * (0.5 * (2.0f64 / 3.0).log2() + 0.5) + 0.5 * (4.0f64 / 3.0).log2();
    assert!((v - exact).abs() < 1e-15, "{v} {exact}");
    assert_eq!(v, jensen_shannon_bits(&[1.0, 0.0], &[1.0, 1.0]).unwrap());
    assert!(jensen_shannon_bits(&[0.0, 0.0], &[1.0, 1.0]).is_err());
    assert!(jensen_shannon_bits(&[1.0], &[1.0, 1.0]).is_err());
}

#[test]
fn pdfs_of_shifted_uniform_samples() {
    // data uniform on [0,1), model uniform on [0.5,1.5): with 30 fixed bins over
    // [0, 1.5) the overlap is exactly half of each mass; JS = 1/2 bit, L1 = 1.
    let n = 3000;
    let a: Vec<f64> = (0..n).map(|k| (k as f64 + 0.5) / n as f64).collect();
    let b: Vec<f64> = a.iter().map(|v| v + 0.5).collect();
    let pa = Points::from_series(&a).unwrap();
    let pb = Points::from_series(&b).unwrap();
    let cmp = compare_pdfs(&pa, &pb, Bins::Fixed(30)).unwrap();
    let c = &cmp.coords[0];
    assert!((c.js_bits - 0.5).abs() < 1e-3, "{}", c.js_bits);
    assert!((c.l1 - 1.0).abs() < 1e-3, "{}", c.l1);
    let integral: f64 = c.data_density.iter().sum::<f64>() * (c.edges[1] - c.edges[0]);
    assert!((integral - 1.0).abs() < 1e-12);
    let same = compare_pdfs(&pa, &pa, Bins::default()).unwrap();
    assert_eq!(same.max_js_bits, 0.0);
    // Freedman-Diaconis: the pooled density is 1/2, 1, 1/2 on the three half-unit
    // intervals, so its quartiles are 0.5 and 1.0 (IQR 0.5); n = 3000 -> width
    // 2 * 0.5 / 3000^(1/3) = 0.0693 -> ceil(1.5 / 0.0693) = 22 bins.
    let fd = compare_pdfs(&pa, &pb, Bins::default()).unwrap();
    assert_eq!(fd.coords[0].centers.len(), 22);
}

#[test]
fn rejects_mismatch() {
    let a = Points::from_flat(2, vec![0.0, 1.0, 2.0, 3.0]).unwrap();
    let b = Points::from_series(&[0.0, 1.0]).unwrap();
    assert!(matches!(compare_pdfs(&a, &b, Bins::default()), Err(ChaosError::Shape { .. })));
}
