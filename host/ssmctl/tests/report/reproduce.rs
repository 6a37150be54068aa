use serde_json::Value;
use ssmctl::report::Report;
use ssmctl::report::reproduce::*;
use std::path::Path;

/// `v` without the wall-clock keys (at any depth).
fn without_wall(mut v: Value) -> Value {
    match &mut v {
        Value::Object(m) => {
            m.remove("wall_seconds");
            for x in m.values_mut() {
                *x = without_wall(x.take());
            }
        }
        Value::Array(a) => a.iter_mut().for_each(|x| *x = without_wall(x.take())),
        _ => {}
    }
    v
}

/// The scenes section (`--quick`) on a 1-thread and a 2-thread pool: the same summary
/// (wall times aside), the same trajectories, metadata and figures, byte for byte.
#[test]
fn scenes_section_is_bit_identical_on_one_and_two_threads() {
    let on = |threads: usize| {
        let dir = std::env::temp_dir().join(format!("ssmctl-scenes-par-{}-{threads}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let mut rep = Report::new(&dir).unwrap();
        std::fs::create_dir_all(dir.join("fig")).unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| scenes_section(&mut rep, true, true).map_err(|e| e.to_string())).unwrap();
        (dir, without_wall(Value::Object(rep.summary.clone())))
    };
    let ((d1, s1), (d2, s2)) = (on(1), on(2));
    assert_eq!(s1, s2);
    let scenes = s1["scenes"].as_array().unwrap();
    assert!(scenes.len() >= 5, "{s1}");
    for sc in scenes {
        let name = sc["name"].as_str().unwrap();
        for rel in [format!("scenes/{name}.csv"), format!("fig/{name}.png")] {
            let (a, b) = (std::fs::read(d1.join(&rel)).unwrap(), std::fs::read(d2.join(&rel)).unwrap());
            assert!(a == b, "{rel} differs between 1 and 2 threads");
        }
        let meta = |d: &Path| {
            without_wall(
                serde_json::from_slice(&std::fs::read(d.join(format!("scenes/{name}.json"))).unwrap()).unwrap(),
            )
        };
        assert_eq!(meta(&d1), meta(&d2), "{name}.json");
    }
    for d in [d1, d2] {
        std::fs::remove_dir_all(d).unwrap();
    }
}
