//! The decoded model in fixed-capacity storage: what the device keeps in RAM.

use super::DecodeError;
use super::wire::{BytesIn, check};
use crate::config::{ControllerConfig, Gains};

/// A decoded, validated model with capacities `P` (embedding dimension), `D` (reduced
/// dimension), `K` (RBF centres) and `T` (lift monomials). Actual sizes are at most these;
/// unused entries are zero. Matrices are stored row by row.
#[derive(Clone, Debug, PartialEq)]
pub struct Model<const P: usize, const D: usize, const K: usize, const T: usize> {
    config: ControllerConfig,
    p: usize,
    d: usize,
    k: usize,
    n_terms: usize,
    shift: usize,
    sample_period: f32,
    offset: f32,
    scale: f32,
    lift_order: usize,
    v1: [[f32; D]; P],
    lift: [[f32; T]; P],
    centres: [[f32; D]; K],
    weights: [[f32; D]; K],
    affine_lin: [[f32; D]; D],
    affine_bias: [f32; D],
}

/// Copies little-endian f32 bytes (`rows x cols`, row-major) into the leading block of `dst`.
fn fill<const C: usize>(dst: &mut [[f32; C]], bytes: &[u8], cols: usize) {
    if cols == 0 {
        return;
    }
    for (row, chunk) in dst.iter_mut().zip(bytes.chunks_exact(4 * cols)) {
        for (x, b) in row.iter_mut().zip(chunk.chunks_exact(4)) {
            let mut a = [0u8; 4];
            a.copy_from_slice(b);
            *x = f32::from_le_bytes(a);
        }
    }
}

impl<const P: usize, const D: usize, const K: usize, const T: usize> Model<P, D, K, T> {
    /// An all-zero placeholder (p = d = k = 0) to decode into; usable in a `static`.
    /// Not a valid model: nothing reads it before a successful [`Self::decode_into`].
    pub const fn empty() -> Self {
        Self {
            config: ControllerConfig { gains: Gains::new(), ki: 0.0, dt: 0.0, delay: 0, u_max: None, quant: None },
            p: 0,
            d: 0,
            k: 0,
            n_terms: 0,
            shift: 0,
            sample_period: 0.0,
            offset: 0.0,
            scale: 0.0,
            lift_order: 0,
            v1: [[0.0; D]; P],
            lift: [[0.0; T]; P],
            centres: [[0.0; D]; K],
            weights: [[0.0; D]; K],
            affine_lin: [[0.0; D]; D],
            affine_bias: [0.0; D],
        }
    }

    /// Decodes and checks `blob` (see [`crate::model`]); on error `self` is unchanged.
    pub fn decode_into(&mut self, blob: &[u8]) -> Result<(), DecodeError> {
        let c = check(blob, [P, D, K, T])?;
        let pl = &c.payload;
        let (p, d, k) = (usize::from(pl.p), usize::from(pl.d), usize::from(pl.k));
        *self = Self::empty_with(pl.config);
        self.p = p;
        self.d = d;
        self.k = k;
        self.n_terms = c.n_terms;
        self.shift = usize::from(pl.shift);
        self.sample_period = pl.sample_period;
        self.offset = pl.offset;
        self.scale = pl.scale;
        self.lift_order = usize::from(pl.lift_order);
        let BytesIn(v1) = pl.v1;
        fill(&mut self.v1, v1, d);
        fill(&mut self.lift, pl.lift.0, c.n_terms);
        fill(&mut self.centres, pl.centres.0, d);
        fill(&mut self.weights, pl.weights.0, d);
        // affine is d x (d+1): split into the linear block and the constant column.
        if d > 0 {
            for ((lin, bias), chunk) in
                self.affine_lin.iter_mut().zip(self.affine_bias.iter_mut()).zip(pl.affine.0.chunks_exact(4 * (d + 1)))
            {
                let mut vals = chunk.chunks_exact(4).map(|b| {
                    let mut a = [0u8; 4];
                    a.copy_from_slice(b);
                    f32::from_le_bytes(a)
                });
                for x in lin.iter_mut().take(d) {
                    *x = vals.next().unwrap_or(0.0);
                }
                *bias = vals.next().unwrap_or(0.0);
            }
        }
        Ok(())
    }

    /// Decodes `blob` into a new value (convenient on the host; on the device prefer
    /// [`Self::decode_into`] a `static`, the value can be large).
    pub fn decode(blob: &[u8]) -> Result<Self, DecodeError> {
        let mut m = Self::empty();
        m.decode_into(blob)?;
        Ok(m)
    }

    fn empty_with(config: ControllerConfig) -> Self {
        let mut m = Self::empty();
        m.config = config;
        m
    }

    pub fn config(&self) -> &ControllerConfig {
        &self.config
    }
    /// Embedding dimension.
    pub fn p(&self) -> usize {
        self.p
    }
    /// Reduced dimension.
    pub fn d(&self) -> usize {
        self.d
    }
    /// Number of RBF centres.
    pub fn k(&self) -> usize {
        self.k
    }
    /// Number of lift monomials.
    pub fn lift_terms(&self) -> usize {
        self.n_terms
    }
    pub fn lift_order(&self) -> usize {
        self.lift_order
    }
    /// Delay between embedding components, samples.
    pub fn shift(&self) -> usize {
        self.shift
    }
    pub fn sample_period(&self) -> f32 {
        self.sample_period
    }
    pub fn offset(&self) -> f32 {
        self.offset
    }
    pub fn scale(&self) -> f32 {
        self.scale
    }
    /// Rows of `V1` (`p` rows; the first `d` entries of each are meaningful).
    pub fn v1(&self) -> &[[f32; D]] {
        self.v1.get(..self.p).unwrap_or(&[])
    }
    /// Rows of the lift coefficients (`p` rows; first `lift_terms` entries meaningful).
    pub fn lift(&self) -> &[[f32; T]] {
        self.lift.get(..self.p).unwrap_or(&[])
    }
    /// RBF centres (`k` rows of `d`).
    pub fn centres(&self) -> &[[f32; D]] {
        self.centres.get(..self.k).unwrap_or(&[])
    }
    /// RBF weights (`k` rows of `d`).
    pub fn weights(&self) -> &[[f32; D]] {
        self.weights.get(..self.k).unwrap_or(&[])
    }
    /// Linear block of the affine part (`d` rows of `d`).
    pub fn affine_linear(&self) -> &[[f32; D]] {
        self.affine_lin.get(..self.d).unwrap_or(&[])
    }
    /// Constant column of the affine part (`d` entries).
    pub fn affine_bias(&self) -> &[f32] {
        self.affine_bias.get(..self.d).unwrap_or(&[])
    }

    /// Copies the model out as the host's owned form (round trips through `encode`).
    #[cfg(feature = "std")]
    pub fn to_owned_model(&self) -> super::OwnedModel {
        let rows =
            |m: &[[f32; D]], cols: usize| -> Vec<f32> { m.iter().flat_map(|r| r.iter().take(cols).copied()).collect() };
        let (d, t) = (self.d, self.n_terms);
        super::OwnedModel {
            config: self.config,
            p: self.p,
            shift: self.shift,
            sample_period: self.sample_period,
            offset: self.offset,
            scale: self.scale,
            d,
            lift_order: self.lift_order,
            k: self.k,
            v1: rows(self.v1(), d),
            lift: self.lift().iter().flat_map(|r| r.iter().take(t).copied()).collect(),
            centres: rows(self.centres(), d),
            weights: rows(self.weights(), d),
            affine: self
                .affine_linear()
                .iter()
                .zip(self.affine_bias())
                .flat_map(|(r, b)| r.iter().take(d).copied().chain(core::iter::once(*b)))
                .collect(),
        }
    }
}
