//! The tests of `furuta::convergence`.

use furuta::Error;
use furuta::convergence::*;

/// At 31 ms, order 7: against the exact map, the invariance error falls with the order on
/// the sphere of 0.05 rad (half the 2-torus amplitude) and the reduced map's rate error
/// there is small; on the sphere of 0.18 rad (the slow saddle cycle) it does not fall.
#[test]
fn exact_invariance_falls_inside_and_not_at_the_saddle_cycle() {
    let scene = furuta::full_system::scene_at(31.0).unwrap();
    let c = convergence(&scene, 7, &[0.05, 0.18], 4).unwrap();
    eprintln!("{}", c.to_text());
    assert_eq!(c.rows.len(), 6);
    let (a, b) = (&c.rows[..3], &c.rows[3..]);
    assert!(a[1].invariance < a[0].invariance / 2.0 && a[2].invariance < a[1].invariance / 2.0, "{a:?}");
    assert!(a[2].rate_error[0] < 1e-2 && a[2].rate_error[1] < 1e-2, "{:?}", a[2]);
    assert!(b[2].invariance > b[1].invariance / 2.0, "{b:?}");
    assert!(c.validity_radius == 0.05, "{}", c.validity_radius);
    // Root test on the 0.05 rad sphere: the radius estimates (in the table printed above)
    // lie in a narrow band around the torus amplitude.
    for &(r, _, est) in c.radius_estimates.iter().filter(|e| e.0 == 0.05) {
        assert!((0.09..0.12).contains(&est), "{r} {est}");
    }
    assert!(matches!(convergence(&scene, 11, &[0.05], 4), Err(Error::BadOption { what: "order", .. })));
    assert!(matches!(convergence(&scene, 7, &[-0.05], 4), Err(Error::BadOption { what: "radii", .. })));
}
