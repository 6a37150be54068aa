//! Forced-response figure: steady-state amplitude against forcing frequency, stable branches
//! solid, unstable dashed, the backbone curve and the calibration point.

use crate::plot::{self, PlotError};
use plotters::prelude::*;
use ssm::backbone::Backbone;
use ssm::frc::Frc;
use std::path::Path;

const STABLE: RGBColor = RGBColor(20, 60, 160);
const UNSTABLE: RGBColor = RGBColor(200, 30, 30);
const BACKBONE: RGBColor = RGBColor(120, 120, 120);

/// Writes the PNG: `frc`'s branches (frequency in rad/s), the backbone of the forced mode
/// within the plotted frequencies when given, and the calibration point.
pub fn frc_figure(
    path: &Path,
    title: &str,
    frc: &Frc,
    backbone: Option<&Backbone>,
    amplitude_label: &str,
) -> Result<(), PlotError> {
    plot::ensure_font();
    let e = |m: &dyn std::fmt::Display| PlotError::new(path, m);
    let pts = || frc.branches.iter().flat_map(|b| b.freq_rad_s.iter().copied().zip(b.amplitude.iter().copied()));
    let (mut x0, mut x1, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, 0.0_f64);
    for (x, y) in pts().filter(|p| p.0.is_finite() && p.1.is_finite()) {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y1 = y1.max(y);
    }
    if !(x0.is_finite() && x1 > x0 && y1 > 0.0) {
        return Err(e(&"no forced response points to plot"));
    }
    crate::plot::render_png(path, (760, 420), |root| {
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(64)
            .build_cartesian_2d(x0..x1, 0.0..1.05 * y1)
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc("forcing frequency [rad/s]")
            .y_desc(amplitude_label)
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|x| e(&x))?;
        if let Some(bb) = backbone {
            let line: Vec<(f64, f64)> = bb
                .points
                .iter()
                .map(|p| (p.freq_rad_s, p.amplitude))
                .filter(|p| p.0 >= x0 && p.0 <= x1 && p.1 <= 1.05 * y1)
                .collect();
            chart
                .draw_series(LineSeries::new(line, BACKBONE.stroke_width(1)))
                .map_err(|x| e(&x))?
                .label("backbone")
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BACKBONE.stroke_width(2)));
        }
        let (mut first_stable, mut first_unstable) = (true, true);
        for b in &frc.branches {
            let line: Vec<(f64, f64)> = b.freq_rad_s.iter().copied().zip(b.amplitude.iter().copied()).collect();
            if b.stable {
                let s = chart.draw_series(LineSeries::new(line, STABLE.stroke_width(2))).map_err(|x| e(&x))?;
                if std::mem::take(&mut first_stable) {
                    s.label("stable")
                        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], STABLE.stroke_width(2)));
                }
            } else {
                let s = chart
                    .draw_series(DashedLineSeries::new(line, 6, 4, UNSTABLE.stroke_width(2)))
                    .map_err(|x| e(&x))?;
                if std::mem::take(&mut first_unstable) {
                    s.label("unstable")
                        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], UNSTABLE.stroke_width(2)));
                }
            }
        }
        let c = frc.calibration;
        chart
            .draw_series(std::iter::once(Circle::new((c.freq_rad_s, c.amplitude), 5, BLACK.filled())))
            .map_err(|x| e(&x))?
            .label("calibration")
            .legend(|(x, y)| Circle::new((x + 8, y), 4, BLACK.filled()));
        plot::draw_legend(&mut chart, 13, SeriesLabelPosition::UpperLeft, path)?;
        root.present().map_err(|x| e(&x))?;
        Ok(())
    })
}
