//! (d) Every `try_new` rejects each bad field with the variant naming it.

use crate::common;

use common::{H_ADC, paper_counts};
use controller::{ConfigError, ControllerConfig, Field, FloatPd, Gain, IntPd, Law, LiteralPd, QuantMode, Quantization};

type Path = fn(ControllerConfig) -> Result<(), ConfigError>;

fn float(cfg: ControllerConfig) -> Result<(), ConfigError> {
    FloatPd::<f64, 4>::try_new(&cfg).map(|_| ())
}
fn float32(cfg: ControllerConfig) -> Result<(), ConfigError> {
    FloatPd::<f32, 4>::try_new(&cfg).map(|_| ())
}
fn int(cfg: ControllerConfig) -> Result<(), ConfigError> {
    IntPd::<4>::try_new(&cfg).map(|_| ())
}
fn literal(cfg: ControllerConfig) -> Result<(), ConfigError> {
    LiteralPd::<4>::try_new(&cfg).map(|_| ())
}
fn law(cfg: ControllerConfig) -> Result<(), ConfigError> {
    Law::<4>::try_new(&cfg).map(|_| ())
}

fn literal_cfg() -> ControllerConfig {
    let mut c = paper_counts(0.0, 1);
    c.quant = c.quant.map(|q| Quantization { mode: QuantMode::Literal, ..q });
    c
}

/// Bad values of a common field, for every path.
fn check_common(set: fn(&mut ControllerConfig, f64), field: Field, positive: bool) {
    let bases =
        [ControllerConfig { u_max: Some(10.0), ..ControllerConfig::paper(0.025) }, paper_counts(1.0, 1), literal_cfg()];
    let mut bad = vec![
        (f64::NAN, ConfigError::NonFinite(field)),
        (f64::INFINITY, ConfigError::NonFinite(field)),
        (f64::NEG_INFINITY, ConfigError::NonFinite(field)),
    ];
    if positive {
        bad.push((0.0, ConfigError::NonPositive(field)));
        bad.push((-1.0, ConfigError::NonPositive(field)));
    }
    for base in bases {
        for &(v, expected) in &bad {
            let mut cfg = base;
            set(&mut cfg, v);
            let paths: [Path; 2] = match base.quant.map(|q| q.mode) {
                None => [float, float32],
                Some(QuantMode::Counts) => [int, law],
                Some(QuantMode::Literal) => [literal, law],
            };
            for path in paths {
                assert_eq!(path(cfg), Err(expected), "{field} = {v}, base {base:?}");
            }
        }
        // The unchanged base is valid.
        assert_eq!(law(base), Ok(()));
    }
}

#[test]
fn common_fields() {
    check_common(|c, v| c.gains[0].p = v, Field::P(0), false);
    check_common(|c, v| c.gains[0].d = v, Field::D(0), false);
    check_common(|c, v| c.gains[1].d = v, Field::D(1), false);
    check_common(|c, v| c.gains[1].p = v, Field::P(1), false);
    check_common(|c, v| c.ki = v, Field::Ki, false);
    check_common(|c, v| c.dt = v, Field::Dt, true);
    check_common(|c, v| c.u_max = Some(v), Field::UMax, true);
}

#[test]
fn quantization_fields() {
    type Set = fn(&mut ControllerConfig, f64);
    let sets: [(Set, Field); 3] = [
        (|c, v| c.gains[0].h_adc = v, Field::HAdc(0)),
        (|c, v| c.gains[1].h_adc = v, Field::HAdc(1)),
        (|c, v| c.quant.as_mut().unwrap().h_dac = v, Field::HDac),
    ];
    for base in [paper_counts(1.0, 1), literal_cfg()] {
        for (set, field) in sets {
            for (v, expected) in [
                (f64::NAN, ConfigError::NonFinite(field)),
                (f64::INFINITY, ConfigError::NonFinite(field)),
                (0.0, ConfigError::NonPositive(field)),
                (-H_ADC, ConfigError::NonPositive(field)),
            ] {
                let mut cfg = base;
                set(&mut cfg, v);
                assert_eq!(law(cfg), Err(expected), "{field} = {v}");
                let direct = match cfg.quant.unwrap().mode {
                    QuantMode::Counts => int(cfg),
                    QuantMode::Literal => literal(cfg),
                };
                assert_eq!(direct, Err(expected), "{field} = {v}");
            }
        }
    }
}

#[test]
fn delay_and_modes() {
    // H = 4 holds delay <= 2.
    let cases: [(Path, ControllerConfig); 4] = [
        (float, ControllerConfig::paper(0.025)),
        (float32, ControllerConfig::paper(0.025)),
        (int, paper_counts(0.0, 1)),
        (literal, literal_cfg()),
    ];
    for (path, base) in cases {
        assert_eq!(path(ControllerConfig { delay: 2, ..base }), Ok(()));
        assert_eq!(path(ControllerConfig { delay: 3, ..base }), Err(ConfigError::DelayTooLong { delay: 3, max: 2 }));
        assert_eq!(
            path(ControllerConfig { delay: u32::MAX, ..base }),
            Err(ConfigError::DelayTooLong { delay: u32::MAX, max: 2 })
        );
    }
    assert_eq!(
        FloatPd::<f64, 1>::try_new(&ControllerConfig { delay: 0, ..ControllerConfig::paper(0.025) }).map(|_| ()),
        Err(ConfigError::DelayTooLong { delay: 0, max: 0 })
    );
    assert_eq!(
        FloatPd::<f64, 2>::try_new(&ControllerConfig { delay: 0, ..ControllerConfig::paper(0.025) }).map(|_| ()),
        Ok(())
    );
    // Quantization presence and mode.
    assert_eq!(float(paper_counts(0.0, 1)), Err(ConfigError::UnexpectedQuantization));
    assert_eq!(int(ControllerConfig::paper(0.025)), Err(ConfigError::MissingQuantization));
    assert_eq!(literal(ControllerConfig::paper(0.025)), Err(ConfigError::MissingQuantization));
    assert_eq!(
        int(literal_cfg()),
        Err(ConfigError::WrongQuantMode { expected: QuantMode::Counts, found: QuantMode::Literal })
    );
    assert_eq!(
        literal(paper_counts(0.0, 1)),
        Err(ConfigError::WrongQuantMode { expected: QuantMode::Literal, found: QuantMode::Counts })
    );
}

#[test]
fn representability() {
    // f32: 1e39 overflows, 1e-50 flushes to zero.
    let f = ControllerConfig::paper(0.025);
    let with = |c: ControllerConfig, set: fn(&mut ControllerConfig)| {
        let mut c = c;
        set(&mut c);
        c
    };
    assert_eq!(float32(with(f, |c| c.gains[0].p = 1e39)), Err(ConfigError::OutOfRange(Field::P(0))));
    assert_eq!(float32(with(f, |c| c.gains[0].d = -1e-50)), Err(ConfigError::OutOfRange(Field::D(0))));
    assert_eq!(float32(ControllerConfig { dt: 1e-50, ..f }), Err(ConfigError::OutOfRange(Field::Dt)));
    assert_eq!(float32(ControllerConfig { u_max: Some(1e40), ..f }), Err(ConfigError::OutOfRange(Field::UMax)));
    assert_eq!(float(with(f, |c| c.gains[0].p = 1e39)), Ok(()));
    // Q16: the D gain is 21.8 pi ~ 68.5 codes/count at dt = 25 ms; at dt = 0.2 ms it is
    // ~8560 > 8192: out of range, named by the gain's field.
    let c = paper_counts(1.0, 1);
    assert_eq!(int(ControllerConfig { dt: 2e-4, ki: 0.0, ..c }), Err(ConfigError::OutOfRange(Field::D(0))));
    assert_eq!(int(ControllerConfig { dt: 2.5e-4, ki: 0.0, ..c }), Ok(()));
    assert_eq!(int(with(c, |c| c.gains[0].p = 3e4)), Err(ConfigError::OutOfRange(Field::P(0))));
    assert_eq!(int(with(c, |c| c.gains[1].d = 700.0)), Err(ConfigError::OutOfRange(Field::D(1))));
    // A non-zero gain that rounds to zero in Q16 would vanish silently: rejected.
    // I = ki * 0.0025 pi codes per count; below 2^-17 for ki < 9.7e-4.
    assert_eq!(int(ControllerConfig { ki: 9e-4, ..c }), Err(ConfigError::OutOfRange(Field::Ki)));
    assert_eq!(int(ControllerConfig { ki: 1e-3, ..c }), Ok(()));
    assert_eq!(int(ControllerConfig { ki: 0.0, ..c }), Ok(()));
    // DAC range: u_max below one code, or beyond i32.
    assert_eq!(int(ControllerConfig { u_max: Some(0.004), ..c }), Err(ConfigError::OutOfRange(Field::UMax)));
    assert_eq!(int(ControllerConfig { u_max: Some(1e8), ..c }), Err(ConfigError::OutOfRange(Field::UMax)));
    assert_eq!(int(ControllerConfig { u_max: None, ..c }), Ok(()));
    assert_eq!(
        literal(ControllerConfig { u_max: Some(1e-3), ..literal_cfg() }),
        Err(ConfigError::OutOfRange(Field::UMax))
    );
}

#[test]
fn gain_vector_shape() {
    // Empty, and two entries on one state index.
    let mut c = ControllerConfig::paper(0.025);
    c.gains.truncate(0);
    for path in [float, float32, law] {
        assert_eq!(path(c), Err(ConfigError::NoGains));
    }
    let mut c = paper_counts(0.0, 1);
    c.gains[1].index = c.gains[0].index;
    for path in [int, law] {
        assert_eq!(path(c), Err(ConfigError::DuplicateIndex { index: 0 }));
    }
    // One to four coordinates are valid on every path.
    let mut c = paper_counts(1.0, 1);
    for n in 1..=4u8 {
        c.gains.truncate(usize::from(n) - 1);
        c.gains.push(Gain { index: 10 + n, p: 1.0, d: 0.5, h_adc: H_ADC }).unwrap();
        assert_eq!(int(c), Ok(()), "{n} coordinates");
        assert_eq!(float(ControllerConfig { quant: None, ..c }), Ok(()), "{n} coordinates");
        assert_eq!(literal(ControllerConfig { quant: literal_cfg().quant, ..c }), Ok(()), "{n} coordinates");
    }
    assert!(c.gains.push(Gain { index: 20, p: 1.0, d: 0.5, h_adc: H_ADC }).is_err());
}

#[test]
fn errors_display_the_field() {
    assert_eq!(ConfigError::NonFinite(Field::D(1)).to_string(), "controller config: `gains[1].d` is not finite");
    assert!(ConfigError::NoGains.to_string().contains("`gains` is empty"));
    assert!(ConfigError::DuplicateIndex { index: 3 }.to_string().contains("state index 3"));
    assert!(ConfigError::GainSum.to_string().contains("codes per count"));
    assert_eq!(ConfigError::NonPositive(Field::HDac).to_string(), "controller config: `quant.h_dac` must be > 0");
    assert!(ConfigError::DelayTooLong { delay: 9, max: 2 }.to_string().contains("`delay` = 9"));
    assert!(ConfigError::OutOfRange(Field::Ki).to_string().contains("`ki`"));
    assert!(
        ConfigError::WrongQuantMode { expected: QuantMode::Counts, found: QuantMode::Literal }
            .to_string()
            .contains("Literal")
    );
}
