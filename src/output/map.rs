//! The files of a map: `map.json`, `grid.csv`, one `.npy` per metric shaped like the grid,
//! a PNG per metric (per 2-D slice of a 3-D grid), and `bifurcation.png`.

use crate::config::{MapSpec, Metric};
use crate::map::MapRun;
use crate::model::Status;
use crate::output::npy::{write_npy_f64, write_npy_u8};
use crate::render::{Axis, heatmap, scatter};
use anyhow::{Context, Result};
use serde_json::json;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The arrays written per metric: (file stem, metric, accessor).
type Column = (
    &'static str,
    Metric,
    fn(&crate::reduce::InstanceResult) -> f64,
);

const COLUMNS: [Column; 8] = [
    ("K", Metric::K, |r| r.k),
    ("R", Metric::R, |r| r.r),
    ("period", Metric::Period, |r| r.period),
    ("hops", Metric::Hops, |r| r.hops),
    ("impacts_per_s", Metric::ImpactsPerS, |r| r.impacts_per_s),
    ("alpha_min_rad", Metric::AlphaRange, |r| r.alpha_min_rad),
    ("alpha_max_rad", Metric::AlphaRange, |r| r.alpha_max_rad),
    ("power_w", Metric::Power, |r| r.power_w),
];

/// Write every file of a map into `dir` (created if needed); returns the paths written.
pub fn write_map(dir: &Path, spec: &MapSpec, run: &MapRun) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut written = Vec::new();
    let shape = spec.shape();
    let n = spec.instances();

    // grid.csv: a row per instance.
    let csv_path = dir.join("grid.csv");
    let mut w = std::io::BufWriter::new(
        std::fs::File::create(&csv_path)
            .with_context(|| format!("creating {}", csv_path.display()))?,
    );
    let mut header: Vec<String> = spec.axes.iter().map(|a| a.key.clone()).collect();
    header.extend(
        [
            "K",
            "R",
            "period",
            "hops",
            "impacts_per_s",
            "alpha_min_rad",
            "alpha_max_rad",
            "power_w",
            "status",
        ]
        .map(String::from),
    );
    writeln!(w, "{}", header.join(","))?;
    for (k, r) in run.results.iter().enumerate() {
        let mut row: Vec<String> = spec.values_of(k).iter().map(|v| format!("{v}")).collect();
        for (_, _, get) in COLUMNS {
            row.push(fmt(get(r)));
        }
        row.push(r.status.as_str().to_string());
        writeln!(w, "{}", row.join(","))?;
    }
    w.flush()?;
    written.push(csv_path);

    // One .npy per metric array, the axes, and the status codes.
    for (stem, metric, get) in COLUMNS {
        if !spec.wants(metric) {
            continue;
        }
        let data: Vec<f64> = run.results.iter().map(get).collect();
        let p = dir.join(format!("{stem}.npy"));
        write_npy_f64(&p, &shape, &data)?;
        written.push(p);
    }
    let status: Vec<u8> = run.results.iter().map(|r| r.status.code()).collect();
    let p = dir.join("status.npy");
    write_npy_u8(&p, &shape, &status)?;
    written.push(p);
    for (i, a) in spec.axes.iter().enumerate() {
        let p = dir.join(format!("axis{i}.npy"));
        write_npy_f64(&p, &[a.values.len()], &a.values)?;
        written.push(p);
    }

    // Pictures.
    for m in &spec.metrics {
        written.extend(draw_metric(dir, spec, run, *m)?);
    }
    if spec.bifurcation && !run.strobe_tail.is_empty() {
        let axis = &spec.axes[0];
        let (mut xs, mut ys) = (Vec::new(), Vec::new());
        for (k, tail) in run.strobe_tail.iter().enumerate() {
            if run.results[k].status != Status::Ok {
                continue;
            }
            for &v in tail.iter().filter(|v| v.is_finite()) {
                xs.push(axis.values[k]);
                ys.push(v.to_degrees());
            }
        }
        let p = dir.join("bifurcation.png");
        if !xs.is_empty() {
            scatter(
                &p,
                &format!(
                    "Bifurcation diagram: stroboscopic holder angle, last {} periods",
                    spec.bifurcation_samples
                ),
                &axis.label(),
                "holder angle α at the forcing phase (deg)",
                &xs,
                &ys,
                false,
            )?;
            written.push(p);
        }
    }

    // map.json last, so that its presence means the map is complete.
    let counts = |s: Status| run.results.iter().filter(|r| r.status == s).count();
    let files: Vec<String> = written
        .iter()
        .filter_map(|p| p.file_name().map(|f| f.to_string_lossy().into_owned()))
        .collect();
    let doc = json!({
        "axes": spec.axes,
        "shape": shape,
        "instances": n,
        "order": "C order over the axes as listed (last axis varies fastest); .npy arrays have this shape",
        "metrics": spec.metrics,
        "backend": run.engine.kind,
        "backend_reason": run.engine.reason,
        "adapter": run.engine.device,
        "precision": run.engine.precision,
        "segments": run.plan.segments,
        "dt_s": {"min": run.plan.dt_range_s.0, "max": run.plan.dt_range_s.1},
        "steps": {
            "total_instance_steps": run.plan.total_steps,
            "integrated_instance_steps": run.results.iter().map(|r| r.steps).sum::<u64>(),
            "stopped_early": run.stopped_early,
            "per_instance_max": run.plan.instances.iter().map(|p| p.total_steps()).max(),
            "dispatches": run.dispatches,
        },
        "timings_s": run.timings,
        "throughput": {
            "instance_steps_per_s": run.instance_steps_per_s(),
            "segment_steps_per_s": run.segment_steps_per_s(),
        },
        "status_counts": Status::ALL
            .iter()
            .map(|&s| (s.as_str().to_string(), json!(counts(s))))
            .collect::<serde_json::Map<String, serde_json::Value>>(),
        "sampling": {
            "samples_per_period": spec.samples_per_period,
            "strobe_phase": spec.strobe_phase,
            "r_max_samples": spec.r_max_samples,
            "phase_convention": spec.phase_convention,
            "zero_one": {"method": "correlation", "n_c": spec.k_n_c, "seed": spec.k_seed},
            "period": {"max": spec.period_max, "window": spec.period_window, "tol_rad": spec.period_tol_rad},
        },
        "warnings": run.plan.warnings,
        "scene": spec.scene,
        "files": files,
    });
    let p = dir.join("map.json");
    std::fs::write(&p, serde_json::to_string_pretty(&doc)?)
        .with_context(|| format!("writing {}", p.display()))?;
    written.push(p);
    Ok(written)
}

fn fmt(v: f64) -> String {
    if v.is_finite() {
        format!("{v}")
    } else {
        "nan".into()
    }
}

/// Colour-bar label and fixed range of a metric's picture.
fn metric_style(m: Metric, spec: &MapSpec) -> (String, Option<(f64, f64)>) {
    match m {
        Metric::K => ("0–1 test K (0 regular, 1 chaotic)".into(), Some((0.0, 1.0))),
        Metric::R => (
            format!(
                "phase synchronisation R ({} convention)",
                match spec.phase_convention {
                    crate::analysis::PhaseConvention::Standard => "standard",
                    crate::analysis::PhaseConvention::Paper => "paper",
                }
            ),
            Some((0.0, 1.0)),
        ),
        Metric::Period => (
            format!("period (forcing periods; grey: none ≤ {})", spec.period_max),
            Some((1.0, f64::from(spec.period_max.max(2)))),
        ),
        Metric::Hops => ("hops between wells".into(), None),
        Metric::ImpactsPerS => ("impacts per second (1/s)".into(), None),
        Metric::AlphaRange => ("holder angle range max−min (rad)".into(), None),
        Metric::Power => ("mean harvested power (W)".into(), None),
    }
}

/// The picture(s) of one metric: a heat map per 2-D slice, or a curve for a 1-D map.
fn draw_metric(dir: &Path, spec: &MapSpec, run: &MapRun, m: Metric) -> Result<Vec<PathBuf>> {
    let (label, range) = metric_style(m, spec);
    let shape = spec.shape();
    // Period 0 means "no period found": drawn as no-data grey, not as a colour below 1.
    let value = |k: usize| {
        let v = run.results[k].metric(m);
        if m == Metric::Period && v == 0.0 {
            f64::NAN
        } else {
            v
        }
    };
    let bad = |k: usize| run.results[k].status != Status::Ok;
    let mut out = Vec::new();
    match shape.len() {
        1 => {
            let axis = &spec.axes[0];
            let (xs, ys): (Vec<f64>, Vec<f64>) = (0..shape[0])
                .filter(|&k| !bad(k) && value(k).is_finite())
                .map(|k| (axis.values[k], value(k)))
                .unzip();
            if xs.is_empty() {
                return Ok(out);
            }
            let p = dir.join(format!("{}.png", m.name()));
            let diverged = (0..shape[0]).filter(|&k| bad(k)).count();
            let title = if diverged > 0 {
                format!("{label} ({diverged} diverged points omitted)")
            } else {
                label.clone()
            };
            scatter(&p, &title, &axis.label(), &label, &xs, &ys, xs.len() > 1)?;
            out.push(p);
        }
        _ => {
            let (nx, ny) = (shape[0], shape[1]);
            let nz = shape.get(2).copied().unwrap_or(1);
            let (xl, yl) = (spec.axes[0].label(), spec.axes[1].label());
            for iz in 0..nz {
                // heatmap wants rows of x for each y: cell (ix, iy) of slice iz.
                let k_of = |ix: usize, iy: usize| (ix * ny + iy) * nz + iz;
                let mut vals = Vec::with_capacity(nx * ny);
                let mut invalid = Vec::with_capacity(nx * ny);
                for iy in 0..ny {
                    for ix in 0..nx {
                        let k = k_of(ix, iy);
                        vals.push(value(k));
                        invalid.push(bad(k));
                    }
                }
                let (p, title) = if nz == 1 {
                    (dir.join(format!("{}.png", m.name())), label.clone())
                } else {
                    let a = &spec.axes[2];
                    (
                        dir.join(format!("{}_{}{iz:03}.png", m.name(), "slice")),
                        format!("{label} at {} = {}", a.key, a.values[iz]),
                    )
                };
                heatmap(
                    &p,
                    &title,
                    &Axis {
                        label: &xl,
                        values: &spec.axes[0].values,
                    },
                    &Axis {
                        label: &yl,
                        values: &spec.axes[1].values,
                    },
                    &vals,
                    &label,
                    &invalid,
                    range,
                )?;
                out.push(p);
            }
        }
    }
    Ok(out)
}
