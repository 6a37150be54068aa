//! Golden traces of the integer controller: a fixed sequence of encoder counts and the DAC
//! codes and saturation flags the host's `controller::IntPd` computes from it, for several
//! configurations. The firmware runs the same inputs through the same code and must agree
//! exactly (`qemu/src/trace_tests.rs`).

use crate::rng::Rng;
use controller::IntPd;
use shared::{ControllerConfig, Gain, Gains, MAX_GAINS, QuantMode, Quantization};
use std::f64::consts::PI;
use std::fmt::Write as _;

/// History capacity of the controller on both sides (delay up to 6).
pub const H: usize = 8;
/// Steps of the mean-reverting random walk, then the extreme inputs.
pub const WALK: usize = 2000;
pub const EXTREME: usize = 100;

/// One configuration of the trace set.
pub struct Case {
    pub name: &'static str,
    pub config: ControllerConfig,
}

/// The paper's quantized loop: gains KP 15.5, KD 5.45, KphiD 1.5, dt 25 ms,
/// h_adc = h_adc_phi = pi/1000 rad, h_dac = 10/2048 V, with the given integral gain, delay
/// and saturation.
pub fn paper_counts(ki: f64, delay: u32, u_max: Option<f64>) -> ControllerConfig {
    ControllerConfig {
        gains: Gains::shorthand(15.5, 5.45, 1.5, PI / 1000.0, PI / 1000.0),
        ki,
        dt: 0.025,
        delay,
        u_max,
        quant: Some(Quantization { mode: QuantMode::Counts, h_dac: 10.0 / 2048.0 }),
    }
}

/// The paper's loop measuring only theta (one coordinate, P and D).
pub fn one_coordinate(ki: f64, delay: u32) -> ControllerConfig {
    let mut c = paper_counts(ki, delay, Some(10.0));
    c.gains.truncate(1);
    c
}

/// Four coordinates: the paper's two angles and two more encoders (state indices 1 and 3,
/// resolutions pi/2000 and pi/500) with gains of the same order.
pub fn four_coordinates(ki: f64, delay: u32) -> ControllerConfig {
    let mut c = paper_counts(ki, delay, Some(10.0));
    for g in
        [Gain { index: 1, p: -2.0, d: 0.8, h_adc: PI / 2000.0 }, Gain { index: 3, p: 1.5, d: -0.3, h_adc: PI / 500.0 }]
    {
        c.gains.push(g).expect("two of four entries used");
    }
    c
}

/// Three coordinates: the first three of [`four_coordinates`] (the paper's two angles and
/// the encoder on state index 1).
pub fn three_coordinates(ki: f64, delay: u32) -> ControllerConfig {
    let mut c = four_coordinates(ki, delay);
    c.gains.truncate(3);
    c
}

pub fn cases() -> Vec<Case> {
    vec![
        Case { name: "pd_delay1", config: paper_counts(0.0, 1, Some(10.0)) },
        Case { name: "pid_delay1", config: paper_counts(0.5, 1, Some(10.0)) },
        Case { name: "pd_delay3", config: paper_counts(0.0, 3, Some(10.0)) },
        Case { name: "pid_delay3", config: paper_counts(0.5, 3, Some(10.0)) },
        Case { name: "pid_delay1_no_umax", config: paper_counts(0.5, 1, None) },
        Case { name: "pd_one_coordinate_delay1", config: one_coordinate(0.0, 1) },
        Case { name: "pid_four_coordinates_delay2", config: four_coordinates(0.5, 2) },
        Case { name: "pd_three_coordinates_delay1", config: three_coordinates(0.0, 1) },
        Case { name: "pid_three_coordinates_delay4", config: three_coordinates(0.5, 4) },
        Case {
            name: "pd_four_coordinates_delay0_no_umax",
            config: ControllerConfig { u_max: None, ..four_coordinates(0.0, 0) },
        },
    ]
}

/// The counts of every measured coordinate at one sample: the walk's two angles, then two
/// more coordinates formed from them (for the four-coordinate case).
pub type Sample = [i32; MAX_GAINS];

/// `WALK` steps of a mean-reverting random walk in counts (small steps, occasional jumps of
/// up to a few hundred counts, so the codes cover the linear range and both saturations),
/// then `EXTREME` steps drawn from the `i32` extremes and their neighbours. The third and
/// fourth counts are `z - y` and `y / 2 + z / 3` (wrapping at the extremes), so they move
/// with the walk without drawing more random numbers.
pub fn inputs() -> Vec<Sample> {
    pairs().into_iter().map(|(y, z)| [y, z, z.wrapping_sub(y), (y / 2).wrapping_add(z / 3)]).collect()
}

fn pairs() -> Vec<(i32, i32)> {
    let mut rng = Rng(0x4950_4454_5241_4345);
    let (mut y, mut z) = (0i64, 0i64);
    let mut out = Vec::with_capacity(WALK + EXTREME);
    for _ in 0..WALK {
        y += -y / 16 + rng.range(-3, 3);
        z += -z / 32 + rng.range(-6, 6);
        if rng.next().is_multiple_of(40) {
            y += rng.range(-300, 300);
        }
        if rng.next().is_multiple_of(60) {
            z += rng.range(-500, 500);
        }
        out.push((y as i32, z as i32));
    }
    let pool = [i32::MIN, i32::MIN + 1, -1, 0, 1, i32::MAX - 1, i32::MAX];
    for _ in 0..EXTREME {
        let a = pool[rng.range(0, pool.len() as i64 - 1) as usize];
        let b = pool[rng.range(0, pool.len() as i64 - 1) as usize];
        out.push((a, b));
    }
    out
}

/// The host's codes and flags for one case.
pub struct Trace {
    /// The Q16 gains: `p[0..4]`, `d[0..4]`, `i`.
    pub gains: [i64; 2 * MAX_GAINS + 1],
    pub code_max: i32,
    pub codes: Vec<i32>,
    pub saturated: Vec<bool>,
}

/// The Q16 gains of a controller as one array: `p[0..4]`, `d[0..4]`, `i`.
pub fn gain_array(g: &controller::quant::IntGains) -> [i64; 2 * MAX_GAINS + 1] {
    let mut a = [0; 2 * MAX_GAINS + 1];
    a[..MAX_GAINS].copy_from_slice(&g.p);
    a[MAX_GAINS..2 * MAX_GAINS].copy_from_slice(&g.d);
    a[2 * MAX_GAINS] = g.i;
    a
}

pub fn run(config: &ControllerConfig, inputs: &[Sample]) -> Result<Trace, String> {
    let mut pd = IntPd::<H>::try_new(config).map_err(|e| e.to_string())?;
    let n = pd.coordinates();
    let (mut codes, mut saturated) = (Vec::new(), Vec::new());
    for q in inputs {
        let o = pd.step(&q[..n]).map_err(|e| e.to_string())?;
        codes.push(o.code);
        saturated.push(o.saturated);
    }
    Ok(Trace { gains: gain_array(&pd.gains()), code_max: pd.code_max(), codes, saturated })
}

/// A trace that does not exercise both signs, the linear range and the clamp would let a
/// broken device pass: refuse to generate it.
fn check_live(name: &str, t: &Trace) -> Result<(), String> {
    let walk = WALK.min(t.codes.len());
    let (codes, sat) = (&t.codes[..walk], &t.saturated[..walk]);
    let linear_pos = codes.iter().zip(sat).filter(|&(&c, &s)| !s && c > 0).count();
    let linear_neg = codes.iter().zip(sat).filter(|&(&c, &s)| !s && c < 0).count();
    let clamped = sat.iter().filter(|&&s| s).count();
    let clamped_all = t.saturated.iter().filter(|&&s| s).count();
    if linear_pos < walk / 10 || linear_neg < walk / 10 || clamped > walk / 2 || clamped_all < walk / 100 {
        return Err(format!(
            "golden trace {name} is not representative: {linear_pos} positive and {linear_neg} negative unsaturated codes, \
             {clamped} clamped of {walk} walk steps, {clamped_all} clamped in all"
        ));
    }
    Ok(())
}

fn f64_lit(x: f64) -> String {
    format!("f64::from_bits({:#018x})", x.to_bits())
}

fn config_lit(c: &ControllerConfig) -> String {
    let q = c.quant.expect("trace configs are quantized");
    let u_max = match c.u_max {
        Some(u) => format!("Some({})", f64_lit(u)),
        None => "None".into(),
    };
    let gains: Vec<String> = c
        .gains
        .iter()
        .map(|g| {
            format!(
                "shared::Gain {{ index: {}, p: {}, d: {}, h_adc: {} }}",
                g.index,
                f64_lit(g.p),
                f64_lit(g.d),
                f64_lit(g.h_adc)
            )
        })
        .collect();
    format!(
        "shared::ControllerConfig {{ gains: shared::Gains::from_array([{}]), ki: {}, dt: {}, delay: {}, u_max: {u_max}, \
         quant: Some(shared::Quantization {{ mode: shared::QuantMode::Counts, h_dac: {} }}) }}",
        gains.join(", "),
        f64_lit(c.ki),
        f64_lit(c.dt),
        c.delay,
        f64_lit(q.h_dac)
    )
}

/// Summary for the xtask's log: (name, clamped steps, steps).
pub struct Generated {
    pub source: String,
    pub summary: Vec<(&'static str, usize, usize)>,
}

/// `traces.rs` for `qemu/target-data/`.
pub fn generate() -> Result<Generated, String> {
    let input = inputs();
    let n = input.len();
    let mut s = String::new();
    let _ = writeln!(s, "// Generated by `cargo xtask qemu-test` (tests/src/xtask/traces.rs). Do not edit.");
    let _ = writeln!(s, "pub const TRACE_H: usize = {H};");
    let _ = writeln!(s, "pub const TRACE_LEN: usize = {n};");
    let list: Vec<String> = input.iter().map(|q| format!("{q:?}")).collect();
    let _ = writeln!(s, "/// Encoder counts of four coordinates fed to every case, in order (a case with n");
    let _ = writeln!(s, "/// coordinates reads the first n).");
    let _ = writeln!(s, "pub static TRACE_INPUTS: [[i32; {MAX_GAINS}]; {n}] = [{}];", list.join(", "));
    let mut summary = Vec::new();
    let mut case_lits = Vec::new();
    for (i, case) in cases().iter().enumerate() {
        let t = run(&case.config, &input)?;
        check_live(case.name, &t)?;
        summary.push((case.name, t.saturated.iter().filter(|&&b| b).count(), n));
        let codes: Vec<String> = t.codes.iter().map(|c| c.to_string()).collect();
        let _ = writeln!(s, "static TRACE_CODES_{i}: [i32; {n}] = [{}];", codes.join(", "));
        let mut bits = vec![0u32; n.div_ceil(32)];
        for (j, &f) in t.saturated.iter().enumerate() {
            if f {
                bits[j / 32] |= 1 << (j % 32);
            }
        }
        let bits: Vec<String> = bits.iter().map(|b| format!("{b:#010x}")).collect();
        let _ = writeln!(s, "static TRACE_SAT_{i}: [u32; {}] = [{}];", n.div_ceil(32), bits.join(", "));
        case_lits.push(format!(
            "    TraceCase {{ name: {:?}, config: {}, gains: {:?}, code_max: {}, codes: &TRACE_CODES_{i}, saturated: &TRACE_SAT_{i} }},",
            case.name,
            config_lit(&case.config),
            t.gains,
            t.code_max
        ));
    }
    let _ = writeln!(
        s,
        "/// One configuration: the host's Q16 gains [p0..p3, d0..d3, i], DAC range, codes and saturation bitmap (bit j%32 of word j/32)."
    );
    let _ = writeln!(
        s,
        "pub struct TraceCase {{ pub name: &'static str, pub config: shared::ControllerConfig, pub gains: [i64; {}], pub code_max: i32, pub codes: &'static [i32; {n}], pub saturated: &'static [u32] }}",
        2 * MAX_GAINS + 1
    );
    let _ = writeln!(s, "pub static TRACE_CASES: [TraceCase; {}] = [", case_lits.len());
    for l in case_lits {
        let _ = writeln!(s, "{l}");
    }
    let _ = writeln!(s, "];");
    Ok(Generated { source: s, summary })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fixed-point law checked against an independent exact evaluation (i128 on the
    /// documented formula) on the generated inputs: the golden data are what the law says.
    #[test]
    fn host_trace_matches_exact_formula() {
        let input = inputs();
        for case in cases() {
            let t = run(&case.config, &input).unwrap();
            check_live(case.name, &t).unwrap();
            let r = case.config.delay as usize;
            let n = case.config.gains.len();
            let g = t.gains.map(i128::from);
            let (p, d, i) = (&g[..MAX_GAINS], &g[MAX_GAINS..2 * MAX_GAINS], g[2 * MAX_GAINS]);
            let at = |j: isize| if j < 0 { [0i128; MAX_GAINS] } else { input[j as usize].map(i128::from) };
            let mut s = 0i128;
            for (j, (&code, &sat)) in t.codes.iter().zip(&t.saturated).enumerate() {
                let q0 = at(j as isize - r as isize);
                let q1 = at(j as isize - r as isize - 1);
                s += q0[0];
                let mut acc = -i * s;
                for k in 0..n {
                    acc -= p[k] * q0[k] + d[k] * (q0[k] - q1[k]);
                }
                let raw = acc >> 16;
                let c = i128::from(t.code_max);
                let want = raw.clamp(-c, c);
                assert_eq!(i128::from(code), want, "{} step {j}", case.name);
                assert_eq!(sat, want != raw, "{} step {j}", case.name);
            }
        }
    }

    #[test]
    fn gains_are_the_rounded_paper_values() {
        let t = run(&paper_counts(0.5, 1, Some(10.0)), &[]).unwrap();
        let per = |g: f64| (g * 65536.0).round() as i64;
        let (h_adc, h_dac, dt) = (PI / 1000.0, 10.0 / 2048.0, 0.025);
        let z = per(1.5 * h_adc / dt / h_dac);
        assert_eq!(
            t.gains,
            [
                per(15.5 * h_adc / h_dac),
                0,
                0,
                0,
                per(5.45 * h_adc / dt / h_dac),
                -z,
                0,
                0,
                per(0.5 * dt * h_adc / h_dac)
            ]
        );
        assert_eq!(t.code_max, 2048);
    }
}
