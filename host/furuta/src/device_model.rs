//! The reference device model: an RBF SSM model fitted to a simulated scene, as flashed in
//! the processor-in-the-loop runs and measured in the device table.

use sim::closed_loop::simulate;
use sim::scene::Scene;
use ssm::{Dynamics, FitOptions, Ridge, SsmModel, TimeSeries, fit};

/// The reference device model: the scene's primary angle over `periods` simulated periods,
/// a 4D SSM (p = 9, quadratic lift) with a 60-centre RBF map. Returns the model and the
/// series it was fitted to.
pub fn fit_scene_rbf(scene: &Scene, periods: u64) -> Result<(SsmModel, TimeSeries), crate::Error> {
    let mut s = scene.clone();
    s.run.periods = periods;
    let tr = simulate(&s, None)?;
    let ts = TimeSeries::new("theta", tr.t.clone(), tr.primary())?;
    let opts = FitOptions {
        dim: 4,
        embed: 9,
        shift: 1,
        manifold_order: 2,
        dyn_order: 1,
        dynamics: Dynamics::Rbf { centers: 60 },
        ridge: Ridge::Fixed(1e-10),
        linear_anchor: None,
        anchor_joint: false,
    };
    let m = fit(std::slice::from_ref(&ts), &opts)?;
    Ok((m, ts))
}
