//! Small PNG line and bar plots for reports (plotters, bitmap backend, an embedded DejaVu font so
//! no system fonts are needed).

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

static FONT: Once = Once::new();

/// Registers the embedded font for plotters' text; call before drawing any text.
pub fn ensure_font() {
    FONT.call_once(|| {
        // Registration can only fail for an unparsable font, which the embedded DejaVu is not;
        // if it ever did, plotters reports the missing font when drawing, as an error.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, dejavu::sans::regular());
    });
}

/// A plotting failure (backend or file).
#[derive(Debug, thiserror::Error)]
#[error("plot {path}: {message}")]
pub struct PlotError {
    pub path: String,
    pub message: String,
}

impl PlotError {
    pub fn new(path: &Path, e: impl std::fmt::Display) -> Self {
        Self { path: path.display().to_string(), message: e.to_string() }
    }
}

/// An RGB canvas the figures draw into, written as a PNG by [`Png::save`] through an
/// [`AtomicFile`](crate::output::AtomicFile) (a failed run leaves no partial figure). The PNG
/// is encoded with the `png` crate, settings as plotters' own file output (through `image`
/// 0.24) had them (fast compression, adaptive filtering), so figures are byte-identical to
/// before.
pub struct Png {
    size: (u32, u32),
    buf: Vec<u8>,
}

impl Png {
    /// A zeroed (black) canvas of `size` pixels; figures fill it first.
    pub fn new(size: (u32, u32)) -> Self {
        Self { size, buf: vec![0; size.0 as usize * size.1 as usize * 3] }
    }

    /// The drawing area over the whole canvas.
    pub fn area(&mut self) -> DrawingArea<BitMapBackend<'_>, plotters::coord::Shift> {
        BitMapBackend::with_buffer(&mut self.buf, self.size).into_drawing_area()
    }

    /// Encodes the canvas and writes it to `path`.
    pub fn save(&self, path: &Path) -> Result<(), PlotError> {
        let e = |m: &dyn std::fmt::Display| PlotError::new(path, m);
        let mut file = crate::output::AtomicFile::create(path).map_err(|x| e(&x))?;
        {
            let mut enc = png::Encoder::new(std::io::BufWriter::new(&mut file), self.size.0, self.size.1);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            enc.set_compression(png::Compression::Fast);
            enc.set_filter(png::FilterType::Sub);
            enc.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
            let mut w = enc.write_header().map_err(|x| e(&x))?;
            w.write_image_data(&self.buf).map_err(|x| e(&x))?;
            w.finish().map_err(|x| e(&x))?;
        }
        file.commit().map_err(|x| e(&x))
    }
}

/// Draws a figure of `size` pixels with `draw` (given the whole canvas) and writes it to
/// `path` as a PNG (see [`Png`]).
pub fn render_png(
    path: &Path,
    size: (u32, u32),
    draw: impl FnOnce(DrawingArea<BitMapBackend<'_>, plotters::coord::Shift>) -> Result<(), PlotError>,
) -> Result<(), PlotError> {
    let mut png = Png::new(size);
    draw(png.area())?;
    png.save(path)
}

/// One named polyline.
pub struct Series<'a> {
    pub name: &'a str,
    pub points: &'a [(f64, f64)],
    pub color: RGBColor,
}

/// Draws polylines into a PNG of `size` pixels; the ranges cover all finite points.
pub fn lines(
    path: &Path,
    title: &str,
    xlabel: &str,
    ylabel: &str,
    series: &[Series<'_>],
    size: (u32, u32),
) -> Result<(), PlotError> {
    ensure_font();
    let e = |m: &dyn std::fmt::Display| PlotError::new(path, m);
    let finite = series.iter().flat_map(|s| s.points.iter()).filter(|p| p.0.is_finite() && p.1.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in finite {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !(x0.is_finite() && y0.is_finite()) {
        return Err(e(&"no finite points to plot"));
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    let pad = if y1 > y0 { 0.05 * (y1 - y0) } else { 1e-3_f64.max(y0.abs() * 0.05) };
    render_png(path, size, |root| {
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(64)
            .build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .x_desc(xlabel)
            .y_desc(ylabel)
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|x| e(&x))?;
        draw_lines(&mut chart, series, path)?;
        if series.len() > 1 {
            draw_legend(&mut chart, 13, SeriesLabelPosition::MiddleRight, path)?;
        }
        root.present().map_err(|x| e(&x))?;
        Ok(())
    })
}

/// A report chart: f64 axes on a PNG drawing area.
pub type Chart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draws `series` into `chart` as labelled 1-px polylines (non-finite points skipped), each
/// with a 2-px legend sample; `path` names the file in errors.
pub fn draw_lines(chart: &mut Chart<'_, '_>, series: &[Series<'_>], path: &Path) -> Result<(), PlotError> {
    for s in series {
        let color = s.color;
        chart
            .draw_series(LineSeries::new(
                s.points.iter().copied().filter(|q| q.0.is_finite() && q.1.is_finite()),
                color.stroke_width(1),
            ))
            .map_err(|x| PlotError::new(path, x))?
            .label(s.name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2)));
    }
    Ok(())
}

/// The legend box of the reports' charts (white, framed, labels at `font` px) at `position`.
pub fn draw_legend<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    font: u32,
    position: SeriesLabelPosition,
    path: &Path,
) -> Result<(), PlotError> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", font))
        .draw()
        .map_err(|x| PlotError::new(path, x))
}

/// One panel of [`grid`].
pub struct Panel<'a> {
    pub title: String,
    pub xlabel: &'a str,
    pub ylabel: &'a str,
    pub series: Vec<Series<'a>>,
}

fn finite_range(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return None;
    }
    if hi <= lo {
        let w = 1e-3_f64.max(lo.abs() * 0.05);
        return Some((lo - w, hi + w));
    }
    let pad = 0.04 * (hi - lo);
    Some((lo - pad, hi + pad))
}

/// Panels of polylines in a grid of `cols` columns, each with its own ranges; the legend
/// is drawn in the first panel.
pub fn grid(path: &Path, panels: &[Panel<'_>], cols: usize, size: (u32, u32)) -> Result<(), PlotError> {
    ensure_font();
    let e = |m: &dyn std::fmt::Display| PlotError::new(path, m);
    if panels.is_empty() || cols == 0 {
        return Err(e(&"no panels"));
    }
    let rows = panels.len().div_ceil(cols);
    render_png(path, size, |root| {
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let areas = root.split_evenly((rows, cols));
        for (k, (p, area)) in panels.iter().zip(areas.iter()).enumerate() {
            let pts = || p.series.iter().flat_map(|s| s.points.iter());
            let (Some((x0, x1)), Some((y0, y1))) = (finite_range(pts().map(|q| q.0)), finite_range(pts().map(|q| q.1)))
            else {
                return Err(e(&format!("panel `{}`: no finite points", p.title)));
            };
            let mut chart = ChartBuilder::on(area)
                .caption(&p.title, ("sans-serif", 15))
                .margin(6)
                .x_label_area_size(30)
                .y_label_area_size(52)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|x| e(&x))?;
            chart
                .configure_mesh()
                .x_desc(p.xlabel)
                .y_desc(p.ylabel)
                .label_style(("sans-serif", 11))
                .draw()
                .map_err(|x| e(&x))?;
            draw_lines(&mut chart, &p.series, path)?;
            if k == 0 && p.series.len() > 1 {
                draw_legend(&mut chart, 11, SeriesLabelPosition::MiddleRight, path)?;
            }
        }
        root.present().map_err(|x| e(&x))?;
        Ok(())
    })
}

/// Horizontal bars, one per `(label, value)`, top to bottom in the given order; the value
/// (`{:.1}`) is written after each bar. Values must be finite and >= 0.
pub fn bars(
    path: &Path,
    title: &str,
    xlabel: &str,
    bars: &[(String, f64)],
    color: RGBColor,
    size: (u32, u32),
) -> Result<(), PlotError> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    ensure_font();
    let e = |m: &dyn std::fmt::Display| PlotError::new(path, m);
    if bars.is_empty() {
        return Err(e(&"no bars"));
    }
    if let Some((l, v)) = bars.iter().find(|b| !(b.1.is_finite() && b.1 >= 0.0)) {
        return Err(e(&format!("bar `{l}`: value {v} must be finite and >= 0")));
    }
    let n = bars.len();
    let xmax = bars.iter().map(|b| b.1).fold(0.0, f64::max);
    let xmax = if xmax > 0.0 { 1.15 * xmax } else { 1.0 };
    // Bar i sits in segment n - 1 - i, so the first bar is at the top.
    let label_of = |k: usize| bars.get(n - 1 - k).map_or("", |b| b.0.as_str());
    render_png(path, size, |root| {
        root.fill(&WHITE).map_err(|x| e(&x))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(36)
            .y_label_area_size(170)
            .build_cartesian_2d(0.0..xmax, (0..n).into_segmented())
            .map_err(|x| e(&x))?;
        chart
            .configure_mesh()
            .disable_y_mesh()
            .x_max_light_lines(1)
            .y_labels(n)
            .y_label_formatter(&|v| match v {
                SegmentValue::CenterOf(k) if *k < n => label_of(*k).to_string(),
                _ => String::new(),
            })
            .x_desc(xlabel)
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|x| e(&x))?;
        chart
            .draw_series(bars.iter().enumerate().map(|(i, (_, v))| {
                let k = n - 1 - i;
                let mut r =
                    Rectangle::new([(0.0, SegmentValue::Exact(k)), (*v, SegmentValue::Exact(k + 1))], color.filled());
                r.set_margin(3, 3, 0, 0);
                r
            }))
            .map_err(|x| e(&x))?;
        chart
            .draw_series(bars.iter().enumerate().map(|(i, (_, v))| {
                Text::new(
                    format!(" {v:.1}"),
                    (*v, SegmentValue::CenterOf(n - 1 - i)),
                    TextStyle::from(("sans-serif", 12).into_font()).pos(Pos::new(HPos::Left, VPos::Center)),
                )
            }))
            .map_err(|x| e(&x))?;
        root.present().map_err(|x| e(&x))?;
        Ok(())
    })
}
