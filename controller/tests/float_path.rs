//! The exact floating-point path against a direct evaluation of the formula.

use crate::common;

use common::{assert_close, shorthand};
use controller::{ControllerConfig, FloatPd, InputError, Signal};
use proptest::prelude::*;

/// Direct evaluation: `seq` holds the `r + 1` pre-history samples then the inputs; returns
/// `u_i` for every input and the magnitude scale of its terms (the tolerance reference:
/// rounding errors are relative to it, cancellation between terms makes `|u_i|` the wrong
/// yardstick).
fn reference(cfg: &ControllerConfig, seq: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let r = cfg.delay as usize;
    let pre = r + 1;
    (0..seq.len() - pre)
        .map(|i| {
            let k = i + pre; // index of the sample taken at t_i
            let (y0, z0) = seq[k - r];
            let (y1, z1) = seq[k - r - 1];
            // x_I = dt * sum_{j=0..=i} y_{j-r}
            let x_i: f64 = (0..=i).map(|j| seq[j + pre - r].0).sum::<f64>() * cfg.dt;
            let (kp, kd, kphi_d) = cfg.as_shorthand().unwrap();
            let terms = [-kp * y0, -kd * (y0 - y1) / cfg.dt, kphi_d * (z0 - z1) / cfg.dt, -cfg.ki * x_i];
            // Rounding of the running sum scales with the sum of magnitudes, not with x_I.
            let x_i_scale: f64 = (0..=i).map(|j| seq[j + pre - r].0.abs()).sum::<f64>() * cfg.dt;
            let scale = terms[..3].iter().map(|t| t.abs()).sum::<f64>() + cfg.ki.abs() * x_i_scale;
            (terms.iter().sum(), scale)
        })
        .collect()
}

/// `(y, z)` samples as the flattened pre-history the controllers take.
fn flat(s: &[(f64, f64)]) -> Vec<f64> {
    s.iter().flat_map(|&(y, z)| [y, z]).collect()
}

fn gain() -> impl Strategy<Value = f64> {
    prop_oneof![Just(0.0), -50.0..50.0f64]
}

fn config() -> impl Strategy<Value = ControllerConfig> {
    (gain(), gain(), gain(), gain(), 1e-3..0.1f64, prop_oneof![Just(0u32), Just(1), Just(3), 0u32..=6])
        .prop_map(|(kp, kd, kphi_d, ki, dt, delay)| shorthand(kp, kd, kphi_d, ki, dt, delay, None, None))
}

fn samples(n: std::ops::Range<usize>) -> impl Strategy<Value = Vec<(f64, f64)>> {
    prop::collection::vec((-3.0..3.0f64, -100.0..100.0f64), n)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(400))]

    #[test]
    fn f64_matches_direct_formula(cfg in config(), pre in samples(7..8), inputs in samples(1..60)) {
        let r = cfg.delay as usize;
        let mut seq: Vec<(f64, f64)> = pre[..=r].to_vec();
        seq.extend_from_slice(&inputs);
        let expected = reference(&cfg, &seq);
        let mut pd = FloatPd::<f64, 8>::try_new(&cfg).unwrap();
        pd.prime(&flat(&seq[..=r])).unwrap();
        for (i, (&(y, z), &(u_ref, scale))) in inputs.iter().zip(&expected).enumerate() {
            let out = pd.step(&[y, z]).unwrap();
            prop_assert!(!out.saturated);
            assert_close(out.u, u_ref, 1e-12, scale, &format!("step {i}, r = {r}"));
        }
    }

    #[test]
    fn f64_saturation_clamps_and_flags(cfg in config(), u_max in 0.1..200.0f64, inputs in samples(1..40)) {
        let cfg = ControllerConfig { u_max: Some(u_max), ..cfg };
        let r = cfg.delay as usize;
        let mut seq = vec![(0.0, 0.0); r + 1];
        seq.extend_from_slice(&inputs);
        let expected = reference(&cfg, &seq);
        let mut pd = FloatPd::<f64, 8>::try_new(&cfg).unwrap();
        for (&(y, z), &(u_ref, scale)) in inputs.iter().zip(&expected) {
            let out = pd.step(&[y, z]).unwrap();
            // Away from the boundary (beyond rounding) the flag is determined.
            if (u_ref.abs() - u_max).abs() > 1e-9 * scale {
                prop_assert_eq!(out.saturated, u_ref.abs() > u_max);
            }
            if out.saturated {
                prop_assert_eq!(out.u, u_max.copysign(u_ref));
            } else {
                assert_close(out.u, u_ref, 1e-12, scale, "unsaturated");
                prop_assert!(out.u.abs() <= u_max);
            }
        }
    }

    #[test]
    fn f32_matches_f64_formula(cfg in config(), inputs in samples(1..40)) {
        let r = cfg.delay as usize;
        // f32 inputs: use the f32-rounded samples in the reference too.
        let inputs: Vec<(f64, f64)> =
            inputs.iter().map(|&(y, z)| (f64::from(y as f32), f64::from(z as f32))).collect();
        let mut seq = vec![(0.0, 0.0); r + 1];
        seq.extend_from_slice(&inputs);
        let expected = reference(&cfg, &seq);
        let mut pd = FloatPd::<f32, 8>::try_new(&cfg).unwrap();
        for (&(y, z), &(u_ref, scale)) in inputs.iter().zip(&expected) {
            let out = pd.step(&[y as f32, z as f32]).unwrap();
            // f32 gains, dt and arithmetic: a few ulps of 6e-8 per operation, ~60 steps of sum.
            assert_close(f64::from(out.u), u_ref, 1e-5, scale, "f32");
        }
    }
}

#[test]
fn delay_zero_one_three_by_hand() {
    // kp = 2, kd = 0.5, kphi_d = 0.25, ki = 4, dt = 0.5: u = -2 y0 - (y0 - y1) + 0.5 (z0 - z1) - 4 x_I
    let base = shorthand(2.0, 0.5, 0.25, 4.0, 0.5, 0, None, None);
    // r = 0, pre-history (1, 10): input (3, 14): x_I = 1.5; u = -6 - 2 + 2 - 6 = -12.
    let mut pd = FloatPd::<f64, 2>::try_new(&base).unwrap();
    pd.prime(&[1.0, 10.0]).unwrap();
    assert_eq!(pd.step(&[3.0, 14.0]), Ok(controller::Output { u: -12.0, saturated: false }));
    assert_eq!(pd.integral(), 1.5);
    // r = 1, pre-history (1, 10), (2, 11): the first output uses (2, 11) and (1, 10):
    // x_I = 1, u = -4 - 1 + 0.5 - 4 = -8.5; the second uses (3, 14), (2, 11): x_I = 2.5,
    // u = -6 - 1 + 1.5 - 10 = -15.5.
    let mut pd = FloatPd::<f64, 3>::try_new(&ControllerConfig { delay: 1, ..base }).unwrap();
    pd.prime(&[1.0, 10.0, 2.0, 11.0]).unwrap();
    assert_eq!(pd.step(&[3.0, 14.0]).unwrap().u, -8.5);
    assert_eq!(pd.step(&[7.0, 0.0]).unwrap().u, -15.5);
    // r = 3 from rest at (1, 0): outputs i = 0, 1, 2 see y_{i-3} = 1 with zero differences:
    // x_I = 0.5 (i + 1), u = -2 - 2 (i + 1); i = 3 sees y_0 = 5, y_{-1} = 1, x_I = 1.5 + 2.5:
    // u = -10 - 4 - 16 = -30; i = 4 sees y_1 = 6, y_0 = 5, x_I = 4 + 3: u = -12 - 1 - 28 = -41.
    let mut pd = FloatPd::<f64, 5>::try_new(&ControllerConfig { delay: 3, ..base }).unwrap();
    pd.prime_constant(&[1.0, 0.0]).unwrap();
    let us: Vec<f64> = [5.0, 6.0, 7.0, 8.0, 9.0].iter().map(|&y| pd.step(&[y, 0.0]).unwrap().u).collect();
    assert_eq!(us, [-4.0, -6.0, -8.0, -30.0, -41.0]);
}

#[test]
fn non_finite_input_is_rejected_and_leaves_the_state_untouched() {
    let cfg = ControllerConfig { ki: 1.0, ..ControllerConfig::paper(0.025) };
    let mut a = FloatPd::<f64, 4>::try_new(&cfg).unwrap();
    let mut b = a;
    let xs = [(0.1, 0.0), (0.05, 0.2), (-0.02, 0.3), (0.0, 0.1)];
    for (i, &(y, z)) in xs.iter().enumerate() {
        if i == 2 {
            assert_eq!(a.step(&[f64::NAN, z]), Err(InputError::NonFinite(Signal(0))));
            assert_eq!(a.step(&[y, f64::INFINITY]), Err(InputError::NonFinite(Signal(1))));
            assert_eq!(a.step(&[f64::NEG_INFINITY, f64::NAN]), Err(InputError::NonFinite(Signal(0))));
        }
        assert_eq!(a.step(&[y, z]), b.step(&[y, z]));
        assert_eq!(a.integral(), b.integral());
    }
    // Pre-history: wrong length or non-finite, rejected, state unchanged.
    assert_eq!(a.prime(&[0.0, 0.0]), Err(InputError::HistoryLength { expected: 4, found: 2 }));
    assert_eq!(a.prime(&[0.0, 0.0, 0.0, f64::NAN]), Err(InputError::NonFinite(Signal(1))));
    // A sample of the wrong length.
    assert_eq!(a.step(&[0.1]), Err(InputError::Measurements { expected: 2, found: 1 }));
    assert_eq!(a.prime_constant(&[0.1, 0.0, 0.0]), Err(InputError::Measurements { expected: 2, found: 3 }));
    assert_eq!(a.prime_constant(&[f64::NAN, 0.0]), Err(InputError::NonFinite(Signal(0))));
    assert_eq!(a.step(&[0.3, 0.3]), b.step(&[0.3, 0.3]));
}

#[test]
fn overflowing_output_is_an_error_or_saturates_never_nan() {
    let cfg = shorthand(1e10, 0.0, 0.0, 0.0, 1.0, 0, None, None);
    // -kp * 1e300 = -inf: no saturation configured -> error, state unchanged.
    let mut pd = FloatPd::<f64, 2>::try_new(&cfg).unwrap();
    assert_eq!(pd.step(&[1e300, 0.0]), Err(InputError::NonFiniteOutput));
    assert_eq!(pd.step(&[1.0, 0.0]).unwrap().u, -1e10);
    // With u_max the infinite value saturates, flagged.
    let mut pd = FloatPd::<f64, 2>::try_new(&ControllerConfig { u_max: Some(24.0), ..cfg }).unwrap();
    assert_eq!(pd.step(&[1e300, 0.0]), Ok(controller::Output { u: -24.0, saturated: true }));
    // -inf + inf = NaN is an error even with saturation.
    let nan_cfg = ControllerConfig { u_max: Some(24.0), ..shorthand(1e10, -1e10, 0.0, 0.0, 1.0, 0, None, None) };
    let mut pd = FloatPd::<f64, 2>::try_new(&nan_cfg).unwrap();
    assert_eq!(pd.step(&[1e300, 0.0]), Err(InputError::NonFiniteOutput));
    // f32: overflow comes much earlier (3.4e38).
    let mut pd = FloatPd::<f32, 2>::try_new(&ControllerConfig { u_max: Some(24.0), ..cfg }).unwrap();
    assert_eq!(pd.step(&[1e30, 0.0]), Ok(controller::Output { u: -24.0, saturated: true }));
    // Integral overflow: error, not an infinite state.
    let int_cfg = shorthand(0.0, 0.0, 0.0, 1.0, 1e300, 0, Some(1.0), None);
    let mut pd = FloatPd::<f64, 2>::try_new(&int_cfg).unwrap();
    assert_eq!(pd.step(&[1e10, 0.0]), Err(InputError::NonFiniteOutput));
    assert_eq!(pd.integral(), 0.0);
}
