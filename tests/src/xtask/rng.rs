//! Reproducible pseudo-random data for the generated on-target vectors.

/// SplitMix64.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in [-1, 1).
    pub fn sym(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
    /// Uniform integer in `[lo, hi]`.
    pub fn range(&mut self, lo: i64, hi: i64) -> i64 {
        lo + (self.next() % (hi - lo + 1) as u64) as i64
    }
}

/// A random `p x d` matrix with orthonormal columns (Gram-Schmidt on random columns in f64),
/// stored row-major as f32: the projection V1 of a generated model.
pub fn orthonormal_v1(rng: &mut Rng, p: usize, d: usize) -> Vec<f32> {
    let mut cols: Vec<Vec<f64>> = Vec::new();
    while cols.len() < d {
        let mut v: Vec<f64> = (0..p).map(|_| rng.sym()).collect();
        for c in &cols {
            let dot: f64 = v.iter().zip(c).map(|(a, b)| a * b).sum();
            v.iter_mut().zip(c).for_each(|(a, b)| *a -= dot * b);
        }
        let norm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
        if norm > 1e-3 {
            cols.push(v.into_iter().map(|a| a / norm).collect());
        }
    }
    (0..p).flat_map(|i| cols.iter().map(move |c| c[i] as f32)).collect()
}
