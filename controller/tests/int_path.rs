//! The integer (counts) path: against the exact real formula within the documented Q16
//! bound, against an exact i128 evaluation over the whole i32 range, and golden traces.

use crate::common;

use common::{H_ADC, H_DAC, paper_counts};
use controller::AdcError;
use controller::quant::{GAIN_FRAC_BITS, GAIN_MAX_CODES_PER_COUNT, GAIN_MAX_Q, GAIN_ROUNDING, GAIN_SUM_MAX_Q};
use controller::{ControllerConfig, Gain, Gains, IntOutput, IntPd, QuantMode, Quantization, adc};
use proptest::prelude::*;

/// Runs `pd` over `inputs` after priming with `pre` (r + 1 samples).
fn run<const H: usize>(pd: &mut IntPd<H>, pre: &[(i32, i32)], inputs: &[(i32, i32)]) -> Vec<IntOutput> {
    let flat: Vec<i32> = pre.iter().flat_map(|&(y, z)| [y, z]).collect();
    pd.prime(&flat).unwrap();
    inputs.iter().map(|&(y, z)| pd.step(&[y, z]).unwrap()).collect()
}

/// The integer law evaluated exactly in i128 from the Q16 gains, with the documented
/// saturating-i64 integral state, on samples of `n` counts (`pre` the r + 1 before):
/// what the i64 implementation must reproduce bit for bit.
fn exact_vec(pd: &IntPd<8>, pre: &[Vec<i32>], inputs: &[Vec<i32>]) -> Vec<(i32, bool)> {
    let r = pd.delay();
    let g = pd.gains();
    let c = i128::from(pd.code_max());
    let seq: Vec<&Vec<i32>> = pre.iter().chain(inputs).collect();
    let mut s: i64 = 0;
    (0..inputs.len())
        .map(|i| {
            let k = i + r + 1;
            let (q0, q1) = (seq[k - r], seq[k - r - 1]);
            s = s.saturating_add(i64::from(q0[0]));
            let mut acc = -i128::from(g.i) * i128::from(s);
            for j in 0..q0.len() {
                let (a, b) = (i128::from(q0[j]), i128::from(q1[j]));
                acc -= i128::from(g.p[j]) * a + i128::from(g.d[j]) * (a - b);
            }
            let raw = acc >> GAIN_FRAC_BITS; // floor
            let code = raw.clamp(-c, c);
            (i32::try_from(code).unwrap(), code != raw)
        })
        .collect()
}

/// [`exact_vec`] on two-angle samples.
fn exact_q16(pd: &IntPd<8>, pre: &[(i32, i32)], inputs: &[(i32, i32)]) -> Vec<(i32, bool)> {
    let v = |s: &[(i32, i32)]| s.iter().map(|&(y, z)| vec![y, z]).collect::<Vec<_>>();
    exact_vec(pd, &v(pre), &v(inputs))
}

/// A config whose gains are codes per count directly (every resolution, h_dac and dt 1).
fn unit_cfg(kp: f64, kd: f64, kphi_d: f64, ki: f64, delay: u32, u_max: Option<f64>) -> ControllerConfig {
    ControllerConfig {
        gains: Gains::shorthand(kp, kd, kphi_d, 1.0, 1.0),
        ki,
        dt: 1.0,
        delay,
        u_max,
        quant: Some(Quantization { mode: QuantMode::Counts, h_dac: 1.0 }),
    }
}

/// One to four coordinates with unit resolutions and Q16-exact gains whose magnitudes sum
/// to at most [`GAIN_SUM_MAX_Q`] (drawn up to each coordinate's share, often at it).
fn vector_cfg() -> impl Strategy<Value = ControllerConfig> {
    let unit = 1.0 / 65536.0;
    (1usize..=4)
        .prop_flat_map(|n| {
            let share = GAIN_SUM_MAX_Q / n as i64;
            let one = move || {
                // |P + D| + |D| <= |P| + 2 |D| <= share with |P|, |D| <= share / 3: the
                // extremes sum to the bound itself.
                let m = (share / 3).min(GAIN_MAX_Q);
                let g = prop_oneof![Just(m), Just(-m), Just(0), -m..=m];
                (g.clone(), g)
            };
            (prop::collection::vec(one(), n), prop_oneof![Just(0i64), Just(GAIN_MAX_Q), -GAIN_MAX_Q..=GAIN_MAX_Q])
        })
        .prop_map(move |(pd, i)| {
            let mut gains = Gains::new();
            for (k, (p, d)) in pd.into_iter().enumerate() {
                gains.push(Gain { index: k as u8, p: p as f64 * unit, d: d as f64 * unit, h_adc: 1.0 }).unwrap();
            }
            ControllerConfig {
                gains,
                ki: i as f64 * unit,
                dt: 1.0,
                delay: 0,
                u_max: None,
                quant: Some(Quantization { mode: QuantMode::Counts, h_dac: 1.0 }),
            }
        })
}

fn extreme_gain() -> impl Strategy<Value = f64> {
    let m = GAIN_MAX_CODES_PER_COUNT;
    prop_oneof![Just(m), Just(-m), Just(0.0), Just(1.0), 1e-3..m, -m..-1e-3]
}

fn count() -> impl Strategy<Value = i32> {
    prop_oneof![any::<i32>(), Just(i32::MIN), Just(i32::MAX), Just(0), -5..5i32]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    /// (c) Whole i32 range, extreme gains: no panic, no overflow (the test profile has
    /// overflow checks), output within the DAC range, `saturated` exactly when clamped.
    #[test]
    fn whole_i32_range_matches_exact_i128(
        kp in extreme_gain(), kd in extreme_gain(), kphi_d in extreme_gain(), ki in extreme_gain(),
        delay in 0u32..=6,
        u_max in prop_oneof![Just(None), (1u32..=u32::MAX / 2).prop_map(|c| Some(f64::from(c) + 0.5))],
        pre in prop::collection::vec((count(), count()), 7),
        inputs in prop::collection::vec((count(), count()), 1..64),
    ) {
        let cfg = unit_cfg(kp, kd, kphi_d, ki, delay, u_max);
        let mut pd = IntPd::<8>::try_new(&cfg).unwrap();
        let g = pd.gains();
        prop_assert!(g.p.iter().chain(&g.d).chain([&g.i]).all(|x| x.abs() <= GAIN_MAX_Q));
        let c = pd.code_max();
        prop_assert_eq!(c, u_max.map_or(i32::MAX, |m| m.floor() as i32));
        let pre = &pre[..=delay as usize];
        let expected = exact_q16(&pd, pre, &inputs);
        let got = run(&mut pd, pre, &inputs);
        for (i, (o, &(code, sat))) in got.iter().zip(&expected).enumerate() {
            prop_assert!(o.code.abs() <= c, "step {i}: {} outside +-{c}", o.code);
            prop_assert_eq!((o.code, o.saturated), (code, sat), "step {}", i);
        }
    }

    /// (c') The gain vector: one to four coordinates at gains up to the sum bound, whole i32
    /// range, every delay: exact against i128, no overflow (overflow checks are on here).
    #[test]
    fn gain_vector_whole_i32_range_matches_exact_i128(
        cfg in vector_cfg(),
        delay in 0u32..=6,
        u_max in prop_oneof![Just(None), (1u32..=u32::MAX / 2).prop_map(|c| Some(f64::from(c) + 0.5))],
        pre in prop::collection::vec(prop::collection::vec(count(), 4), 7),
        inputs in prop::collection::vec(prop::collection::vec(count(), 4), 1..48),
    ) {
        let cfg = ControllerConfig { delay, u_max, ..cfg };
        let n = cfg.gains.len();
        let mut pd = IntPd::<8>::try_new(&cfg).unwrap();
        let g = pd.gains();
        let total: i64 = (0..n).map(|j| (g.p[j] + g.d[j]).abs() + g.d[j].abs()).sum();
        prop_assert!(total <= GAIN_SUM_MAX_Q);
        let cut = |v: &Vec<Vec<i32>>| v.iter().map(|s| s[..n].to_vec()).collect::<Vec<_>>();
        let (pre, inputs) = (cut(&pre[..=delay as usize].to_vec()), cut(&inputs));
        let expected = exact_vec(&pd, &pre, &inputs);
        pd.prime(&pre.concat()).unwrap();
        let c = pd.code_max();
        for (i, (q, &(code, sat))) in inputs.iter().zip(&expected).enumerate() {
            let o = pd.step(q).unwrap();
            prop_assert!(o.code.abs() <= c, "step {i}: {} outside +-{c}", o.code);
            prop_assert_eq!((o.code, o.saturated), (code, sat), "step {}", i);
        }
    }

    /// (b) Against the exact real-valued formula floor(u / h_dac), realistic gains and counts.
    #[test]
    fn matches_exact_formula_within_q16_bound(
        ki in prop_oneof![Just(0.0), 0.1..5.0f64],
        kp in 5.0..30.0f64, kd in 1.0..8.0f64, kphi_d in -3.0..3.0f64,
        dt in 0.005..0.05f64,
        delay in prop_oneof![Just(0u32), Just(1), Just(3)],
        pre in prop::collection::vec((-3000..3000i32, -3000..3000i32), 4),
        inputs in prop::collection::vec((-3000..3000i32, -3000..3000i32), 1..50),
    ) {
        let cfg = ControllerConfig {
            gains: Gains::shorthand(kp, kd, kphi_d, H_ADC, H_ADC),
            dt,
            ..paper_counts(ki, delay)
        };
        let mut pd = IntPd::<8>::try_new(&cfg).unwrap();
        let g = pd.gains();
        let r = delay as usize;
        let pre = &pre[..=r];
        let got = run(&mut pd, pre, &inputs);
        let seq: Vec<(i32, i32)> = pre.iter().chain(&inputs).copied().collect();
        let mut s = 0i64;
        let mut decided = 0;
        let mut narrow = 0;
        for (i, out) in got.iter().enumerate() {
            let k = i + r + 1;
            let (y0, z0) = seq[k - r];
            let (y1, z1) = seq[k - r - 1];
            s += i64::from(y0);
            let (y0, y1, z0, z1) = (f64::from(y0), f64::from(y1), f64::from(z0), f64::from(z1));
            // The law on the angles q*h, in volts, over h_dac: the exact code value.
            let terms = [
                -kp * (y0 * H_ADC),
                -kd * (y0 * H_ADC - y1 * H_ADC) / dt,
                kphi_d * (z0 * H_ADC - z1 * H_ADC) / dt,
                -ki * (s as f64 * H_ADC * dt),
            ];
            let x = terms.iter().sum::<f64>() / H_DAC;
            let f64_err = 1e-13 * (terms.iter().map(|t| t.abs()).sum::<f64>() / H_DAC + 1.0);
            let i_part = if ki != 0.0 { (s as f64).abs() } else { 0.0 };
            let e = GAIN_ROUNDING * (y0.abs() + (y0 - y1).abs() + (z0 - z1).abs() + i_part);
            // The Q16 value before the floor is within e of x (the documented bound) ...
            let acc = -(g.p[0] as f64) * y0 - g.d[0] as f64 * (y0 - y1) - g.d[1] as f64 * (z0 - z1) - g.i as f64 * s as f64;
            let xq = acc / 65536.0;
            prop_assert!((xq - x).abs() <= e * (1.0 + 1e-9) + f64_err, "step {i}: |{xq} - {x}| > {e}");
            // ... so the code lies between the floors of x -+ e, and equals floor(x) when that
            // interval holds no integer.
            let c = f64::from(pd.code_max());
            let lo_raw = (x - e - f64_err).floor();
            let hi_raw = (x + e + f64_err).floor();
            let (lo, hi) = (lo_raw.clamp(-c, c), hi_raw.clamp(-c, c));
            let code = f64::from(out.code);
            prop_assert!(lo <= code && code <= hi, "step {i}: code {code} not in [{lo}, {hi}], x = {x}");
            if lo == hi {
                prop_assert_eq!(code, x.floor().clamp(-c, c));
            }
            // Narrow windows (<= 0.05 codes) hold an integer with probability <= 5 %.
            if 2.0 * (e + f64_err) <= 0.05 {
                narrow += 1;
                decided += usize::from(lo == hi);
            }
            // The flag: set when both bounds lie outside the range, clear when both inside.
            if lo_raw.abs() > c && hi_raw.abs() > c && lo_raw.signum() == hi_raw.signum() {
                prop_assert!(out.saturated, "step {i}: x = {x} beyond +-{c}, flag clear");
            } else if lo_raw.abs() <= c && hi_raw.abs() <= c {
                prop_assert!(!out.saturated, "step {i}: x = {x} within +-{c}, flag set");
            }
        }
        // The bound is tight: almost every step with a narrow window is decided exactly.
        if narrow >= 20 {
            prop_assert!(decided * 10 >= narrow * 8, "{decided} of {narrow} narrow-window steps decided");
        }
    }
}

/// (e) Golden trace: the paper's gains, dt = 25 ms, h_adc = 2 pi/4096, h_dac = 10/2048,
/// u_max = 10 V (2048 codes), r = 1. In codes the exact law is
/// `x = pi * (-1.55 q_y - 21.8 dq_y + 6 dq_z) - 0.0025 pi ki S`
/// (kp*h_adc/h_dac = 1.55 pi, kd*h_adc/(dt*h_dac) = 21.8 pi, kphi_d*.. = 6 pi,
/// ki*dt*h_adc/h_dac = 0.0025 pi ki); expected codes are floor(x) clamped to +-2048, computed
/// independently at 50 digits (every unclamped x is > 1e-4 codes from an integer, beyond the
/// Q16 bound). E.g. step 0 uses q_y = 3, 0 and q_z = -1, 0: x = pi (-4.65 - 65.4 - 6)
/// = -238.918... -> -239.
#[test]
fn golden_trace_paper_gains() {
    let pre = [(0, 0), (3, -1)];
    let ys = [5, 9, 12, 10, 4, -3, -8, -6, 0, 7, 60, 20, -20, -70, -65, 0, i32::MAX, i32::MIN, 1, 1];
    let zs = [0, -2, -7, -15, -20, -18, -10, 0, 12, 25, 30, 31, 0, -100, -90, 0, i32::MIN, i32::MAX, 0, 0];
    let inputs: Vec<(i32, i32)> = ys.into_iter().zip(zs).collect();
    let sat = [
        false, false, false, false, false, false, false, false, false, false, false, true, true, true, false, false,
        true, true, true, true,
    ];
    let golden: [(f64, [i32; 20]); 2] = [
        (
            0.0,
            [
                -239, -143, -356, -359, -63, 297, 531, 532, 80, -185, -269, -2048, 2048, 2048, 1880, 162, -2048, -2048,
                2048, -2048,
            ],
        ),
        (
            2.0,
            [
                -239, -143, -356, -359, -64, 296, 531, 531, 80, -186, -269, -2048, 2048, 2048, 1879, 163, -2048, -2048,
                2048, -2048,
            ],
        ),
    ];
    for (ki, codes) in golden {
        let mut pd = IntPd::<4>::try_new(&paper_counts(ki, 1)).unwrap();
        assert_eq!(pd.code_max(), 2048);
        let got = run(&mut pd, &pre, &inputs);
        let got_codes: Vec<i32> = got.iter().map(|o| o.code).collect();
        let got_sat: Vec<bool> = got.iter().map(|o| o.saturated).collect();
        assert_eq!(got_codes, codes, "ki = {ki}");
        assert_eq!(got_sat, sat, "ki = {ki}");
        assert_eq!(pd.volts(codes[0]), -239.0 * 10.0 / 2048.0);
        assert_eq!(pd.volts(2048), 10.0);
    }
    // The Q16 gains themselves: round(2^16 * {1.55, 21.8, 6, 0.005} * pi).
    let g = IntPd::<4>::try_new(&paper_counts(2.0, 1)).unwrap().gains();
    assert_eq!((g.p[0], g.d[0], g.p[1], -g.d[1], g.i), (319_125, 4_488_346, 0, 1_235_324, 1_029));
}

#[test]
fn step_from_fresh_and_reset_use_zero_history() {
    let mut pd = IntPd::<4>::try_new(&paper_counts(2.0, 1)).unwrap();
    let a: Vec<IntOutput> = [(5, 1), (7, 2), (-3, 0)].iter().map(|&(y, z)| pd.step(&[y, z]).unwrap()).collect();
    assert_eq!(pd.integral_counts(), 12);
    pd.reset();
    assert_eq!(pd.integral_counts(), 0);
    let b: Vec<IntOutput> = [(5, 1), (7, 2), (-3, 0)].iter().map(|&(y, z)| pd.step(&[y, z]).unwrap()).collect();
    assert_eq!(a, b);
    // r = 1 from zero history: the first output is 0, the second sees q_y = 5, dq = (5, 1):
    // x = pi (-7.75 - 109 + 6) - 0.005 pi * 5 = -348.0099 -> -349.
    assert_eq!(a[0], IntOutput { code: 0, saturated: false });
    assert_eq!(a[1], IntOutput { code: -349, saturated: false });
    assert_eq!(pd.prime(&[0, 0]), Err(controller::InputError::HistoryLength { expected: 4, found: 2 }));
    assert_eq!(pd.step(&[0, 0, 0]), Err(controller::InputError::Measurements { expected: 2, found: 3 }));
}

#[test]
fn adc_floors_and_rejects() {
    let h = H_ADC;
    assert_eq!(adc(0.0, h), Ok(0));
    assert_eq!(adc(10.5 * h, h), Ok(10));
    assert_eq!(adc(-0.5 * h, h), Ok(-1));
    assert_eq!(adc(-1e-300, h), Ok(-1));
    assert_eq!(adc(core::f64::consts::PI, h), Ok(2048));
    assert_eq!(adc(2_147_483_647.5, 1.0), Ok(i32::MAX));
    assert_eq!(adc(2_147_483_648.0, 1.0), Err(AdcError::OutOfRange));
    assert_eq!(adc(-2_147_483_648.0, 1.0), Ok(i32::MIN));
    assert_eq!(adc(-2_147_483_648.5, 1.0), Err(AdcError::OutOfRange));
    assert_eq!(adc(1.0, 1e-320), Err(AdcError::OutOfRange));
    assert_eq!(adc(f64::NAN, h), Err(AdcError::NonFiniteAngle));
    assert_eq!(adc(f64::INFINITY, h), Err(AdcError::NonFiniteAngle));
    assert_eq!(adc(1.0, 0.0), Err(AdcError::BadStep));
    assert_eq!(adc(1.0, -h), Err(AdcError::BadStep));
    assert_eq!(adc(1.0, f64::NAN), Err(AdcError::BadStep));
}

#[test]
fn overflow_checks_are_on_in_this_profile() {
    // (c) relies on debug assertions (and with them overflow checks) being on for tests.
    const { assert!(cfg!(debug_assertions)) };
}
