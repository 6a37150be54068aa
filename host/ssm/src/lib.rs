//! Data-driven spectral submanifold (SSM) models from time series of one or several
//! observables: the SSMLearn algorithm (paper appendix A) in our own code.
//!
//! Pipeline: [`data`] (CSV and SSMLearn `.mat` loading through [`mat`], validation, time
//! windows) -> [`embed`] (delay embedding, over-embedding of several observables) ->
//! [`manifold`] (tangent space by SVD, constrained graph-style polynomial parametrization)
//! -> [`dynamics`] (polynomial flow / polynomial map / linear-kernel RBF map) -> [`fit`](mod@fit)
//! (options, fitted model, prediction with blow-up detection); [`metrics`] holds NMTE,
//! DTW-aligned NMTE and FFT amplitude spectra; [`spectrum`] sliding two-tone amplitudes and
//! interpolated spectral peaks. Linear least squares go through [`ridge`]. On top of a fit:
//! [`auto`] (settings chosen by cross-validation, bootstrap intervals). [`normal_form`] (polar normal forms of flows and maps, with their change of
//! coordinates), [`map_ssm`] (the SSM of a given polynomial map by the parametrization
//! method, reduced map in extended normal form: the equation-driven reference), [`backbone`] (instantaneous damping and frequency against the amplitude of
//! an observable), [`frc`] (forced response curves from the normal form, calibrated at one
//! measured point), [`portrait`] (analysis of the
//! two-mode amplitude equations: fixed points, saddle manifolds, heteroclinic and torus-Hopf
//! detection), [`interp`] (coefficients interpolated in a system parameter) and [`device`]
//! (a fitted RBF model converted to the device's `shared::model` blob); [`tangent`] the
//! analytic Jacobians of the reduced maps, for their Lyapunov spectra.
//!
//! Architecture invariant: this crate knows no plant, no scene and no simulator (it does not
//! depend on `sim`), and draws nothing; its only workspace dependency is `shared`, for the
//! device model format.
// Library code returns errors: no unwrap/expect/panic (CI runs clippy; the tests, which may,
// are in `tests/`).
#![deny(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

pub mod auto;
pub mod backbone;
pub mod data;
pub mod device;
pub mod dynamics;
pub mod embed;
pub mod error;
pub mod fit;
pub mod fixtures;
pub mod frc;
pub mod interp;
pub mod limits;
pub mod manifold;
pub mod map_ssm;
pub mod mat;
pub mod metrics;
pub mod multistep;
pub mod normal_form;
pub mod poly;
pub mod portrait;
pub mod ridge;
pub mod spectrum;
pub mod tangent;
pub mod testing;
pub mod weight;

/// Not part of the API: items of the modules' implementations that the crate's own tests
/// check directly (the tests are compiled outside the library, in `tests/`): the sparse
/// polynomial algebra of the normal forms, the table of the map SSM's monomials, the
/// portrait's amplitude field, the regressions' memory budget and SVD path, and fast paths
/// checked bit for bit against plain ones. Hidden from the documentation, as are the few
/// fields and methods of public types the tests read (`PreparedDynamics::poly`,
/// `PreparedLift::poly`, `PreparedPoly::in_order`, `PolynomialMap::eval_c`, `RidgeLs::s`,
/// `RidgeLs::from_parts`); they may change at any time.
#[doc(hidden)]
pub mod internals {
    pub use crate::dynamics::design_by_columns;
    pub use crate::map_ssm::{Table, structural};
    pub use crate::normal_form::{add_into, compose, map_to_flow, mul, mul_btree, normal_form_parts, one, var};
    pub use crate::portrait::Field;
    pub use crate::ridge::{Budget, Reservation, qr_first, u_blocks};
    pub use crate::tangent::{rbf_jacobian_any, rbf_step_and_jacobian};
}

pub use data::{DataError, MultiSeries, TimeSeries, load_csv, load_csv_column, load_csv_observables, load_mat};
pub use dynamics::{Dynamics, Kernel, LowDegreeStage, ReducedDynamics, RowWeight};
pub use error::FitError;
pub use fit::{
    FitOptions, MODEL_FORMAT, MODEL_FORMAT_VERSION, ModelFileError, Prediction, SsmModel, Stop, StopReason, fit,
    fit_multi,
};
pub use ridge::{Conditioning, Ridge};

/// `ssm`'s module errors lifted into a higher layer's error.
/// Implements `From<E>` for `$target` for every module error `E` of this layer, through this
/// layer's [`Error`]: for a crate above whose error wraps it, since `?` does not chain two
/// `From` steps. The list lives here, beside the enum, so a new module error is lifted everywhere.
#[macro_export]
macro_rules! lift_ssm_errors {
    ($target:ty) => {
        impl ::core::convert::From<$crate::error::FitError> for $target {
            fn from(e: $crate::error::FitError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::data::DataError> for $target {
            fn from(e: $crate::data::DataError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::normal_form::NormalFormError> for $target {
            fn from(e: $crate::normal_form::NormalFormError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::portrait::PortraitError> for $target {
            fn from(e: $crate::portrait::PortraitError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::interp::InterpError> for $target {
            fn from(e: $crate::interp::InterpError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::interp::MixError> for $target {
            fn from(e: $crate::interp::MixError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::spectrum::SpectrumError> for $target {
            fn from(e: $crate::spectrum::SpectrumError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::device::ExportError> for $target {
            fn from(e: $crate::device::ExportError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::fit::ModelFileError> for $target {
            fn from(e: $crate::fit::ModelFileError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::backbone::BackboneError> for $target {
            fn from(e: $crate::backbone::BackboneError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::frc::FrcError> for $target {
            fn from(e: $crate::frc::FrcError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::map_ssm::MapSsmError> for $target {
            fn from(e: $crate::map_ssm::MapSsmError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
        impl ::core::convert::From<$crate::auto::AutoError> for $target {
            fn from(e: $crate::auto::AutoError) -> Self {
                <$target>::from($crate::Error::from(e))
            }
        }
    };
}

/// Anything the SSM layer refuses or fails at: one enum over the module errors (each names
/// the option, file, row, dimension or parameter that is wrong); `?` lifts any of them.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Fit(#[from] crate::error::FitError),
    #[error(transparent)]
    Data(#[from] crate::data::DataError),
    #[error(transparent)]
    NormalForm(#[from] crate::normal_form::NormalFormError),
    #[error(transparent)]
    Portrait(#[from] crate::portrait::PortraitError),
    #[error(transparent)]
    Interp(#[from] crate::interp::InterpError),
    #[error(transparent)]
    Mix(#[from] crate::interp::MixError),
    #[error(transparent)]
    Spectrum(#[from] crate::spectrum::SpectrumError),
    #[error(transparent)]
    Export(#[from] crate::device::ExportError),
    #[error(transparent)]
    ModelFile(#[from] crate::fit::ModelFileError),
    #[error(transparent)]
    Backbone(#[from] crate::backbone::BackboneError),
    #[error(transparent)]
    Frc(#[from] crate::frc::FrcError),
    #[error(transparent)]
    MapSsm(#[from] crate::map_ssm::MapSsmError),
    #[error(transparent)]
    Auto(#[from] crate::auto::AutoError),
}
