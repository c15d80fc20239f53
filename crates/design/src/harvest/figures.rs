//! The search's two pictures: the Pareto plot (bandwidth against band-averaged power) and
//! P(f) of the best designs against the linear baseline.

use super::search::SearchRun;
use super::spec::SearchSpec;
use pendulum_atlas_map::render::RenderError;
use pendulum_atlas_map::render::{
    AxisSpec, Chart, PALETTE, Series, build_chart, canvas, draw_legend, line_chart, plot_value,
};

type Result<T> = std::result::Result<T, RenderError>;
use plotters::prelude::*;
use std::path::Path;

/// A design variable's value in a few characters: the usual symbol and unit for the keys of
/// issue 7, the last part of the key otherwise.
fn short_value(key: &str, x: f64) -> String {
    let n = pendulum_atlas_map::render::fmt_num;
    match key {
        "limiter.clearance_deg" => format!("θc={}°", n(x)),
        "limiter.contact_arc_m" => format!("s_b={} m", n(x)),
        "tip.mass_kg" => format!("M={} g", n(x * 1e3)),
        "piezo.load_ohm" => format!("R_L={} kΩ", n(x / 1e3)),
        other => format!("{}={}", other.rsplit('.').next().unwrap_or(other), n(x)),
    }
}

/// Short label of a design for legends: `#id` and its values.
pub(crate) fn design_label(spec: &SearchSpec, id: usize, values: &[f64]) -> String {
    let parts: Vec<String> = spec
        .variables
        .iter()
        .zip(values)
        .map(|(v, &x)| short_value(&v.key, x))
        .collect();
    format!("#{id} {}", parts.join(", "))
}

/// `pareto.png`: every design's bandwidth against its band-averaged power (log scale), both
/// of the ranked curve, the Pareto front joined, the best design and the baseline marked.
pub(crate) fn pareto_figure(path: &Path, spec: &SearchSpec, run: &SearchRun) -> Result<()> {
    let pts: Vec<(f64, f64, bool)> = run
        .designs
        .iter()
        .filter(|d| d.failed == 0)
        .map(|d| {
            let m = d.ranked(spec.weighting).0;
            (m.bandwidth_hz, m.band_average_w, d.pareto)
        })
        .collect();
    let base = (
        run.baseline.metrics.bandwidth_hz,
        run.baseline.metrics.band_average_w,
    );
    let best = run.best();
    let best_m = best.ranked(spec.weighting).0;
    let best_pt = (best_m.bandwidth_hz, best_m.band_average_w);
    let word = spec.weighting.name();
    let xs = pts.iter().map(|p| p.0).chain([base.0, 0.0]);
    let ys = pts.iter().map(|p| p.1).chain([base.1]);
    let xa = AxisSpec::auto(xs, false, 0.05);
    let ya = AxisSpec::auto(ys.filter_map(|y| plot_value(y, true)), true, 0.05);
    let root = canvas(path, (1000, 700))?;
    let title = format!(
        "{} designs: {word} bandwidth vs band-averaged power",
        run.designs.len()
    );
    let mut chart = build_chart(
        &root,
        Some(&title),
        &xa,
        &ya,
        &format!(
            "{word} bandwidth (Hz) where P ≥ {} W",
            pendulum_atlas_map::render::fmt_num(run.threshold_w)
        ),
        &format!(
            "{word} band-averaged power (W), {}–{} Hz",
            spec.band.start_hz(),
            spec.band.end_hz()
        ),
        true,
        25,
    )?;
    let map = |(x, y): (f64, f64)| Some((xa.map(x)?, ya.map(y)?));
    draw_designs_and_front(&mut chart, &pts, map)?;
    draw_best_and_baseline(&mut chart, map(best_pt), best.id, map(base))?;
    draw_legend(&mut chart, SeriesLabelPosition::LowerRight)?;
    root.present()?;
    Ok(())
}

/// Every design as a grey dot, and the Pareto front (`pts` marked `true`) as red dots joined
/// by increasing bandwidth; `map` takes data to plotting coordinates.
fn draw_designs_and_front(
    chart: &mut Chart,
    pts: &[(f64, f64, bool)],
    map: impl Fn((f64, f64)) -> Option<(f64, f64)>,
) -> Result<()> {
    let grey = RGBColor(150, 150, 150);
    chart
        .draw_series(
            pts.iter()
                .filter_map(|&(x, y, _)| map((x, y)))
                .map(|p| Circle::new(p, 3, grey.mix(0.7).filled())),
        )?
        .label("design")
        .legend(move |(x, y)| Circle::new((x + 12, y), 4, grey.filled()));
    let mut front: Vec<(f64, f64)> = pts
        .iter()
        .filter(|p| p.2)
        .filter_map(|&(x, y, _)| map((x, y)))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    let red = PALETTE[3];
    chart.draw_series(LineSeries::new(front.clone(), red.stroke_width(2)))?;
    chart
        .draw_series(front.iter().map(|&p| Circle::new(p, 5, red.filled())))?
        .label("Pareto front")
        .legend(move |(x, y)| Circle::new((x + 12, y), 5, red.filled()));
    Ok(())
}

/// A ring on the best design (#`best_id`) and a triangle on the baseline, each where it falls
/// on the plot (`None`: off a log axis, not drawn).
fn draw_best_and_baseline(
    chart: &mut Chart,
    best: Option<(f64, f64)>,
    best_id: usize,
    baseline: Option<(f64, f64)>,
) -> Result<()> {
    if let Some(p) = best {
        let c = PALETTE[0];
        chart
            .draw_series(std::iter::once(Circle::new(p, 9, c.stroke_width(3))))?
            .label(format!("best: #{best_id}"))
            .legend(move |(x, y)| Circle::new((x + 12, y), 7, c.stroke_width(3)));
    }
    if let Some(p) = baseline {
        chart
            .draw_series(std::iter::once(TriangleMarker::new(p, 10, BLACK.filled())))?
            .label("linear clamped baseline")
            .legend(|(x, y)| TriangleMarker::new((x + 12, y), 7, BLACK.filled()));
    }
    Ok(())
}

/// `power_vs_frequency.png`: the ranked P(f) (robust or expected) of the top designs, the
/// baseline's P(f) and the threshold, on a log power axis.
pub(crate) fn power_figure(path: &Path, spec: &SearchSpec, run: &SearchRun) -> Result<()> {
    let top = run.top(spec.report_top);
    let labels: Vec<String> = top
        .iter()
        .map(|d| {
            let label = design_label(spec, d.id, &d.values);
            format!("{label} ({})", spec.weighting.name())
        })
        .collect();
    let f = &spec.band.frequencies_hz;
    let mut series: Vec<Series> = top
        .iter()
        .zip(&labels)
        .map(|(d, l)| Series {
            name: l,
            x: f,
            y: d.ranked(spec.weighting).1,
        })
        .collect();
    series.push(Series {
        name: "linear clamped baseline",
        x: &run.baseline.frequencies_hz,
        y: &run.baseline.power_w,
    });
    let tx = [spec.band.start_hz(), spec.band.end_hz()];
    let ty = [run.threshold_w, run.threshold_w];
    if run.threshold_w > 0.0 {
        series.push(Series {
            name: "bandwidth threshold",
            x: &tx,
            y: &ty,
        });
    }
    line_chart(
        path,
        &format!(
            "P(f): best designs vs linear baseline ({})",
            spec.band.excitation.describe()
        ),
        "forcing frequency f (Hz)",
        "mean harvested power P (W)",
        &series,
        false,
        true,
    )
}
