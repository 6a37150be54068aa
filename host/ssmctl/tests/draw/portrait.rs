use ssm::normal_form::{Normalization, PolarNormalForm};
use ssm::portrait::*;
use ssmctl::draw::portrait::*;

/// Lotka-Volterra amplitude equations `rho_i' = rho_i (a_i + sum_k B_ik rho_k^2)` with
/// strong competition: an interior saddle whose manifolds the portrait draws.
fn bistable() -> PolarNormalForm {
    let pexps = ssm::poly::exponents(2, 0, 1);
    let amp = [vec![1.0, -1.0, -2.0], vec![1.0, -2.0, -1.0]];
    let phase = vec![vec![std::f64::consts::TAU * 0.44, 0.0, 0.0], vec![std::f64::consts::TAU * 8.4, 0.0, 0.0]];
    PolarNormalForm {
        modes: 2,
        order: 3,
        eigenvalues: vec![(amp[0][0], phase[0][0]), (amp[1][0], phase[1][0])],
        pexps,
        amp: amp.to_vec(),
        phase,
        normalization: Normalization::UnitEigenvectors,
        extra_resonances: Vec::new(),
        min_divisor: 1.0,
        map_dt: None,
    }
}

#[test]
fn plot_writes_a_png() {
    let opts = PortraitOptions { rho_max: [1.4, 1.4], ..PortraitOptions::default() };
    let p = portrait(&bistable(), &opts).unwrap();
    let dir = std::env::temp_dir().join(format!("portrait-test-{}-plot", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("portrait.png");
    let extra: Vec<(f64, f64)> =
        (0..200).map(|k| (0.1 + 0.002 * k as f64, 0.05 + 0.1 * (k as f64 * 0.1).sin().abs())).collect();
    plot_portrait(&path, &p, "bistable", &[("full system", &extra)]).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert!(bytes.len() > 20_000, "PNG only {} bytes", bytes.len());
    std::fs::remove_dir_all(&dir).unwrap();
    let bad = Portrait { rho_max: [f64::NAN, 1.0], ..p };
    assert!(plot_portrait(&dir.join("x.png"), &bad, "x", &[]).is_err());
}
