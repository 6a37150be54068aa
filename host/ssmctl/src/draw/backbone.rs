//! Backbone-curve figure: amplitude against the instantaneous damping ratio and against the
//! instantaneous frequency, one line per mode (SSMLearn's layout: amplitude on the vertical
//! axis of both panels). Bootstrap bands ([`ssm::auto::BackboneBand`]) are drawn as the
//! outline of the region between their lower and upper curves, in a lighter colour.

use crate::plot::{self, Panel, PlotError, Series};
use plotters::style::RGBColor;
use ssm::auto::BackboneBand;
use ssm::backbone::Backbone;
use std::path::Path;

const COLORS: [RGBColor; 4] = [RGBColor(20, 60, 160), RGBColor(200, 30, 30), RGBColor(30, 140, 60), RGBColor(0, 0, 0)];
const LIGHT: [RGBColor; 4] =
    [RGBColor(140, 170, 230), RGBColor(240, 150, 150), RGBColor(150, 210, 160), RGBColor(150, 150, 150)];

fn series<'a>(pts: &'a [Vec<(f64, f64)>], names: &'a [String], colors: &[RGBColor; 4]) -> Vec<Series<'a>> {
    pts.iter()
        .zip(names)
        .zip(colors.iter().cycle())
        .map(|((p, n), c)| Series { name: n, points: p, color: *c })
        .collect()
}

/// Band outlines (light) then curves.
fn with_bands<'a>(
    bands: &'a [Vec<(f64, f64)>],
    band_names: &'a [String],
    lines: &'a [Vec<(f64, f64)>],
    names: &'a [String],
) -> Vec<Series<'a>> {
    let mut s = series(bands, band_names, &LIGHT);
    s.extend(series(lines, names, &COLORS));
    s
}

/// The closed outline of a band: the lower values up the amplitudes, the upper values back.
fn outline(amp: &[f64], band: &[ssm::auto::Interval], scale: f64) -> Vec<(f64, f64)> {
    let lo = amp.iter().zip(band).map(|(a, i)| (scale * i.lo, *a));
    let hi = amp.iter().zip(band).rev().map(|(a, i)| (scale * i.hi, *a));
    let mut v: Vec<(f64, f64)> = lo.chain(hi).filter(|p| p.0.is_finite()).collect();
    if let Some(first) = v.first().copied() {
        v.push(first);
    }
    v
}

/// Writes the two-panel PNG; `amplitude_label` names the observable and its unit; `bands`
/// (possibly none) are drawn behind the curves.
pub fn backbone_figure(
    path: &Path,
    title: &str,
    curves: &[Backbone],
    amplitude_label: &str,
    bands: &[BackboneBand],
) -> Result<(), PlotError> {
    let names: Vec<String> = curves.iter().map(|b| format!("mode {}", b.mode)).collect();
    let band_names: Vec<String> = bands.iter().map(|b| format!("mode {}: 95 % band", b.mode)).collect();
    let damping: Vec<Vec<(f64, f64)>> =
        curves.iter().map(|b| b.points.iter().map(|p| (100.0 * p.damping_ratio, p.amplitude)).collect()).collect();
    let freq: Vec<Vec<(f64, f64)>> = curves
        .iter()
        .map(|b| b.points.iter().map(|p| (p.freq_rad_s / std::f64::consts::TAU, p.amplitude)).collect())
        .collect();
    let damping_bands: Vec<Vec<(f64, f64)>> =
        bands.iter().map(|b| outline(&b.amplitude, &b.damping_ratio, 100.0)).collect();
    let freq_bands: Vec<Vec<(f64, f64)>> =
        bands.iter().map(|b| outline(&b.amplitude, &b.freq_rad_s, 1.0 / std::f64::consts::TAU)).collect();
    let panels = [
        Panel {
            title: format!("{title}: damping"),
            xlabel: "damping ratio [%]",
            ylabel: amplitude_label,
            series: with_bands(&damping_bands, &band_names, &damping, &names),
        },
        Panel {
            title: format!("{title}: frequency"),
            xlabel: "frequency [Hz]",
            ylabel: amplitude_label,
            series: with_bands(&freq_bands, &band_names, &freq, &names),
        },
    ];
    plot::grid(path, &panels, 2, (900, 360))
}
