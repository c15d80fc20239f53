//! Cell-based colour maps: wavelet scalogram and parameter heat map, each
//! with a viridis colour bar.

use std::path::Path;

use super::error::{Result, bad_input};
use pendulum_atlas_core::config::AxisScale;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::colormap::{blend, viridis};
use super::grid::{cell_edges, cell_of, grid_spec};
use super::palette::{INVALID_COLOR, NODATA_COLOR, Palette};
use super::{
    Area, Axis, AxisSpec, Chart, LABEL_PX, TICK_PX, build_chart, canvas, finite_min_max, font,
    nice_ticks, titled,
};

/// Figure size of both maps.
const SIZE: (u32, u32) = (1000, 700);
/// Width of the colour-bar column (px).
const BAR_COL: u32 = 170;
/// Dynamic range (octaves) shown by the scalogram below its maximum.
const SCALOGRAM_OCTAVES: f64 = 16.0;

/// Fails unless `v` is non-empty, finite and strictly increasing.
fn check_axis(name: &str, v: &[f64]) -> Result<()> {
    if v.is_empty() || v.iter().any(|x| !x.is_finite()) || v.windows(2).any(|w| w[1] <= w[0]) {
        bad_input!("{name}: values must be non-empty, finite and strictly increasing");
    }
    Ok(())
}

/// Paints every pixel of the chart's plotting area with `color(ix, iy, x, y)`,
/// where (x, y) are the pixel's plotting coordinates and (ix, iy) its cell.
fn paint_cells(
    chart: &Chart,
    xe: &[f64],
    ye: &[f64],
    color: impl Fn(usize, usize, f64, f64, (i32, i32)) -> RGBColor,
) -> Result<()> {
    let (xa, ya) = (
        chart.as_coord_spec().get_x_range(),
        chart.as_coord_spec().get_y_range(),
    );
    let p0 = chart.backend_coord(&(xa.start, ya.start));
    let p1 = chart.backend_coord(&(xa.end, ya.end));
    let screen = chart.plotting_area().use_screen_coord();
    let (px, py) = chart.plotting_area().get_pixel_range();
    let fx =
        |p: i32| xa.start + (p - p0.0) as f64 / (p1.0 - p0.0).max(1) as f64 * (xa.end - xa.start);
    let fy =
        |p: i32| ya.start + (p - p0.1) as f64 / (p1.1 - p0.1).min(-1) as f64 * (ya.end - ya.start);
    for j in py {
        let y = fy(j);
        let Some(iy) = cell_of(ye, y) else { continue };
        for i in px.clone() {
            let x = fx(i);
            if let Some(ix) = cell_of(xe, x) {
                screen.draw_pixel((i, j), &color(ix, iy, x, y, (i, j)))?;
            }
        }
    }
    Ok(())
}

/// Vertical colour bar of `stops` (low to high) with ticks and a label in `area`, plus
/// optional legend swatches (e.g. "diverged") underneath.
fn colorbar(
    area: &Area,
    (lo, hi): (f64, f64),
    stops: &[RGBColor],
    label: &str,
    legend: &[LegendEntry],
) -> Result<()> {
    let xa = AxisSpec::fixed(0.0, 1.0, false);
    let mut ya = AxisSpec::fixed(lo, hi, false);
    ya.ticks = nice_ticks(lo, hi, 8);
    let mut chart = ChartBuilder::on(area)
        .margin_top(15)
        .margin_bottom(75)
        .margin_left(20)
        .right_y_label_area_size(110)
        .build_cartesian_2d(xa.coord(), ya.coord())?;
    let yf = |v: &f64| format!(" {}", ya.label(*v));
    chart
        .configure_mesh()
        .disable_x_mesh()
        .disable_y_mesh()
        .disable_x_axis()
        .y_label_formatter(&yf)
        .label_style(font(TICK_PX))
        .axis_desc_style(font(LABEL_PX))
        .draw()?;
    let n = stops.len().max(1);
    chart.draw_series(stops.iter().enumerate().map(|(k, c)| {
        let (a, b) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
        let (y0, y1) = (lo + a * (hi - lo), lo + b * (hi - lo));
        Rectangle::new([(0.0, y0), (1.0, y1)], c.filled())
    }))?;
    chart.draw_series(std::iter::once(Rectangle::new(
        [(0.0, lo), (1.0, hi)],
        BLACK,
    )))?;
    let (w, h) = area.dim_in_pixel();
    // Label drawn by hand: plotters misplaces right-hand axis descriptions.
    let style = font(LABEL_PX)
        .transform(FontTransform::Rotate270)
        .pos(Pos::new(HPos::Center, VPos::Top));
    area.draw_text(label, &style, (w as i32 - 34, (15 + h as i32 - 75) / 2))?;
    for (k, entry) in legend.iter().enumerate() {
        legend_entry(area, (10, h as i32 - 60 + 26 * k as i32), entry)?;
    }
    Ok(())
}

/// A legend entry: its name, its colour, and the cell marks drawn over that colour
/// (`[inferred, sensitive, transient]`, as [`marked_pixel`] takes them; none for a plain
/// swatch).
type LegendEntry<'a> = (&'a str, RGBColor, [bool; 3]);

/// A legend entry's 18-px swatch at `(x, y)`, patterned as its marks draw a cell, and its name
/// beside it.
fn legend_entry(area: &Area, (x, y): (i32, i32), &(name, c, marks): &LegendEntry) -> Result<()> {
    area.draw(&Rectangle::new([(x, y), (x + 18, y + 18)], c.filled()))?;
    for (i, j) in (0..18).flat_map(|i| (0..18).map(move |j| (i, j))) {
        if marked_pixel(marks, (i, j)) {
            area.draw_pixel((x + i, y + j), &hatch(c))?;
        }
    }
    area.draw(&Rectangle::new([(x, y), (x + 18, y + 18)], BLACK))?;
    area.draw(&Text::new(name.to_string(), (x + 24, y), font(TICK_PX)))?;
    Ok(())
}

/// Length of a minor tick mark outside the plotting area (px).
const MINOR_TICK_PX: i32 = 3;

/// Short unlabelled marks outside the chart's plotting area at the minor ticks of its axes
/// (a log axis over a few decades: 2…9 × 10^k); nothing is drawn for axes without any.
fn minor_tick_marks(root: &Area, chart: &Chart, xa: &AxisSpec, ya: &AxisSpec) -> Result<()> {
    let marks = xa.minor.iter().map(|&t| {
        let (x, y) = chart.backend_coord(&(t, ya.lo));
        [(x, y + 1), (x, y + MINOR_TICK_PX)]
    });
    let marks = marks.chain(ya.minor.iter().map(|&t| {
        let (x, y) = chart.backend_coord(&(xa.lo, t));
        [(x - MINOR_TICK_PX, y), (x - 1, y)]
    }));
    for m in marks {
        root.draw(&PathElement::new(m.to_vec(), BLACK))?;
    }
    Ok(())
}

/// Wavelet power scalogram, 1000×700 px: colour = log2(`power`) (viridis,
/// showing the top 16 octaves), y = period on a log2 axis ("Period (s)",
/// ticks at powers of two), x = time. `power` is `[period][time]`; `times_s`
/// and `periods_s` (> 0) are strictly increasing cell centres. The cone of
/// influence (period > `coi_s[t]`, linearly interpolated; pass `&[]` for none)
/// is washed out with white; where `significance_ratio` (power / 95 % level,
/// same shape) crosses 1 a black contour is drawn.
#[allow(clippy::too_many_arguments)]
pub fn scalogram(
    path: &Path,
    title: &str,
    times_s: &[f64],
    periods_s: &[f64],
    power: &[Vec<f64>],
    coi_s: &[f64],
    significance_ratio: Option<&[Vec<f64>]>,
    time_label: &str,
) -> Result<()> {
    check_scalogram_input(times_s, periods_s, power, coi_s, significance_ratio)?;
    let (nt, np) = (times_s.len(), periods_s.len());
    let lp: Vec<Vec<f64>> = power
        .iter()
        .map(|r| r.iter().map(|p| p.log2()).collect())
        .collect();
    let (lo, hi) = match finite_min_max(lp.iter().flatten().copied()) {
        Some((a, b)) if b > a => (a.max(b - SCALOGRAM_OCTAVES), b),
        Some((a, _)) => (a - 0.5, a + 0.5),
        None => (0.0, 1.0),
    };
    let log_p: Vec<f64> = periods_s.iter().map(|p| p.log2()).collect();
    let (xe, ye) = (cell_edges(times_s), cell_edges(&log_p));
    let xa = AxisSpec::fixed(xe[0], xe[nt], false);
    let ya = AxisSpec::log2(ye[0], ye[np]);

    let root = canvas(path, SIZE)?;
    let body = titled(&root, title)?;
    let (main, bar) = body.split_horizontally(SIZE.0 - BAR_COL);
    let mut chart = build_chart(&main, None, &xa, &ya, time_label, "Period (s)", false, 15)?;
    let coi_at = |t: f64| coi_log2_at(times_s, coi_s, t);
    paint_cells(&chart, &xe, &ye, |ix, iy, x, y, _| {
        let v = lp[iy][ix];
        let c = if v.is_finite() {
            viridis((v - lo) / (hi - lo))
        } else {
            NODATA_COLOR
        };
        if !coi_s.is_empty() && y > coi_at(x) {
            blend(c, WHITE, 0.55)
        } else {
            c
        }
    })?;
    if !coi_s.is_empty() {
        let line = times_s.iter().map(|&t| (t, coi_at(t).clamp(ya.lo, ya.hi)));
        chart.draw_series(DashedLineSeries::new(
            line,
            8,
            5,
            RGBColor(60, 60, 60).stroke_width(2),
        ))?;
    }
    if let Some(sig) = significance_ratio {
        let segs = contour(times_s, &log_p, |i, j| sig[i][j], 1.0);
        chart.draw_series(
            segs.into_iter()
                .map(|s| PathElement::new(s.to_vec(), BLACK.stroke_width(2))),
        )?;
    }
    let stops: Vec<RGBColor> = (0..256)
        .map(|k| viridis((k as f64 + 0.5) / 256.0))
        .collect();
    colorbar(&bar, (lo, hi), &stops, "log2 power (normalised)", &[])?;
    root.present()?;
    Ok(())
}

/// Refuse axes that are not strictly increasing, non-positive periods, a power or
/// significance matrix not shaped [periods][times], and a COI not one value per time.
fn check_scalogram_input(
    times_s: &[f64],
    periods_s: &[f64],
    power: &[Vec<f64>],
    coi_s: &[f64],
    significance_ratio: Option<&[Vec<f64>]>,
) -> Result<()> {
    check_axis("scalogram times", times_s)?;
    check_axis("scalogram periods", periods_s)?;
    if periods_s[0] <= 0.0 {
        bad_input!("scalogram: periods must be positive");
    }
    let (nt, np) = (times_s.len(), periods_s.len());
    let shape_ok = |m: &[Vec<f64>]| m.len() == np && m.iter().all(|r| r.len() == nt);
    if !shape_ok(power) || significance_ratio.is_some_and(|s| !shape_ok(s)) {
        bad_input!("scalogram: power/significance must be [{np} periods][{nt} times]");
    }
    if !coi_s.is_empty() && coi_s.len() != nt {
        bad_input!("scalogram: coi has {} values, expected {nt}", coi_s.len());
    }
    Ok(())
}

/// log2 of the cone of influence at time `t` (s), interpolated linearly between the times
/// and held beyond them: the period above which edge effects dominate.
fn coi_log2_at(times_s: &[f64], coi_s: &[f64], t: f64) -> f64 {
    let nt = times_s.len();
    let k = times_s.partition_point(|&x| x <= t);
    let c = if k == 0 {
        coi_s[0]
    } else if k >= nt {
        coi_s[nt - 1]
    } else {
        let f = (t - times_s[k - 1]) / (times_s[k] - times_s[k - 1]);
        coi_s[k - 1] + f * (coi_s[k] - coi_s[k - 1])
    };
    c.max(0.0).log2()
}

/// Marching-squares contour of `f(iy, ix)` at `level` on the node grid
/// (`xs[ix]`, `ys[iy]`); returns line segments. Cells touching a
/// non-finite value are skipped.
fn contour(
    xs: &[f64],
    ys: &[f64],
    f: impl Fn(usize, usize) -> f64,
    level: f64,
) -> Vec<[(f64, f64); 2]> {
    let mut out = vec![];
    for i in 0..ys.len().saturating_sub(1) {
        for j in 0..xs.len().saturating_sub(1) {
            // Corners counter-clockwise from bottom-left.
            let c = [(i, j), (i, j + 1), (i + 1, j + 1), (i + 1, j)];
            let v = c.map(|(a, b)| f(a, b) - level);
            if v.iter().any(|x| !x.is_finite()) {
                continue;
            }
            let mut pts = [(0.0, 0.0); 4];
            let mut hit = [false; 4];
            for e in 0..4 {
                let (a, b) = (e, (e + 1) % 4);
                if (v[a] >= 0.0) != (v[b] >= 0.0) {
                    let t = v[a] / (v[a] - v[b]);
                    let (pa, pb) = (c[a], c[b]);
                    let x = xs[pa.1] + t * (xs[pb.1] - xs[pa.1]);
                    let y = ys[pa.0] + t * (ys[pb.0] - ys[pa.0]);
                    pts[e] = (x, y);
                    hit[e] = true;
                }
            }
            let h: Vec<usize> = (0..4).filter(|&e| hit[e]).collect();
            match h.len() {
                2 => out.push([pts[h[0]], pts[h[1]]]),
                4 => {
                    let centre = v.iter().sum::<f64>() / 4.0;
                    if (centre >= 0.0) == (v[0] >= 0.0) {
                        out.push([pts[0], pts[1]]);
                        out.push([pts[2], pts[3]]);
                    } else {
                        out.push([pts[3], pts[0]]);
                        out.push([pts[1], pts[2]]);
                    }
                }
                _ => {}
            }
        }
    }
    out
}

/// The colour range of a viridis heat map: `range` when given (a metric with fixed bounds),
/// else the finite values of the valid cells ([`Palette::range`] of a sequential palette).
pub fn colour_range(values: &[f64], invalid: &[bool], range: Option<(f64, f64)>) -> (f64, f64) {
    Palette::Sequential(range).range(values, invalid)
}

/// The colour of one viridis heat-map cell ([`Palette::colour`] of a sequential palette).
pub fn cell_colour(value: f64, invalid: bool, range: (f64, f64)) -> RGBColor {
    Palette::Sequential(None).colour(value, invalid, range)
}

/// `text` broken at spaces into lines no wider than `width` px in the font of `px` pixels (a
/// word wider than that stands on a line of its own).
pub(crate) fn wrap_text(text: &str, px: u32, width: u32) -> Result<Vec<String>> {
    super::ensure_font()?;
    let fits = |line: &str| -> Result<bool> {
        let (w, _) = font(px)
            .font
            .box_size(line)
            .map_err(|e| super::error::RenderError::Draw(format!("text size: {e:?}")))?;
        Ok(w <= width)
    };
    let mut lines: Vec<String> = Vec::new();
    for word in text.split_whitespace() {
        match lines.last_mut() {
            Some(line) if fits(&format!("{line} {word}"))? => {
                line.push(' ');
                line.push_str(word);
            }
            _ => lines.push(word.to_string()),
        }
    }
    Ok(lines)
}

/// A categorical legend in `area`: a swatch and a name per entry, the label above them,
/// wrapped to the column's width.
fn legend_box(area: &Area, label: &str, entries: &[LegendEntry]) -> Result<()> {
    let width = area.dim_in_pixel().0.saturating_sub(20);
    let lines = wrap_text(label, LABEL_PX, width)?;
    let line_px = LABEL_PX as i32 + 4;
    for (i, line) in lines.iter().enumerate() {
        area.draw(&Text::new(
            line.clone(),
            (10, 16 + line_px * i as i32),
            font(LABEL_PX),
        ))?;
    }
    let top = 16 + line_px * lines.len() as i32 + 14;
    for (k, entry) in entries.iter().enumerate() {
        legend_entry(area, (10, top + 26 * k as i32), entry)?;
    }
    Ok(())
}

/// Per-cell marks of a heat map (row-major like its values; an empty slice marks none).
#[derive(Debug, Clone, Copy, Default)]
pub struct CellMarks<'a> {
    /// The run failed: drawn magenta, "diverged" in the legend.
    pub invalid: &'a [bool],
    /// Filled from its block by refinement: a diagonal hatch every [`HATCH_PX`] pixels.
    pub inferred: &'a [bool],
    /// Curves drawn over the cells (bifurcation curves), in data coordinates.
    pub lines: &'a [Overlay],
    /// The start decides (nudged copies disagree): an anti-diagonal hatch, "start decides" in
    /// the legend.
    pub sensitive: &'a [bool],
    /// The verdict is the orbit after a chaotic transient: dots every [`DOT_PX`] pixels,
    /// "after transient" in the legend.
    pub transient: &'a [bool],
}

/// Pixels between the dots of a cell whose verdict follows a chaotic transient.
pub const DOT_PX: i32 = 6;

/// How a marked cell's pixel at `(i, j)` is drawn: in the hatch colour where one of its marks
/// (`[inferred, sensitive, transient]`) puts a line or dot there.
fn marked_pixel([inferred, sensitive, transient]: [bool; 3], (i, j): (i32, i32)) -> bool {
    (inferred && (i + j).rem_euclid(HATCH_PX) == 0)
        || (sensitive && (i - j).rem_euclid(HATCH_PX) == 0)
        || (transient && i.rem_euclid(DOT_PX) < 2 && j.rem_euclid(DOT_PX) < 2)
}

/// A curve drawn over a heat map: points `(x, y)` in data coordinates, a colour and its
/// legend entry (one entry per label).
#[derive(Debug, Clone, PartialEq)]
pub struct Overlay {
    /// The points.
    pub points: Vec<(f64, f64)>,
    /// Its colour.
    pub colour: RGBColor,
    /// Its legend entry.
    pub label: String,
}

/// Pixels between the hatch lines of inferred cells.
pub const HATCH_PX: i32 = 5;

/// The colour of a hatch line over a cell of colour `c`: halfway to white, or to black on a
/// light cell.
fn hatch(c: RGBColor) -> RGBColor {
    let light = 0.299 * f64::from(c.0) + 0.587 * f64::from(c.1) + 0.114 * f64::from(c.2) > 160.0;
    let to = if light { 0.0 } else { 255.0 };
    let mix = |v: u8| (0.5 * f64::from(v) + 0.5 * to).round() as u8;
    RGBColor(mix(c.0), mix(c.1), mix(c.2))
}

/// Heat map of `values` (row-major `[iy][ix]`, cells between midpoints of
/// the possibly non-uniform centres in `x`/`y`), 1000×700 px, coloured by `palette`: a
/// labelled colour bar for a sequential or diverging palette (its range from
/// [`Palette::range`]; values beyond are clamped), a legend of the categories present for a
/// categorical one. Cells marked invalid are drawn in magenta with a "diverged" legend
/// entry, inferred ones hatched ([`CellMarks`]); valid cells without a value are grey
/// ("no data"). 1×N and N×1 grids work. Both axes linear: [`heatmap_scaled`] draws log ones.
#[allow(clippy::too_many_arguments)]
pub fn heatmap(
    path: &Path,
    title: &str,
    x: &Axis,
    y: &Axis,
    values: &[f64],
    colorbar_label: &str,
    marks: &CellMarks,
    palette: &Palette,
) -> Result<()> {
    let linear = [AxisScale::Linear; 2];
    heatmap_scaled(
        path,
        title,
        x,
        y,
        linear,
        values,
        colorbar_label,
        marks,
        palette,
    )
}

/// Refuse axes that are not strictly increasing, values and flags not one per cell, and a
/// fixed colour range that is not finite and increasing.
fn check_heatmap_input(
    x: &Axis,
    y: &Axis,
    values: &[f64],
    invalid: &[bool],
    palette: &Palette,
) -> Result<()> {
    check_axis("heatmap x", x.values)?;
    check_axis("heatmap y", y.values)?;
    let (nx, ny) = (x.values.len(), y.values.len());
    if values.len() != nx * ny || !(invalid.is_empty() || invalid.len() == values.len()) {
        bad_input!(
            "heatmap: {} values / {} flags for a {ny}×{nx} grid",
            values.len(),
            invalid.len()
        );
    }
    if let Palette::Sequential(Some((a, b))) = palette
        && !(a.is_finite() && b.is_finite() && a < b)
    {
        bad_input!(
            "heatmap: invalid colour range from {} to {}: give finite ends, the first below the second",
            pendulum_atlas_core::text::num(*a),
            pendulum_atlas_core::text::num(*b)
        );
    }
    Ok(())
}

/// [`heatmap`] with each axis on its scale (`scales`: x, then y). A log axis is drawn in log
/// space: cells between geometric midpoints `√(c_i·c_{i+1})` of the centres, the outer edges
/// half a log step out (so > 0), ticks at decades (minor ones at 2…9 × 10^k), at 1, 2 and
/// 5 × 10^k over one to three decades, or at round values within less than one (the module
/// `grid`). A log axis reaching 0 or below is drawn linear; a linear axis as [`heatmap`].
#[allow(clippy::too_many_arguments)]
pub fn heatmap_scaled(
    path: &Path,
    title: &str,
    x: &Axis,
    y: &Axis,
    scales: [AxisScale; 2],
    values: &[f64],
    colorbar_label: &str,
    marks: &CellMarks,
    palette: &Palette,
) -> Result<()> {
    let invalid = marks.invalid;
    check_heatmap_input(x, y, values, invalid, palette)?;
    let nx = x.values.len();
    let bad = |k: usize| invalid.get(k).copied().unwrap_or(false);
    let flag = |f: &[bool], k: usize| f.get(k).copied().unwrap_or(false);
    let inferred = |k: usize| flag(marks.inferred, k);
    let sensitive = |k: usize| flag(marks.sensitive, k);
    let transient = |k: usize| flag(marks.transient, k);
    let range = palette.range(values, invalid);
    let ((xe, xa), (ye, ya)) = (
        grid_spec(x.values, scales[0]),
        grid_spec(y.values, scales[1]),
    );

    let root = canvas(path, SIZE)?;
    let body = titled(&root, title)?;
    let (main, bar) = body.split_horizontally(SIZE.0 - BAR_COL);
    let chart = build_chart(&main, None, &xa, &ya, x.label, y.label, false, 15)?;
    paint_cells(&chart, &xe, &ye, |ix, iy, _, _, (i, j)| {
        let k = iy * nx + ix;
        let c = palette.colour(values[k], bad(k), range);
        let on = [inferred(k), sensitive(k), transient(k)];
        if marked_pixel(on, (i, j)) {
            hatch(c)
        } else {
            c
        }
    })?;
    draw_overlays(&chart, (&xa, &ya), marks.lines)?;
    minor_tick_marks(&root, &chart, &xa, &ya)?;
    let present = palette.present(values, invalid);
    const PLAIN: [bool; 3] = [false; 3];
    let mut legend: Vec<LegendEntry> = present
        .iter()
        .map(|c| (c.label.as_str(), c.colour, PLAIN))
        .collect();
    for o in marks.lines {
        if !legend.iter().any(|(l, ..)| *l == o.label) {
            legend.push((o.label.as_str(), o.colour, PLAIN));
        }
    }
    if (0..values.len()).any(bad) {
        legend.push(("diverged", INVALID_COLOR, PLAIN));
    }
    for (name, any, mark) in [
        (
            "hatched: inferred",
            (0..values.len()).any(inferred),
            [true, false, false],
        ),
        (
            "start decides",
            (0..values.len()).any(sensitive),
            [false, true, false],
        ),
        (
            "after transient",
            (0..values.len()).any(transient),
            [false, false, true],
        ),
    ] {
        if any {
            legend.push((name, NODATA_COLOR, mark));
        }
    }
    if (0..values.len()).any(|k| !bad(k) && palette.colour(values[k], false, range) == NODATA_COLOR)
    {
        legend.push(("no data", NODATA_COLOR, PLAIN));
    }
    match palette {
        Palette::Categorical(_) => legend_box(&bar, colorbar_label, &legend)?,
        _ => colorbar(&bar, range, &palette.bar(256), colorbar_label, &legend)?,
    }
    root.present()?;
    Ok(())
}

/// The overlays drawn on `chart` (points mapped to its plotting space: log10 on a log axis),
/// 3 px wide; a curve of one point is a dot.
fn draw_overlays(chart: &Chart, (xa, ya): (&AxisSpec, &AxisSpec), lines: &[Overlay]) -> Result<()> {
    let to = |a: &AxisSpec, v: f64| if a.base.is_some() { v.log10() } else { v };
    for o in lines {
        let pts: Vec<(f64, f64)> = o
            .points
            .iter()
            .map(|&(x, y)| (to(xa, x), to(ya, y)))
            .collect();
        let style = ShapeStyle::from(&o.colour).stroke_width(3);
        if pts.len() == 1 {
            chart
                .plotting_area()
                .draw(&Circle::new(pts[0], 3, style.filled()))?;
        } else {
            chart.plotting_area().draw(&PathElement::new(pts, style))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::ensure_font;
    use super::*;

    /// The colours inside a legend swatch of `marks`, drawn on a bitmap of its own.
    fn swatch_colours(marks: [bool; 3]) -> std::collections::BTreeSet<(u8, u8, u8)> {
        ensure_font().unwrap();
        let (w, h) = (120u32, 30u32);
        let mut buf = vec![255u8; (w * h * 3) as usize];
        {
            let area = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
            legend_entry(&area, (4, 4), &("mark", NODATA_COLOR, marks)).unwrap();
            area.present().unwrap();
        }
        let at = |x: u32, y: u32| {
            let k = ((y * w + x) * 3) as usize;
            (buf[k], buf[k + 1], buf[k + 2])
        };
        (5..22)
            .flat_map(|x| (5..22).map(move |y| (x, y)))
            .map(|(x, y)| at(x, y))
            .collect()
    }

    #[test]
    fn a_marked_cells_legend_swatch_carries_its_pattern() {
        let c = |c: RGBColor| (c.0, c.1, c.2);
        assert_eq!(swatch_colours([false; 3]), [c(NODATA_COLOR)].into());
        for marks in [
            [true, false, false],
            [false, true, false],
            [false, false, true],
        ] {
            let want = [c(NODATA_COLOR), c(hatch(NODATA_COLOR))].into();
            assert_eq!(swatch_colours(marks), want, "{marks:?}");
        }
    }

    #[test]
    fn a_legend_label_is_wrapped_to_the_colour_bar_column() {
        let label = "most likely attractor (Pp: period p; wells + α > 0, − α < 0, ± both)";
        let width = BAR_COL - 20;
        let lines = wrap_text(label, LABEL_PX, width).unwrap();
        ensure_font().unwrap();
        assert!(lines.len() > 1, "{lines:?}");
        for line in &lines {
            let (w, _) = font(LABEL_PX).font.box_size(line).unwrap();
            assert!(w <= width || !line.contains(' '), "{line:?} is {w} px wide");
        }
        assert_eq!(lines.join(" "), label);
    }

    /// A 6 × 4 heat map with a log x axis from 10^-3 to 10^3 and a linear y axis, at `name`
    /// in the temporary folder (`PENDULUM_ATLAS_KEEP_PNG` keeps it, to look at).
    fn log_heatmap(name: &str, xs: &[f64]) -> Result<std::path::PathBuf> {
        let ys = [0.0, 1.0, 2.0, 3.0];
        let vals: Vec<f64> = (0..xs.len() * ys.len()).map(|k| k as f64).collect();
        let dir = std::env::temp_dir().join(format!("atlas_render_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join(name);
        let (x, y) = (
            Axis {
                label: "forcing amplitude A (m)",
                values: xs,
            },
            Axis {
                label: "y (1)",
                values: &ys,
            },
        );
        let scales = [AxisScale::Log, AxisScale::Linear];
        let marks = CellMarks::default();
        let palette = Palette::Sequential(None);
        heatmap_scaled(&p, "log x", &x, &y, scales, &vals, "k", &marks, &palette)?;
        Ok(p)
    }

    #[test]
    fn a_heat_map_draws_a_log_axis_and_falls_back_to_linear_below_zero() {
        let xs: Vec<f64> = (0..6).map(|i| 10f64.powf(-3.0 + 1.2 * i as f64)).collect();
        let p = log_heatmap("log_x.png", &xs).unwrap();
        assert!(std::fs::metadata(&p).unwrap().len() > 1000);
        let q = log_heatmap("log_x_from_zero.png", &[0.0, 1.0, 2.0]).unwrap();
        assert!(q.is_file());
        let xs: Vec<f64> = (0..6).map(|i| 10f64.powf(0.6 * i as f64)).collect();
        log_heatmap("three.png", &xs).unwrap();
        if std::env::var_os("PENDULUM_ATLAS_KEEP_PNG").is_none() {
            let _ = std::fs::remove_dir_all(p.parent().unwrap());
        }
    }
}
