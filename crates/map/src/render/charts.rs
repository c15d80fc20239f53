//! Line charts, stacked panels, histograms, scatter plots and the 0–1-test figure.

use std::path::Path;

use super::error::{Result, bad_input};
use plotters::prelude::*;

use super::{
    Area, AxisSpec, PALETTE, Panel, Series, build_chart, canvas, check_series, draw_legend,
    plot_value, segments, titled,
};

/// Default figure size in pixels.
const SIZE: (u32, u32) = (1000, 700);
/// Relative padding of auto ranges.
const PAD: f64 = 0.04;

/// Draws `series` as lines into `area` (shared by [`line_chart`] and [`stacked_panels`]).
fn draw_lines(
    area: &Area,
    caption: Option<&str>,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log_x: bool,
    log_y: bool,
) -> Result<()> {
    check_series(series)?;
    let valid = || {
        series.iter().flat_map(|s| {
            s.x.iter()
                .zip(s.y)
                .filter_map(|(&x, &y)| Some((plot_value(x, log_x)?, plot_value(y, log_y)?)))
        })
    };
    let xa = AxisSpec::auto(valid().map(|p| p.0), log_x, 0.0);
    let ya = AxisSpec::auto(valid().map(|p| p.1), log_y, PAD);
    let mut chart = build_chart(area, caption, &xa, &ya, x_label, y_label, true, 25)?;
    let total: usize = series.iter().map(|s| s.x.len()).sum();
    let width = if total > 5000 { 1 } else { 2 };
    for (i, s) in series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        for seg in segments(s, &xa, &ya) {
            if seg.len() == 1 {
                chart.draw_series(std::iter::once(Circle::new(seg[0], 2, color.filled())))?;
            } else {
                chart.draw_series(LineSeries::new(seg, color.stroke_width(width)))?;
            }
        }
        if series.len() > 1 {
            chart
                .draw_series(LineSeries::new(
                    std::iter::empty::<(f64, f64)>(),
                    color.stroke_width(width),
                ))?
                .label(s.name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(3))
                });
        }
    }
    if series.len() > 1 {
        draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    }
    Ok(())
}

/// Line chart of one or more series (legend when there is more than one),
/// 1000×700 px. Non-finite points (and non-positive ones on log axes) are
/// skipped and break the line; empty input draws empty axes.
pub fn line_chart(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    log_x: bool,
    log_y: bool,
) -> Result<()> {
    check_series(series)?;
    let root = canvas(path, SIZE)?;
    draw_lines(&root, Some(title), x_label, y_label, series, log_x, log_y)?;
    root.present()?;
    Ok(())
}

/// Vertically stacked line charts sharing one title (e.g. time series over
/// spectrum); 1000 px wide, 300 px per panel plus a title band.
pub fn stacked_panels(path: &Path, title: &str, panels: &[Panel]) -> Result<()> {
    if panels.is_empty() {
        bad_input!("stacked_panels: no panels given");
    }
    for p in panels {
        check_series(&p.series)?;
    }
    let h = 60 + 300 * panels.len() as u32;
    let root = canvas(path, (SIZE.0, h))?;
    let body = titled(&root, title)?;
    for (area, p) in body.split_evenly((panels.len(), 1)).iter().zip(panels) {
        draw_lines(area, None, p.x_label, p.y_label, &p.series, false, p.log_y)?;
    }
    root.present()?;
    Ok(())
}

/// Bar histogram: bar `i` spans `edges[i]..edges[i+1]` with height
/// `density[i]` (`edges.len() == density.len() + 1`, edges strictly increasing).
/// Non-finite densities are left out. 1000×700 px.
pub fn histogram(
    path: &Path,
    title: &str,
    edges: &[f64],
    density: &[f64],
    x_label: &str,
    y_label: &str,
) -> Result<()> {
    if density.is_empty() || edges.len() != density.len() + 1 {
        bad_input!(
            "histogram: need edges.len() == density.len() + 1 > 1 (got {} edges, {} bars)",
            edges.len(),
            density.len()
        );
    }
    if edges.iter().any(|e| !e.is_finite()) || edges.windows(2).any(|w| w[1] <= w[0]) {
        bad_input!("histogram: edges must be finite and strictly increasing");
    }
    let xa = AxisSpec::fixed(edges[0], edges[edges.len() - 1], false);
    let top = density
        .iter()
        .copied()
        .filter(|d| d.is_finite())
        .fold(0.0f64, f64::max);
    let ya = AxisSpec::fixed(0.0, if top > 0.0 { top * 1.08 } else { 1.0 }, false);
    let root = canvas(path, SIZE)?;
    let mut chart = build_chart(&root, Some(title), &xa, &ya, x_label, y_label, true, 25)?;
    let fill = PALETTE[0];
    let bars = edges.windows(2).zip(density).filter(|(_, d)| d.is_finite());
    chart.draw_series(
        bars.clone()
            .map(|(w, &d)| Rectangle::new([(w[0], 0.0), (w[1], d)], fill.mix(0.8).filled())),
    )?;
    if density.len() <= 200 {
        chart.draw_series(bars.map(|(w, &d)| {
            Rectangle::new(
                [(w[0], 0.0), (w[1], d)],
                RGBColor(20, 60, 100).stroke_width(1),
            )
        }))?;
    }
    root.present()?;
    Ok(())
}

/// Scatter plot (dots; radius shrinks for many points, e.g. bifurcation
/// diagrams) or, with `as_line`, a connected path (phase portrait). 1000×700 px.
pub fn scatter(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    x: &[f64],
    y: &[f64],
    as_line: bool,
) -> Result<()> {
    let s = [Series { name: "", x, y }];
    if as_line {
        return line_chart(path, title, x_label, y_label, &s, false, false);
    }
    check_series(&s)?;
    let root = canvas(path, SIZE)?;
    draw_points(&root, Some(title), x_label, y_label, x, y, None)?;
    root.present()?;
    Ok(())
}

/// Dots of several groups on one pair of axes, a colour per group named in the legend: the
/// first group filled, the others as rings a little larger, so that where groups coincide
/// (the two directions of a continuation on one orbit) both stay visible. 1000×700 px.
pub fn scatter_groups(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    groups: &[Series],
) -> Result<()> {
    check_series(groups)?;
    let pts = |s: &Series| -> Vec<(f64, f64)> {
        s.x.iter()
            .zip(s.y)
            .filter(|(a, b)| a.is_finite() && b.is_finite())
            .map(|(&a, &b)| (a, b))
            .collect()
    };
    let all: Vec<Vec<(f64, f64)>> = groups.iter().map(pts).collect();
    let xa = AxisSpec::auto(all.iter().flatten().map(|p| p.0), false, PAD);
    let ya = AxisSpec::auto(all.iter().flatten().map(|p| p.1), false, PAD);
    let root = canvas(path, SIZE)?;
    let mut chart = build_chart(&root, Some(title), &xa, &ya, x_label, y_label, true, 25)?;
    let r = match all.iter().map(Vec::len).sum::<usize>() {
        0..=2000 => 3,
        2001..=20_000 => 2,
        _ => 1,
    };
    for (i, (s, p)) in groups.iter().zip(&all).enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let style = if i == 0 {
            color.filled()
        } else {
            color.stroke_width(1)
        };
        let radius = r + 2 * i as i32;
        chart
            .draw_series(p.iter().map(|&q| Circle::new(q, radius, style)))?
            .label(s.name)
            .legend(move |(x, y)| Circle::new((x + 12, y), 4, style));
    }
    draw_legend(&mut chart, SeriesLabelPosition::UpperRight)?;
    root.present()?;
    Ok(())
}

/// Draws dots; `hline` adds a horizontal reference line and includes it (and
/// [0, 1]) in the y range.
fn draw_points(
    area: &Area,
    caption: Option<&str>,
    x_label: &str,
    y_label: &str,
    x: &[f64],
    y: &[f64],
    hline: Option<f64>,
) -> Result<()> {
    let pts: Vec<(f64, f64)> = x
        .iter()
        .zip(y)
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|(&a, &b)| (a, b))
        .collect();
    let xa = AxisSpec::auto(pts.iter().map(|p| p.0), false, PAD);
    let extra: Vec<f64> = match hline {
        Some(k) => vec![k, 0.0, 1.0],
        None => vec![],
    };
    let ya = AxisSpec::auto(pts.iter().map(|p| p.1).chain(extra), false, PAD);
    let mut chart = build_chart(area, caption, &xa, &ya, x_label, y_label, true, 25)?;
    if let Some(k) = hline.filter(|k| k.is_finite()) {
        chart.draw_series(LineSeries::new(
            [(xa.lo, k), (xa.hi, k)],
            PALETTE[3].stroke_width(2),
        ))?;
    }
    let (r, alpha) = match pts.len() {
        0..=2000 => (3, 1.0),
        2001..=50_000 => (1, 0.8),
        _ => (1, 0.5),
    };
    let c = PALETTE[0].mix(alpha).filled();
    chart.draw_series(pts.iter().map(|&p| Circle::new(p, r, c)))?;
    Ok(())
}

/// 0–1 test for chaos figure, 1400×700 px: left the translation-variable path
/// (p_c, q_c), right K_c against c as dots with a horizontal line at the
/// median `k`, whose value is shown in the panel title ("K = 0.98").
pub fn zero_one_figure(
    path: &Path,
    p: &[f64],
    q: &[f64],
    c_values: &[f64],
    k_c: &[f64],
    k: f64,
) -> Result<()> {
    if p.len() != q.len() || c_values.len() != k_c.len() {
        bad_input!(
            "zero_one_figure: p/q lengths {}/{} or c/K_c lengths {}/{} differ",
            p.len(),
            q.len(),
            c_values.len(),
            k_c.len()
        );
    }
    let root = canvas(path, (1400, 700))?;
    let body = titled(&root, "0–1 test for chaos")?;
    let (left, right) = body.split_horizontally(700);
    let pq = [Series {
        name: "",
        x: p,
        y: q,
    }];
    draw_lines(
        &left,
        Some("Translation variables"),
        "p_c",
        "q_c",
        &pq,
        false,
        false,
    )?;
    let caption = format!("K = {k:.2}");
    draw_points(
        &right,
        Some(&caption),
        "c (rad)",
        "K_c",
        c_values,
        k_c,
        Some(k),
    )?;
    root.present()?;
    Ok(())
}
