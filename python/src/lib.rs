//! `pendulum_atlas._native`: the library's scenes, maps, single runs and record analysis for
//! Python. Every number comes from the `pendulum-atlas` crate; this module only converts
//! (TOML values in, NumPy arrays and Python dicts out) and runs the engine off the interpreter
//! ([`poll`]). The Python package (`python/pendulum_atlas/`) turns what it returns into
//! `xarray` datasets.

mod convert;
mod poll;

use convert::serialised;
use numpy::{PyArray1, PyArrayMethods, PyReadonlyArray1};
use pendulum_atlas_core::analysis::{RecordOptions, Sampling, analyze_record};
use pendulum_atlas_core::config::{
    ConfigError, DEFAULT_MAP_TOML, MapSpec, PAPER_SCENE_TOML, Scene, apply_override, lookup_key,
    map_from_toml, parse_override_value, parse_toml,
};
use pendulum_atlas_core::engine::{
    Backend, Engine, EngineError, EnsemblePlan, Integrator, Precision, StepPlan,
};
use pendulum_atlas_core::model::Status;
use pendulum_atlas_map::machine::memory_available;
use pendulum_atlas_map::map::cell::{
    CELL_SECTION, CELL_SNAP_REL, CellStages, cell_grid_values, cell_index, map_cell_report,
    map_cell_table, read_cell_scene,
};
use pendulum_atlas_map::map::run_map;
use pendulum_atlas_map::output::budget::RunSize;
use pendulum_atlas_map::output::manifest::{Manifest, MapManifest};
use pendulum_atlas_map::output::map::{
    ArrayData, MapArray, bifurcations_json, map_arrays, map_manifest,
};
use pendulum_atlas_map::output::{
    RunFacts, RunReport, TrajectoryRecorder, record_analysis, row_columns, run_warnings,
};
use pendulum_atlas_map::record::{RecordSource, TimeAxis, read_record as read_record_file};
use poll::run_polled;
use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyList, PyString, PyTuple};
use std::collections::BTreeMap;
use std::collections::btree_map::Entry;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::Instant;

create_exception!(
    pendulum_atlas,
    SceneError,
    PyValueError,
    "A scene that the library refuses; the message names the key and its accepted range."
);
/// The Python exceptions whose names are also the library's Rust types.
mod py_errors {
    use pyo3::create_exception;
    use pyo3::exceptions::PyRuntimeError;

    create_exception!(
        pendulum_atlas,
        EngineError,
        PyRuntimeError,
        "The engine could not run (no GPU adapter, a run too long for it, ...)."
    );
}

fn scene_error(e: ConfigError) -> PyErr {
    SceneError::new_err(said(e))
}

/// A message for Python, with what it quotes from inputs made safe for the terminal a
/// traceback is printed on (`text::printable`).
pub(crate) fn said(e: impl std::fmt::Display) -> String {
    pendulum_atlas_core::text::printable(&e.to_string())
}

/// An engine error in Python terms: what mends it spelt as the function's arguments.
fn engine_error(e: EngineError) -> PyErr {
    let mend = match &e {
        EngineError::GpuNeedsF32 => " (use precision='f32', or backend='cpu' for f64)",
        EngineError::ReferenceNeedsF64 => " (use precision='f64' with integrator='reference')",
        EngineError::NoAdapter { .. }
        | EngineError::TooManySegments { .. }
        | EngineError::SoftwareLoopBudget { .. } => " (use backend='cpu')",
        _ => "",
    };
    match e {
        EngineError::Config(c) => scene_error(c),
        other => py_errors::EngineError::new_err(said(format!("{other}{mend}"))),
    }
}

fn parse_backend(name: &str) -> PyResult<Backend> {
    match name {
        "auto" => Ok(Backend::Auto),
        "gpu" => Ok(Backend::Gpu),
        "cpu" => Ok(Backend::Cpu),
        _ => Err(PyValueError::new_err(format!(
            "backend={name:?}: use 'auto' (a hardware GPU, else lavapipe or the CPU), 'gpu' or 'cpu'"
        ))),
    }
}

fn parse_precision(name: Option<&str>) -> PyResult<Option<Precision>> {
    match name {
        None => Ok(None),
        Some("f32") => Ok(Some(Precision::F32)),
        Some("f64") => Ok(Some(Precision::F64)),
        Some(other) => Err(PyValueError::new_err(format!(
            "precision={other:?}: use None (the engine's own), 'f32' or 'f64'"
        ))),
    }
}

fn parse_integrator(name: &str) -> PyResult<Integrator> {
    match name {
        "engine" => Ok(Integrator::Engine),
        "reference" => Ok(Integrator::Reference),
        _ => Err(PyValueError::new_err(format!(
            "integrator={name:?}: use 'engine' (the maps' RK4/IMEX, adaptive or fixed steps as the scene says) or 'reference' (adaptive DOP853, f64)"
        ))),
    }
}

/// How deeply lists and dicts may nest in a scene value (the deepest scene key, an entry of
/// `map.axes`, nests two levels).
const MAX_VALUE_DEPTH: usize = 32;

/// A Python value as a TOML value: bool, int, float, str, and lists, tuples or dicts (inline
/// tables, e.g. the entries of `map.axes`) of them, nested at most [`MAX_VALUE_DEPTH`] deep.
fn toml_value(v: &Bound<'_, PyAny>) -> PyResult<toml::Value> {
    toml_value_at(v, 0)
}

fn toml_value_at(v: &Bound<'_, PyAny>, depth: usize) -> PyResult<toml::Value> {
    if depth > MAX_VALUE_DEPTH {
        return Err(SceneError::new_err(format!(
            "a scene value nests lists or dicts more than {MAX_VALUE_DEPTH} levels deep; no scene key takes that"
        )));
    }
    let inner = |item: &Bound<'_, PyAny>| toml_value_at(item, depth + 1);
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if let Ok(i) = v.extract::<i64>() {
        return Ok(toml::Value::Integer(i));
    }
    if let Ok(x) = v.extract::<f64>() {
        return Ok(toml::Value::Float(x));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    if v.is_instance_of::<PyList>() || v.is_instance_of::<PyTuple>() {
        let items: Vec<Bound<'_, PyAny>> = v.try_iter()?.collect::<PyResult<_>>()?;
        return Ok(toml::Value::Array(
            items.iter().map(inner).collect::<PyResult<_>>()?,
        ));
    }
    if let Ok(d) = v.cast::<PyDict>() {
        let mut table = toml::Table::new();
        for (k, item) in d.iter() {
            table.insert(k.extract::<String>()?, inner(&item)?);
        }
        return Ok(toml::Value::Table(table));
    }
    Err(PyTypeError::new_err(format!(
        "a scene value must be a bool, int, float, str, or a list or dict of them, not {}",
        v.get_type().name()?
    )))
}

/// A map folder's `map.json`, read and checked by the one type the command writes it with
/// (every field it needs, files listed by name only), as a dict.
#[pyfunction]
fn read_map_manifest(py: Python<'_>, path: std::path::PathBuf) -> PyResult<Bound<'_, PyAny>> {
    let manifest = MapManifest::read(&path).map_err(|e| PyValueError::new_err(said(&e)))?;
    serialised(py, &manifest)
}

/// The result schema (`pendulum_atlas_core::schema::FIELDS`): one dict per result a map can
/// store, with its name, unit, dtype, description and the metric that brings it.
#[pyfunction]
fn result_fields(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    use pendulum_atlas_core::schema::{Dtype, FIELDS};
    let rows: Vec<serde_json::Value> = FIELDS
        .iter()
        .filter(|f| f.in_map)
        .map(|f| {
            serde_json::json!({
                "name": f.name,
                "unit": f.unit,
                "dtype": match f.dtype {
                    Dtype::F64 => "float64",
                    Dtype::I8 => "int8",
                    Dtype::U8 => "uint8",
                    Dtype::U64 => "uint64",
                },
                "description": f.description,
                "metric": f.metric.map(|m| m.name()),
            })
        })
        .collect();
    convert::to_python(py, &serde_json::Value::Array(rows))
}

/// `key=value` as `--set` takes it, from a Python value. The key must be a dotted scene key
/// (letters, digits, `_` and `-` between dots): anything else, an `=` or a `#` above all, would
/// let the key carry a value of its own.
#[pyfunction]
fn set_arg(key: &str, value: &Bound<'_, PyAny>) -> PyResult<String> {
    let part_ok = |p: &str| {
        !p.is_empty()
            && p.chars()
                .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
    };
    if !key.split('.').all(part_ok) {
        return Err(SceneError::new_err(format!(
            "{key:?} is not a scene key: a key is names of letters, digits, `_` and `-` joined by dots, e.g. \"excitation.frequency_hz\""
        )));
    }
    Ok(format!("{key}={}", toml_value(value)?))
}

/// Validate a scene: `("map" | "scene", its TOML after the overrides, the base scene of a
/// map (its TOML without `[map]`; the scene itself for a plain scene))`.
#[pyfunction]
fn check_scene(text: &str, origin: &str, sets: Vec<String>) -> PyResult<(String, String, String)> {
    let table = parse_toml(text, origin).map_err(scene_error)?;
    let to_text = |t: &toml::Table| toml::to_string(t).map_err(|e| SceneError::new_err(said(&e)));
    if table.contains_key("map") {
        let spec = map_from_toml(text, origin, &sets).map_err(scene_error)?;
        return Ok((
            "map".into(),
            to_text(&spec.source_table)?,
            to_text(&spec.base_table)?,
        ));
    }
    read_cell_scene(text, origin, &sets).map_err(scene_error)?;
    let mut resolved = table;
    for s in &sets {
        apply_override(&mut resolved, s).map_err(scene_error)?;
    }
    let t = to_text(&resolved)?;
    Ok(("scene".into(), t.clone(), t))
}

/// The engines this process has opened, by what was asked for: the GPU device, its compiled
/// kernels and `auto`'s measured choice are made once and reused by every later map (one map
/// at a time).
static ENGINES: Mutex<BTreeMap<(Backend, Option<Precision>), Engine>> = Mutex::new(BTreeMap::new());

/// A map's arrays, `map.json` (without files) and the engine's name, made off the interpreter.
struct MapOut {
    arrays: Vec<MapArray>,
    manifest: MapManifest,
    /// `bifurcations.json`'s content, when the map found orbits.
    bifurcations: Option<serde_json::Value>,
}

fn map_work(
    spec: &MapSpec,
    backend: Backend,
    precision: Option<Precision>,
    ticker: &poll::Ticker,
) -> Result<MapOut, EngineError> {
    let mut engines = ENGINES
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner());
    let engine = match engines.entry((backend, precision)) {
        Entry::Occupied(e) => {
            let engine = e.into_mut();
            engine.mark_reused();
            engine
        }
        Entry::Vacant(e) => e.insert(Engine::open(backend, precision)?),
    };
    if let Some(accepted) = pendulum_atlas_map::map::size::check_map_size(spec, 1, engine)? {
        eprintln!("{accepted}");
    }
    let run = run_map(spec, engine, &|d, t, u| ticker.report(d, t, u))?;
    Ok(MapOut {
        arrays: map_arrays(spec, &run),
        manifest: map_manifest(spec, &run, &[]),
        bifurcations: run.orbits.as_ref().map(|o| bifurcations_json(spec, o)),
    })
}

/// A NumPy array of a map array's values in its own dtype and shape.
fn to_numpy<'py>(py: Python<'py>, a: MapArray) -> PyResult<Bound<'py, PyAny>> {
    let shape = a.shape;
    Ok(match a.data {
        ArrayData::F64(v) => PyArray1::from_vec(py, v).reshape(shape)?.into_any(),
        ArrayData::I8(v) => PyArray1::from_vec(py, v).reshape(shape)?.into_any(),
        ArrayData::U8(v) => PyArray1::from_vec(py, v).reshape(shape)?.into_any(),
        ArrayData::I32(v) => PyArray1::from_vec(py, v).reshape(shape)?.into_any(),
    })
}

/// Run a map scene: `{"arrays": {name: ndarray}, "manifest": map.json's content,
/// "bifurcations": bifurcations.json's content or None}`.
#[pyfunction]
#[pyo3(signature = (text, origin, sets, backend="auto", precision=None, progress=None))]
fn run_map_scene<'py>(
    py: Python<'py>,
    text: &str,
    origin: &str,
    sets: Vec<String>,
    backend: &str,
    precision: Option<&str>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    let spec = map_from_toml(text, origin, &sets).map_err(scene_error)?;
    pendulum_atlas_map::map::check_host_memory(&spec).map_err(engine_error)?;
    let (backend, precision) = (parse_backend(backend)?, parse_precision(precision)?);
    let out = run_polled(py, progress.as_ref(), move |ticker| {
        map_work(&spec, backend, precision, ticker)
    })?
    .map_err(engine_error)?;
    let arrays = PyDict::new(py);
    for a in out.arrays {
        let name = a.name.clone();
        arrays.set_item(name, to_numpy(py, a)?)?;
    }
    let d = PyDict::new(py);
    d.set_item("arrays", arrays)?;
    d.set_item("manifest", serialised(py, &out.manifest)?)?;
    match &out.bifurcations {
        Some(b) => d.set_item("bifurcations", serialised(py, b)?)?,
        None => d.set_item("bifurcations", py.None())?,
    }
    Ok(d)
}

/// A single run off the interpreter: its columns, units and `run.json`.
struct RunOut {
    columns: Vec<(&'static str, &'static str, Vec<f64>)>,
    report: serde_json::Value,
}

/// Why a single run gave no result.
enum WorkError {
    /// The engine refused or failed.
    Engine(EngineError),
    /// `run.json` could not be made.
    Report(serde_json::Error),
}

impl From<EngineError> for WorkError {
    fn from(e: EngineError) -> Self {
        WorkError::Engine(e)
    }
}

fn work_error(e: WorkError) -> PyErr {
    match e {
        WorkError::Engine(e) => engine_error(e),
        WorkError::Report(e) => PyRuntimeError::new_err(said(format!("run.json of the run: {e}"))),
    }
}

fn simulate_work(
    scene: &Scene,
    plan: &StepPlan,
    (integrator, precision): (Integrator, Precision),
    cell: Option<&MapSpec>,
    ticker: &Arc<poll::Ticker>,
) -> Result<RunOut, WorkError> {
    let total = plan.steps;
    let t = Arc::clone(ticker);
    let mut rec = TrajectoryRecorder {
        load_ohm: scene.piezo_params().map(|z| z.load_ohm),
        on_row: Some(Box::new(move |step| {
            t.report(
                step,
                total,
                pendulum_atlas_core::engine::ProgressUnit::Steps,
            )
        })),
        ..Default::default()
    };
    let started = Instant::now();
    let run = pendulum_atlas_core::engine::run_scene(scene, plan, integrator, precision, &mut rec)?;
    if rec.stopped {
        return Err(WorkError::Engine(
            pendulum_atlas_core::engine::EngineError::Cancelled,
        ));
    }
    let wall_time_s = started.elapsed().as_secs_f64();
    let mut warnings = run_warnings(plan, &run.outcome);
    let analysis = (run.outcome.status == Status::Ok)
        .then(|| record_analysis(scene, plan, &rec.rows))
        .and_then(|r| {
            r.map_err(|e| warnings.push(said(format!("analysis of the run skipped: {e}"))))
                .ok()
        });
    let modes = scene.modes().map_err(EngineError::from)?;
    let facts = RunFacts {
        scene,
        plan,
        integrator,
        run: &run,
        modes: &modes,
        rows: rec.rows.len(),
        wall_time_s,
    };
    let mut report = RunReport::new(facts, &warnings, analysis.as_ref());
    if let Some(spec) = cell {
        let t = Arc::clone(ticker);
        report.map_cell = Some(map_cell_report(spec, &|d, n, u| t.report(d, n, u))?);
    }
    let columns = row_columns(scene.piezo_params().is_some())
        .iter()
        .map(|&(name, unit, get)| (name, unit, rec.rows.iter().map(get).collect()))
        .collect();
    Ok(RunOut {
        columns,
        report: serde_json::to_value(&report).map_err(WorkError::Report)?,
    })
}

/// The run's rows must fit in memory; a run of no step is refused.
fn check_run_size(scene: &Scene, plan: &StepPlan) -> PyResult<()> {
    RunSize::of_run(scene, plan)
        .and_then(|size| size.check_against(memory_available(), None, Path::new(".")))
        .map_err(|e| SceneError::new_err(said(&e)))
}

/// Run a plain scene once: `{"columns": {name: ndarray}, "units": {name: unit}, "report":
/// run.json as a dict, "notes": what reading the scene noted}`.
#[pyfunction]
#[pyo3(signature = (text, origin, sets, integrator="engine", precision=None, progress=None))]
fn run_single_scene<'py>(
    py: Python<'py>,
    text: &str,
    origin: &str,
    sets: Vec<String>,
    integrator: &str,
    precision: Option<&str>,
    progress: Option<Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    if parse_toml(text, origin)
        .map_err(scene_error)?
        .contains_key("map")
    {
        return Err(SceneError::new_err(
            "this scene has a [map] section: simulate runs one scene; use pendulum_atlas.map, or scene.cell(...) for one cell of the map",
        ));
    }
    let (scene, cell) = read_cell_scene(text, origin, &sets).map_err(scene_error)?;
    let integrator = parse_integrator(integrator)?;
    let precision = parse_precision(precision)?.unwrap_or(Precision::F64);
    if integrator == Integrator::Reference && precision == Precision::F32 {
        return Err(engine_error(EngineError::ReferenceNeedsF64));
    }
    let plan = StepPlan::for_scene(&scene).map_err(|e| scene_error(e.into()))?;
    check_run_size(&scene, &plan)?;
    // What `simulate` prints as warnings before it runs (keys given but not used, a settling
    // map's cell that cannot be rerun as its map computed it).
    let notes: Vec<String> = scene.notes.iter().map(said).collect();
    let out = run_polled(py, progress.as_ref(), move |ticker| {
        simulate_work(
            &scene,
            &plan,
            (integrator, precision),
            cell.as_ref(),
            ticker,
        )
    })?
    .map_err(work_error)?;
    let columns = PyDict::new(py);
    let units = PyDict::new(py);
    for (name, unit, v) in out.columns {
        columns.set_item(name, PyArray1::from_vec(py, v))?;
        units.set_item(name, unit)?;
    }
    let d = PyDict::new(py);
    d.set_item("columns", columns)?;
    d.set_item("units", units)?;
    d.set_item("report", convert::to_python(py, &out.report)?)?;
    d.set_item("notes", notes)?;
    Ok(d)
}

/// The paper's indicators of a record (`docs/analysis.md`), as a dict.
// Keyword arguments of one Python function: a struct would only move them.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (signal, sample_rate_hz, forcing_hz=None, reference=None, transient_s=0.0, start_s=0.0, clearance_deg=None, sampling=None))]
fn analyze_signal<'py>(
    py: Python<'py>,
    signal: PyReadonlyArray1<'_, f64>,
    sample_rate_hz: f64,
    forcing_hz: Option<f64>,
    reference: Option<PyReadonlyArray1<'_, f64>>,
    transient_s: f64,
    start_s: f64,
    clearance_deg: Option<f64>,
    sampling: Option<&str>,
) -> PyResult<Bound<'py, PyAny>> {
    let sampling = match sampling {
        None => Sampling::default_for(forcing_hz),
        Some(name) => Sampling::from_name(name).ok_or_else(|| {
            PyValueError::new_err(format!(
                "sampling={name:?}: use None (stroboscopic with forcing_hz, else extrema), 'stroboscopic', 'extrema' or 'uniform'"
            ))
        })?,
    };
    if sampling == Sampling::Stroboscopic && forcing_hz.is_none() {
        return Err(PyValueError::new_err(
            "sampling='stroboscopic' needs the forcing frequency (forcing_hz=...); or choose 'extrema' or 'uniform'",
        ));
    }
    let signal = signal.as_slice()?.to_vec();
    let reference = reference
        .map(|r| r.as_slice().map(<[f64]>::to_vec))
        .transpose()?;
    let opts = RecordOptions {
        forcing_hz,
        sampling,
        transient_s,
        clearance_rad: clearance_deg.map(f64::to_radians),
        ..RecordOptions::default()
    };
    let analysis = py
        .detach(|| {
            analyze_record(
                &signal,
                reference.as_deref(),
                sample_rate_hz,
                start_s,
                &opts,
            )
        })
        .map_err(|e| PyValueError::new_err(said(&e)))?;
    serialised(py, &analysis)
}

/// A measured CSV record as `analyze` reads it (`pendulum_atlas_map::record`): `{"signal",
/// "reference" (ndarray or None), "sample_rate_hz", "start_s", "resampled", "notes",
/// "warnings"}`. Exactly one of `time` (a column) and `sample_rate_hz` is given.
// Keyword arguments of one Python function: a struct would only move them.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (path, signal, reference=None, time=None, time_unit="s", sample_rate_hz=None, resample=false, allow_gaps=false))]
fn read_record<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    signal: &str,
    reference: Option<&str>,
    time: Option<String>,
    time_unit: &str,
    sample_rate_hz: Option<f64>,
    resample: bool,
    allow_gaps: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let time = match (time, sample_rate_hz) {
        (Some(_), Some(_)) => {
            return Err(PyValueError::new_err(
                "give the time column (time=...) or the sample rate (sample_rate_hz=...), not both",
            ));
        }
        (Some(name), None) => Some(TimeAxis::Column {
            name,
            unit: time_unit.to_string(),
            resample,
            allow_gaps,
        }),
        (None, Some(rate)) if rate.is_finite() && rate > 0.0 => Some(TimeAxis::Rate(rate)),
        (None, Some(rate)) => {
            return Err(PyValueError::new_err(format!(
                "sample_rate_hz must lie in (0, inf) Hz, got {rate}"
            )));
        }
        (None, None) => None,
    };
    let source = RecordSource {
        path: &path,
        signal,
        reference,
        time,
    };
    let record = py
        .detach(|| read_record_file(&source))
        .map_err(|e| PyValueError::new_err(said(&e)))?;
    let d = PyDict::new(py);
    d.set_item("signal", PyArray1::from_vec(py, record.signal))?;
    match record.reference {
        Some(r) => d.set_item("reference", PyArray1::from_vec(py, r))?,
        None => d.set_item("reference", py.None())?,
    }
    d.set_item("sample_rate_hz", record.rate)?;
    d.set_item("start_s", record.start)?;
    d.set_item("resampled", record.resampled)?;
    let safe = |lines: Vec<String>| lines.iter().map(said).collect::<Vec<_>>();
    d.set_item("notes", safe(record.notes))?;
    d.set_item("warnings", safe(record.warnings))?;
    Ok(d)
}

/// The cell of the map `text` (with `sets`) that the axis keys of `cell_sets` (`key=value`,
/// as `--set` takes them) name: `{"index": its grid index in C order, "values": {axis key:
/// the grid value the cell runs}, "snapped": [(key, given, grid value)] for each value given
/// within `CELL_SNAP_REL` of a grid value but not on it, "tolerance": CELL_SNAP_REL, "axes":
/// [(key, [values])], "settles": whether the map settles, "starts": starts per cell}`. Every
/// axis is needed, each value on its grid (`pendulum_atlas_map::map::cell::cell_index`); the
/// keys that are not axes are left out.
#[pyfunction]
fn cell_at<'py>(
    py: Python<'py>,
    text: &str,
    origin: &str,
    sets: Vec<String>,
    cell_sets: Vec<String>,
) -> PyResult<Bound<'py, PyDict>> {
    let spec = map_from_toml(text, origin, &sets).map_err(scene_error)?;
    let axis_keys: Vec<&str> = spec.axes.iter().map(|a| a.key.as_str()).collect();
    let mut coords = Vec::new();
    for s in &cell_sets {
        let (key, raw) = s.split_once('=').unwrap_or((s.as_str(), ""));
        let key = key.trim();
        if axis_keys.contains(&key) {
            let v = parse_override_value(raw);
            let x = v
                .as_float()
                .or(v.as_integer().map(|i| i as f64))
                .ok_or_else(|| {
                    SceneError::new_err(said(format!("cell(): {key} takes a number, got {raw}")))
                })?;
            coords.push((key.to_string(), x));
        }
    }
    let k = cell_index(&spec, &coords)
        .map_err(|e| SceneError::new_err(said(format!("cell(): {e}"))))?;
    let grid = cell_grid_values(&spec, k);
    let values = PyDict::new(py);
    let mut snapped = Vec::new();
    for (key, x) in &grid {
        values.set_item(key, x)?;
        if let Some(&(_, given)) = coords.iter().find(|(c, _)| c == key)
            && given.to_bits() != x.to_bits()
        {
            snapped.push((key.clone(), given, *x));
        }
    }
    let axes: Vec<(String, Vec<f64>)> = spec
        .axes
        .iter()
        .map(|a| (a.key.clone(), a.values.clone()))
        .collect();
    let d = PyDict::new(py);
    d.set_item("index", k)?;
    d.set_item("values", values)?;
    d.set_item("snapped", snapped)?;
    d.set_item("tolerance", CELL_SNAP_REL)?;
    d.set_item("axes", axes)?;
    d.set_item("settles", spec.settle_max_s.is_some())?;
    d.set_item("starts", spec.starts_per_cell())?;
    Ok(d)
}

/// The keys that pin cell `index` of the map `text` (with `sets`) to what the map ran, as
/// the explorer's download of the cell has them (`map::cell::map_cell_table`, its one
/// recipe): the method (`method`, `map.json`'s where the map's run is known, else the one its
/// plan takes), the step control, its step (`integration.dt_s` at fixed steps,
/// `integration.base_step_s` at adaptive ones) and the row rate, with the keys `others`
/// (`key=value`, not axes) set; and, for a plain map, its `[cell]` section (`cell`; with the
/// cell's `ran_on` where the map settles and its run says, and `copies`: whether the map ran
/// the cell's nudged copies, its `start_sensitivity` finite). `start`: the start of
/// `map.initial_states` whose run the map kept for the cell (its `start.npy`), whose initial
/// state the cell then has.
// Keyword arguments of one Python function: a struct would only move them.
#[allow(clippy::too_many_arguments)]
#[pyfunction]
#[pyo3(signature = (text, origin, sets, index, others, method=None, ran_on=None, start=None, copies=None))]
fn cell_pins<'py>(
    py: Python<'py>,
    text: &str,
    origin: &str,
    sets: Vec<String>,
    index: usize,
    others: Vec<String>,
    method: Option<String>,
    ran_on: Option<bool>,
    start: Option<usize>,
    copies: Option<bool>,
) -> PyResult<Bound<'py, PyDict>> {
    let spec = map_from_toml(text, origin, &sets).map_err(scene_error)?;
    if index >= spec.instances() {
        return Err(PyValueError::new_err(format!(
            "cell {index} is not one of this map's {} cells",
            spec.instances()
        )));
    }
    if let Some(s) = start
        && s >= spec.starts_per_cell()
    {
        return Err(SceneError::new_err(format!(
            "cell(): start {s} is not one of this map's {} starts per cell: the run is of another map",
            spec.starts_per_cell()
        )));
    }
    if ran_on == Some(true) && spec.settle_max_s.is_none() {
        return Err(SceneError::new_err(
            "cell(): ran_on=True, but this map does not settle (map.settle = false, or a map that cannot): none of its cells ran on",
        ));
    }
    let (pinned, keys) = py
        .detach(
            || -> Result<(toml::Table, &'static [&'static str]), EngineError> {
                let method = match method {
                    Some(m) => m,
                    None => EnsemblePlan::new(&spec)?.method.name().to_string(),
                };
                let ran = CellStages { ran_on, copies };
                map_cell_table(&spec, index, start, &method, ran, &others)
            },
        )
        .map_err(engine_error)?;
    let d = PyDict::new(py);
    for &key in keys.iter().chain([&CELL_SECTION]) {
        let Some(value) = lookup_key(&pinned, key) else {
            if key == CELL_SECTION {
                continue;
            }
            return Err(PyRuntimeError::new_err(format!("{key} was not pinned")));
        };
        d.set_item(
            key,
            convert::to_python(py, &serde_json::to_value(value).unwrap_or_default())?,
        )?;
    }
    Ok(d)
}

/// `s` as a message may quote it: its control characters and bidirectional overrides written
/// as escapes (`pendulum_atlas_core::text::printable`, as every message of the library).
#[pyfunction]
fn printable(s: &str) -> String {
    pendulum_atlas_core::text::printable(s)
}

#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("EngineError", py.get_type::<py_errors::EngineError>())?;
    m.add("DEFAULT_MAP_TOML", DEFAULT_MAP_TOML)?;
    m.add("PAPER_SCENE_TOML", PAPER_SCENE_TOML)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(set_arg, m)?)?;
    m.add_function(wrap_pyfunction!(read_map_manifest, m)?)?;
    m.add_function(wrap_pyfunction!(result_fields, m)?)?;
    m.add_function(wrap_pyfunction!(check_scene, m)?)?;
    m.add_function(wrap_pyfunction!(run_map_scene, m)?)?;
    m.add_function(wrap_pyfunction!(run_single_scene, m)?)?;
    m.add_function(wrap_pyfunction!(analyze_signal, m)?)?;
    m.add_function(wrap_pyfunction!(read_record, m)?)?;
    m.add_function(wrap_pyfunction!(cell_at, m)?)?;
    m.add_function(wrap_pyfunction!(cell_pins, m)?)?;
    m.add_function(wrap_pyfunction!(printable, m)?)?;
    Ok(())
}
