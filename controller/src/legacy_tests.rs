//! The two-angle laws as they were before the gain vector (kp, kd on the primary angle,
//! kphi_d on the secondary one), their arithmetic kept line for line, as the reference the
//! gain-vector paths must reproduce bit for bit on the shorthand configurations.

use proptest::prelude::*;
use shared::{ControllerConfig, Gains, QuantMode, Quantization};

use crate::quant::{GAIN_FRAC_BITS, GAIN_MAX_CODES_PER_COUNT, GAIN_MAX_Q};
use crate::{FloatPd, IntPd, LiteralPd};

/// The old configuration's fields.
#[derive(Clone, Copy, Debug)]
struct Old {
    kp: f64,
    kd: f64,
    kphi_d: f64,
    ki: f64,
    dt: f64,
    delay: usize,
    u_max: Option<f64>,
    h_adc: f64,
    h_adc_phi: f64,
    h_dac: f64,
}

impl Old {
    fn config(&self, mode: Option<QuantMode>) -> ControllerConfig {
        ControllerConfig {
            gains: Gains::shorthand(self.kp, self.kd, self.kphi_d, self.h_adc, self.h_adc_phi),
            ki: self.ki,
            dt: self.dt,
            delay: self.delay as u32,
            u_max: self.u_max,
            quant: mode.map(|mode| Quantization { mode, h_dac: self.h_dac }),
        }
    }
}

/// The delayed samples `(k - r, k - r - 1)` after pushing `new` onto `hist` (newest last).
fn delayed<S: Copy>(hist: &mut Vec<S>, new: S, r: usize) -> (S, S) {
    hist.push(new);
    let n = hist.len();
    (hist[n - 1 - r], hist[n - 2 - r])
}

fn saturate(u: f64, u_max: Option<f64>) -> (f64, bool) {
    match u_max {
        Some(m) if u > m => (m, true),
        Some(m) if u < -m => (-m, true),
        _ => (u, false),
    }
}

/// The old `FloatPd<f64>` step sequence from a constant pre-history.
fn old_float(c: &Old, pre: (f64, f64), inputs: &[(f64, f64)]) -> Vec<(u64, bool)> {
    let mut hist = vec![pre; c.delay + 1];
    let mut integral = 0.0f64;
    inputs
        .iter()
        .map(|&s| {
            let ((y0, z0), (y1, z1)) = delayed(&mut hist, s, c.delay);
            integral = if c.ki == 0.0 { integral } else { integral + y0 * c.dt };
            let u = -c.kp * y0 - c.kd * (y0 - y1) / c.dt + c.kphi_d * (z0 - z1) / c.dt - c.ki * integral;
            let (u, sat) = saturate(u, c.u_max);
            (u.to_bits(), sat)
        })
        .collect()
}

/// The old `LiteralPd` step sequence.
fn old_literal(c: &Old, pre: (f64, f64), inputs: &[(f64, f64)]) -> Vec<(u64, bool)> {
    let mut hist = vec![pre; c.delay + 1];
    let mut integral = 0.0f64;
    let h = c.h_adc;
    let n_max = c.u_max.map(|u| (u / h).floor());
    inputs
        .iter()
        .map(|&s| {
            let ((y0, z0), (y1, z1)) = delayed(&mut hist, s, c.delay);
            integral = if c.ki == 0.0 { integral } else { integral + y0 * c.dt };
            let ydot = (y0 - y1) / c.dt;
            let zdot = (z0 - z1) / c.dt;
            let mut s = -c.kp * (y0 / h).floor() - c.kd * (ydot / h).floor() + c.kphi_d * (zdot / h).floor();
            if c.ki != 0.0 {
                s -= c.ki * (integral / h).floor();
            }
            let (n, sat) = saturate(s.floor(), n_max);
            ((h * n).to_bits(), sat)
        })
        .collect()
}

/// The old `IntPd`'s Q16 gains `[p, d, z, i]`, and whether its `try_new` accepted them
/// (each within `GAIN_MAX_Q`, none rounded to zero from a non-zero value, `u_max / h_dac`
/// within `1..=i32::MAX`).
fn old_gains(c: &Old) -> ([i64; 4], bool) {
    let q16 = |x: f64| libm::round(x * (1u64 << GAIN_FRAC_BITS) as f64);
    let per_volt = 1.0 / c.h_dac;
    let g = [
        (q16(c.kp * c.h_adc * per_volt), c.kp),
        (q16(c.kd * c.h_adc / c.dt * per_volt), c.kd),
        (q16(c.kphi_d * c.h_adc_phi / c.dt * per_volt), c.kphi_d),
        (q16(c.ki * c.dt * c.h_adc * per_volt), c.ki),
    ];
    let ok = g.iter().all(|&(q, src)| q.abs() <= GAIN_MAX_Q as f64 && !(q == 0.0 && src != 0.0))
        && c.u_max.is_none_or(|u| (1.0..=f64::from(i32::MAX)).contains(&(u / c.h_dac).floor()));
    (g.map(|(q, _)| q as i64), ok)
}

/// The old `IntPd` step sequence: Q16 gains `[p, d, z, i]`, then the four-product step
/// (only for gains the old `try_new` accepted).
fn old_int(c: &Old, pre: (i32, i32), inputs: &[(i32, i32)]) -> (Vec<(i32, bool)>, [i64; 4]) {
    let (g, ok) = old_gains(c);
    assert!(ok, "the old controller refused {c:?}");
    let code_max = c.u_max.map_or(i64::from(i32::MAX), |u| (u / c.h_dac).floor() as i64);
    let [gz, gd, gpd] = [g[2] as i32, g[1] as i32, (g[0] + g[1]) as i32];
    let mut hist = vec![pre; c.delay + 1];
    let mut sum = 0i64;
    let out = inputs
        .iter()
        .map(|&s| {
            let ((y0, z0), (y1, z1)) = delayed(&mut hist, s, c.delay);
            sum = sum.saturating_add(i64::from(y0));
            let m = |a: i32, b: i32| i64::from(a) * i64::from(b);
            let pdz = m(gz, z0) - m(gz, z1) - m(gpd, y0) + m(gd, y1);
            let integral = if g[3] == 0 {
                0
            } else if sum.unsigned_abs() < 1 << 33 {
                g[3].wrapping_mul(sum)
            } else {
                g[3].saturating_mul(sum)
            };
            let acc = pdz.saturating_sub(integral);
            let raw = acc >> GAIN_FRAC_BITS;
            let code = raw.clamp(code_max.saturating_neg(), code_max);
            (i32::try_from(code).unwrap(), code != raw)
        })
        .collect();
    (out, g)
}

fn gain() -> impl Strategy<Value = f64> {
    prop_oneof![1 => Just(0.0), 8 => -60.0..60.0f64]
}

fn old_config() -> impl Strategy<Value = Old> {
    (
        (gain(), gain(), gain(), prop_oneof![Just(0.0), -5.0..5.0f64]),
        (1e-3..0.05f64, 0usize..=6, prop_oneof![Just(None), (0.5..20.0f64).prop_map(Some)]),
        (1e-4..1e-2f64, 1e-4..1e-2f64, 1e-3..0.05f64),
    )
        .prop_map(|((kp, kd, kphi_d, ki), (dt, delay, u_max), (h_adc, h_adc_phi, h_dac))| Old {
            kp,
            kd,
            kphi_d,
            ki,
            dt,
            delay,
            u_max,
            h_adc,
            h_adc_phi,
            h_dac,
        })
}

fn angles(n: std::ops::Range<usize>) -> impl Strategy<Value = Vec<(f64, f64)>> {
    prop::collection::vec(
        (prop_oneof![1 => Just(0.0), 9 => -2.0..2.0f64], prop_oneof![1 => Just(0.0), 9 => -20.0..20.0f64]),
        n,
    )
}

fn extreme_gain() -> impl Strategy<Value = f64> {
    let m = GAIN_MAX_CODES_PER_COUNT;
    prop_oneof![Just(m), Just(-m), Just(0.0), Just(1.0), 1e-3..m, -m..-1e-3]
}

fn count() -> impl Strategy<Value = i32> {
    prop_oneof![any::<i32>(), Just(i32::MIN), Just(i32::MAX), Just(0), -3000..3000i32]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Exact path: every output bit and flag as before, on random configurations and states.
    #[test]
    fn float_path_is_bit_identical_to_the_two_angle_law(
        c in old_config(), pre in angles(1..2), inputs in angles(1..80), sat in any::<bool>(),
    ) {
        let c = Old { u_max: if sat { c.u_max } else { None }, ..c };
        let want = old_float(&c, pre[0], &inputs);
        let mut pd = FloatPd::<f64, 8>::try_new(&c.config(None)).unwrap();
        pd.prime_constant(&[pre[0].0, pre[0].1]).unwrap();
        for (i, (&(y, z), &(bits, s))) in inputs.iter().zip(&want).enumerate() {
            let o = pd.step(&[y, z]).unwrap();
            prop_assert_eq!((o.u.to_bits(), o.saturated), (bits, s), "step {}: {} vs {}", i, o.u, f64::from_bits(bits));
        }
    }

    /// The paper's literal reading: bit for bit as before.
    #[test]
    fn literal_path_is_bit_identical_to_the_two_angle_law(
        c in old_config(), pre in angles(1..2), inputs in angles(1..80),
    ) {
        let want = old_literal(&c, pre[0], &inputs);
        let mut pd = LiteralPd::<8>::try_new(&c.config(Some(QuantMode::Literal))).unwrap();
        pd.prime_constant(&[pre[0].0, pre[0].1]).unwrap();
        for (i, (&(y, z), &(bits, s))) in inputs.iter().zip(&want).enumerate() {
            let o = pd.step(&[y, z]).unwrap();
            prop_assert_eq!((o.u.to_bits(), o.saturated), (bits, s), "step {}", i);
        }
    }

    /// Counts path: the same Q16 gains and the same codes and flags, realistic configurations.
    #[test]
    fn int_path_is_bit_identical_to_the_two_angle_law(
        c in old_config(), pre in (count(), count()), inputs in prop::collection::vec((count(), count()), 1..80),
    ) {
        // Accepted exactly when the old controller accepted the configuration.
        let new = IntPd::<8>::try_new(&c.config(Some(QuantMode::Counts)));
        prop_assert_eq!(new.is_ok(), old_gains(&c).1);
        let Ok(mut pd) = new else { return Ok(()) };
        let (want, g) = old_int(&c, pre, &inputs);
        let ng = pd.gains();
        prop_assert_eq!([ng.p[0], ng.d[0], -ng.d[1], ng.i], g);
        prop_assert_eq!(ng.p[1], 0);
        pd.prime_constant(&[pre.0, pre.1]).unwrap();
        for (i, (&(y, z), &w)) in inputs.iter().zip(&want).enumerate() {
            let o = pd.step(&[y, z]).unwrap();
            prop_assert_eq!((o.code, o.saturated), w, "step {}", i);
        }
    }

    /// Counts path at the extreme gains the old code accepted (unit steps: gains are codes per
    /// count) over the whole i32 range: still accepted, still the same codes.
    #[test]
    fn int_path_matches_at_extreme_gains(
        kp in extreme_gain(), kd in extreme_gain(), kphi_d in extreme_gain(), ki in extreme_gain(),
        delay in 0usize..=6, u_max in prop_oneof![Just(None), (1u32..=u32::MAX / 2).prop_map(|c| Some(f64::from(c) + 0.5))],
        pre in (count(), count()), inputs in prop::collection::vec((count(), count()), 1..64),
    ) {
        let c = Old { kp, kd, kphi_d, ki, dt: 1.0, delay, u_max, h_adc: 1.0, h_adc_phi: 1.0, h_dac: 1.0 };
        let (want, g) = old_int(&c, pre, &inputs);
        prop_assert!(g.iter().all(|x| x.abs() <= GAIN_MAX_Q));
        let mut pd = IntPd::<8>::try_new(&c.config(Some(QuantMode::Counts))).unwrap();
        pd.prime_constant(&[pre.0, pre.1]).unwrap();
        for (i, (&(y, z), &w)) in inputs.iter().zip(&want).enumerate() {
            prop_assert_eq!(pd.step(&[y, z]).map(|o| (o.code, o.saturated)), Ok(w), "step {}", i);
        }
    }
}
