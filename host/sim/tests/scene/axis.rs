use sim::plant::furuta::FurutaParams;
use sim::scene::Scene;
use sim::scene::axis::*;

fn scene(name: &str) -> Scene {
    Scene::load(name, &[]).unwrap()
}

#[test]
fn names_resolve_to_gains_and_parameters() {
    let s = scene("cartpole-pd");
    let a = SceneAxis::parse(&s, "x.p").unwrap();
    assert!(matches!(&a, SceneAxis::Gain { slot: 1, derivative: false, .. }), "{a:?}");
    assert_eq!(a.value(&s).unwrap(), -20.0);
    assert_eq!(SceneAxis::parse(&s, "gains.theta.d").unwrap().value(&s).unwrap(), -7.0);
    assert_eq!(SceneAxis::parse(&s, "kd").unwrap().value(&s).unwrap(), -7.0);
    let m = SceneAxis::parse(&s, "plant.parameters.m").unwrap();
    assert_eq!(m.value(&s).unwrap(), 0.2);
    assert_eq!(m.value(&m.apply(&s, 0.25).unwrap()).unwrap(), 0.25);
    // The Furuta's shorthand: kphi_d is minus the D gain of phi.
    let f = scene("furuta-dt25");
    let k = SceneAxis::parse(&f, "kphi_d").unwrap();
    assert_eq!(k.value(&f).unwrap(), 1.5);
    assert_eq!(SceneAxis::parse(&f, "phi.d").unwrap().value(&f).unwrap(), -1.5);
    assert_eq!(SceneAxis::parse(&f, "plant.params.b1").unwrap().value(&f).unwrap(), FurutaParams::default().b1);
}

#[test]
fn applying_an_axis_equals_the_same_override() {
    let s = scene("furuta-dt25");
    let a = SceneAxis::parse(&s, "phi.p").unwrap();
    // Not expressible in the shorthand: the scene switches to per-coordinate gains.
    let t = a.apply(&s, 0.7).unwrap();
    let mut want = s.controller_config();
    a.set_gain(&mut want, 0.7);
    assert_eq!(t.controller_config(), want);
    assert_eq!(want.gains[1].p, 0.7);
    let k = SceneAxis::parse(&s, "kphi_d").unwrap();
    assert_eq!(k.apply(&s, 2.0).unwrap(), Scene::load("furuta-dt25", &["controller.kphi_d=2.0".into()]).unwrap());
    let c = scene("cartpole-pd");
    let m = SceneAxis::parse(&c, "plant.parameters.M").unwrap();
    assert_eq!(m.apply(&c, 0.7).unwrap(), Scene::load("cartpole-pd", &["plant.parameters.M=0.7".into()]).unwrap());
}

#[test]
fn unknown_names_list_the_scene_axes() {
    let s = scene("cartpole-pd");
    for (bad, why) in [
        ("y.p", "`y` is not a coordinate"),
        ("theta.i", "unknown axis `theta.i`"),
        ("plant.parameters.q", "`q` is not a parameter"),
        ("plant.params.m", "plant.parameters.NAME"),
    ] {
        let e = SceneAxis::parse(&s, bad).unwrap_err().to_string();
        assert!(e.contains(why) && e.contains("theta.p, theta.d, x.p, x.d") && e.contains("plant.parameters.M"), "{e}");
        assert!(e.contains(bad), "{e}");
    }
    let p = scene("pendulum-pd");
    let e = SceneAxis::parse(&p, "kphi_d").unwrap_err().to_string();
    assert!(e.contains("second coordinate"), "{e}");
}
