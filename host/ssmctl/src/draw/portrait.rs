//! Drawing a computed phase portrait of the two-mode amplitude equations
//! ([`ssm::portrait::Portrait`]) as a PNG.

use std::path::Path;

use plotters::prelude::*;
use ssm::portrait::*;

use crate::plot::{PlotError, draw_legend, ensure_font};

/// PNG phase portrait: grey sample trajectories, manifolds (stable blue, unstable red),
/// 3-tori (green), fixed points (filled = stable, open = unstable or non-hyperbolic,
/// cross = saddle), and `extra` named polylines in distinct colours with a legend.
pub fn plot_portrait(path: &Path, p: &Portrait, title: &str, extra: &[(&str, &[(f64, f64)])]) -> Result<(), PlotError> {
    ensure_font();
    let e = |m: &dyn std::fmt::Display| PlotError::new(path, m);
    if !p.rho_max.iter().all(|r| r.is_finite() && *r > 0.0) {
        return Err(e(&format!("bad box rho_max = {:?}", p.rho_max)));
    }
    crate::plot::render_png(path, (900, 760), |root| {
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..p.rho_max[0], 0.0..p.rho_max[1])
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("rho_1 (slow mode)")
            .y_desc("rho_2 (fast mode)")
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|x| e(&x))?;
        let inside = |q: &(f64, f64)| q.0.is_finite() && q.1.is_finite();
        let grey = RGBColor(190, 190, 190);
        for (k, tr) in p.flow.iter().enumerate() {
            let s = chart
                .draw_series(LineSeries::new(tr.iter().copied().filter(inside), grey.stroke_width(1)))
                .map_err(|x| e(&x))?;
            if k == 0 {
                s.label("flow").legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], grey.stroke_width(2)));
            }
        }
        let blue = RGBColor(30, 80, 220);
        let red = RGBColor(210, 30, 30);
        let (mut st_label, mut un_label) = (false, false);
        for b in &p.manifolds {
            let (color, labelled) = match b.direction {
                Direction::Stable => (blue, &mut st_label),
                Direction::Unstable => (red, &mut un_label),
            };
            let s = chart
                .draw_series(LineSeries::new(b.points.iter().copied().filter(inside), color.stroke_width(2)))
                .map_err(|x| e(&x))?;
            if !*labelled {
                *labelled = true;
                let name = if b.direction == Direction::Stable { "stable manifold" } else { "unstable manifold" };
                s.label(name).legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2)));
            }
        }
        let green = RGBColor(20, 150, 40);
        for (k, o) in p.orbits.iter().enumerate() {
            let s = chart
                .draw_series(LineSeries::new(o.points.iter().copied().filter(inside), green.stroke_width(3)))
                .map_err(|x| e(&x))?;
            if k == 0 {
                s.label("3-torus")
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], green.stroke_width(3)));
            }
        }
        let palette = [
            RGBColor(230, 140, 0),
            RGBColor(140, 60, 170),
            RGBColor(0, 150, 160),
            RGBColor(120, 80, 40),
            RGBColor(230, 60, 150),
            BLACK,
        ];
        for (k, (name, pts)) in extra.iter().enumerate() {
            let color = palette[k % palette.len()];
            chart
                .draw_series(LineSeries::new(pts.iter().copied().filter(inside), color.stroke_width(2)))
                .map_err(|x| e(&x))?
                .label(*name)
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2)));
        }
        for fp in &p.fixed_points {
            let c = (fp.rho[0], fp.rho[1]);
            match fp.stability {
                Stability::Saddle => {
                    chart.draw_series(std::iter::once(Cross::new(c, 7, BLACK.stroke_width(3)))).map_err(|x| e(&x))?;
                }
                s if s.is_stable() => {
                    chart.draw_series(std::iter::once(Circle::new(c, 6, BLACK.filled()))).map_err(|x| e(&x))?;
                }
                _ => {
                    chart.draw_series(std::iter::once(Circle::new(c, 6, BLACK.stroke_width(2)))).map_err(|x| e(&x))?;
                }
            }
        }
        draw_legend(&mut chart, 13, SeriesLabelPosition::UpperRight, path)?;
        root.present().map_err(|x| e(&x))?;
        Ok(())
    })
}
