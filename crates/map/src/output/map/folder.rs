//! The folder of a map: `grid.csv`, `map_scene.toml`, the arrays, the pictures (a PNG per
//! metric, per 2-D slice of a 3-D grid, `bifurcation.png`, the attractors, the hysteresis),
//! and `map.json` last.

use super::ArrayData;
use super::{
    ATTRACTORS_JSON, Dtype, MapSpec, Metric, Regime, Status, map_arrays, map_fields, map_manifest,
    stem,
};
use crate::map::MapRun;
use crate::output::OutputError;
use crate::output::files::{AtomicFile, create_dir, draw, write_json, write_toml};
use crate::output::npy::{write_npy_f64, write_npy_i8, write_npy_i32, write_npy_u8};
use crate::render::{
    Axis, Category, CellMarks, Overlay, Palette, RGBColor, Series, heatmap_scaled, scatter,
    scatter_groups,
};
use serde_json::json;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Write every file of a map into `dir` (created if needed); returns the paths written.
/// `map.json` comes last, so that its presence means the map is complete.
pub fn write_map(dir: &Path, spec: &MapSpec, run: &MapRun) -> Result<Vec<PathBuf>, OutputError> {
    create_dir(dir)?;
    let mut written = vec![
        write_grid_csv(&dir.join("grid.csv"), spec, run)?,
        write_scene_toml(&dir.join("map_scene.toml"), spec)?,
    ];
    written.extend(write_arrays(dir, spec, run)?);
    for m in &spec.metrics {
        written.extend(draw_metric(dir, spec, run, *m)?);
    }
    if spec.bifurcation && !run.strobe_tail.is_empty() {
        written.extend(draw_bifurcation(&dir.join("bifurcation.png"), spec, run)?);
    }
    if let Some(h) = run
        .continuation
        .as_ref()
        .and_then(|c| c.hysteresis.as_ref())
    {
        let style = Style {
            label: "up and down differ (1: on different attractors)".into(),
            palette: Palette::Sequential(Some((0.0, 1.0))),
        };
        let value = |k: usize| f64::from(u8::from(h.differs[k]));
        written.extend(draw_values(
            dir,
            spec,
            run,
            stem::HYSTERESIS,
            &style,
            &value,
        )?);
    }
    if let Some(a) = &run.attractors {
        written.push(write_json(
            &dir.join(ATTRACTORS_JSON),
            &json!({ "starts": spec.starts(), "attractors": a }),
        )?);
        written.extend(draw_attractors(dir, spec, run, a)?);
    }
    if let Some(o) = &run.orbits {
        use super::orbits::{bifurcations_json, orbits_json};
        written.push(write_json(
            &dir.join(super::ORBITS_JSON),
            &orbits_json(spec, o),
        )?);
        written.push(write_json(
            &dir.join(super::BIFURCATIONS_JSON),
            &bifurcations_json(spec, o),
        )?);
    }
    let files: Vec<String> = written
        .iter()
        .filter_map(|p| p.file_name().map(|f| f.to_string_lossy().into_owned()))
        .collect();
    written.push(write_json(
        &dir.join("map.json"),
        &map_manifest(spec, run, &files),
    )?);
    Ok(written)
}

/// `map_scene.toml`: the whole map scene after its `--set` overrides, so that the folder alone
/// reruns (`pendulum-atlas map map_scene.toml`) or explores the map.
fn write_scene_toml(path: &Path, spec: &MapSpec) -> Result<PathBuf, OutputError> {
    write_toml(
        path,
        &spec.source_table,
        "The scene of this map after every --set override.\n\
         `pendulum-atlas map map_scene.toml` runs the map again; `pendulum-atlas explore` reads it.",
    )
}

/// `grid.csv`: a row per instance, the axis values, every stored result ([`map_fields`]:
/// values as numbers, `nan` where not formed; codes by name), then `inferred`.
fn write_grid_csv(path: &Path, spec: &MapSpec, run: &MapRun) -> Result<PathBuf, OutputError> {
    let io = |e| OutputError::io(path, e);
    let mut w = AtomicFile::create(path)?;
    let mut header: Vec<&str> = spec.axes.iter().map(|a| a.key.as_str()).collect();
    header.extend(map_fields().map(|f| f.name));
    header.push(stem::INFERRED);
    writeln!(w, "{}", header.join(",")).map_err(io)?;
    for (k, r) in run.results.iter().enumerate() {
        let mut row: Vec<String> = spec.values_of(k).iter().map(|v| format!("{v}")).collect();
        row.extend(map_fields().map(|f| match f.dtype {
            Dtype::F64 | Dtype::U64 => fmt((f.get)(r)),
            Dtype::I8 | Dtype::U8 if f.formed_for(&spec.metrics) => f.code_name(r),
            Dtype::I8 | Dtype::U8 => "nan".into(),
        }));
        row.push(u8::from(run.inferred.get(k).copied().unwrap_or(false)).to_string());
        writeln!(w, "{}", row.join(",")).map_err(io)?;
    }
    w.commit()
}

/// One `.npy` per array of [`map_arrays`].
fn write_arrays(dir: &Path, spec: &MapSpec, run: &MapRun) -> Result<Vec<PathBuf>, OutputError> {
    map_arrays(spec, run)
        .into_iter()
        .map(|a| {
            let p = dir.join(format!("{}.npy", a.name));
            match &a.data {
                ArrayData::F64(v) => write_npy_f64(&p, &a.shape, v)?,
                ArrayData::I8(v) => write_npy_i8(&p, &a.shape, v)?,
                ArrayData::U8(v) => write_npy_u8(&p, &a.shape, v)?,
                ArrayData::I32(v) => write_npy_i32(&p, &a.shape, v)?,
            }
            Ok(p)
        })
        .collect()
}

fn fmt(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else {
        "nan".into()
    }
}

/// The bifurcation diagram of a 1-D map: the stroboscopic tail of every `ok` instance.
fn draw_bifurcation(
    path: &Path,
    spec: &MapSpec,
    run: &MapRun,
) -> Result<Option<PathBuf>, OutputError> {
    let axis = &spec.axes[0];
    let n = spec.bifurcation_samples as usize;
    let title = format!(
        "Bifurcation diagram: stroboscopic holder angle, last {} periods",
        spec.bifurcation_samples
    );
    let label = "holder angle α at the forcing phase (deg)";
    let Some(c) = &run.continuation else {
        let (xs, ys) = bifurcation_points(&axis.values, &run.results, &run.strobe_tail, n);
        if xs.is_empty() {
            return Ok(None);
        }
        return draw(path, |p| {
            scatter(p, &title, &axis.label(), label, &xs, &ys, false)
        })
        .map(Some);
    };
    let points: Vec<(String, Points)> = c
        .legs
        .iter()
        .map(|leg| {
            let name = format!("sweeping {}", leg.direction.name());
            let xy = bifurcation_points(&axis.values, &leg.results, &leg.strobe_tail, n);
            (name, xy)
        })
        .collect();
    if points.iter().all(|(_, (xs, _))| xs.is_empty()) {
        return Ok(None);
    }
    let groups: Vec<Series> = points
        .iter()
        .map(|(name, (x, y))| Series { name, x, y })
        .collect();
    let title = format!("{title}, by continuation");
    draw(path, |p| {
        scatter_groups(p, &title, &axis.label(), label, &groups)
    })
    .map(Some)
}

/// Points of a scatter plot: x values and y values.
type Points = (Vec<f64>, Vec<f64>);

/// The (axis value, α in degrees) points of a 1-D map's bifurcation diagram: the last `n`
/// stroboscopic samples of every `ok` cell.
fn bifurcation_points(
    values: &[f64],
    results: &[pendulum_atlas_core::reduce::InstanceResult],
    tails: &[Vec<f64>],
    n: usize,
) -> Points {
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    for (k, tail) in tails.iter().enumerate() {
        if results[k].status != Status::Ok {
            continue;
        }
        let tail = &tail[tail.len().saturating_sub(n)..];
        for &v in tail.iter().filter(|v| v.is_finite()) {
            xs.push(values[k]);
            ys.push(v.to_degrees());
        }
    }
    (xs, ys)
}

/// How a metric's picture is labelled and coloured.
#[derive(Debug, Clone)]
pub struct Style {
    /// Colour-bar (or legend) label, with units.
    pub label: String,
    /// The colour rule.
    pub palette: Palette,
}

/// The picture style of a metric: viridis over a fixed or the data's range, blue-white-red
/// about 0 for λ1, categories for the regime.
pub fn metric_style(m: Metric, spec: &MapSpec) -> Style {
    let seq = |label: String, range| Style {
        label,
        palette: Palette::Sequential(range),
    };
    match m {
        Metric::K => seq(m.label().into(), Some((0.0, 1.0))),
        Metric::R => seq(
            format!(
                "{} ({} convention)",
                m.label(),
                match spec.phase_convention {
                    pendulum_atlas_core::analysis::PhaseConvention::Standard => "standard",
                    pendulum_atlas_core::analysis::PhaseConvention::Paper => "paper",
                }
            ),
            Some((0.0, 1.0)),
        ),
        Metric::Period => seq(
            format!("period (forcing periods; grey: none ≤ {})", spec.period_max),
            Some((1.0, f64::from(spec.period_max.max(2)))),
        ),
        Metric::Lyapunov => Style {
            label: m.label().into(),
            palette: Palette::Diverging(None),
        },
        Metric::Regime => Style {
            label: m.label().into(),
            palette: regime_palette(spec.period_max),
        },
        _ => seq(m.label().into(), None),
    }
}

/// The value a regime picture shows for a cell of regime code `code` and period `period`:
/// the code, except a periodic cell's, which is 10 + its period (a shade per period).
pub fn regime_shade(code: f64, period: f64) -> f64 {
    if code == f64::from(Regime::Periodic.code()) && period > 0.0 {
        10.0 + period
    } else {
        code
    }
}

/// The regime legend: periodic cells in shades of blue by period (light for period 1, dark
/// for `period_max`), regular green, chaotic vermillion, undecided yellow (Okabe–Ito hues);
/// failed cells take every map's magenta.
fn regime_palette(period_max: u32) -> Palette {
    let pm = period_max.max(1);
    let mut c: Vec<Category> = (1..=pm)
        .map(|p| {
            let t = if pm == 1 {
                0.5
            } else {
                f64::from(p - 1) / f64::from(pm - 1)
            };
            let mix = |a: f64, b: f64| (a + t * (b - a)).round() as u8;
            Category {
                value: 10.0 + f64::from(p),
                label: format!("periodic, period {p}"),
                colour: RGBColor(mix(158.0, 8.0), mix(202.0, 48.0), mix(225.0, 107.0)),
            }
        })
        .collect();
    c.push(Category {
        value: f64::from(Regime::Regular.code()),
        label: "regular, no period".into(),
        colour: RGBColor(0, 158, 115),
    });
    c.push(Category {
        value: f64::from(Regime::Chaotic.code()),
        label: "chaotic".into(),
        colour: RGBColor(213, 94, 0),
    });
    c.push(Category {
        value: f64::from(Regime::Undecided.code()),
        label: "undecided".into(),
        colour: RGBColor(240, 228, 66),
    });
    Palette::Categorical(c)
}

/// The value drawn for cell `k`: period 0 ("no period found") is drawn as no-data grey, not
/// as a colour below 1; the regime as its shade ([`regime_shade`]).
fn drawn_value(run: &MapRun, m: Metric, k: usize) -> f64 {
    let r = &run.results[k];
    match m {
        Metric::Regime => regime_shade(f64::from(r.regime.code()), r.period),
        _ => shown_value(m, r.metric(m)),
    }
}

/// A stored value as pictures show it: period 0 ("no period found") becomes NaN (no-data
/// grey), every other value is itself.
pub fn shown_value(m: Metric, v: f64) -> f64 {
    if m == Metric::Period && v == 0.0 {
        f64::NAN
    } else {
        v
    }
}

/// The picture(s) of one metric: a heat map per 2-D slice, or a curve for a 1-D map.
fn draw_metric(
    dir: &Path,
    spec: &MapSpec,
    run: &MapRun,
    m: Metric,
) -> Result<Vec<PathBuf>, OutputError> {
    let style = metric_style(m, spec);
    draw_values(dir, spec, run, m.name(), &style, &|k| {
        drawn_value(run, m, k)
    })
}

/// The picture(s) of one value per cell, `stem.png` (or one per 2-D slice): a heat map, or a
/// curve for a 1-D map.
fn draw_values(
    dir: &Path,
    spec: &MapSpec,
    run: &MapRun,
    stem: &str,
    style: &Style,
    value: &dyn Fn(usize) -> f64,
) -> Result<Vec<PathBuf>, OutputError> {
    if spec.axes.len() == 1 {
        return Ok(draw_curve(dir, spec, run, stem, style, value)?
            .into_iter()
            .collect());
    }
    let nz = spec.shape().get(2).copied().unwrap_or(1);
    (0..nz)
        .map(|iz| draw_slice(dir, spec, run, (stem, style, value), iz))
        .collect()
}

/// The bifurcation curves of a plane drawn over its regime and period pictures
/// ([`crate::render::curve_style`]).
fn curve_overlays(run: &MapRun) -> Vec<Overlay> {
    let Some(o) = &run.orbits else {
        return Vec::new();
    };
    o.curves
        .iter()
        .map(|c| {
            let (colour, label) = crate::render::curve_style(c.kind);
            Overlay {
                points: c.points.iter().map(|p| (p[0], p[1])).collect(),
                colour,
                label: label.into(),
            }
        })
        .collect()
}

/// `attractors.png` (distinct attractors per cell, with several starts) and `attractor.png`
/// (the most likely attractor's label, a colour per family named in the legend; in a basin
/// picture, the attractor each start reached).
fn draw_attractors(
    dir: &Path,
    spec: &MapSpec,
    run: &MapRun,
    a: &pendulum_atlas_core::reduce::AttractorMap,
) -> Result<Vec<PathBuf>, OutputError> {
    let mut out = Vec::new();
    if a.starts > 1 {
        let count = Style {
            label: format!("distinct attractors among {} starts", a.starts),
            palette: Palette::Sequential(None),
        };
        out = draw_values(dir, spec, run, stem::ATTRACTORS, &count, &|k| {
            f64::from(a.count[k])
        })?;
    }
    let what = if a.starts > 1 {
        "most likely attractor"
    } else {
        "attractor reached"
    };
    let labels = attractor_style(what, &a.families);
    let shown = |k: usize| shown_label(a.most_likely[k]);
    out.extend(draw_values(
        dir,
        spec,
        run,
        stem::ATTRACTOR,
        &labels,
        &shown,
    )?);
    Ok(out)
}

/// The style of an attractor-label picture: `what` it shows, a colour per family.
pub fn attractor_style(
    what: &str,
    families: &[pendulum_atlas_core::reduce::attractors::Family],
) -> Style {
    Style {
        label: format!("{what} (Pp: period p; wells + α > 0, − α < 0, ± both)"),
        palette: attractor_palette(families),
    }
}

/// An attractor label as its picture draws it: no data for none (−1), the later labels in
/// the last colour.
pub fn shown_label(label: i32) -> f64 {
    if label < 0 {
        f64::NAN
    } else {
        f64::from(label.min(ATTRACTOR_COLOURS.len() as i32 - 1))
    }
}

/// Colours of attractor labels 0, 1, …; the last one stands for every later label.
const ATTRACTOR_COLOURS: [RGBColor; 9] = [
    RGBColor(0, 114, 178),
    RGBColor(213, 94, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(86, 180, 233),
    RGBColor(230, 159, 0),
    RGBColor(240, 228, 66),
    RGBColor(120, 94, 240),
    RGBColor(140, 140, 140),
];

/// One category per family, named by its fingerprint (`0: P1 +`); families
/// beyond the colours share the last one.
fn attractor_palette(families: &[pendulum_atlas_core::reduce::attractors::Family]) -> Palette {
    let last = ATTRACTOR_COLOURS.len() - 1;
    let mut c: Vec<Category> = families
        .iter()
        .take(last)
        .map(|f| Category {
            value: f.label as f64,
            label: format!("{}: {}", f.label, family_words(&f.fingerprint)),
            colour: ATTRACTOR_COLOURS[f.label],
        })
        .collect();
    if families.len() > last {
        c.push(Category {
            value: last as f64,
            label: format!("{last} and later labels"),
            colour: ATTRACTOR_COLOURS[last],
        });
    }
    Palette::Categorical(c)
}

/// A family in a few characters: its regime or period and its wells (`P2 +`: period 2 in the
/// α > 0 well).
pub fn family_words(f: &pendulum_atlas_core::reduce::Fingerprint) -> String {
    use pendulum_atlas_core::reduce::attractors::Wells;
    let wells = match f.wells {
        Wells::Positive => "+",
        Wells::Negative => "−",
        Wells::Both => "±",
    };
    match f.regime {
        Regime::Periodic => format!("P{} {wells}", f.period),
        Regime::Regular => format!("regular {wells}"),
        Regime::Chaotic => format!("chaotic {wells}"),
        Regime::Undecided | Regime::Failed => format!("undecided {wells}"),
    }
}

/// The curve of a 1-D map; failed points are left out (and counted in the title).
fn draw_curve(
    dir: &Path,
    spec: &MapSpec,
    run: &MapRun,
    stem: &str,
    style: &Style,
    value: &dyn Fn(usize) -> f64,
) -> Result<Option<PathBuf>, OutputError> {
    let label = style.label.clone();
    let axis = &spec.axes[0];
    let bad = |k: usize| run.results[k].status != Status::Ok;
    let (xs, ys): (Vec<f64>, Vec<f64>) = (0..axis.values.len())
        .filter(|&k| !bad(k) && value(k).is_finite())
        .map(|k| (axis.values[k], value(k)))
        .unzip();
    if xs.is_empty() {
        return Ok(None);
    }
    let diverged = (0..axis.values.len()).filter(|&k| bad(k)).count();
    let title = if diverged > 0 {
        format!("{label} ({diverged} diverged points omitted)")
    } else {
        label.clone()
    };
    let p = dir.join(format!("{stem}.png"));
    draw(&p, |t| {
        scatter(t, &title, &axis.label(), &label, &xs, &ys, xs.len() > 1)
    })
    .map(Some)
}

/// The heat map of slice `iz` of a 2-D or 3-D map; failed cells are marked.
fn draw_slice(
    dir: &Path,
    spec: &MapSpec,
    run: &MapRun,
    (stem, style, value): (&str, &Style, &dyn Fn(usize) -> f64),
    iz: usize,
) -> Result<PathBuf, OutputError> {
    let Style { label, palette } = style.clone();
    let shape = spec.shape();
    let (nx, ny) = (shape[0], shape[1]);
    let nz = shape.get(2).copied().unwrap_or(1);
    // heatmap wants rows of x for each y: cell (ix, iy) of slice iz.
    let cells = (0..ny).flat_map(|iy| (0..nx).map(move |ix| (ix * ny + iy) * nz + iz));
    let vals: Vec<f64> = cells.clone().map(value).collect();
    let invalid: Vec<bool> = cells
        .clone()
        .map(|k| run.results[k].status != Status::Ok)
        .collect();
    let inferred: Vec<bool> = cells
        .clone()
        .map(|k| run.inferred.get(k).copied().unwrap_or(false))
        .collect();
    let verdict_picture = [Metric::Regime.name(), Metric::Period.name()].contains(&stem);
    let (sensitive, transient) = match (&run.transients, verdict_picture) {
        (Some(t), true) => cells
            .map(|k| {
                (
                    t.start_decides_at(k),
                    t.after_transient.get(k).copied().unwrap_or(false),
                )
            })
            .unzip(),
        _ => (Vec::new(), Vec::new()),
    };
    let (p, title) = if nz == 1 {
        (dir.join(format!("{stem}.png")), label.clone())
    } else {
        let a = &spec.axes[2];
        (
            dir.join(format!("{stem}_slice{iz:03}.png")),
            format!("{label} at {} = {}", a.key, a.values[iz]),
        )
    };
    let (xl, yl) = (spec.axes[0].label(), spec.axes[1].label());
    let x = Axis {
        label: &xl,
        values: &spec.axes[0].values,
    };
    let y = Axis {
        label: &yl,
        values: &spec.axes[1].values,
    };
    let lines = if nz == 1 && verdict_picture {
        curve_overlays(run)
    } else {
        Vec::new()
    };
    draw(&p, |t| {
        let marks = CellMarks {
            invalid: &invalid,
            inferred: &inferred,
            lines: &lines,
            sensitive: &sensitive,
            transient: &transient,
        };
        let scales = [spec.axes[0].scale, spec.axes[1].scale];
        heatmap_scaled(t, &title, &x, &y, scales, &vals, &label, &marks, &palette)
    })
}
