//! The paper's literal formula (golden values at 50 digits) and the `Law` dispatcher.

use crate::common;

use common::{H_ADC, H_DAC, paper_counts};
use controller::{
    ControllerConfig, FloatPd, InputError, IntPd, Law, LiteralPd, Output, QuantMode, Quantization, Signal,
};

fn literal_cfg(u_max: Option<f64>) -> ControllerConfig {
    let mut c = paper_counts(0.0, 1);
    c.u_max = u_max;
    c.quant = c.quant.map(|q| Quantization { mode: QuantMode::Literal, ..q });
    c
}

/// Angles given in units of h = h_adc, r = 1, dt = 25 ms,
/// `u = h * floor(-15.5 floor(y/h) - 5.45 floor(ydot/h) + 1.5 floor(zdot/h))`. Expected integers computed independently at 50
/// digits; every inner quotient is at least 0.04 from an integer and every sum at least 0.15,
/// far beyond f64 rounding. Step 0 for example: floor(2.709) is 2,
/// floor((2.709 - 0.313)/0.025) is floor(95.84) = 95, floor((-0.402 - 0.117)/0.025) is
/// floor(-20.76) = -21, so the sum is -31 - 517.75 - 31.5 = -580.25 and n is -581.
/// u_max = 10 V clamps n to floor(10/h) = 6518.
#[test]
fn literal_golden_trace() {
    let pre = [(0.313, 0.117), (2.709, -0.402)];
    let ys = [5.231, 9.917, 12.352, 10.053, -3.611, -7.457, 400.219, -400.733];
    let zs = [0.151, -2.337, -7.813, -15.109, -20.641, -9.917, 0.213, 0.437];
    let n = [-581, -590, -1309, -1045, -92, 2710, 1605, -6518];
    let sat = [false, false, false, false, false, false, false, true];
    let mut pd = LiteralPd::<3>::try_new(&literal_cfg(Some(10.0))).unwrap();
    let pre: Vec<f64> = pre.iter().flat_map(|&(a, b)| [a * H_ADC, b * H_ADC]).collect();
    pd.prime(&pre).unwrap();
    for i in 0..ys.len() {
        let out = pd.step(&[ys[i] * H_ADC, zs[i] * H_ADC]).unwrap();
        assert_eq!(out, Output { u: H_ADC * f64::from(n[i]), saturated: sat[i] }, "step {i}");
    }
    // Without u_max the last value is not clamped: -94465.65 -> -94466.
    let mut pd = LiteralPd::<3>::try_new(&literal_cfg(None)).unwrap();
    pd.prime(&pre).unwrap();
    let last = ys.iter().zip(&zs).map(|(&y, &z)| pd.step(&[y * H_ADC, z * H_ADC]).unwrap()).last().unwrap();
    assert_eq!(last, Output { u: H_ADC * -94466.0, saturated: false });
    // Non-finite input: rejected, state unchanged.
    let before = pd;
    assert_eq!(pd.step(&[f64::NAN, 0.0]), Err(InputError::NonFinite(Signal(0))));
    let mut twin = before;
    assert_eq!(pd.step(&[0.1, 0.2]), twin.step(&[0.1, 0.2]));
}

#[test]
fn law_dispatches_to_each_path() {
    let history = [0.02, 0.1, 0.015, 0.12];
    let samples = [(0.01, 0.13), (-0.004, 0.2), (-0.03, 0.1), (0.5, -3.0), (0.0, 0.0)];
    // Exact.
    let exact = ControllerConfig { ki: 1.0, u_max: Some(10.0), ..ControllerConfig::paper(0.025) };
    let mut law = Law::<4>::try_new(&exact).unwrap();
    let mut pd = FloatPd::<f64, 4>::try_new(&exact).unwrap();
    law.prime(&history).unwrap();
    pd.prime(&history).unwrap();
    for &(y, z) in &samples {
        assert_eq!(law.step(&[y, z]), pd.step(&[y, z]));
    }
    // Counts: adc of both angles, IntPd, volts.
    let counts = paper_counts(1.0, 1);
    let mut law = Law::<4>::try_new(&counts).unwrap();
    let mut pd = IntPd::<4>::try_new(&counts).unwrap();
    law.prime(&history).unwrap();
    let q = |a: f64| controller::adc(a, H_ADC).unwrap();
    pd.prime(&[q(0.02), q(0.1), q(0.015), q(0.12)]).unwrap();
    let mut saw_saturation = false;
    for &(y, z) in &samples {
        let o = pd.step(&[q(y), q(z)]).unwrap();
        saw_saturation |= o.saturated;
        assert_eq!(law.step(&[y, z]), Ok(Output { u: H_DAC * f64::from(o.code), saturated: o.saturated }));
    }
    assert!(saw_saturation);
    assert_eq!(law.step(&[1e10, 0.0]), Err(InputError::AdcOutOfRange(Signal(0))));
    assert_eq!(law.step(&[0.0, f64::NAN]), Err(InputError::NonFinite(Signal(1))));
    assert_eq!(law.prime(&history[..2]), Err(InputError::HistoryLength { expected: 4, found: 2 }));
    assert_eq!(law.step(&[0.0]), Err(InputError::Measurements { expected: 2, found: 1 }));
    assert_eq!(law.prime_constant(&[0.0, -1e10]), Err(InputError::AdcOutOfRange(Signal(1))));
    // Literal.
    let lit = literal_cfg(Some(10.0));
    let mut law = Law::<4>::try_new(&lit).unwrap();
    let mut pd = LiteralPd::<4>::try_new(&lit).unwrap();
    law.prime_constant(&[0.01, 0.0]).unwrap();
    pd.prime_constant(&[0.01, 0.0]).unwrap();
    for &(y, z) in &samples {
        assert_eq!(law.step(&[y, z]), pd.step(&[y, z]));
    }
}
