use sim::scene::Scene;
use ssmctl::draw::chart::*;

#[test]
fn writes_a_png() {
    let dir = std::env::temp_dir().join(format!("chart-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("stability.png");
    let scene = Scene::load("furuta-dt25", &[]).unwrap();
    let s = chart_for_scene(&scene, &out, &[20.0, 25.0], (0.0, 40.0, 41), (0.0, 8.0, 33)).unwrap();
    let bytes = std::fs::read(&out).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR width and height.
    let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    assert_eq!((w, h), (2 * 620, 560 + 50));
    assert_eq!(s.panels.len(), 2);
    assert_eq!(s.base_point, (15.5, 5.45));
    std::fs::remove_dir_all(&dir).unwrap();
}
