//! Costly values that the tests of several modules check, computed once per test process.

use std::sync::OnceLock;

use crate::parametric::FurutaOptions;
use crate::shared_tangent::{SharedParametricModel, shared_parametric};

/// The report's shared-tangent model (default training options): `shared_tangent`'s tests
/// check it against the exact rates and the full system, `map_global`'s iterate it.
pub(crate) fn shared_model() -> &'static SharedParametricModel {
    static M: OnceLock<SharedParametricModel> = OnceLock::new();
    M.get_or_init(|| shared_parametric(&FurutaOptions::default()).unwrap())
}
