use plotters::style::RGBColor;
use ssmctl::draw::basin::*;

#[test]
fn cell_edges_meet_halfway() {
    assert_eq!(edges(&[1.0, 2.0, 4.0]), vec![(0.5, 1.5), (1.5, 3.0), (3.0, 5.0)]);
    assert_eq!(edges(&[2.0]), vec![(1.0, 3.0)]);
    let c = escape_color(0.0);
    assert_eq!((c.0, c.1, c.2), (150, 20, 20));
    let box_ = ((0.0, 1.0), (0.0, 1.0));
    let parts = inside_parts(
        &[(0.1, 0.1), (0.2, 0.2), (1.5, 0.3), (0.5, 0.5), (0.6, 0.6), (0.7, f64::NAN), (0.8, 0.8)],
        box_.0,
        box_.1,
    );
    assert_eq!(parts, vec![vec![(0.1, 0.1), (0.2, 0.2)], vec![(0.5, 0.5), (0.6, 0.6)]]);
}

/// Two panels with curves and marks make a PNG; a grid of the wrong size is an error.
#[test]
fn overlay_writes_a_png_and_checks_shapes() {
    let (x, y) = ([0.1, 0.2, 0.3], [0.01, 0.02]);
    let bounded = [true, true, true, false, false, false];
    let panel = |c: &str| OverlayPanel {
        caption: c.into(),
        x: &x,
        y: &y,
        bounded: &bounded,
        marks: vec![("model disagrees".into(), RGBColor(0, 0, 0), vec![false, true, false, false, true, false])],
        curves: vec![("separatrix".into(), RGBColor(30, 80, 220), vec![vec![(0.05, 0.0), (0.25, 0.03), (0.4, 0.05)]])],
    };
    let dir = std::env::temp_dir().join(format!("basin-overlay-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("b.png");
    draw_basin_overlay(&out, "t", "rho_1", "rho_2", &[panel("a"), panel("b")]).unwrap();
    let bytes = std::fs::read(&out).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    let bad = OverlayPanel { bounded: &bounded[..5], ..panel("c") };
    assert!(draw_basin_overlay(&dir.join("c.png"), "t", "x", "y", &[bad]).is_err());
    assert!(draw_basin_overlay(&dir.join("d.png"), "t", "x", "y", &[]).is_err());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The legend has its own band: it overlaps no panel (axes and data) nor the title, holds
/// every entry once, and wraps into more rows when the entries do not fit in one.
#[test]
fn the_legend_band_stays_off_the_panels() {
    let (x, y) = ([0.1, 0.2, 0.3], [0.01, 0.02]);
    let bounded = [true; 6];
    let panel = |c: &str, marks: usize| OverlayPanel {
        caption: c.into(),
        x: &x,
        y: &y,
        bounded: &bounded,
        marks: (0..marks).map(|m| (format!("model {m} differs"), RGBColor(0, 0, 0), vec![false; 6])).collect(),
        curves: vec![("separatrix".into(), RGBColor(30, 80, 220), vec![vec![(0.1, 0.0), (0.2, 0.03)]])],
    };
    for (n, marks) in [(1, 1), (2, 3), (5, 12)] {
        let panels: Vec<OverlayPanel> = (0..n).map(|k| panel(&format!("p{k}"), marks)).collect();
        let l = overlay_layout(&panels);
        assert_eq!(l.panels.len(), n);
        assert_eq!(l.entries.len(), 1 + marks, "each label once");
        for r in &l.panels {
            assert!(!r.overlaps(&l.legend) && !r.overlaps(&l.title), "{r:?} vs {:?}", l.legend);
            assert!(r.x1 <= l.size.0 && r.y1 <= l.size.1);
        }
        for (_, _, _, (ex, ey)) in &l.entries {
            let e = Rect { x0: *ex, y0: *ey, x1: ex + 1, y1: ey + LEGEND_ROW_H - 4 };
            assert!(e.overlaps(&l.legend) && l.panels.iter().all(|r| !r.overlaps(&e)), "{e:?}");
        }
        if marks == 12 {
            assert!(l.legend.y1 - l.legend.y0 > 2 * LEGEND_ROW_H, "12 entries wrap: {:?}", l.legend);
        }
    }
}
