use sim::units::*;

/// The factor is the one the scene files have always been read with: the decimal
/// periods of the study convert to the same doubles as before.
#[test]
fn conversions_are_the_historical_factors() {
    for ms in [25.0, 30.5, 31.41, 31.55, 32.3] {
        assert_eq!(ms_to_s(ms).to_bits(), (ms * 1e-3).to_bits());
    }
    assert_eq!(s_to_ms(0.0125), 12.5);
}
