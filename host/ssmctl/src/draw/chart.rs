//! Drawing a computed [`Chart`] as a PNG with plotters (one panel per sampling period).

use sim::units::s_to_ms;
use std::path::{Path, PathBuf};
use std::time::Instant;

use plotters::prelude::*;
use serde::Serialize;

use crate::plot::{PlotError, ensure_font};
use sim::chart::{Axis, Chart, Crossing, Panel, PanelSummary};
use sim::scene::Scene;
use sim::scene::axis::SceneAxis;
use sim::stability::{StabilityError, scene_chart, scene_chart_axes};

const STABLE_FILL: RGBColor = RGBColor(170, 220, 170);
const STATIC_COLOR: RGBColor = RGBColor(30, 80, 200);
const DYNAMIC_COLOR: RGBColor = RGBColor(210, 30, 30);
const FLIP_COLOR: RGBColor = RGBColor(230, 140, 0);
const PANEL_W: u32 = 620;
const PANEL_H: u32 = 560;
const TITLE_H: u32 = 50;

fn label(kind: Crossing) -> (&'static str, RGBColor) {
    match kind {
        Crossing::Static => ("static boundary (real multiplier at +1)", STATIC_COLOR),
        Crossing::Dynamic => ("dynamic boundary (complex pair on |mu| = 1)", DYNAMIC_COLOR),
        Crossing::Flip => ("flip boundary (real multiplier at -1)", FLIP_COLOR),
    }
}

/// Write `chart` to `out` as a PNG.
pub fn draw_chart(out: &Path, chart: &Chart) -> Result<(), PlotError> {
    ensure_font();
    let err = |e: &dyn std::fmt::Display| PlotError::new(out, e);
    let n = chart.panels.len().max(1) as u32;
    crate::plot::render_png(out, (PANEL_W * n, PANEL_H + TITLE_H), |root| {
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let b = &chart.base;
        let integral = if b.ki != 0.0 { format!(", KI = {} V/(rad s)", b.ki) } else { String::new() };
        let title = match &chart.names {
            None => format!(
                "Linear stability of the sampled PD loop with ZOH, delay r = {}, KphiD = {} V s/rad{integral}",
                b.delay,
                b.as_shorthand().map_or(0.0, |s| s.2)
            ),
            Some([x, y]) => {
                let integral = if b.ki != 0.0 { format!(", KI = {}", b.ki) } else { String::new() };
                format!(
                    "Linear stability of the sampled loop with ZOH, delay r = {}, over ({x}, {y}){integral}",
                    b.delay
                )
            }
        };
        let (top, body) = root.split_vertically(TITLE_H);
        top.titled(&title, ("sans-serif", 24)).map_err(|e| err(&e))?;
        for (area, panel) in body.split_evenly((1, n as usize)).iter().zip(&chart.panels) {
            draw_panel(area, chart, panel).map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
        Ok(())
    })
}

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    chart: &Chart,
    panel: &Panel,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (kp, kd) = (chart.kp, chart.kd);
    let s = &panel.summary;
    let (x_desc, y_desc) = match &chart.names {
        None => ("KP [V/rad]".to_string(), "KD [V s/rad]".to_string()),
        Some([x, y]) => (x.clone(), y.clone()),
    };
    let caption = format!("dt = {:.1} ms: stable {:.1} % of the grid", s_to_ms(panel.dt_s), 100.0 * s.stable_fraction);
    let mut cc = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(55)
        .build_cartesian_2d(kp.lo..kp.hi, kd.lo..kd.hi)?;
    cc.configure_mesh()
        .x_desc(x_desc.as_str())
        .y_desc(y_desc.as_str())
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 17))
        .light_line_style(WHITE.mix(0.0))
        .bold_line_style(BLACK.mix(0.12))
        .draw()?;
    // Stable cells, centred on the grid points.
    let (hx, hy) = (0.5 * kp.step(), 0.5 * kd.step());
    let cells = (0..kd.n).flat_map(|i| (0..kp.n).map(move |j| (i, j))).filter_map(|(i, j)| {
        (panel.radius[i * kp.n + j] < 1.0).then(|| {
            let (x, y) = (kp.at(j), kd.at(i));
            Rectangle::new(
                [((x - hx).max(kp.lo), (y - hy).max(kd.lo)), ((x + hx).min(kp.hi), (y + hy).min(kd.hi))],
                STABLE_FILL.filled(),
            )
        })
    });
    cc.draw_series(cells)?
        .label("stable (all multipliers inside |mu| = 1)")
        .legend(|(x, y)| Rectangle::new([(x, y - 6), (x + 18, y + 6)], STABLE_FILL.filled()));
    // D-curves, one legend entry per kind present.
    for kind in [Crossing::Static, Crossing::Dynamic, Crossing::Flip] {
        let (text, color) = label(kind);
        let mut first = true;
        for curve in panel.curves.iter().filter(|c| c.kind == kind) {
            let series = cc.draw_series(LineSeries::new(curve.points.iter().copied(), color.stroke_width(2)))?;
            if first {
                series.label(text).legend(move |(x, y)| PathElement::new([(x, y), (x + 18, y)], color.stroke_width(2)));
                first = false;
            }
        }
    }
    // Frequency of the pair on the circle, at the middle of each longer dynamic piece.
    let freq_labels = panel.curves.iter().filter(|c| c.kind == Crossing::Dynamic && c.points.len() >= 20).map(|c| {
        let k = c.points.len() / 2;
        let (x, y) = c.points[k];
        let at = (x + 0.012 * (kp.hi - kp.lo), y - 0.02 * (kd.hi - kd.lo));
        Text::new(format!("{:.2} Hz", c.freq_hz[k]), at, ("sans-serif", 14).into_font().color(&DYNAMIC_COLOR))
    });
    cc.draw_series(freq_labels)?;
    // The base gains.
    let (bx, by) = base_point(chart);
    if bx >= kp.lo && bx <= kp.hi && by >= kd.lo && by <= kd.hi {
        let text = match &chart.names {
            None => format!("KP = {bx} V/rad, KD = {by} V s/rad (|mu|max = {:.4})", s.base_radius),
            Some([x, y]) => format!("{x} = {bx}, {y} = {by} (|mu|max = {:.4})", s.base_radius),
        };
        cc.draw_series(std::iter::once(Cross::new((bx, by), 7, BLACK.stroke_width(3))))?
            .label(text)
            .legend(|(x, y)| Cross::new((x + 9, y), 5, BLACK.stroke_width(2)));
    }
    cc.configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.4))
        .label_font(("sans-serif", 13))
        .draw()?;
    Ok(())
}

/// The marked point: the scene's values on the axes, else its shorthand (KP, KD).
fn base_point(chart: &Chart) -> (f64, f64) {
    chart.base_point.unwrap_or_else(|| chart.base.as_shorthand().map_or((f64::NAN, f64::NAN), |s| (s.0, s.1)))
}

/// What [`chart_for_scene`] returns.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChartSummary {
    pub png: PathBuf,
    /// The names of the first and second axis (absent: KP and KD).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub axes: Option<[String; 2]>,
    /// The first axis.
    pub kp: Axis,
    /// The second axis.
    pub kd: Axis,
    /// The scene's values on the two axes: the marked point.
    pub base_point: (f64, f64),
    pub panels: Vec<PanelSummary>,
    /// Wall time of the computation (without drawing), s.
    pub compute_seconds: f64,
    /// Wall time of drawing and writing the PNG, s.
    pub draw_seconds: f64,
}

/// Why a chart could not be made or drawn.
#[derive(Debug, thiserror::Error)]
pub enum ChartDrawError {
    #[error(transparent)]
    Chart(#[from] sim::chart::ChartError),
    #[error(transparent)]
    Stability(#[from] StabilityError),
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// A panel's sampling period (`--dt-ms`) the discretization refuses.
    #[error("--dt-ms {}: {source}", short(*.dt_ms))]
    Period { dt_ms: f64, source: sim::linear::LinearError },
}

/// A number as typed, unless that would be a long string of zeros.
fn short(v: f64) -> String {
    if v == 0.0 || (1e-4..1e6).contains(&v.abs()) { v.to_string() } else { format!("{v:e}") }
}

fn summarize(out: &Path, chart: &Chart, compute_seconds: f64) -> Result<ChartSummary, PlotError> {
    let t1 = Instant::now();
    draw_chart(out, chart)?;
    let draw_seconds = t1.elapsed().as_secs_f64();
    Ok(ChartSummary {
        png: out.to_path_buf(),
        axes: chart.names.clone(),
        kp: chart.kp,
        kd: chart.kd,
        base_point: base_point(chart),
        panels: chart.panels.iter().map(|p| p.summary.clone()).collect(),
        compute_seconds,
        draw_seconds,
    })
}

/// The (KP, KD) stability chart of the scene's plant for several sampling periods (ms),
/// written to `out`.
pub fn chart_for_scene(
    scene: &Scene,
    out: &Path,
    dts_ms: &[f64],
    kp: (f64, f64, usize),
    kd: (f64, f64, usize),
) -> Result<ChartSummary, ChartDrawError> {
    let (chart, seconds) = scene_chart(scene, dts_ms, kp, kd).map_err(|e| match e {
        StabilityError::Chart { source: sim::chart::ChartError::Period { dt, source }, .. } => {
            let dt_ms = dts_ms.iter().copied().find(|&ms| sim::units::ms_to_s(ms) == dt).unwrap_or(dt * 1e3);
            ChartDrawError::Period { dt_ms, source }
        }
        e => ChartDrawError::Stability(e),
    })?;
    Ok(summarize(out, &chart, seconds)?)
}

/// The stability chart of the scene over two named axes (gains or plant parameters,
/// [`SceneAxis`]) for several sampling periods (ms), written to `out`.
pub fn chart_for_scene_axes(
    scene: &Scene,
    out: &Path,
    dts_ms: &[f64],
    x: (&SceneAxis, (f64, f64, usize)),
    y: (&SceneAxis, (f64, f64, usize)),
) -> Result<ChartSummary, ChartDrawError> {
    let (chart, seconds) = scene_chart_axes(scene, dts_ms, (x.0, x.1.into()), (y.0, y.1.into()))?;
    Ok(summarize(out, &chart, seconds)?)
}
