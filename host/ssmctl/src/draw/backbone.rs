//! Backbone-curve figure: amplitude against the instantaneous damping ratio and against the
//! instantaneous frequency, one line per mode (SSMLearn's layout: amplitude on the vertical
//! axis of both panels).

use crate::plot::{self, Panel, PlotError, Series};
use plotters::style::RGBColor;
use ssm::backbone::Backbone;
use std::path::Path;

const COLORS: [RGBColor; 4] = [RGBColor(20, 60, 160), RGBColor(200, 30, 30), RGBColor(30, 140, 60), RGBColor(0, 0, 0)];

fn series<'a>(pts: &'a [Vec<(f64, f64)>], names: &'a [String]) -> Vec<Series<'a>> {
    pts.iter()
        .zip(names)
        .zip(COLORS.iter().cycle())
        .map(|((p, n), c)| Series { name: n, points: p, color: *c })
        .collect()
}

/// Writes the two-panel PNG; `amplitude_label` names the observable and its unit.
pub fn backbone_figure(path: &Path, title: &str, curves: &[Backbone], amplitude_label: &str) -> Result<(), PlotError> {
    let names: Vec<String> = curves.iter().map(|b| format!("mode {}", b.mode)).collect();
    let damping: Vec<Vec<(f64, f64)>> =
        curves.iter().map(|b| b.points.iter().map(|p| (100.0 * p.damping_ratio, p.amplitude)).collect()).collect();
    let freq: Vec<Vec<(f64, f64)>> = curves
        .iter()
        .map(|b| b.points.iter().map(|p| (p.freq_rad_s / std::f64::consts::TAU, p.amplitude)).collect())
        .collect();
    let panels = [
        Panel {
            title: format!("{title}: damping"),
            xlabel: "damping ratio [%]",
            ylabel: amplitude_label,
            series: series(&damping, &names),
        },
        Panel {
            title: format!("{title}: frequency"),
            xlabel: "frequency [Hz]",
            ylabel: amplitude_label,
            series: series(&freq, &names),
        },
    ];
    plot::grid(path, &panels, 2, (900, 360))
}
