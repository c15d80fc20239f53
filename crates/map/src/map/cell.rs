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
pub(crate) const CELL_MAP_KEYS: [&str; 17] = [
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
    "transient_copies",
    "transient_nudge_deg_s",
];

/// `[cell]`'s settling time of a cell of a settling map (its map's `map.settle_max_s`).
const SETTLE_MAX_S: &str = "settle_max_s";

/// `[cell]`'s start of a cell run on (its map's `map.settle_from`).
const SETTLE_FROM: &str = "settle_from";

/// `[cell]`'s flag of a cell of a settling map that its map ran on.
const RAN_ON: &str = "ran_on";

/// `[cell]`'s flag of a cell run on whose map ran its nudged copies (`map.transient_copies`;
/// absent: it did not).
const COPIES: &str = "copies";

/// What only a map's run knows of one of its cells (`None`: not known): whether settling ran
/// it on (`ran_on.npy`), and whether the transient stage ran its nudged copies
/// (`start_sensitivity.npy` finite).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CellStages {
    /// Settling ran it on past the map's length.
    pub ran_on: Option<bool>,
    /// Its nudged copies ran.
    pub copies: Option<bool>,
}

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

/// How far (relative to its magnitude) a value given for a cell may lie from a value of its
/// axis and still name it: a value read back from a dataset's coordinate, or computed as
/// `start + i·step`, lands within this of the grid value it means. The cell then runs the grid
/// value itself ([`cell_index`], [`cell_grid_values`]).
pub const CELL_SNAP_REL: f64 = 1e-9;

/// The grid index of the cell of `spec` whose axis values are `coords` (key, value): every
/// axis named, each value one of its axis's values to within [`CELL_SNAP_REL`] of its
/// magnitude (a value read back from a dataset's coordinate matches; the cell is the grid
/// value's, which [`cell_grid_values`] gives). A missing axis or a value between grid points
/// is refused, naming the key and the grid values nearest the one given: the cell would not
/// be one the map ran.
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
        let close = |x: f64| (x - v).abs() <= CELL_SNAP_REL * x.abs().max(v.abs()).max(1e-300);
        let Some(i) = values.iter().position(|&x| close(x)) else {
            return Err(refuse(format!(
                "{} is not a value of this map's axis ({} values from {} to {}; the nearest: {}): a cell runs one of them",
                num(v),
                values.len(),
                num(lo),
                num(hi),
                nearest(values, v)
            )));
        };
        k = k * values.len() + i;
    }
    Ok(k)
}

/// The axis values of cell `k` of `spec`, by key: what a cell named by values within
/// [`CELL_SNAP_REL`] of them runs.
pub fn cell_grid_values(spec: &MapSpec, k: usize) -> Vec<(String, f64)> {
    spec.axes
        .iter()
        .map(|a| a.key.clone())
        .zip(spec.values_of(k))
        .collect()
}

/// The (at most three) values of an axis nearest `v`, in the axis's order, as a message
/// lists them.
fn nearest(values: &[f64], v: f64) -> String {
    let mut by_distance: Vec<usize> = (0..values.len()).collect();
    by_distance.sort_by(|&a, &b| (values[a] - v).abs().total_cmp(&(values[b] - v).abs()));
    by_distance.truncate(3);
    by_distance.sort_unstable();
    let shown: Vec<String> = by_distance.iter().map(|&i| num(values[i])).collect();
    shown.join(", ")
}

/// The `[cell]` section of a cell of `spec`: the map's `CELL_MAP_KEYS` (empty where the
/// map keeps every default), and for a map that settles, its `settle_max_s` and whether the
/// cell `ran_on` (the cell's result: the map's neighbours decided it; only the map's run
/// knows it, `ran_on.npy`) and whether its nudged `copies` ran (`start_sensitivity.npy`
/// finite; absent: they did not). A settling map's cell whose `ran_on` is not known (`None`: a map
/// scene without its run) gets the settling keys without `ran_on`, which
/// [`read_cell_scene`] reads as a cell that cannot be rerun as its map computed it, and says
/// so ([`UNKNOWN_RAN_ON`]). `None` for a map whose cells are not one plain run each (starts,
/// continuation, refinement).
pub fn cell_section(spec: &MapSpec, ran: CellStages) -> Option<Table> {
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
        if let Some(ran_on) = ran.ran_on {
            section.insert(RAN_ON.into(), Value::Boolean(ran_on));
        }
        // Absent reads as false: written only where the copies ran.
        if ran.copies == Some(true) && spec.transients.is_some() {
            section.insert(COPIES.into(), Value::Boolean(true));
        }
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

/// What a cell's scene says (a note of its [`Scene`], which `simulate` prints as a warning and
/// Python's `pa.simulate` warns of) when it is a settling map's cell without `ran_on`: its
/// values as its map computes them depend on whether the map ran it on, which only the map's
/// run knows, so they are not given.
pub const UNKNOWN_RAN_ON: &str = "this is a cell of a settling map ([cell] has settle_max_s) that does not say whether its map ran it on past the map's length (cell.ran_on, which only the map's run knows: its ran_on.npy): its values as the map computes them are not given, and this run's own analysis can differ from the map's; take the cell from the map's run (the explorer's download, or Scene.cell(..., run=dataset) in Python), or set cell.ran_on = true or false";

/// The scene table of cell `k` of `spec` as its map ran it, the one recipe of the explorer's
/// download of a cell and Python's `Scene.cell`: the cell's axis values (and start `start` of
/// `map.initial_states`, the cell's representative one, where the map has starts), the
/// overrides `sets` (none for the map's own cell), the map's integration method `method`
/// (`map.json`'s), the method, step control, step and row rate pinned ([`pinned_cell`]), and
/// the `[cell]` section ([`cell_section`], with the cell's `ran_on` and `copies` where the
/// map's run gives them). Also which keys were pinned.
pub fn map_cell_table(
    spec: &MapSpec,
    k: usize,
    start: Option<usize>,
    method: &str,
    ran: CellStages,
    sets: &[String],
) -> Result<(Table, &'static [&'static str]), EngineError> {
    let mut table = match start {
        Some(s) => spec.start_table(k, s),
        None => spec.instance_table(k),
    }?;
    for s in sets {
        apply_override(&mut table, s)?;
    }
    set_key(
        &mut table,
        "integration.method",
        Value::String(method.into()),
    )?;
    let (mut table, keys) = pinned_cell(table, &EnsembleOptions::from_spec(spec))?;
    if let Some(section) = cell_section(spec, ran) {
        table.insert(CELL_SECTION.into(), Value::Table(section));
    }
    Ok((table, keys))
}

/// A scene's TOML text with its overrides `sets`: the scene, and, where it has a `[cell]`
/// section (a map cell, as [`cell_section`] writes it), the map of that cell alone, whose one
/// run [`rerun_cell`] gives the cell's values as its map computed them. A settling map's cell
/// without `ran_on` has no such map: its scene carries the note [`UNKNOWN_RAN_ON`].
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
    let mut scene = Scene::from_table(table.clone())?;
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
    check_cell_keys(&map)?;
    if map.contains_key(SETTLE_MAX_S) && !map.contains_key(RAN_ON) {
        scene.notes.push(UNKNOWN_RAN_ON.into());
        return Ok((scene, None));
    }
    let spec = one_cell_map(table, map, frequency_hz, origin)?;
    Ok((scene, Some(spec)))
}

/// `[cell]` takes the map keys that shape a cell's values and the settling keys, nothing else.
fn check_cell_keys(map: &Table) -> Result<(), ConfigError> {
    let taken = |k: &str| {
        CELL_MAP_KEYS.contains(&k) || [SETTLE_MAX_S, SETTLE_FROM, RAN_ON, COPIES].contains(&k)
    };
    if let Some(key) = map.keys().find(|k| !taken(k)) {
        return Err(ConfigError::Inconsistent {
            key: format!("{CELL_SECTION}.{key}"),
            reason: format!(
                "[cell] takes the map keys that shape a cell's values ({}), and a settling map's {SETTLE_MAX_S}, {SETTLE_FROM}, {RAN_ON} and {COPIES}",
                CELL_MAP_KEYS.join(", ")
            ),
        });
    }
    Ok(())
}

/// The map of one cell: the scene `table`, the `[cell]` keys `map` and an axis of the scene's
/// own frequency `frequency_hz` (so that its one run is the scene itself).
fn one_cell_map(
    mut table: Table,
    mut map: Table,
    frequency_hz: f64,
    origin: &str,
) -> Result<MapSpec, ConfigError> {
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
/// (it runs on whatever its own confidence), any other does not (`map.settle = false`); its
/// nudged copies run where its map ran them (`copies`), whatever its own confidence.
fn settle_keys(map: &mut Table) -> Result<(), ConfigError> {
    let ran_on = flag(
        map.remove(RAN_ON),
        RAN_ON,
        "whether the cell's map ran it on",
    )?;
    let copies = flag(
        map.remove(COPIES),
        COPIES,
        "whether its map ran the cell's nudged copies",
    )?;
    let max_s = map.remove(SETTLE_MAX_S);
    // The copies run where the map ran them: never on a cell not run on.
    if !(ran_on && copies) {
        map.insert("transient_copies".into(), Value::Integer(0));
        map.remove("transient_nudge_deg_s");
    }
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

/// A `[cell]` flag `key` (false where absent).
fn flag(v: Option<Value>, key: &str, what: &str) -> Result<bool, ConfigError> {
    match v {
        None => Ok(false),
        Some(Value::Boolean(b)) => Ok(b),
        Some(_) => Err(ConfigError::Inconsistent {
            key: format!("{CELL_SECTION}.{key}"),
            reason: format!("true or false: {what}"),
        }),
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use pendulum_atlas_core::config::DEFAULT_MAP_TOML;

    fn default_map() -> MapSpec {
        map_from_toml(DEFAULT_MAP_TOML, "<default map>", &[]).unwrap()
    }

    fn at(f: f64, a: f64) -> Vec<(String, f64)> {
        vec![
            ("excitation.frequency_hz".into(), f),
            ("excitation.amplitude_m".into(), a),
        ]
    }

    #[test]
    fn a_value_within_the_tolerance_names_its_grid_value_and_others_are_refused() {
        let spec = default_map();
        let (f, a) = (spec.axes[0].values[5], spec.axes[1].values[7]);
        let k = cell_index(&spec, &at(f * (1.0 + 1e-12), a)).unwrap();
        assert_eq!(k, 5 * spec.axes[1].values.len() + 7);
        let grid = cell_grid_values(&spec, k);
        assert_eq!(grid[0].1.to_bits(), f.to_bits());
        assert_eq!(grid[1].1.to_bits(), a.to_bits());
        let refused = cell_index(&spec, &at(f * (1.0 + 1e-6), a))
            .unwrap_err()
            .to_string();
        assert!(
            refused.contains("excitation.frequency_hz") && refused.contains("the nearest: "),
            "{refused}"
        );
        assert!(refused.contains(&num(f)), "{refused}");
    }

    #[test]
    fn a_settling_maps_cell_without_ran_on_reads_as_one_that_cannot_be_rerun() {
        let spec = default_map();
        assert!(spec.settle_max_s.is_some(), "the default map settles");
        let method = EnsemblePlan::new(&spec).unwrap().method.name();
        for (ran_on, rerun) in [(None, false), (Some(false), true), (Some(true), true)] {
            let ran = CellStages {
                ran_on,
                copies: None,
            };
            let (table, _) = map_cell_table(&spec, 3, None, method, ran, &[]).unwrap();
            let text = toml::to_string(&table).unwrap();
            let (scene, cell) = read_cell_scene(&text, "<cell>", &[]).unwrap();
            assert_eq!(cell.is_some(), rerun, "{ran_on:?}");
            let noted = scene.notes.iter().any(|n| n == UNKNOWN_RAN_ON);
            assert_eq!(noted, !rerun, "{ran_on:?}: {:?}", scene.notes);
        }
    }
}
