//! Drawing a merged basin-map sweep as a PNG: the cells over the first two axes (x, y),
//! green where the full closed loop stayed bounded, red where it escaped (darker = earlier
//! escape, when `escape_t` is recorded); one panel per value combination of further axes.
//! [`draw_basin_overlay`]: basin grids with reduced models' curves and marked cells over them.

use std::path::Path;

use furuta::sweep::shard::SweepResult;
use plotters::prelude::*;

use crate::plot::{PlotError, ensure_font};

const BOUNDED: RGBColor = RGBColor(170, 220, 170);
const PANEL_W: u32 = 620;
const PANEL_H: u32 = 560;
const TITLE_H: u32 = 50;
const MIN_W: u32 = 1000;
/// Most panels one figure shows (combinations of the axes after the first two).
pub const MAX_PANELS: usize = 12;

/// Cell edges: halfway to the neighbours, the end cells as wide as their inner half.
pub fn edges(v: &[f64]) -> Vec<(f64, f64)> {
    if v.len() == 1 {
        let w = if v[0] == 0.0 { 0.5 } else { 0.5 * v[0].abs() };
        return vec![(v[0] - w, v[0] + w)];
    }
    (0..v.len())
        .map(|i| {
            let lo = if i == 0 { v[0] - 0.5 * (v[1] - v[0]) } else { 0.5 * (v[i - 1] + v[i]) };
            let hi = if i + 1 == v.len() { v[i] + 0.5 * (v[i] - v[i - 1]) } else { 0.5 * (v[i] + v[i + 1]) };
            (lo, hi)
        })
        .collect()
}

/// The colour of a cell that escaped, by when (`frac` of the run: 0 at once, 1 last).
pub fn escape_color(frac: f64) -> RGBColor {
    // frac 0 (escaped at once) -> dark red, 1 (escaped last) -> light orange.
    let f = frac.clamp(0.0, 1.0);
    RGBColor((150.0 + 100.0 * f) as u8, (20.0 + 160.0 * f) as u8, (20.0 + 80.0 * f) as u8)
}

/// Writes the basin map of `r` to `out`; `Ok(Some(reason))` when this result cannot be drawn
/// (more than [`MAX_PANELS`] panels, axis values not increasing, `bounded` not recorded).
pub fn draw_basin(out: &Path, r: &SweepResult) -> Result<Option<String>, PlotError> {
    let s = &r.spec;
    if r.cells.iter().any(|c| c.bounded.is_none()) {
        return Ok(Some("the basin figure needs `bounded` recorded".into()));
    }
    if let Some(a) = s.axes.iter().take(2).find(|a| a.values.windows(2).any(|w| w[1] <= w[0])) {
        return Ok(Some(format!("the basin figure needs increasing values on axis `{}`", a.name.as_str())));
    }
    let extra: usize = s.axes.iter().skip(2).map(|a| a.values.len()).product();
    if extra > MAX_PANELS {
        return Ok(Some(format!(
            "{extra} panels (the axes after the first two); the figure shows at most {MAX_PANELS}"
        )));
    }
    ensure_font();
    let cols = extra.min(3);
    let rows = extra.div_ceil(cols);
    // At least MIN_W wide, so the title fits above a single panel.
    let size = ((PANEL_W * cols as u32).max(MIN_W), PANEL_H * rows as u32 + TITLE_H);
    crate::plot::render_png(out, size, |root| draw_into(out, root, r, (rows, cols), extra))?;
    Ok(None)
}

/// Draws the figure onto `root`: a title and `extra` panels in `rows` x `cols`.
fn draw_into<DB: DrawingBackend>(
    out: &Path,
    root: DrawingArea<DB, plotters::coord::Shift>,
    r: &SweepResult,
    (rows, cols): (usize, usize),
    extra: usize,
) -> Result<(), PlotError> {
    let s = &r.spec;
    let err = |e: &dyn std::fmt::Display| PlotError::new(out, e);
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let b = s.basin.as_ref();
    let title = format!(
        "{}: bounded (green) or |theta| > {} rad (red, darker = earlier) within {} periods",
        s.name,
        b.map_or(f64::NAN, |b| b.escape_theta),
        b.map_or(0, |b| b.periods)
    );
    let (top, body) = root.split_vertically(TITLE_H);
    top.titled(&title, ("sans-serif", 18)).map_err(|e| err(&e))?;
    let t_max = r.cells.iter().filter_map(|c| c.escape_t).fold(0.0_f64, f64::max);
    let x = &s.axes[0];
    let y = s.axes.get(1);
    let (xe, ye) = (edges(&x.values), y.map_or_else(|| vec![(0.0, 1.0)], |y| edges(&y.values)));
    let (ny, np) = (ye.len(), extra);
    for (p, area) in body.split_evenly((rows, cols)).iter().enumerate().take(np) {
        // Panel p: the p-th combination of the further axes (row-major like the grid).
        let mut rest = vec![0usize; s.axes.len().saturating_sub(2)];
        let mut q = p;
        for (k, a) in rest.iter_mut().zip(s.axes.iter().skip(2)).rev() {
            *k = q % a.values.len();
            q /= a.values.len();
        }
        let caption: Vec<String> =
            s.axes.iter().skip(2).zip(&rest).map(|(a, &k)| format!("{} = {}", a.name.as_str(), a.values[k])).collect();
        let (x0, x1) = (xe[0].0, xe[xe.len() - 1].1);
        let (y0, y1) = (ye[0].0, ye[ny - 1].1);
        let mut cc = ChartBuilder::on(area)
            .caption(caption.join(", "), ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(45)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(|e| err(&e))?;
        cc.configure_mesh()
            .x_desc(x.name.as_str())
            .y_desc(y.map_or("", |y| y.name.as_str()))
            .label_style(("sans-serif", 15))
            .axis_desc_style(("sans-serif", 17))
            .disable_mesh()
            .draw()
            .map_err(|e| err(&e))?;
        let mut rects = Vec::with_capacity(xe.len() * ny);
        for (j, &(ylo, yhi)) in ye.iter().enumerate() {
            for (i, &(xlo, xhi)) in xe.iter().enumerate() {
                let mut pos = vec![i];
                if y.is_some() {
                    pos.push(j);
                }
                pos.extend(&rest);
                let c = &r.cells[s.index_of(&pos) as usize];
                let color = match (c.bounded, c.escape_t) {
                    (Some(true), _) => BOUNDED,
                    (_, Some(t)) if t_max > 0.0 => escape_color(t / t_max),
                    _ => escape_color(0.0),
                };
                rects.push(Rectangle::new([(xlo, ylo), (xhi, yhi)], color.filled()));
            }
        }
        cc.draw_series(rects).map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

/// A labelled set of polylines drawn over a panel: `(label, colour, polylines)`.
pub type Curves = (String, RGBColor, Vec<Vec<(f64, f64)>>);

/// One panel of [`draw_basin_overlay`]: a 2D grid of full-system outcomes with curves and
/// marked cells drawn over it.
pub struct OverlayPanel<'a> {
    pub caption: String,
    /// Grid values on x and y (increasing).
    pub x: &'a [f64],
    pub y: &'a [f64],
    /// Bounded per cell, x-major: entry `i * y.len() + j` is `(x[i], y[j])`.
    pub bounded: &'a [bool],
    /// Cell marks, same order: `(label, colour, which cells)`; each set is drawn as small
    /// markers of its own shape (cross, circle, triangle, in order; named in the legend).
    pub marks: Vec<(String, RGBColor, Vec<bool>)>,
    /// Curves over the grid: `(label, colour, polylines)`; polylines are cut at the grid's box.
    pub curves: Vec<Curves>,
}

/// The parts of `line` inside the box `[x0, x1] x [y0, y1]` (points outside end a part).
pub fn inside_parts(line: &[(f64, f64)], (x0, x1): (f64, f64), (y0, y1): (f64, f64)) -> Vec<Vec<(f64, f64)>> {
    let mut parts = vec![Vec::new()];
    for &(x, y) in line {
        if x.is_finite() && y.is_finite() && (x0..=x1).contains(&x) && (y0..=y1).contains(&y) {
            if let Some(p) = parts.last_mut() {
                p.push((x, y));
            }
        } else if parts.last().is_some_and(|p| !p.is_empty()) {
            parts.push(Vec::new());
        }
    }
    parts.retain(|p| p.len() >= 2);
    parts
}

/// A pixel rectangle `[x0, x1) x [y0, y1)` of a figure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rect {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
}

impl Rect {
    /// Whether the two rectangles share a pixel.
    pub fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }
}

/// One legend entry of [`draw_basin_overlay`]: a curve's line or a mark set's marker shape.
#[derive(Clone, Debug, PartialEq)]
pub enum LegendKey {
    Line,
    /// The marker of mark set `m` (cross, circle, triangle, in order).
    Marker(usize),
}

/// Where [`draw_basin_overlay`] puts things: the title strip, the legend strip (its own band
/// between the title and the panels, so no legend sits on the data) and each panel's area
/// (axes, labels and data).
#[derive(Clone, Debug)]
pub struct OverlayLayout {
    pub size: (u32, u32),
    pub title: Rect,
    pub legend: Rect,
    pub panels: Vec<Rect>,
    /// Legend entries: label, colour, key, top-left corner of the entry.
    pub entries: Vec<(String, RGBColor, LegendKey, (u32, u32))>,
}

/// Height of a legend row (pixels).
pub const LEGEND_ROW_H: u32 = 22;
const LEGEND_FONT: u32 = 14;
/// Width of a legend entry's key (line or marker) and the gaps around its text.
const LEGEND_KEY_W: u32 = 30;
const LEGEND_GAP: u32 = 24;

/// The entries of the panels' legends, each label once, in order of first appearance:
/// curves as lines, mark sets by their marker (cross, circle, triangle by position).
fn legend_entries(panels: &[OverlayPanel]) -> Vec<(String, RGBColor, LegendKey)> {
    let mut out: Vec<(String, RGBColor, LegendKey)> = Vec::new();
    for p in panels {
        let curves = p.curves.iter().filter(|c| !c.2.is_empty()).map(|(l, c, _)| (l.clone(), *c, LegendKey::Line));
        let marks =
            p.marks.iter().enumerate().map(|(m, (l, c, _))| {
                (format!("{l} ({})", ["x", "o", "triangle"][m % 3]), *c, LegendKey::Marker(m % 3))
            });
        for e in curves.chain(marks) {
            if !out.iter().any(|o| o.0 == e.0) {
                out.push(e);
            }
        }
    }
    out
}

/// The figure's layout for `panels`: up to 2 panels a row under a title and a legend band
/// wide enough for every entry (entries flow left to right, wrapping into more rows).
pub fn overlay_layout(panels: &[OverlayPanel]) -> OverlayLayout {
    let cols = panels.len().clamp(1, 2);
    let rows = panels.len().div_ceil(cols).max(1);
    let width = (PANEL_W * cols as u32).max(MIN_W);
    // DejaVu Sans averages about 0.6 em per character.
    let text_w = |s: &str| (s.chars().count() as u32 * LEGEND_FONT * 6).div_ceil(10);
    let mut entries = Vec::new();
    let (mut x, mut row) = (LEGEND_GAP, 0u32);
    for (label, color, key) in legend_entries(panels) {
        let w = LEGEND_KEY_W + text_w(&label) + LEGEND_GAP;
        if x > LEGEND_GAP && x + w > width {
            x = LEGEND_GAP;
            row += 1;
        }
        entries.push((label, color, key, (x, TITLE_H + row * LEGEND_ROW_H + 4)));
        x += w;
    }
    let legend_h = if entries.is_empty() { 0 } else { (row + 1) * LEGEND_ROW_H + 8 };
    let top = TITLE_H + legend_h;
    let panels = (0..panels.len() as u32)
        .map(|k| {
            let (c, r) = (k % cols as u32, k / cols as u32);
            let w = width / cols as u32;
            Rect { x0: c * w, y0: top + r * PANEL_H, x1: (c + 1) * w, y1: top + (r + 1) * PANEL_H }
        })
        .collect();
    OverlayLayout {
        size: (width, top + PANEL_H * rows as u32),
        title: Rect { x0: 0, y0: 0, x1: width, y1: TITLE_H },
        legend: Rect { x0: 0, y0: TITLE_H, x1: width, y1: top },
        panels,
        entries,
    }
}

/// Writes panels of full-system basin grids (green bounded, red escaped) with the reduced
/// models' curves (e.g. saddle manifolds) and marked cells (e.g. where a model disagrees)
/// drawn over them: up to 2 panels a row, one legend for all of them in a band above the
/// panels (see [`overlay_layout`]), never over the data.
pub fn draw_basin_overlay(
    out: &Path,
    title: &str,
    xdesc: &str,
    ydesc: &str,
    panels: &[OverlayPanel],
) -> Result<(), PlotError> {
    let err = |e: &dyn std::fmt::Display| PlotError::new(out, e);
    if panels.is_empty() || panels.len() > MAX_PANELS {
        return Err(err(&format!("{} panels; need 1 ..= {MAX_PANELS}", panels.len())));
    }
    for p in panels {
        let n = p.x.len() * p.y.len();
        if n == 0 || p.bounded.len() != n || p.marks.iter().any(|m| m.2.len() != n) {
            return Err(err(&format!(
                "panel `{}`: {} x {} grid with {} cells",
                p.caption,
                p.x.len(),
                p.y.len(),
                p.bounded.len()
            )));
        }
        if [p.x, p.y].iter().any(|v| v.windows(2).any(|w| !(w[1] > w[0]))) {
            return Err(err(&format!("panel `{}`: grid values must increase", p.caption)));
        }
    }
    ensure_font();
    let layout = overlay_layout(panels);
    crate::plot::render_png(out, layout.size, |root| {
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (top, _) = root.split_vertically(TITLE_H);
        top.titled(title, ("sans-serif", 18)).map_err(|e| err(&e))?;
        let font = ("sans-serif", LEGEND_FONT).into_font().color(&BLACK);
        for (label, color, key, (x, y)) in &layout.entries {
            let (x, y) = (*x as i32, *y as i32);
            let mid = (x + LEGEND_KEY_W as i32 / 2 - 4, y + LEGEND_ROW_H as i32 / 2 - 2);
            let style = color.stroke_width(if *key == LegendKey::Line { 3 } else { 2 });
            match key {
                LegendKey::Line => root.draw(&PathElement::new(vec![(x, mid.1), (x + 20, mid.1)], style)),
                LegendKey::Marker(0) => root.draw(&Cross::new(mid, 4, style)),
                LegendKey::Marker(1) => root.draw(&Circle::new(mid, 5, style)),
                LegendKey::Marker(_) => root.draw(&TriangleMarker::new(mid, 5, style)),
            }
            .map_err(|e| err(&e))?;
            root.draw(&Text::new(label.clone(), (x + LEGEND_KEY_W as i32 - 2, y + 3), font.clone()))
                .map_err(|e| err(&e))?;
        }
        for (p, r) in panels.iter().zip(&layout.panels) {
            let area = root.clone().shrink((r.x0, r.y0), (r.x1 - r.x0, r.y1 - r.y0));
            let (xe, ye) = (edges(p.x), edges(p.y));
            let (bx, by) = ((xe[0].0, xe[xe.len() - 1].1), (ye[0].0, ye[ye.len() - 1].1));
            let mut cc = ChartBuilder::on(&area)
                .caption(&p.caption, ("sans-serif", 17))
                .margin(12)
                .x_label_area_size(45)
                .y_label_area_size(60)
                .build_cartesian_2d(bx.0..bx.1, by.0..by.1)
                .map_err(|e| err(&e))?;
            cc.configure_mesh()
                .x_desc(xdesc)
                .y_desc(ydesc)
                .label_style(("sans-serif", 14))
                .axis_desc_style(("sans-serif", 16))
                .disable_mesh()
                .draw()
                .map_err(|e| err(&e))?;
            let ny = p.y.len();
            let mut rects = Vec::with_capacity(p.bounded.len());
            for (i, &(xlo, xhi)) in xe.iter().enumerate() {
                for (j, &(ylo, yhi)) in ye.iter().enumerate() {
                    let c = if p.bounded[i * ny + j] { BOUNDED } else { escape_color(0.6) };
                    rects.push(Rectangle::new([(xlo, ylo), (xhi, yhi)], c.filled()));
                }
            }
            cc.draw_series(rects).map_err(|e| err(&e))?;
            for (_, color, lines) in &p.curves {
                for part in lines.iter().flat_map(|l| inside_parts(l, bx, by)) {
                    cc.draw_series(LineSeries::new(part, color.stroke_width(3))).map_err(|e| err(&e))?;
                }
            }
            for (m, (_, color, which)) in p.marks.iter().enumerate() {
                let at: Vec<(f64, f64)> =
                    which.iter().enumerate().filter(|(_, w)| **w).map(|(k, _)| (p.x[k / ny], p.y[k % ny])).collect();
                let style = color.stroke_width(2);
                match m % 3 {
                    0 => cc.draw_series(at.iter().map(|&c| Cross::new(c, 4, style).into_dyn())),
                    1 => cc.draw_series(at.iter().map(|&c| Circle::new(c, 5, style).into_dyn())),
                    _ => cc.draw_series(at.iter().map(|&c| TriangleMarker::new(c, 5, style).into_dyn())),
                }
                .map_err(|e| err(&e))?;
            }
        }
        root.present().map_err(|e| err(&e))?;
        Ok(())
    })
}
