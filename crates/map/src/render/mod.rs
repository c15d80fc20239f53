//! PNG figure rendering for pendulum-atlas (line charts, stacked panels,
//! wavelet scalograms, heat maps, histograms, 0–1-test figures, scatter plots).
//!
//! Everything is drawn with `plotters`' bitmap backend and an embedded
//! DejaVu Sans font (registered once via `ab_glyph`), so no system fonts or
//! fontconfig are needed. Every function writes one PNG with a white
//! background and returns `Result<(), RenderError>`; bad input (mismatched lengths,
//! non-monotonic axes, ...) yields `Err`, while empty or non-finite data is
//! drawn gracefully (empty axes, skipped points) — nothing here panics.

mod charts;
mod colormap;
mod error;
mod grid;
mod maps;
mod palette;

use std::sync::Once;
use std::sync::atomic::{AtomicBool, Ordering};

use error::{Result, bad_input};
use plotters::prelude::*;
use plotters::style::FontStyle;

pub use charts::{histogram, line_chart, scatter, scatter_groups, stacked_panels, zero_one_figure};
pub use colormap::viridis;
pub use error::RenderError;
pub use grid::{GridAxis, grid_axis};
pub use maps::{
    CellMarks, DOT_PX, HATCH_PX, Overlay, cell_colour, colour_range, heatmap, heatmap_scaled,
    scalogram,
};
pub use palette::{Category, INVALID_COLOR, NODATA_COLOR, Palette, curve_style};
pub use plotters::style::RGBColor;

/// One named curve: `x[i]`, `y[i]` pairs (both slices must have equal length).
#[derive(Debug, Clone, Copy)]
pub struct Series<'a> {
    /// Legend entry (shown when a chart has more than one series).
    pub name: &'a str,
    /// Abscissae.
    pub x: &'a [f64],
    /// Ordinates.
    pub y: &'a [f64],
}

/// One panel of [`stacked_panels`]: a line chart with its own axes.
#[derive(Debug, Clone)]
pub struct Panel<'a> {
    /// x-axis label including units, e.g. `"Time (s)"`.
    pub x_label: &'a str,
    /// y-axis label including units.
    pub y_label: &'a str,
    /// Curves drawn in this panel.
    pub series: Vec<Series<'a>>,
    /// Logarithmic y axis (non-positive values are skipped).
    pub log_y: bool,
}

/// A heat-map axis: label with units and the cell centres (strictly
/// increasing, possibly non-uniform).
#[derive(Debug, Clone, Copy)]
pub struct Axis<'a> {
    /// Axis label including units.
    pub label: &'a str,
    /// Cell centres, strictly increasing.
    pub values: &'a [f64],
}

/// Font family name under which the embedded font is registered.
pub(crate) const FONT: &str = "sans-serif";
/// Title font size (px).
pub(crate) const TITLE_PX: u32 = 26;
/// Axis description font size (px).
pub(crate) const LABEL_PX: u32 = 20;
/// Tick label / legend font size (px).
pub(crate) const TICK_PX: u32 = 16;

static FONT_BYTES: &[u8] = include_bytes!(concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/assets/fonts/DejaVuSans.ttf"
));
static FONT_ONCE: Once = Once::new();
static FONT_OK: AtomicBool = AtomicBool::new(false);

/// Registers the embedded DejaVu Sans font with plotters (idempotent).
pub(crate) fn ensure_font() -> Result<()> {
    FONT_ONCE.call_once(|| {
        let ok = plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES).is_ok();
        FONT_OK.store(ok, Ordering::SeqCst);
    });
    if FONT_OK.load(Ordering::SeqCst) {
        Ok(())
    } else {
        Err(RenderError::Font)
    }
}

/// Text style helper.
pub(crate) fn font(px: u32) -> TextStyle<'static> {
    (FONT, px).into_font().color(&BLACK)
}

/// Qualitative palette (matplotlib "tab10").
pub const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Grid line colour.
pub(crate) const GRID: RGBColor = RGBColor(225, 225, 225);
/// Minor grid line colour.
pub(crate) const GRID_MINOR: RGBColor = RGBColor(242, 242, 242);

/// A resolved axis in plotting coordinates (log10 of data for log axes).
#[derive(Debug, Clone)]
pub struct AxisSpec {
    /// Lower end (plotting space).
    pub lo: f64,
    /// Upper end (plotting space).
    pub hi: f64,
    /// Log base of the axis (plotting space = log_base(data)), None = linear.
    pub base: Option<f64>,
    /// Labelled ticks (plotting space).
    pub ticks: Vec<f64>,
    /// Unlabelled minor ticks (plotting space).
    pub minor: Vec<f64>,
}

impl AxisSpec {
    /// Auto-ranges over plotting-space values (already log10 for log axes),
    /// padding by `pad` of the span; empty or constant data get a default span.
    pub fn auto(values: impl Iterator<Item = f64>, log: bool, pad: f64) -> Self {
        let (mut lo, mut hi) = finite_min_max(values).unwrap_or((0.0, 1.0));
        if hi - lo <= 1e-12 * lo.abs().max(hi.abs()).max(1e-300) {
            let d = if log || lo == 0.0 {
                0.5
            } else {
                0.1 * lo.abs()
            };
            lo -= d;
            hi += d;
        } else {
            let p = pad * (hi - lo);
            lo -= p;
            hi += p;
        }
        Self::fixed(lo, hi, log)
    }

    /// Axis over a fixed plotting-space range with automatic ticks.
    pub fn fixed(lo: f64, hi: f64, log: bool) -> Self {
        let (ticks, minor) = if log {
            log_ticks(lo, hi)
        } else {
            (nice_ticks(lo, hi, 9), vec![])
        };
        AxisSpec {
            lo,
            hi,
            base: log.then_some(10.0),
            ticks,
            minor,
        }
    }

    /// Log2 axis over plotting-space `[lo, hi]` (= log2 of data) with ticks
    /// at integer powers of two.
    pub fn log2(lo: f64, hi: f64) -> Self {
        let n = (hi - lo).max(1.0);
        let stride = ((n / 10.0).ceil() as i64).max(1);
        let mut ticks: Vec<f64> = (lo.ceil() as i64..=hi.floor() as i64)
            .filter(|k| k.rem_euclid(stride) == 0)
            .map(|k| k as f64)
            .collect();
        if ticks.len() < 2 {
            ticks = nice_ticks(lo.exp2(), hi.exp2(), 5)
                .into_iter()
                .filter(|&v| v > 0.0)
                .map(f64::log2)
                .collect();
        }
        AxisSpec {
            lo,
            hi,
            base: Some(2.0),
            ticks,
            minor: vec![],
        }
    }

    /// Maps a data value into plotting space (None if not representable).
    pub fn map(&self, v: f64) -> Option<f64> {
        match self.base {
            None => plot_value(v, false),
            Some(10.0) => plot_value(v, true),
            Some(b) => (v > 0.0).then(|| v.log(b)).filter(|t| t.is_finite()),
        }
    }

    /// Formats a tick given in plotting space.
    pub fn label(&self, t: f64) -> String {
        fmt_num(match self.base {
            Some(b) => b.powf(t),
            None => t,
        })
    }

    /// The plotters coordinate for this axis.
    pub(crate) fn coord(&self) -> Coord {
        Coord {
            inner: (self.lo..self.hi).into(),
            ticks: self.ticks.clone(),
            minor: self.minor.clone(),
        }
    }
}

/// Linear f64 coordinate with explicit major (labelled) and minor tick
/// positions (plotting space); labels are formatted by the chart.
pub struct Coord {
    inner: plotters::coord::types::RangedCoordf64,
    ticks: Vec<f64>,
    minor: Vec<f64>,
}

impl Ranged for Coord {
    type FormatOption = plotters::coord::ranged1d::DefaultFormatting;
    type ValueType = f64;
    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }
    fn key_points<Hint: plotters::coord::ranged1d::KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            self.minor.clone()
        } else {
            self.ticks.clone()
        }
    }
    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }
}

/// Data value to plotting space: log10 for log axes; None if non-finite
/// (or non-positive on a log axis).
pub fn plot_value(v: f64, log: bool) -> Option<f64> {
    let t = if log {
        if v > 0.0 { v.log10() } else { return None }
    } else {
        v
    };
    t.is_finite().then_some(t)
}

/// Drawing area of the bitmap backend in pixel coordinates.
pub(crate) type Area<'b> = DrawingArea<BitMapBackend<'b>, plotters::coord::Shift>;
/// A configured 2-D chart.
pub type Chart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<Coord, Coord>>;

/// Builds a chart with axes, labels and (optionally) grid lines on `area`.
#[allow(clippy::too_many_arguments)]
pub fn build_chart<'a, 'b>(
    area: &'a Area<'b>,
    caption: Option<&str>,
    xa: &AxisSpec,
    ya: &AxisSpec,
    x_label: &str,
    y_label: &str,
    grid: bool,
    right_margin: u32,
) -> Result<Chart<'a, 'b>> {
    let mut cb = ChartBuilder::on(area);
    cb.margin(15)
        .margin_right(right_margin)
        .x_label_area_size(60)
        .y_label_area_size(100);
    if let Some(c) = caption {
        cb.caption(c, font(TITLE_PX));
    }
    let mut chart = cb.build_cartesian_2d(xa.coord(), ya.coord())?;
    let xf = |v: &f64| xa.label(*v);
    let yf = |v: &f64| ya.label(*v);
    let mut mesh = chart.configure_mesh();
    mesh.x_desc(x_label)
        .y_desc(y_label)
        .axis_desc_style(font(LABEL_PX))
        .label_style(font(TICK_PX))
        .x_label_formatter(&xf)
        .y_label_formatter(&yf)
        .bold_line_style(GRID)
        .light_line_style(GRID_MINOR)
        .axis_style(BLACK);
    if !grid {
        mesh.disable_x_mesh().disable_y_mesh();
    }
    mesh.draw()?;
    Ok(chart)
}

/// Draws the legend of `chart`'s labelled series at `position`, in the house style.
pub fn draw_legend<'a, 'b: 'a>(
    chart: &mut Chart<'a, 'b>,
    position: SeriesLabelPosition,
) -> Result<()> {
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(font(TICK_PX))
        .draw()?;
    Ok(())
}

/// Draws a centred figure title at the top of `area`; returns the area below it.
pub(crate) fn titled<'b>(area: &Area<'b>, title: &str) -> Result<Area<'b>> {
    Ok(area.margin(10, 0, 0, 0).titled(title, font(TITLE_PX))?)
}

/// Creates a white bitmap of `size` at `path` (font registered first).
pub fn canvas(path: &std::path::Path, size: (u32, u32)) -> Result<Area<'_>> {
    ensure_font()?;
    let root = BitMapBackend::new(path, size).into_drawing_area();
    root.fill(&WHITE)?;
    Ok(root)
}

/// Min and max over the finite values, or None if there are none.
pub(crate) fn finite_min_max(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((a, b)) => Some((a.min(v), b.max(v))),
        })
}

/// "Nice" ticks (1, 2, 2.5, 5 × 10^k steps) inside `[lo, hi]`, at most `max_n`.
pub(crate) fn nice_ticks(lo: f64, hi: f64, max_n: usize) -> Vec<f64> {
    let span = hi - lo;
    if !(span.is_finite() && span > 0.0) {
        return vec![];
    }
    let raw = span / max_n.max(2) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= max_n as f64)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last)
        .map(|k| {
            let v = k as f64 * step;
            if v.abs() < step * 1e-9 { 0.0 } else { v }
        })
        .collect()
}

/// Ticks for a log10 axis over plotting-space `[lo, hi]`: (major, minor).
fn log_ticks(lo: f64, hi: f64) -> (Vec<f64>, Vec<f64>) {
    if hi - lo < 1.0 {
        // Less than one decade: linear nice ticks in data space.
        let t = nice_ticks(10f64.powf(lo), 10f64.powf(hi), 6);
        return (t.into_iter().map(f64::log10).collect(), vec![]);
    }
    let decades = (hi - lo).ceil() as i64;
    let stride = ((decades as f64 / 8.0).ceil() as i64).max(1);
    let major: Vec<f64> = (lo.ceil() as i64..=hi.floor() as i64)
        .filter(|k| k.rem_euclid(stride) == 0)
        .map(|k| k as f64)
        .collect();
    let mut minor = vec![];
    if major.len() < 3 {
        // Few decades: also label 2 and 5 × 10^k.
        let mut m: Vec<f64> = (lo.floor() as i64..=hi.ceil() as i64)
            .flat_map(|k| [1.0f64, 2.0, 5.0].map(|f| k as f64 + f.log10()))
            .filter(|t| *t >= lo && *t <= hi)
            .collect();
        m.sort_by(f64::total_cmp);
        return (m, minor);
    }
    if stride == 1 && decades <= 8 {
        for k in lo.floor() as i64..=hi.ceil() as i64 {
            for m in 2..10 {
                let t = k as f64 + (m as f64).log10();
                if t >= lo && t <= hi {
                    minor.push(t);
                }
            }
        }
    }
    (major, minor)
}

/// Compact number formatting for tick labels.
pub fn fmt_num(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    if a < 1e-12 {
        return "0".into();
    }
    if !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.2e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        return format!("{}e{}", trim_zeros(m), e);
    }
    let decimals = (3 - a.log10().floor() as i32).clamp(0, 6) as usize;
    trim_zeros(&format!("{v:.decimals$}"))
}

fn trim_zeros(s: &str) -> String {
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s.to_string()
    }
}

/// Splits a point list into runs of consecutive mappable points (breaks at
/// non-finite or, for log axes, non-positive values).
pub fn segments(s: &Series, xa: &AxisSpec, ya: &AxisSpec) -> Vec<Vec<(f64, f64)>> {
    let mut out = vec![];
    let mut cur = vec![];
    for (&x, &y) in s.x.iter().zip(s.y) {
        match (xa.map(x), ya.map(y)) {
            (Some(a), Some(b)) => cur.push((a, b)),
            _ => {
                if !cur.is_empty() {
                    out.push(std::mem::take(&mut cur));
                }
            }
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// Checks that every series has equal-length x and y.
pub(crate) fn check_series(series: &[Series]) -> Result<()> {
    for s in series {
        if s.x.len() != s.y.len() {
            bad_input!(
                "series '{}': x has {} points but y has {}",
                s.name,
                s.x.len(),
                s.y.len()
            );
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_and_format() {
        assert_eq!(
            nice_ticks(0.0, 10.0, 9),
            vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
        );
        assert_eq!(fmt_num(0.125), "0.125");
        assert_eq!(fmt_num(1000.0), "1000");
        assert_eq!(fmt_num(1e-5), "1e-5");
        assert_eq!(fmt_num(2.5e7), "2.5e7");
        let (maj, min) = log_ticks(-2.2, 1.3);
        assert_eq!(maj, vec![-2.0, -1.0, 0.0, 1.0]);
        assert!(!min.is_empty());
        let a = AxisSpec::auto([3.0, 3.0].into_iter(), false, 0.05);
        assert!(a.lo < 3.0 && a.hi > 3.0);
        let e = AxisSpec::auto(std::iter::empty(), false, 0.05);
        assert!(e.lo < e.hi);
    }
}
