//! The reduced-model format: what the host exports and the device is flashed with.
//!
//! This module owns the byte layout of a model blob, its validation and the fixed-capacity
//! decoded form. It never allocates (the `std`-only [`OwnedModel`] aside) and never panics:
//! every malformed blob is a [`DecodeError`] naming what is wrong.
//!
//! # What a model is
//!
//! An SSM-reduced model (paper, appendix A) of a scalar observable `s`, sampled every
//! `sample_period` seconds:
//!
//! - **Delay embedding**: `y = [s(t), s(t + h), ..., s(t + (p-1) h)]` with `h = shift` samples;
//!   component 0 is the oldest sample of the window, component `p-1` the newest.
//! - **Normalization**: the model works on `(y - offset) / scale` (the same scalar for every
//!   component).
//! - **Projection**: reduced coordinates `eta = V1^T (y - offset) / scale`, `V1` is `p x d`.
//! - **Lift** (SSM parametrization): `M(eta) = V1 eta + L m(eta)` with `L` the `p x n_terms`
//!   coefficient matrix and `m(eta)` the monomials of degree `2..=lift_order` in the graded
//!   order of [`monomial`]; the physical embedding is `M(eta) * scale + offset`.
//! - **Reduced dynamics**: the RBF map with linear kernel advancing `t` by one sample period,
//!   `eta' = A [eta; 1] + sum_i w_i ||eta - c_i||_2`, with `K` centres `c_i` (each of dim `d`),
//!   weights `w_i` (each of dim `d`) and the affine part `A` (`d x (d+1)`, last column the
//!   constant term).
//! - The [`ControllerConfig`](crate::ControllerConfig) of the closed loop the model was
//!   identified on (carried here, validated by `controller::validate_config`).
//!
//! All matrices are `f32`, row-major.
//!
//! # Blob layout (format version 2)
//!
//! Version 2 carries the controller's gain vector (`ControllerConfig::gains`: per measured
//! coordinate its state index, `p`, `d` and encoder resolution) where version 1 had the
//! Furuta's `kp`, `kd`, `kphi_d` and two resolutions; a version-1 blob is refused with an
//! error naming both versions (re-export it).
//!
//! A fixed little-endian header of [`HEADER_LEN`] bytes:
//!
//! | offset | size | field                                              |
//! |--------|------|----------------------------------------------------|
//! | 0      | 4    | magic `b"SSMR"`                                    |
//! | 4      | 2    | format version (u16)                               |
//! | 6      | 2    | `d` (u16)                                          |
//! | 8      | 2    | `p` (u16)                                          |
//! | 10     | 2    | `K`, number of RBF centres (u16)                   |
//! | 12     | 2    | `n_terms`, number of lift monomials (u16)          |
//! | 14     | 4    | payload length in bytes (u32)                      |
//! | 18     | 4    | CRC-32 (ISO-HDLC, the zlib/PNG one) of the payload |
//!
//! followed by exactly `payload length` bytes of postcard: the fields of the private
//! `Payload` struct in declaration order (`config`, `p`, `shift`, `sample_period`, `offset`,
//! `scale`, `d`, `lift_order`, `n_terms`, `k`, then the matrices `v1`, `lift`, `centres`,
//! `weights`, `affine`, each a postcard byte string of little-endian `f32`s). The header
//! dimensions are repeated in the payload and must agree: a reader checks shapes before it
//! touches a number.

mod error;
mod fixed;
mod header;
pub mod monomial;
#[cfg(feature = "std")]
mod owned;
mod wire;

pub use error::{DecodeError, EncodeError};
pub use fixed::Model;
pub use header::Header;
pub use monomial::lift_terms;
#[cfg(feature = "std")]
pub use owned::OwnedModel;
pub use wire::ModelRef;

/// The four bytes every model blob starts with.
pub const MAGIC: [u8; 4] = *b"SSMR";
/// The format version this crate writes.
pub const FORMAT_VERSION: u16 = 2;
/// The format versions this crate reads.
pub const SUPPORTED_VERSIONS: &[u16] = &[2];
/// Length of the fixed header in bytes.
pub const HEADER_LEN: usize = 22;

/// The checksum over the payload: CRC-32/ISO-HDLC (as in zlib, PNG, Ethernet).
pub(crate) const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// The scalar fields of a model, as the encoder and the decoder both check them.
///
/// The controller configuration a blob carries is not checked here: its one validation is
/// the controller's (`controller::validate_config`, the `try_new`s), which a scene, a decoded
/// blob (`ssmctl inspect`, the firmware's load), and `ssmctl export` all go through, so a
/// configuration is accepted or refused the same way, with the same message, wherever it
/// crosses a boundary. Decoding it cannot fail beyond postcard's own checks.
pub(crate) struct Scalars {
    pub p: usize,
    pub d: usize,
    pub shift: usize,
    pub sample_period: f32,
    pub offset: f32,
    pub scale: f32,
    pub lift_order: usize,
}

/// Checks shared by the encoder and the decoder, on the scalar fields.
pub(crate) fn check_scalars(m: &Scalars) -> Result<(), DecodeError> {
    use DecodeError::{Invalid, NonFinite};
    for (what, v) in [("sample_period", m.sample_period), ("offset", m.offset), ("scale", m.scale)] {
        if !v.is_finite() {
            return Err(NonFinite { what });
        }
    }
    if m.p == 0 {
        return Err(Invalid { what: "p must be at least 1" });
    }
    if m.d == 0 {
        return Err(Invalid { what: "d must be at least 1" });
    }
    if m.d > m.p {
        return Err(Invalid { what: "d must not exceed p" });
    }
    if m.shift == 0 {
        return Err(Invalid { what: "shift must be at least 1 sample" });
    }
    if m.sample_period <= 0.0 {
        return Err(Invalid { what: "sample_period must be positive" });
    }
    if m.scale == 0.0 {
        return Err(Invalid { what: "scale must be non-zero" });
    }
    if m.lift_order == 0 {
        return Err(Invalid { what: "lift_order must be at least 1" });
    }
    Ok(())
}
