//! The host's owned model (`std` only): build it, then [`OwnedModel::encode`] it.

use super::{EncodeError, ModelRef};
use crate::config::ControllerConfig;

/// A model with `Vec` storage; fields as in [`ModelRef`] (row-major matrices).
#[derive(Clone, Debug, PartialEq)]
pub struct OwnedModel {
    pub config: ControllerConfig,
    pub p: usize,
    pub shift: usize,
    pub sample_period: f32,
    pub offset: f32,
    pub scale: f32,
    pub d: usize,
    pub lift_order: usize,
    pub k: usize,
    pub v1: Vec<f32>,
    pub lift: Vec<f32>,
    pub centres: Vec<f32>,
    pub weights: Vec<f32>,
    pub affine: Vec<f32>,
}

impl OwnedModel {
    pub fn as_ref(&self) -> ModelRef<'_> {
        ModelRef {
            config: self.config,
            p: self.p,
            shift: self.shift,
            sample_period: self.sample_period,
            offset: self.offset,
            scale: self.scale,
            d: self.d,
            lift_order: self.lift_order,
            k: self.k,
            v1: &self.v1,
            lift: &self.lift,
            centres: &self.centres,
            weights: &self.weights,
            affine: &self.affine,
        }
    }

    /// Checks the model and encodes it as a blob.
    pub fn encode(&self) -> Result<Vec<u8>, EncodeError> {
        let r = self.as_ref();
        let mut buf = vec![0u8; r.encoded_len_bound()];
        let n = r.encode_into(&mut buf)?;
        buf.truncate(n);
        Ok(buf)
    }
}
