//! The tests of `chaos_study::lyapunov`.

use chaos_study::lyapunov::*;
use ssm::tangent::rbf_jacobian;

use chaos::{BenettinParams, benettin_qr};
use ssm::dynamics::ReducedDynamics;
use ssm::fixtures::random_rbf;

/// A Benettin run through [`dynamics_lyapunov`] (the fused step and Jacobian of
/// `ssm::tangent::Tangent`) against `benettin_qr` with the RBF map's step and
/// Jacobian apart, in dimensions 2..=6: the same spectrum bit for bit.
#[test]
fn fused_benettin_equals_the_separate_step_and_jacobian() {
    let mut rng = ssm::testing::XorShift64::new(0x9e37_79b9_7f4a_7c15);
    let mut rnd = move || rng.centered();
    for d in 2..=6 {
        let m = random_rbf(d, 100, true, &mut rnd);
        let dynamics = ReducedDynamics::Rbf(m.clone());
        let eta0: Vec<f64> = (0..d).map(|_| 0.2 * rnd()).collect();
        let fused = dynamics_lyapunov(&dynamics, &eta0, 1e3, 100, 2000).unwrap();
        let p =
            BenettinParams { transient: 100, steps: 2000, time_step: 0.03, renorm_every: 1, bound: 1e3, blocks: 20 };
        let mut feat = Vec::new();
        let apart = benettin_qr(
            &eta0,
            |x, out| {
                out.copy_from_slice(x);
                m.step(out, &mut feat);
            },
            |x, j| rbf_jacobian(&m, x, j),
            d,
            &p,
        )
        .unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&fused.spectrum), bits(&apart.exponents), "d {d}");
        assert_eq!(fused.std_error.to_bits(), apart.std_error[0].to_bits());
        assert_eq!(fused.kaplan_yorke.map(f64::to_bits), chaos::kaplan_yorke(&apart.exponents).map(f64::to_bits));
    }
}
