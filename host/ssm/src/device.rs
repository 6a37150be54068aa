//! Export of a fitted SSM-RBF model to the device blob (`shared::model`), and the check that
//! the device's f32 predictor code reproduces the host's f64 model.
//!
//! Conventions bridged here (both sides documented in their modules): the fitter evaluates
//! monomials and the RBF kernel on scaled reduced coordinates; the blob holds everything in
//! unscaled `eta = V1^T y`. The RBF fit uses one common scale `s` for all coordinates, so
//! `||eta/s - c|| = ||eta - s c|| / s` and the conversion is exact (up to f32 rounding).
//! Monomial orders agree (graded, exponent vectors descending lexicographically); the
//! conversion checks this rather than assuming it.
// Parses untrusted input: no indexing that can panic (CI runs clippy).
#![cfg_attr(not(test), deny(clippy::indexing_slicing))]

use crate::{ReducedDynamics, SsmModel};
use shared::ControllerConfig;
use shared::model::OwnedModel;

#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    #[error(
        "only RBF reduced dynamics can be exported to the device (this model has {0} dynamics); fit with --dynamics rbf"
    )]
    NotRbf(&'static str),
    #[error(
        "the device predictor implements the linear RBF kernel phi(r) = r only; this model's kernel is {0} (refit with --dynamics rbf to export)"
    )]
    Kernel(String),
    #[error("the RBF scale is not common to all coordinates ({0:?}); refit with this version")]
    NonUniformScale(Vec<f64>),
    #[error("lift monomial {0:?} is not in the device's graded order for d = {1}, order {2}")]
    Monomial(Vec<u32>, usize, usize),
    #[error("value {what} = {value} does not fit in f32")]
    F32 { what: &'static str, value: f64 },
    #[error("the device predictor embeds one observable; this model has {0}")]
    Observables(usize),
    #[error("encoding: {0}")]
    Encode(String),
    #[error("{what}: index {index} outside its {len} values (an unvalidated model)")]
    Shape { what: &'static str, index: usize, len: usize },
    #[error("{what} = {got} exceeds the limit of {max}")]
    Size { what: &'static str, got: usize, max: usize },
    #[error(
        "the model's sampling step {model_dt} s differs from the loop's controller dt {loop_dt} s (relative tolerance {rtol}); refit on data sampled at the loop's period"
    )]
    StepMismatch { model_dt: f64, loop_dt: f64, rtol: f64 },
}

/// Capacities of the host's blob decoder (`ssmctl inspect`, `export`'s round trip, the Python
/// module's `inspect_blob`): `p`, `d`, RBF centres, lift monomials.
pub type HostModel = shared::model::Model<256, { crate::limits::MAX_DIM }, 8192, 4096>;

/// Why [`decode_host`] returned no model: the blob's format, or the decoder's thread.
#[derive(Debug, thiserror::Error)]
pub enum HostDecodeError {
    #[error(transparent)]
    Decode(#[from] shared::model::DecodeError),
    /// The decoder's thread could not be started or did not finish.
    #[error("the blob decoder could not run: {0}")]
    Decoder(String),
}

/// Decodes `bytes` with the host decoder ([`HostModel`]: every check the device makes). The
/// fixed-capacity model is several MB, and an unoptimized build constructs it on the stack
/// (more than a main thread's 8 MB): it is decoded on a thread with room for it. Not generic,
/// so the decoder is compiled here, at this crate's optimization level, for every caller.
pub fn decode_host(bytes: &[u8]) -> Result<Box<HostModel>, HostDecodeError> {
    let bytes = bytes.to_vec();
    std::thread::Builder::new()
        .name("blob-decoder".into())
        .stack_size(64 << 20)
        .spawn(move || {
            let mut m = Box::new(HostModel::empty());
            m.decode_into(&bytes).map(|()| m)
        })
        .map_err(|e| HostDecodeError::Decoder(e.to_string()))?
        .join()
        .map_err(|_| HostDecodeError::Decoder("it panicked".into()))?
        .map_err(HostDecodeError::Decode)
}

/// `v[index]`, or an error naming the field (models are validated on load; this keeps an
/// unvalidated one from indexing out of bounds).
fn at(what: &'static str, v: &[f64], index: usize) -> Result<f64, ExportError> {
    v.get(index).copied().ok_or(ExportError::Shape { what, index, len: v.len() })
}

/// Checks that a model sampled every `model_dt` seconds can run in a loop sampled every
/// `loop_dt` seconds (the device predicts one sample ahead per controller period): equal
/// within [`crate::dynamics::MAP_DT_RTOL`]. Used by `export --scene` and the PIL host.
pub fn check_loop_dt(model_dt: f64, loop_dt: f64) -> Result<(), ExportError> {
    let rtol = crate::dynamics::MAP_DT_RTOL;
    if model_dt.is_finite() && loop_dt.is_finite() && (model_dt - loop_dt).abs() <= rtol * loop_dt.abs() {
        Ok(())
    } else {
        Err(ExportError::StepMismatch { model_dt, loop_dt, rtol })
    }
}

/// Exponent vectors of degrees 2..=order in the device's graded order.
pub fn device_exponents(d: usize, order: usize) -> Vec<Vec<u32>> {
    let mut out = Vec::new();
    for deg in 2..=order as u32 {
        let mut v: Vec<Vec<u32>> = Vec::new();
        fn rec(d: usize, left: u32, cur: &mut Vec<u32>, v: &mut Vec<Vec<u32>>) {
            if cur.len() == d - 1 {
                cur.push(left);
                v.push(cur.clone());
                cur.pop();
                return;
            }
            for e in (0..=left).rev() {
                cur.push(e);
                rec(d, left - e, cur, v);
                cur.pop();
            }
        }
        rec(d, deg, &mut Vec::new(), &mut v);
        out.extend(v);
    }
    out
}

fn f32_of(what: &'static str, value: f64) -> Result<f32, ExportError> {
    let v = value as f32;
    if v.is_finite() { Ok(v) } else { Err(ExportError::F32 { what, value }) }
}

/// Converts a fitted RBF model to the device model for controller configuration `cfg`.
pub fn to_device_model(m: &SsmModel, cfg: ControllerConfig) -> Result<OwnedModel, ExportError> {
    if m.observables != 1 {
        return Err(ExportError::Observables(m.observables));
    }
    let rbf = match &m.dynamics {
        ReducedDynamics::Rbf(r) => r,
        ReducedDynamics::Flow { .. } => return Err(ExportError::NotRbf("flow")),
        ReducedDynamics::Map { .. } => return Err(ExportError::NotRbf("polynomial map")),
    };
    if rbf.kernel != crate::Kernel::Linear {
        return Err(ExportError::Kernel(rbf.kernel.name()));
    }
    let man = &m.manifold;
    let (p, d, k) = (man.p, man.dim, rbf.n_centers());
    let s = rbf.scale.first().copied().unwrap_or(1.0);
    if rbf.scale.iter().any(|v| (v - s).abs() > 1e-15 * s.abs()) {
        return Err(ExportError::NonUniformScale(rbf.scale.clone()));
    }
    let mut v1 = Vec::with_capacity(p * d);
    for i in 0..p {
        for j in 0..d {
            v1.push(f32_of("v1", at("manifold.v1", &man.v1, j * p + i)?)?);
        }
    }
    let order = man
        .nonlinear
        .as_ref()
        .map_or(1, |poly| poly.exps.iter().map(|e| e.iter().sum::<u32>()).max().unwrap_or(1) as usize);
    let n_terms = shared::model::lift_terms(d, order).unwrap_or(usize::MAX);
    if d == 0 || n_terms > crate::limits::MAX_TERMS {
        return Err(ExportError::Size {
            what: "lift monomials (d, lift order)",
            got: n_terms,
            max: crate::limits::MAX_TERMS,
        });
    }
    let exps = device_exponents(d, order);
    let mut lift = vec![0.0f32; p * exps.len()];
    if let Some(poly) = &man.nonlinear {
        for (kk, e) in poly.exps.iter().enumerate() {
            let col = exps.iter().position(|x| x == e).ok_or_else(|| ExportError::Monomial(e.clone(), d, order))?;
            // monomial of eta/s_m = monomial(eta) / prod s_m^e
            let div: f64 = e.iter().zip(&poly.scale).map(|(&ej, sj)| sj.powi(ej as i32)).product();
            for (i, row) in lift.chunks_exact_mut(exps.len().max(1)).enumerate() {
                let slot =
                    row.get_mut(col).ok_or(ExportError::Shape { what: "lift column", index: col, len: exps.len() })?;
                *slot = f32_of("lift", at("manifold.nonlinear.coef", &poly.coef, kk * p + i)? / div)?;
            }
        }
    }
    let mut centres = Vec::with_capacity(k * d);
    for c in &rbf.centers {
        centres.push(f32_of("centre", c * s)?);
    }
    let mut weights = Vec::with_capacity(k * d);
    for i in 0..k {
        for j in 0..d {
            weights.push(f32_of("weight", at("dynamics.Rbf.coef", &rbf.coef, i * d + j)? / s)?);
        }
    }
    let mut affine = Vec::with_capacity(d * (d + 1));
    for j in 0..d {
        for l in 0..d {
            let id = if j == l { 1.0 } else { 0.0 };
            affine.push(f32_of("affine", id + at("dynamics.Rbf.coef", &rbf.coef, (k + l) * d + j)? / s)?);
        }
        affine.push(f32_of("affine bias", at("dynamics.Rbf.coef", &rbf.coef, (k + d) * d + j)?)?);
    }
    Ok(OwnedModel {
        config: cfg,
        p,
        shift: m.options.shift,
        sample_period: f32_of("sample_period", rbf.dt)?,
        offset: 0.0,
        scale: 1.0,
        d,
        lift_order: order,
        k,
        v1,
        lift,
        centres,
        weights,
        affine,
    })
}

/// Encodes the device blob.
pub fn encode(model: &OwnedModel) -> Result<Vec<u8>, ExportError> {
    model.encode().map_err(|e| ExportError::Encode(e.to_string()))
}
