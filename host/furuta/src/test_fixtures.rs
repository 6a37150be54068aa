//! Costly values that the tests of several modules check, computed once per test process.

use std::sync::OnceLock;

use crate::parametric::{FurutaOptions, TrainingRuns};
use crate::shared_tangent::{SharedParametricModel, shared_parametric_from};

/// The default training options with the runs cut at 0.3 rad instead of 0.2
/// (`map_global`'s training-cut test).
pub(crate) fn cut_03() -> FurutaOptions {
    FurutaOptions { max_theta: 0.3, ..FurutaOptions::default() }
}

/// The training runs of the default options and of [`cut_03`], simulated once up to the
/// larger cut as the report simulates them: every series cut from them is the one
/// `parametric::training_series` simulates on its own
/// (`parametric::tests::shared_training_runs_give_the_separate_runs_series`).
pub(crate) fn training_runs() -> &'static TrainingRuns {
    static R: OnceLock<TrainingRuns> = OnceLock::new();
    R.get_or_init(|| TrainingRuns::simulate(&[&FurutaOptions::default(), &cut_03()]).unwrap())
}

/// The report's shared-tangent model (default training options, fitted on
/// [`training_runs`] as the report fits it): `shared_tangent`'s tests check it against the
/// exact rates and the full system, `map_global`'s iterate it.
pub(crate) fn shared_model() -> &'static SharedParametricModel {
    static M: OnceLock<SharedParametricModel> = OnceLock::new();
    M.get_or_init(|| shared_parametric_from(&FurutaOptions::default(), training_runs()).unwrap())
}
