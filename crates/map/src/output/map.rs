//! The files of a map: `map.json`, `grid.csv`, `map_scene.toml` (the map's scene after its
//! overrides), one `.npy` per metric shaped like the grid, a PNG per metric (per 2-D slice of
//! a 3-D grid), and `bifurcation.png`.

use super::manifest::{ManifestAxis, MapManifest, StepRange};
use crate::map::MapRun;
use crate::map::continuation::ContinuationRun;
use pendulum_atlas_core::config::{MapSpec, Metric};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_core::reduce::{InstanceResult, Regime};
use pendulum_atlas_core::schema::{Dtype, FIELDS, Field};
use serde_json::{Value, json};

// The writer of the whole folder and its pictures: behind the `pictures` feature, which the
// Python extension leaves out (it returns arrays and the manifest, never a folder).
#[cfg(feature = "pictures")]
mod folder;
mod orbits;
mod transients;
#[cfg(feature = "pictures")]
pub use folder::{
    Style, attractor_style, family_words, metric_style, regime_shade, shown_label, shown_value,
    write_map,
};
pub use orbits::bifurcations_json;

/// The results a map folder stores (the result schema's rows with `in_map`), in `grid.csv`
/// order: the values, then the codes (`regime`, `status`).
pub(crate) fn map_fields() -> impl Iterator<Item = &'static Field> {
    FIELDS.iter().filter(|f| f.in_map)
}

/// The stored results that are values (`float64` arrays), with their units.
pub fn value_fields() -> impl Iterator<Item = &'static Field> {
    map_fields().filter(|f| f.dtype == Dtype::F64)
}

/// One result of every instance of `results` as an array of its schema type.
fn field_data(f: &Field, results: &[InstanceResult]) -> ArrayData {
    let values = results.iter().map(|r| (f.get)(r));
    match f.dtype {
        Dtype::F64 | Dtype::U64 => ArrayData::F64(values.collect()),
        Dtype::I8 => ArrayData::I8(values.map(|v| v as i8).collect()),
        Dtype::U8 => ArrayData::U8(values.map(|v| v as u8).collect()),
    }
}

/// The values of one stored array, in its own type.
#[derive(Debug, Clone, PartialEq)]
pub enum ArrayData {
    /// A metric (`float64`).
    F64(Vec<f64>),
    /// Regime codes (`int8`).
    I8(Vec<i8>),
    /// Status codes and flags (`uint8`).
    U8(Vec<u8>),
    /// Attractor labels and counts (`int32`; −1: none).
    I32(Vec<i32>),
}

/// The stems of a map's arrays besides the results (`map_fields`) and the axes
/// (`axis0`, ...): every name [`map_arrays`] gives, and what the folder check recognises as a
/// map's own where no `map.json` lists the files (a killed map), so that a new array named
/// here is known to both. The second direction of a continuation adds `_down` to the
/// results' stems; `hysteresis` and the attractors' stems are also pictures.
pub mod stem {
    /// Refinement's inferred flags.
    pub(crate) const INFERRED: &str = "inferred";
    /// Distinct attractors per cell.
    pub(crate) const ATTRACTORS: &str = "attractors";
    /// The most likely attractor's label.
    pub(crate) const ATTRACTOR: &str = "attractor";
    /// Share of failed starts.
    pub(crate) const FAILED_FRACTION: &str = "failed_fraction";
    /// The representative start.
    pub(crate) const START: &str = "start";
    /// The first start of each attractor.
    pub(crate) const ATTRACTOR_START: &str = "attractor_start";
    /// Basin fraction per attractor.
    pub(crate) const BASIN_FRACTION: &str = "basin_fraction";
    /// Where up and down ended on different attractors.
    pub(crate) const HYSTERESIS: &str = "hysteresis";
    /// What shooting from the cell's end state gave.
    pub(crate) const ORBIT_STATUS: &str = "orbit_status";
    /// The cell's orbit's least period.
    pub(crate) const ORBIT_PERIOD: &str = "orbit_period";
    /// Its residual.
    pub(crate) const ORBIT_RESIDUAL: &str = "orbit_residual";
    /// Its largest multiplier modulus.
    pub(crate) const FLOQUET_MAX: &str = "floquet_max";
    /// Its real multiplier nearest −1.
    pub(crate) const FLOQUET_MINUS1: &str = "floquet_minus1";
    /// Its real multiplier nearest +1.
    pub(crate) const FLOQUET_PLUS1: &str = "floquet_plus1";
    /// Its holder-angle range.
    pub(crate) const ORBIT_EXTENT: &str = "orbit_extent_rad";
    /// Its family.
    pub(crate) const ORBIT_FAMILY: &str = "orbit_family";
    /// Orbits known at the cell.
    pub(crate) const ORBITS_KNOWN: &str = "orbits_known";
    /// Of those, the stable ones.
    pub(crate) const ORBITS_STABLE: &str = "orbits_stable";
    /// The chaotic transient's mean lifetime from the nudged copies.
    pub(crate) const TRANSIENT_S: &str = "transient_s";
    /// Its standard error.
    pub(crate) const TRANSIENT_SE_S: &str = "transient_se_s";
    /// The share of nudged copies that disagree with the cell.
    pub(crate) const START_SENSITIVITY: &str = "start_sensitivity";
    /// Every one of them.
    pub const ALL: [&str; 21] = [
        INFERRED,
        ATTRACTORS,
        ATTRACTOR,
        FAILED_FRACTION,
        START,
        ATTRACTOR_START,
        BASIN_FRACTION,
        HYSTERESIS,
        ORBIT_STATUS,
        ORBIT_PERIOD,
        ORBIT_RESIDUAL,
        FLOQUET_MAX,
        FLOQUET_MINUS1,
        FLOQUET_PLUS1,
        ORBIT_EXTENT,
        ORBIT_FAMILY,
        ORBITS_KNOWN,
        ORBITS_STABLE,
        TRANSIENT_S,
        TRANSIENT_SE_S,
        START_SENSITIVITY,
    ];
}

/// The file of a map's attractor table.
pub(crate) const ATTRACTORS_JSON: &str = "attractors.json";
/// The file of a map's orbits at every cell.
pub(crate) const ORBITS_JSON: &str = "orbits.json";
/// The file of a map's bifurcation curves.
pub(crate) const BIFURCATIONS_JSON: &str = "bifurcations.json";
/// The JSON files a map may write besides `map.json`.
pub(crate) const MAP_JSONS: [&str; 3] = [ATTRACTORS_JSON, ORBITS_JSON, BIFURCATIONS_JSON];

/// One array of a map: its name (the `.npy` file's stem), shape and values (C order).
#[derive(Debug, Clone, PartialEq)]
pub struct MapArray {
    /// File stem, e.g. `K` or `axis0`.
    pub name: String,
    /// Shape (the grid's, or an axis's length).
    pub shape: Vec<usize>,
    /// Values.
    pub data: ArrayData,
}

/// Every array of a map as the `.npy` files hold them: the requested metrics, `regime`,
/// `status`, `inferred` (refined maps) and the axes. The files and the Python package both
/// take them from here.
pub fn map_arrays(spec: &MapSpec, run: &MapRun) -> Vec<MapArray> {
    let shape = spec.shape();
    let grid = |name: &str, data| MapArray {
        name: name.to_string(),
        shape: shape.clone(),
        data,
    };
    let mut arrays: Vec<MapArray> = map_fields()
        .filter(|f| f.formed_for(&spec.metrics))
        .map(|f| grid(f.name, field_data(f, &run.results)))
        .collect();
    if !run.inferred.is_empty() {
        let flags = run.inferred.iter().map(|&i| u8::from(i)).collect();
        arrays.push(grid(stem::INFERRED, ArrayData::U8(flags)));
    }
    if let Some(a) = &run.attractors {
        let count = a.count.iter().map(|&n| i32::from(n)).collect();
        arrays.push(grid(stem::ATTRACTORS, ArrayData::I32(count)));
        arrays.push(grid(stem::ATTRACTOR, ArrayData::I32(a.most_likely.clone())));
        arrays.push(grid(
            stem::FAILED_FRACTION,
            ArrayData::F64(a.failed.clone()),
        ));
        // Arrays with one value per (label, cell): shape (labels, *grid).
        let per_label = |name: &str, data| MapArray {
            name: name.to_string(),
            shape: std::iter::once(a.families.len())
                .chain(shape.iter().copied())
                .collect(),
            data,
        };
        if a.starts > 1 {
            let start = a.representative.iter().map(|&s| s as i32).collect();
            arrays.push(grid(stem::START, ArrayData::I32(start)));
            let firsts = ArrayData::I32(a.first_starts().concat());
            arrays.push(per_label(stem::ATTRACTOR_START, firsts));
        }
        arrays.push(per_label(
            stem::BASIN_FRACTION,
            ArrayData::F64(a.fractions.concat()),
        ));
    }
    if let Some(c) = &run.continuation {
        arrays.extend(continuation_arrays(spec, c));
    }
    if let Some(t) = &run.transients {
        arrays.extend(transients::transient_arrays(spec, t));
    }
    if let Some(o) = &run.orbits {
        arrays.extend(orbits::orbit_arrays(spec, o));
    }
    for (i, a) in spec.axes.iter().enumerate() {
        arrays.push(MapArray {
            name: format!("axis{i}"),
            shape: vec![a.values.len()],
            data: ArrayData::F64(a.values.clone()),
        });
    }
    arrays
}

/// The arrays of a map run both ways: the second direction's metrics, regime and status
/// (`K_down.npy`, ...), and `hysteresis` (1 where up and down ended on different attractors).
fn continuation_arrays(spec: &MapSpec, c: &ContinuationRun) -> Vec<MapArray> {
    let grid = |name: String, data| MapArray {
        name,
        shape: spec.shape(),
        data,
    };
    let mut arrays = Vec::new();
    for leg in &c.legs[1..] {
        let suffix = leg.direction.name();
        for f in map_fields().filter(|f| f.formed_for(&spec.metrics)) {
            arrays.push(grid(
                format!("{}_{suffix}", f.name),
                field_data(f, &leg.results),
            ));
        }
    }
    if let Some(h) = &c.hysteresis {
        let flags = ArrayData::U8(h.differs.iter().map(|&d| u8::from(d)).collect());
        arrays.push(grid(stem::HYSTERESIS.into(), flags));
    }
    arrays
}

/// `map.json`: what the map is, how it ran, and which files belong to it (`files`; the
/// Python package passes none, its arrays stay in memory).
pub fn map_manifest(spec: &MapSpec, run: &MapRun, files: &[String]) -> MapManifest {
    let counts = |s: Status| run.results.iter().filter(|r| r.status == s).count();
    MapManifest {
        axes: spec
            .axes
            .iter()
            .map(|a| ManifestAxis {
                key: a.key.clone(),
                values: a.values.clone(),
                scale: word(&a.scale),
                unit: pendulum_atlas_core::config::key_unit(&a.key).map(String::from),
                label: a.label(),
            })
            .collect(),
        units: value_fields()
            .map(|f| (f.name.to_string(), f.unit.to_string()))
            .collect(),
        descriptions: map_fields()
            .map(|f| (f.name.to_string(), f.description.to_string()))
            .collect(),
        shape: spec.shape(),
        instances: spec.instances(),
        order: "C order over the axes as listed (last axis varies fastest); .npy arrays have this shape".into(),
        mode: spec.mode.name().into(),
        metrics: spec.metrics.iter().map(word).collect(),
        backend: word(&run.engine.kind),
        backend_reason: run.engine.reason.clone(),
        adapter: run.engine.device.clone(),
        precision: word(&run.engine.precision),
        segments: run.plan.segments,
        method: word(&run.plan.method),
        method_reason: run.plan.method_reason.clone(),
        imex_matrix_sets: run.plan.imex_matrix_sets,
        method_steps_of_base_scene: json!(
            pendulum_atlas_core::engine::method::MethodSteps::of_scene(&spec.scene).ok()
        ),
        damping_of_base_scene: json!(spec.scene.damping_report().ok()),
        dt_s: StepRange {
            min: run.plan.dt_range_s.0,
            max: run.plan.dt_range_s.1,
        },
        steps: steps_json(run),
        timings_s: json!(run.timings),
        wall_share: json!(run.timings.wall_share()),
        throughput: json!({
            "instance_steps_per_s": run.instance_steps_per_s(),
            "segment_steps_per_s": run.segment_steps_per_s(),
        }),
        status_counts: Status::ALL
            .iter()
            .map(|&s| (s.as_str().to_string(), counts(s)))
            .collect(),
        status_codes: Status::ALL
            .iter()
            .map(|&s| (s.as_str().to_string(), s.code()))
            .collect(),
        regime: regime_json(spec, run),
        lyapunov: lyapunov_json(spec, run),
        sampling: json!({
            "samples_per_period": spec.samples_per_period,
            "strobe_phase": spec.strobe_phase,
            "r_max_samples": spec.r_max_samples,
            "phase_convention": spec.phase_convention,
            "zero_one": {"method": "correlation", "n_c": spec.k_n_c, "seed": spec.k_seed},
            "period": {"max": spec.period_max, "window": spec.period_window, "tol_rad": spec.period_tol_rad},
        }),
        refine: json!(run.refine),
        settle: json!(run.settle),
        attractors: run.attractors.as_ref().map_or(Value::Null, |a| json!({
            "starts": spec.starts(),
            "labels": a.families.len(),
            "rule": a.rule,
            "arrays": {
                "attractors": "distinct attractors per cell (failed runs not counted)",
                "attractor": "the label most starts reached (-1: every start failed)",
                "basin_fraction": "share of the cell's starts per label, shape (labels, *grid)",
                "attractor_start": "with several starts: the first start of the cell that reached each label, shape (labels, *grid), -1 where none did",
                "failed_fraction": "share of the cell's starts that failed",
            },
            "metric_arrays": "each cell's metric arrays hold its representative run: the first start that reached its most likely attractor",
            "runs": run.runs,
            "details": "attractors.json",
        })),
        continuation: run
            .continuation
            .as_ref()
            .map_or(Value::Null, |c| continuation_json(spec, c)),
        transients: run
            .transients
            .as_ref()
            .map_or(Value::Null, transients::transients_summary),
        orbits: run
            .orbits
            .as_ref()
            .map_or(Value::Null, |o| orbits::orbits_summary(o, run.timings.orbits_s)),
        warnings: spec
            .notes
            .iter()
            .chain(&run.plan.warnings)
            .cloned()
            .collect(),
        shards: json!(run.shards),
        scene: json!(spec.scene),
        files: files.to_vec(),
    }
}

/// A unit enum's serialised name (`"cpu"`, `"f64"`, `"rk4"`, `"linear"`, a metric's name).
fn word(v: &impl serde::Serialize) -> String {
    match serde_json::to_value(v) {
        Ok(Value::String(s)) => s,
        Ok(other) => other.to_string(),
        Err(e) => format!("<{e}>"),
    }
}

/// `map.json`'s `continuation`: the axis, the directions, restarts, and where up and down
/// differ.
fn continuation_json(spec: &MapSpec, c: &ContinuationRun) -> serde_json::Value {
    let other: Vec<&str> = spec
        .axes
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != c.spec.axis)
        .map(|(_, a)| a.key.as_str())
        .collect();
    json!({
        "axis": c.spec.key,
        "sweep": c.spec.sweep,
        "directions": c.legs,
        "metric_arrays": format!(
            "the metric arrays hold the {} direction{}",
            c.legs[0].direction.name(),
            if c.legs.len() > 1 { "; NAME_down.npy the other" } else { "" }
        ),
        "hysteresis": c.hysteresis.as_ref().map(|h| json!({
            "cells": h.cells,
            "rule": h.rule,
            "band_line_keys": other,
            "bands": h.bands,
            "array": "hysteresis.npy: 1 where up and down ended on different attractors (or one failed)",
        })),
    })
}

/// `map.json`'s `steps`: what the grid would take in full, what was integrated (in base steps
/// with adaptive steps, and the sub-steps tried within them, `null` at fixed steps), and what
/// the early stop and refinement saved.
fn steps_json(run: &MapRun) -> serde_json::Value {
    let inferred = |k: usize| run.inferred.get(k).copied().unwrap_or(false);
    let planned = |k: usize| run.plan.instances[k].total_steps();
    let integrated: u64 = run.results.iter().map(|r| r.steps).sum();
    let by_refinement: u64 = (0..run.results.len())
        .filter(|&k| inferred(k))
        .map(planned)
        .sum();
    let by_early_stop: u64 = (0..run.results.len())
        .filter(|&k| !inferred(k) && run.results[k].status == Status::Ok)
        .map(|k| planned(k) - run.results[k].steps.min(planned(k)))
        .sum();
    json!({
        "total_instance_steps": run.plan.total_steps,
        "integrated_instance_steps": integrated,
        "saved_instance_steps": run.plan.total_steps.saturating_sub(integrated),
        "saved_by_early_stop": by_early_stop,
        "saved_by_refinement": by_refinement,
        "stopped_early": run.stopped_early,
        "inferred": run.inferred.iter().filter(|&&i| i).count(),
        "per_instance_max": run.plan.instances.iter().map(|p| p.total_steps()).max(),
        "dispatches": run.dispatches,
        "sub_steps_tried": run.sub_steps,
    })
}

/// `map.json`'s `regime`: the cells of each verdict and the rule's thresholds (`null` when
/// the regime was not asked for).
fn regime_json(spec: &MapSpec, run: &MapRun) -> serde_json::Value {
    use pendulum_atlas_core::reduce::regime::{REGIME_FLAT_PER_PERIOD, REGIME_K_CHAOS, REGIME_Z};
    if !spec.wants(Metric::Regime) {
        return serde_json::Value::Null;
    }
    let counts: serde_json::Map<String, serde_json::Value> = Regime::ALL
        .iter()
        .map(|&g| {
            let n = run.results.iter().filter(|r| r.regime == g).count();
            (g.name().to_string(), json!(n))
        })
        .collect();
    json!({
        "counts": counts,
        "codes": Regime::ALL.iter().map(|g| (g.name().to_string(), json!(g.code()))).collect::<serde_json::Map<_, _>>(),
        "rule": {
            "z": REGIME_Z,
            "flat_per_period": REGIME_FLAT_PER_PERIOD,
            "k_chaos": REGIME_K_CHAOS,
            "k_firm_samples": pendulum_atlas_core::analysis::ZERO_ONE_COMFORTABLE_SAMPLES,
            "doc": "docs/analysis.md, section 10",
        },
        "confidence": crate::map::confidence::summary(run),
    })
}

/// `map.json`'s `lyapunov`: how the twins ran (`null` without λ1).
fn lyapunov_json(spec: &MapSpec, run: &MapRun) -> serde_json::Value {
    if !spec.wants(Metric::Lyapunov) {
        return serde_json::Value::Null;
    }
    let windows = run
        .plan
        .instances
        .iter()
        .filter_map(|p| p.twin.map(|t| t.window));
    json!({
        "separation": run.plan.twin_separation(run.engine.precision).ok().flatten(),
        "precision": run.engine.precision,
        "window_s": spec.lyapunov.window_s,
        "window_periods": {"min": windows.clone().min(), "max": windows.max()},
        "align_periods": spec.lyapunov.align_periods,
        "blocks": pendulum_atlas_core::reduce::lyapunov::LYAPUNOV_BLOCKS,
        "renormalised": "every forcing period, at the stroboscopic phase",
        "unit": "1/s",
    })
}
