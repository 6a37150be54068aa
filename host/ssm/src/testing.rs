//! Test support: small deterministic random generators for the tests of this crate and of
//! the crates above it (xorshift64, shifts 13, 7, 17; and an LCG, [`lcg_centered`]). Reproducible inputs for known-answer
//! and bit-for-bit tests, no statistical quality claimed; library code draws its noise
//! elsewhere.

/// Marsaglia's xorshift64 generator (shifts 13, 7, 17).
#[derive(Clone, Debug)]
pub struct XorShift64(u64);

impl XorShift64 {
    /// The generator from `seed` (0, the generator's fixed point, is taken as 1).
    pub fn new(seed: u64) -> Self {
        Self(if seed == 0 { 1 } else { seed })
    }

    /// The next state.
    pub fn next_u64(&mut self) -> u64 {
        let mut s = self.0;
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        self.0 = s;
        s
    }

    /// Uniform in [-0.5, 0.5): the top 53 bits over 2^53, minus 1/2.
    pub fn centered(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }

    /// Uniform in (0, 1): the top 53 bits plus 1/2, over 2^53.
    pub fn open01(&mut self) -> f64 {
        ((self.next_u64() >> 11) as f64 + 0.5) / (1u64 << 53) as f64
    }

    /// Standard normal by Box-Muller (cosine branch) from two [`XorShift64::open01`] draws.
    pub fn gauss(&mut self) -> f64 {
        let (u1, u2) = (self.open01(), self.open01());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// A second generator for the tests that were written with it: a 64-bit LCG (Knuth's MMIX
/// constants), its top 53 bits as a uniform value in [-0.5, 0.5), from `seed`.
pub fn lcg_centered(seed: u64) -> impl FnMut() -> f64 {
    let mut st = seed;
    move || {
        st = st.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        ((st >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    }
}
