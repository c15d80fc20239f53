//! One cell of an ensemble as a plain scene that runs exactly what the ensemble ran: the
//! integration method, the step control and the step the plan took pinned (at fixed steps
//! `integration.dt_s = 1/(f·spp)`; at adaptive steps that base step,
//! `integration.base_step_s`, with the same tolerances), and rows at a whole number of steps
//! so that the record's sample rate is exact. The explorer's "run this cell" and Python's
//! `Scene.cell` both come here.
//!
//! A map cell's scene also carries a `[cell]` section ([`cell_section`]: the map's keys that
//! shape a cell's values), so that `simulate` (and `pa.simulate`) reports beside its
//! record's analysis the cell's values as the map computes them ([`read_cell_scene`],
//! [`rerun_cell`]): a map of that cell alone, with the same plan, loop and reductions, so the
//! same numbers, bit for bit, as a map run on the CPU engine in f64 (`docs/guide/maps.md`,
//! "A cell again").

use pendulum_atlas_core::config::{
    ConfigError, ExcitationKind, MapMode, MapSpec, Scene, StepControl, apply_override,
    map_from_toml, parse_toml, set_key,
};
use pendulum_atlas_core::engine::{
    Engine, EngineError, EnsembleOptions, EnsemblePlan, Precision, Progress,
};
use pendulum_atlas_core::reduce::InstanceResult;
use pendulum_atlas_core::schema::{FIELDS, Stage};
use pendulum_atlas_core::text::num;
use toml::{Table, Value};

/// The section of a cell's scene that holds the map's settings of its values.
pub const CELL_SECTION: &str = "cell";

/// The `[map]` keys that shape one cell's values, kept in a cell's `[cell]`: what the
/// cell's run records and how it is reduced (metrics, the strobe, R's series, the 0–1 test's
/// c values, the period test, the early stop, λ1's twin). The others are the grid's (its
/// axes, starts, continuation, refinement, the bifurcation picture) and are left out; a
/// settling map's cell carries its settling time and whether it ran on ([`cell_section`]).
pub(crate) const CELL_MAP_KEYS: [&str; 15] = [
    "metrics",
    "samples_per_period",
    "strobe_phase",
    "r_max_samples",
    "phase_convention",
    "k_n_c",
    "k_seed",
    "period_max",
    "period_window",
    "period_tol_rad",
    "early_stop",
    "early_stop_tol",
    "lyapunov_window_s",
    "lyapunov_align_periods",
    "lyapunov_perturbation",
];

/// `[cell]`'s settling time of a cell of a settling map (its map's `map.settle_max_s`).
const SETTLE_MAX_S: &str = "settle_max_s";

/// `[cell]`'s start of a cell run on (its map's `map.settle_from`).
const SETTLE_FROM: &str = "settle_from";

/// `[cell]`'s flag of a cell of a settling map that its map ran on.
const RAN_ON: &str = "ran_on";

/// The keys [`pinned_cell`] sets: the method, the step control and its step, the row rate.
pub const PINNED_KEYS: [&str; 4] = [
    "integration.method",
    "integration.step",
    "integration.dt_s",
    "output.sample_rate_hz",
];

/// The keys [`pinned_cell`] sets at adaptive steps (the base step in place of `dt_s`).
pub const PINNED_ADAPTIVE_KEYS: [&str; 4] = [
    "integration.method",
    "integration.step",
    "integration.base_step_s",
    "output.sample_rate_hz",
];

/// The scene table of one instance (`table`, with the ensemble's `integration.method` already
/// set where the ensemble fixed one), with the method, step control, step and row rate its
/// ensemble plan (`opts`) takes set in it; and which keys were set ([`PINNED_KEYS`] or
/// [`PINNED_ADAPTIVE_KEYS`]).
pub fn pinned_cell(
    mut table: Table,
    opts: &EnsembleOptions,
) -> Result<(Table, &'static [&'static str]), EngineError> {
    let scene = Scene::from_table(table.clone())?;
    let plan = EnsemblePlan::from_scenes(std::slice::from_ref(&scene), opts)?;
    let p = &plan.instances[0];
    // Rows at a whole number of steps, so the record's sample rate is exact.
    let every = (f64::from(p.spp) * p.frequency_hz / scene.output.sample_rate_hz)
        .round()
        .max(1.0);
    let rate = p.frequency_hz * f64::from(p.spp) / every;
    let set =
        |t: &mut Table, key: &str, v: Value| -> Result<(), ConfigError> { set_key(t, key, v) };
    set(
        &mut table,
        "integration.method",
        Value::String(plan.method.name().into()),
    )?;
    let (step, keys) = match p.control {
        StepControl::Adaptive { .. } => (
            ("adaptive", "integration.base_step_s"),
            &PINNED_ADAPTIVE_KEYS,
        ),
        StepControl::Fixed => (("fixed", "integration.dt_s"), &PINNED_KEYS),
    };
    set(&mut table, "integration.step", Value::String(step.0.into()))?;
    set(&mut table, step.1, Value::Float(p.dt_s))?;
    set(&mut table, "output.sample_rate_hz", Value::Float(rate))?;
    Ok((table, keys))
}

/// The grid index of the cell of `spec` whose axis values are `coords` (key, value): every
/// axis named, each value one of its axis's values (to within 1e-9 of its magnitude, so that
/// a value read back from a dataset's coordinate matches). A missing axis or a value between
/// grid points is refused: the cell would not be one the map ran.
pub fn cell_index(spec: &MapSpec, coords: &[(String, f64)]) -> Result<usize, ConfigError> {
    let mut k = 0;
    for axis in &spec.axes {
        let refuse = |reason: String| ConfigError::Inconsistent {
            key: axis.key.clone(),
            reason,
        };
        let values = &axis.values;
        let (lo, hi) = (values[0], values[values.len() - 1]);
        let Some(&(_, v)) = coords.iter().find(|(key, _)| *key == axis.key) else {
            return Err(refuse(format!(
                "a cell of this map needs a value of each axis, and this one has none: give one of its {} values from {} to {}",
                values.len(),
                num(lo),
                num(hi)
            )));
        };
        let close = |x: f64| (x - v).abs() <= 1e-9 * x.abs().max(v.abs()).max(1e-300);
        let Some(i) = values.iter().position(|&x| close(x)) else {
            return Err(refuse(format!(
                "{} is not a value of this map's axis ({} values from {} to {}): a cell runs one of them",
                num(v),
                values.len(),
                num(lo),
                num(hi)
            )));
        };
        k = k * values.len() + i;
    }
    Ok(k)
}

/// The `[cell]` section of a cell of `spec`: the map's `CELL_MAP_KEYS` (empty where the
/// map keeps every default), and for a map that settles, its `settle_max_s` and whether the
/// cell `ran_on` (the cell's result: the map's neighbours decided it). `None` for a map whose
/// cells are not one plain run each (starts, continuation, refinement), and for a cell of a
/// settling map whose `ran_on` is not known (a map scene without its run).
pub fn cell_section(spec: &MapSpec, ran_on: Option<bool>) -> Option<Table> {
    if !matches!(spec.mode, MapMode::Plain) {
        return None;
    }
    let mut section = Table::new();
    if let Some(max_s) = spec.settle_max_s {
        section.insert(SETTLE_MAX_S.into(), Value::Float(max_s));
        section.insert(
            SETTLE_FROM.into(),
            Value::String(spec.settle_from.name().into()),
        );
        section.insert(RAN_ON.into(), Value::Boolean(ran_on?));
    }
    if let Some(Value::Table(map)) = spec.source_table.get("map") {
        for key in CELL_MAP_KEYS {
            if let Some(v) = map.get(key) {
                section.insert(key.into(), v.clone());
            }
        }
    }
    Some(section)
}

/// A scene's TOML text with its overrides `sets`: the scene, and, where it has a `[cell]`
/// section (a map cell, as [`cell_section`] writes it), the map of that cell alone, whose one
/// run [`rerun_cell`] gives the cell's values as its map computed them.
pub fn read_cell_scene(
    text: &str,
    origin: &str,
    sets: &[String],
) -> Result<(Scene, Option<MapSpec>), ConfigError> {
    let mut table = parse_toml(text, origin)?;
    for s in sets {
        apply_override(&mut table, s)?;
    }
    let Some(cell) = table.remove(CELL_SECTION) else {
        return Ok((Scene::from_table(table)?, None));
    };
    let scene = Scene::from_table(table.clone())?;
    let ExcitationKind::Harmonic { frequency_hz, .. } = scene.excitation.kind else {
        return Err(ConfigError::Inconsistent {
            key: CELL_SECTION.into(),
            reason: "a map cell has harmonic excitation (its map's stroboscopic section needs one forcing period)".into(),
        });
    };
    let Value::Table(map) = cell else {
        return Err(ConfigError::Inconsistent {
            key: CELL_SECTION.into(),
            reason: "[cell] holds the map's settings of a cell's values, as a table".into(),
        });
    };
    let spec = one_cell_map(table, map, frequency_hz, origin)?;
    Ok((scene, Some(spec)))
}

/// The map of one cell: the scene `table`, the `[cell]` keys `map` and an axis of the scene's
/// own frequency `frequency_hz` (so that its one run is the scene itself).
fn one_cell_map(
    mut table: Table,
    mut map: Table,
    frequency_hz: f64,
    origin: &str,
) -> Result<MapSpec, ConfigError> {
    let taken =
        |k: &str| CELL_MAP_KEYS.contains(&k) || [SETTLE_MAX_S, SETTLE_FROM, RAN_ON].contains(&k);
    if let Some(key) = map.keys().find(|k| !taken(k)) {
        return Err(ConfigError::Inconsistent {
            key: format!("{CELL_SECTION}.{key}"),
            reason: format!(
                "[cell] takes the map keys that shape a cell's values ({}), and a settling map's {SETTLE_MAX_S}, {SETTLE_FROM} and {RAN_ON}",
                CELL_MAP_KEYS.join(", ")
            ),
        });
    }
    settle_keys(&mut map)?;
    let mut axis = Table::new();
    axis.insert(
        "key".into(),
        Value::String("excitation.frequency_hz".into()),
    );
    axis.insert(
        "values".into(),
        Value::Array(vec![Value::Float(frequency_hz)]),
    );
    map.insert("axes".into(), Value::Array(vec![Value::Table(axis)]));
    table.insert("map".into(), Value::Table(map));
    let text = toml::to_string(&table).map_err(|e| ConfigError::Inconsistent {
        key: CELL_SECTION.into(),
        reason: format!("the cell's map does not write as TOML: {e}"),
    })?;
    map_from_toml(&text, origin, &[])
}

/// `[cell]`'s settling keys as the map of one cell takes them: a cell its map ran on settles
/// (it runs on whatever its own confidence), any other does not (`map.settle = false`).
fn settle_keys(map: &mut Table) -> Result<(), ConfigError> {
    let ran_on = match map.remove(RAN_ON) {
        None => false,
        Some(Value::Boolean(b)) => b,
        Some(_) => {
            return Err(ConfigError::Inconsistent {
                key: format!("{CELL_SECTION}.{RAN_ON}"),
                reason: "true or false: whether the cell's map ran it on".into(),
            });
        }
    };
    let max_s = map.remove(SETTLE_MAX_S);
    match (ran_on, max_s) {
        (true, Some(v)) => {
            map.insert(SETTLE_MAX_S.into(), v);
        }
        (true, None) => {
            return Err(ConfigError::Inconsistent {
                key: format!("{CELL_SECTION}.{RAN_ON}"),
                reason: format!("a cell its map ran on needs the map's {SETTLE_MAX_S}"),
            });
        }
        (false, _) => {
            map.remove(SETTLE_FROM);
            map.insert("settle".into(), Value::Boolean(false));
        }
    }
    Ok(())
}

/// The values of the one cell of `spec` (a map of one cell and one start, as
/// [`read_cell_scene`] makes it) as the map computes them on the CPU engine in f64: the map's
/// plan, lanes and reductions, and where its map ran it on, the settling stage.
pub fn rerun_cell(spec: &MapSpec, progress: Progress) -> Result<InstanceResult, EngineError> {
    let runs = spec.instances() * spec.starts_per_cell();
    if runs != 1 {
        return Err(EngineError::Config(ConfigError::Inconsistent {
            key: "map.axes".into(),
            reason: format!(
                "a run of one map cell takes a [map] of one cell and one start, and this one has {runs} runs: run it with `map`, or take one cell of it (explore, Scene.cell)"
            ),
        }));
    }
    let cpu = Engine::cpu(Precision::F64);
    let run = super::run_map_settling(spec, super::settle::Which::Every, &cpu, progress)?;
    Ok(run.results[0])
}

/// The values of `r`, a cell of a map of `spec`'s metrics, by the schema's names: numbers
/// (null where not formed), the regime and status by name. The confidence, which the grid's
/// neighbours give, is left out.
pub fn cell_values(
    spec: &MapSpec,
    r: &InstanceResult,
) -> serde_json::Map<String, serde_json::Value> {
    FIELDS
        .iter()
        .filter(|f| f.in_map && f.formed_for(&spec.metrics) && f.stage != Stage::Confidence)
        .map(|f| {
            let value = match f.name {
                "regime" | "status" => serde_json::Value::String(f.code_name(r)),
                _ => serde_json::Number::from_f64((f.get)(r))
                    .map_or(serde_json::Value::Null, Into::into),
            };
            (f.name.to_string(), value)
        })
        .collect()
}

/// What `run.json`'s `map_cell` holds for the one cell of `spec` (a map cell's scene, read by
/// [`read_cell_scene`]): its values as its map computes them ([`rerun_cell`],
/// [`cell_values`]), the engine, and how far they carry.
pub fn map_cell_report(
    spec: &MapSpec,
    progress: Progress,
) -> Result<serde_json::Value, EngineError> {
    let r = rerun_cell(spec, progress)?;
    Ok(serde_json::json!({
        "engine": "cpu f64, SIMD lanes (the CPU engine's map)",
        "values": cell_values(spec, &r),
        "note": "this cell's values as its map computes them (a map of this cell alone): bit for bit those of a map run on the CPU engine in f64; a map run in f32 (the GPU) can differ where the orbit is sensitive; the verdict's confidence needs the cell's neighbours and is not given",
    }))
}
