//! What the integrator integration tests share.

use sim::closed_loop::Trajectory;
use sim::scene::{IntegratorSpec, MethodKind, Scene, SceneBuilder, Task};

/// Bundled scene `name` for `periods` periods with an adaptive `method` at `rtol`
/// (atol = rtol / 100) and optionally another delay.
pub fn scene(name: &str, periods: u64, method: MethodKind, rtol: f64, delay: Option<u32>) -> Scene {
    let mut s = SceneBuilder::load(name)
        .unwrap()
        .periods(periods)
        .tasks(&[Task::Simulate])
        .integrator(IntegratorSpec { method, rtol: Some(rtol), atol: Some(rtol * 1e-2), steps: None })
        .build()
        .unwrap();
    if let Some(d) = delay {
        s.controller.delay = d;
        s.validate().unwrap();
    }
    s
}

/// Largest error of any state relative to the reference's size (at least 1).
pub fn max_relative_state_error(got: &Trajectory, reference: &Trajectory) -> f64 {
    let mut rel = 0.0f64;
    for i in 0..got.rows() {
        for k in 0..got.n_states() {
            let r = reference.state(i, k);
            rel = rel.max((got.state(i, k) - r).abs() / r.abs().max(1.0));
        }
    }
    rel
}

/// The scene validation refuses `steps` and a negative `rtol` for the adaptive `method`.
pub fn assert_scene_key_is_validated(method: MethodKind) {
    let mut s = scene("furuta-dt30.8", 10, method, 1e-8, None);
    s.integrator.steps = Some(4);
    let e = s.validate().unwrap_err().to_string();
    assert!(e.contains("integrator.steps"), "{e}");
    s.integrator.steps = None;
    s.integrator.rtol = Some(-1.0);
    let e = s.validate().unwrap_err().to_string();
    assert!(e.contains("integrator.rtol"), "{e}");
}
