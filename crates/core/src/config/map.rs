//! Map scenes: a base scene plus a `[map]` section naming 1–3 swept keys, the metrics wanted
//! and how each instance is sampled.
//!
//! ```toml
//! [map]
//! metrics = ["K", "R", "period", "hops", "impacts_per_s", "alpha_range"]
//! [[map.axes]]
//! key = "excitation.frequency_hz"
//! start = 4.0
//! end = 12.0
//! count = 33
//! ```
//!
//! Every instance is the base scene with the axis keys set to the grid values, validated like
//! any scene, so a swept value out of range is reported with its key.

use super::continuation::ContinuationSpec;
use super::error::ConfigError;
use super::field::SceneField;
use super::mode::{MapMode, ModeKeys, RefineFollow, RefineSpec};
use super::reader::{Range, Reader, apply_override, parse_toml, set_key};
use super::scene::{ExcitationKind, Scene};
use super::settle::SettleFrom;
use super::starts::StartSet;
use super::sweep::{MapAxis, SweepList, lookup_key};
use crate::analysis::PhaseConvention;
use crate::schema::Metric;
use crate::text::num;
use rayon::prelude::*;
use serde::Serialize;
use toml::{Table, Value};

/// The embedded default map (`configs/maps/default.toml`): what `pendulum-atlas map` runs with no scene.
pub const DEFAULT_MAP_TOML: &str = include_str!("../../../../configs/maps/default.toml");

/// Largest grid accepted (instances). Beyond this the results alone need gigabytes.
pub const MAX_INSTANCES: usize = 4_000_000;

/// A validated map scene.
#[derive(Debug, Clone, Serialize)]
pub struct MapSpec {
    /// The base scene (what every instance starts from), validated.
    pub scene: Scene,
    /// The base scene table (after overrides, without `[map]`), from which instances are made.
    #[serde(skip)]
    pub base_table: Table,
    /// The whole map scene after overrides (`[map]` included): what `scene.toml` of a map
    /// folder holds, so that the map can be rerun or explored from its folder alone.
    #[serde(skip)]
    pub source_table: Table,
    /// The swept keys, 1 to 3; the grid is their Cartesian product, last axis fastest.
    pub axes: Vec<MapAxis>,
    /// The metrics to compute, in output order. Anything else is neither computed nor stored.
    pub metrics: Vec<Metric>,
    /// Draw a bifurcation diagram (1-D maps only): stroboscopic α against the axis.
    pub bifurcation: bool,
    /// Integration steps per forcing period are a multiple of this; it is also the sampling
    /// rate (per period) of the series R is computed from.
    pub samples_per_period: u32,
    /// Phase of the stroboscopic samples within the forcing period, in [0, 1).
    pub strobe_phase: f64,
    /// Longest series R is computed from (a power of two).
    pub r_max_samples: u32,
    /// Phase-difference convention of R.
    pub phase_convention: crate::analysis::PhaseConvention,
    /// Number of c values of the 0–1 test.
    pub k_n_c: usize,
    /// Seed of the c values.
    pub k_seed: u64,
    /// Longest period searched (forcing periods).
    pub period_max: u32,
    /// Number of trailing stroboscopic samples that must repeat.
    pub period_window: u32,
    /// Tolerance of the period test (rad).
    pub period_tol_rad: f64,
    /// Number of stroboscopic samples per instance kept for the bifurcation diagram.
    pub bifurcation_samples: u32,
    /// Stop instances whose periodic orbit is confirmed, their indicators continued.
    pub early_stop: bool,
    /// Relative tolerance of the early-stop confirmation (`None`: by the float type).
    pub early_stop_tol: Option<f64>,
    /// The GPU's integration kernel (`gpu.kernel`).
    pub gpu_kernel: super::GpuKernelChoice,
    /// `map.settle_max_s`: run the cells whose verdict is not firm on up to this time (s),
    /// with the early stop (`super::settle`); `None`: the map's length is final.
    pub settle_max_s: Option<f64>,
    /// `map.settle_from`: where a cell run on starts again.
    pub settle_from: SettleFrom,
    /// `map.orbits`: the orbit stage (`super::orbits`); `None`: no orbits.
    pub orbits: Option<super::OrbitSpec>,
    /// `map.transient_copies`: the nudged copies of the cells settling leaves not firm
    /// (`super::transients`); `None`: none run.
    pub transients: Option<super::TransientSpec>,
    /// How λ1's twin runs (used when `lyapunov` is among the metrics).
    pub lyapunov: LyapunovSettings,
    /// `map.accept_huge`: run a map above the size at which `map` asks first (`--yes`).
    pub accept_huge: bool,
    /// How the cells run: plain, several starts (attractors, basins), continuation or
    /// refinement, one of them.
    pub mode: MapMode,
    /// Keys set but not used (the base scene's and the map's own), for the user.
    #[serde(skip)]
    pub notes: Vec<String>,
}

/// The size of the twin's separation, `d0` in the weighted state norm (`docs/analysis.md`, §9).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Perturbation {
    /// The measured default of the engine's float type.
    Auto,
    /// This `d0`.
    Given(f64),
}

/// The largest initial separation d0 of λ1's twin accepted (`map.lyapunov_perturbation`; λ1
/// within 3.4e-3 of its small-d0 value there).
pub const SEPARATION_MAX: f64 = 1e-3;

/// `map.lyapunov_*`: how the twin trajectory of λ1 runs.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LyapunovSettings {
    /// λ1 averaged over the last this many seconds of the run (`None`: every forcing period
    /// after the transient and the alignment).
    pub window_s: Option<f64>,
    /// Renormalisations (forcing periods) before the window that align the separation.
    pub align_periods: u32,
    /// The separation d0.
    pub perturbation: Perturbation,
}

impl Default for LyapunovSettings {
    fn default() -> Self {
        LyapunovSettings {
            window_s: None,
            align_periods: 8,
            perturbation: Perturbation::Auto,
        }
    }
}

/// Runs between two checks of [`MapSpec::run_scenes_while`]'s `go_on` (a few ms of planning).
pub(crate) const PLAN_CHECK_RUNS: usize = 4096;

impl MapSpec {
    /// Shape of the grid (one entry per axis).
    pub fn shape(&self) -> Vec<usize> {
        self.axes.iter().map(|a| a.values.len()).collect()
    }

    /// Number of instances.
    pub fn instances(&self) -> usize {
        self.shape().iter().product()
    }

    /// Axis indices of instance `k` (C order: the last axis varies fastest).
    pub fn index_of(&self, k: usize) -> Vec<usize> {
        c_order_index(&self.shape(), k)
    }

    /// Axis values of instance `k`.
    pub fn values_of(&self, k: usize) -> Vec<f64> {
        grid_point(self.axes.iter().map(|a| a.values.as_slice()), k)
    }

    /// Whether a metric was asked for.
    pub fn wants(&self, m: Metric) -> bool {
        self.metrics.contains(&m)
    }

    /// The scene table of instance `k`: the base table with the axis keys set.
    pub fn instance_table(&self, k: usize) -> Result<Table, ConfigError> {
        let mut table = self.base_table.clone();
        for (axis, v) in self.axes.iter().zip(self.values_of(k)) {
            set_number(&mut table, &axis.key, v)?;
        }
        Ok(table)
    }

    /// Adaptive refinement's settings, in a refined map.
    pub fn refine(&self) -> Option<&RefineSpec> {
        match &self.mode {
            MapMode::Refined(r) => Some(r),
            _ => None,
        }
    }

    /// The continuation, in a map run by continuation.
    pub fn continuation(&self) -> Option<&ContinuationSpec> {
        match &self.mode {
            MapMode::Continuation(c) => Some(c),
            _ => None,
        }
    }

    /// The starts of `map.initial_states`, when given.
    pub fn starts(&self) -> Option<&StartSet> {
        match &self.mode {
            MapMode::Attractors { starts, .. } => starts.as_ref(),
            _ => None,
        }
    }

    /// Whether the map is a basin picture: every axis a key of the start, so that every cell
    /// runs the same scene from another start.
    pub fn is_basin_picture(&self) -> bool {
        matches!(self.mode, MapMode::Attractors { basin: true, .. })
    }

    /// Runs per cell: the starts of `map.initial_states`, or 1.
    pub fn starts_per_cell(&self) -> usize {
        self.starts().map_or(1, StartSet::len)
    }

    /// The scene table of start `s` of cell `k`: the cell's table with `initial.angle_deg`
    /// and `initial.rate_deg_s` of the start (the cell's own with one start per cell).
    pub fn start_table(&self, k: usize, s: usize) -> Result<Table, ConfigError> {
        let mut table = self.instance_table(k)?;
        self.set_start(&mut table, s)?;
        Ok(table)
    }

    /// Write start `s`'s `initial.angle_deg` and `initial.rate_deg_s` into `table` (nothing
    /// with one start per cell).
    fn set_start(&self, table: &mut Table, s: usize) -> Result<(), ConfigError> {
        if let Some(start) = self.starts().and_then(|set| set.states.get(s)) {
            set_key(table, "initial.angle_deg", Value::Float(start.angle_deg))?;
            set_key(table, "initial.rate_deg_s", Value::Float(start.rate_deg_s))?;
        }
        Ok(())
    }

    /// The validated scene of run `i` of the map's ensemble: start `i % k` of cell `i / k`
    /// with `k` starts per cell (the cell's own scene with one).
    pub fn run_scene(&self, i: usize) -> Result<Scene, ConfigError> {
        let k = self.starts_per_cell();
        if k == 1 {
            return self.instance_scene(i);
        }
        Scene::from_table(self.start_table(i / k, i % k)?).map_err(|e| ConfigError::Inconsistent {
            key: "map.initial_states".into(),
            reason: format!(
                "start {} of cell {} gives an invalid scene: {e}",
                i % k,
                i / k
            ),
        })
    }

    /// The validated scene of every run of the map's ensemble, in order: what
    /// [`MapSpec::run_scene`] gives for each.
    ///
    /// Where every swept key (and the starts' keys) is a [`SceneField`] of the base scene, the
    /// map is planned once: each swept value is validated once by the reader, on the base
    /// scene, and each run's scene is the validated base with its values set in typed fields
    /// (`config/field.rs` says why that is exact). Otherwise each run's table is read.
    pub fn run_scenes(&self) -> Result<Vec<Scene>, ConfigError> {
        Ok(self
            .run_scenes_while(&|_| true)?
            .expect("planning that always goes on ends"))
    }

    /// [`MapSpec::run_scenes`], asking `go_on(run)` at every `PLAN_CHECK_RUNS`-th run
    /// whether to go on; `None` when it said no (a cancel while a huge map is planned).
    pub(crate) fn run_scenes_while(
        &self,
        go_on: &(dyn Fn(u64) -> bool + Sync),
    ) -> Result<Option<Vec<Scene>>, ConfigError> {
        let runs = self.instances() * self.starts_per_cell();
        let goes_on = |i: usize| !i.is_multiple_of(PLAN_CHECK_RUNS) || go_on(i as u64);
        match self.typed_fields()? {
            Some(fields) => Ok((0..runs)
                .into_par_iter()
                .map(|i| goes_on(i).then(|| self.typed_run_scene(&fields, i)))
                .collect()),
            None => (0..runs)
                .into_par_iter()
                .map(|i| match goes_on(i) {
                    true => self.run_scene(i).map(Some),
                    false => Ok(None),
                })
                .collect(),
        }
    }

    /// The axes' fields, when every axis key and the starts' keys are fields that apply to
    /// the base scene, after checking every axis value and every start on the base scene.
    fn typed_fields(&self) -> Result<Option<Vec<SceneField>>, ConfigError> {
        let Some(fields) = self
            .axes
            .iter()
            .map(|a| SceneField::of_key(&a.key).filter(|f| f.applies(&self.scene)))
            .collect::<Option<Vec<_>>>()
        else {
            return Ok(None);
        };
        for axis in &self.axes {
            for &v in &axis.values {
                self.check_axis_value(axis, v)?;
            }
        }
        if let Some(set) = self.starts() {
            for s in 0..set.len() {
                self.check_start(s)?;
            }
        }
        Ok(Some(fields))
    }

    /// The reader's verdict on one axis value, set alone on the base scene's table.
    fn check_axis_value(&self, axis: &MapAxis, v: f64) -> Result<(), ConfigError> {
        let mut table = self.base_table.clone();
        set_number(&mut table, &axis.key, v)?;
        Scene::from_table(table).map_err(|e| ConfigError::Inconsistent {
            key: "map.axes".into(),
            reason: format!(
                "the grid points with {} = {} give an invalid scene: {e}",
                axis.key,
                num(v)
            ),
        })?;
        Ok(())
    }

    /// The reader's verdict on start `s` of `map.initial_states`, on the base scene's table.
    fn check_start(&self, s: usize) -> Result<(), ConfigError> {
        let mut table = self.base_table.clone();
        self.set_start(&mut table, s)?;
        Scene::from_table(table).map_err(|e| ConfigError::Inconsistent {
            key: "map.initial_states".into(),
            reason: format!("start {s} gives an invalid scene: {e}"),
        })?;
        Ok(())
    }

    /// Run `i`'s scene from the validated base and the typed fields of its axes.
    fn typed_run_scene(&self, fields: &[SceneField], i: usize) -> Scene {
        let k = self.starts_per_cell();
        let mut scene = self.scene.clone();
        for (f, v) in fields.iter().zip(self.values_of(i / k)) {
            f.set(&mut scene, v);
        }
        if let Some(start) = self.starts().and_then(|set| set.states.get(i % k)) {
            SceneField::AngleDeg.set(&mut scene, start.angle_deg);
            SceneField::RateDegS.set(&mut scene, start.rate_deg_s);
        }
        scene
    }

    /// The same map run for `duration_s` seconds, the transient lengthened so that the
    /// indicators keep their window (the settling stage's rerun, `super::settle`).
    pub fn lengthened(&self, duration_s: f64) -> Result<MapSpec, ConfigError> {
        let i = &self.scene.integration;
        let transient_s = duration_s - (i.duration_s - i.transient_s);
        let mut spec = self.clone();
        let table = &mut spec.base_table;
        set_key(table, "integration.duration_s", Value::Float(duration_s))?;
        set_key(table, "integration.transient_s", Value::Float(transient_s))?;
        spec.scene = Scene::from_table(spec.base_table.clone())?;
        spec.settle_max_s = None;
        Ok(spec)
    }

    /// Whether the map keeps each cell's end state for a stage after the reductions (settling,
    /// the orbits).
    pub fn keeps_final_state(&self) -> bool {
        self.settle_max_s.is_some() || self.orbits.is_some() || self.transients.is_some()
    }

    /// The validated scene at axis values `values` (one per axis), on the grid or between its
    /// points: the base table with the axis keys set.
    pub fn scene_at(&self, values: &[f64]) -> Result<Scene, ConfigError> {
        let mut table = self.base_table.clone();
        for (axis, &v) in self.axes.iter().zip(values) {
            set_number(&mut table, &axis.key, v)?;
        }
        Scene::from_table(table)
    }

    /// The validated scene of instance `k`: the base scene with the axis keys set.
    pub fn instance_scene(&self, k: usize) -> Result<Scene, ConfigError> {
        Scene::from_table(self.instance_table(k)?).map_err(|e| ConfigError::Inconsistent {
            key: "map.axes".into(),
            reason: format!(
                "grid point {} gives an invalid scene: {e}",
                self.axes
                    .iter()
                    .zip(self.values_of(k))
                    .map(|(a, v)| format!("{} = {}", a.key, num(v)))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        })
    }
}

/// The indices along each axis of flat index `k` of a grid of `shape` in C order (the last
/// axis varies fastest), as NumPy's `unravel_index`.
pub fn c_order_index(shape: &[usize], mut k: usize) -> Vec<usize> {
    let mut idx = vec![0; shape.len()];
    for (d, &n) in shape.iter().enumerate().rev() {
        idx[d] = k % n;
        k /= n;
    }
    idx
}

/// The values at flat index `k` (C order) of the grid spanned by `axes`.
pub fn grid_point<'a>(axes: impl Iterator<Item = &'a [f64]> + Clone, k: usize) -> Vec<f64> {
    let shape: Vec<usize> = axes.clone().map(<[f64]>::len).collect();
    c_order_index(&shape, k)
        .into_iter()
        .zip(axes)
        .map(|(i, a)| a[i])
        .collect()
}

/// Set a numeric key in a scene table, keeping integer keys integer.
fn set_number(table: &mut Table, key: &str, v: f64) -> Result<(), ConfigError> {
    let existing_int = lookup_key(table, key).is_some_and(|x| x.is_integer());
    let value = if existing_int {
        if v.fract() != 0.0 {
            return Err(ConfigError::WrongType {
                key: key.into(),
                expected: "an integer (it is swept by a map axis)".into(),
                found: format!("the number {}", num(v)),
            });
        }
        Value::Integer(v as i64)
    } else {
        Value::Float(v)
    };
    set_key(table, key, value)
}

/// The text of a scene file, or of the embedded default (`default_name` names it in errors),
/// with the origin to quote in messages.
pub fn scene_text(
    path: Option<&std::path::Path>,
    default_text: &str,
    default_name: &str,
) -> Result<(String, String), ConfigError> {
    match path {
        None => Ok((
            default_text.to_string(),
            format!("<embedded {default_name}>"),
        )),
        Some(p) => Ok((super::reader::read_scene_file(p)?, p.display().to_string())),
    }
}

/// Parse scene text, apply the `--set` overrides, and split off the tool's own `[section]`:
/// returns the scene table (without it) and the section. A missing section is an error
/// whose message ends with `hint`.
pub fn split_section(
    text: &str,
    origin: &str,
    sets: &[String],
    section: &str,
    hint: &str,
) -> Result<(Table, Table), ConfigError> {
    let mut table = parse_toml(text, origin)?;
    for s in sets {
        apply_override(&mut table, s)?;
    }
    match table.remove(section) {
        Some(Value::Table(t)) => Ok((table, t)),
        Some(_) => Err(ConfigError::WrongType {
            key: section.into(),
            expected: "a section".into(),
            found: "a value".into(),
        }),
        None => Err(ConfigError::Inconsistent {
            key: section.into(),
            reason: format!("`{origin}` has no [{section}] section: {hint}"),
        }),
    }
}

/// Refuse a `--set` of a key that `section.<array>` sweeps (`[[map.axes]]`,
/// `[[search.variables]]`): every instance sets its own value, so the override would be
/// silently replaced.
pub fn refuse_sets_on_swept(
    sets: &[String],
    section: &Table,
    array: &str,
    what: &str,
) -> Result<(), ConfigError> {
    let Some(Value::Array(items)) = section.get(array) else {
        return Ok(());
    };
    let swept: Vec<&str> = items
        .iter()
        .filter_map(|v| v.get("key").and_then(Value::as_str))
        .collect();
    for arg in sets {
        let key = arg.split_once('=').map_or(arg.as_str(), |(k, _)| k).trim();
        if swept.contains(&key) {
            return Err(ConfigError::BadOverride {
                arg: arg.clone(),
                reason: format!(
                    "`{key}` is {what}: every instance takes its own value, so --set cannot \
                     fix it; change its range in the scene file, or remove it there"
                ),
            });
        }
    }
    Ok(())
}

/// Read a map scene: `path` (or the embedded default map when `None`) with `--set` overrides.
/// Overrides may target scene keys (`excitation.amplitude_m=0.012`) or map keys
/// (`map.samples_per_period=32`).
pub fn load_map(path: Option<&std::path::Path>, sets: &[String]) -> Result<MapSpec, ConfigError> {
    let (text, origin) = scene_text(path, DEFAULT_MAP_TOML, "configs/maps/default.toml")?;
    map_from_toml(&text, &origin, sets)
}

/// Parse a map scene from TOML text.
pub fn map_from_toml(text: &str, origin: &str, sets: &[String]) -> Result<MapSpec, ConfigError> {
    let (mut table, map) = split_section(
        text,
        origin,
        sets,
        "map",
        "a map scene names its axes in [[map.axes]] (see configs/maps/)",
    )?;
    refuse_sets_on_swept(sets, &map, "axes", "an axis of this map")?;
    // [gpu] is the engine's, not the scene's: read with the map's keys.
    let gpu = table.remove("gpu");
    let mut source_table = table.clone();
    source_table.insert("map".into(), Value::Table(map.clone()));
    if let Some(g) = &gpu {
        source_table.insert("gpu".into(), g.clone());
    }
    let scene = Scene::from_table(table.clone())?;
    if !matches!(scene.excitation.kind, ExcitationKind::Harmonic { .. }) {
        return Err(ConfigError::Inconsistent {
            key: "excitation.kind".into(),
            reason:
                "maps need harmonic excitation (a stroboscopic section needs one forcing period)"
                    .into(),
        });
    }
    read_map(map, gpu, scene, (table, source_table))
}

fn read_map(
    mut map: Table,
    gpu: Option<Value>,
    scene: Scene,
    (base_table, source_table): (Table, Table),
) -> Result<MapSpec, ConfigError> {
    let axes_value = map.remove("axes");
    let metrics_value = map.remove("metrics");
    let starts_value = map.remove("initial_states");
    let mut wrapped = Table::new();
    if !map.is_empty() {
        wrapped.insert("map".into(), Value::Table(map));
    }
    super::gpu::refuse_removed(gpu.as_ref())?;
    if let Some(g) = gpu {
        wrapped.insert("gpu".into(), g);
    }
    let mut r = Reader::new(wrapped);

    let axes = MAP_AXES.read(axes_value, None, axis_refusal)?;
    let metrics = read_metrics(metrics_value, &scene)?;
    let bifurcation = r.boolean("map.bifurcation", false)?;
    if bifurcation && axes.len() != 1 {
        return Err(ConfigError::Inconsistent {
            key: "map.bifurcation".into(),
            reason: format!(
                "a bifurcation diagram needs exactly one axis, this map has {}",
                axes.len()
            ),
        });
    }
    let samples_per_period = r.integer("map.samples_per_period", 16, 4, 4096)? as u32;
    let strobe_phase = r.number("map.strobe_phase", 0.0, Range::ClosedOpen(0.0, 1.0), "")?;
    let r_max_samples = read_r_max_samples(&mut r)?;
    let phase_convention = read_phase_convention(&mut r)?;
    let k_n_c = r.integer("map.k_n_c", 100, 1, 1000)? as usize;
    let k_seed = r.integer("map.k_seed", 0, 0, i64::MAX)? as u64;
    let period_max = r.integer("map.period_max", 8, 1, 64)? as u32;
    let period_window = r.integer("map.period_window", 16, 1, 4096)? as u32;
    let period_tol_rad = r.number("map.period_tol_rad", 1e-3, Range::Positive, "rad")?;
    let bifurcation_samples = r.integer("map.bifurcation_samples", 64, 1, 4096)? as u32;
    let early_stop = r.boolean("map.early_stop", true)?;
    let early_stop_tol = read_early_stop_tol(&mut r)?;
    let gpu_kernel = super::gpu::read_kernel(&mut r)?;
    let lyapunov = read_lyapunov(&mut r)?;
    let accept_huge = r.boolean("map.accept_huge", false)?;
    let refine = read_refine(&mut r, &axes, &metrics, bifurcation)?;
    let cells = axes.iter().map(|a| a.values.len()).product();
    let axis_keys: Vec<&str> = axes.iter().map(|a| a.key.as_str()).collect();
    let starts =
        super::starts::read_starts(&mut r, starts_value, &scene, (cells, MAX_INSTANCES), &axes)?;
    let mode = MapMode::of(ModeKeys {
        starts,
        start_axis: axis_keys.iter().any(|k| START_KEYS.contains(k)),
        all_start_axes: axis_keys.iter().all(|k| START_KEYS.contains(k)),
        continuation: super::continuation::read_continuation(&mut r, &axes)?,
        refine,
    })?;
    let metrics = if matches!(mode, MapMode::Attractors { .. }) {
        with_attractor_metrics(metrics, &scene)
    } else {
        metrics
    };
    note_switched_off(&mut r, &mode, &metrics, (early_stop, bifurcation))?;
    let settle_max_s = super::settle::read_settle(
        &mut r,
        &scene,
        super::settle::SettleContext {
            metrics: &metrics,
            early_stop,
            mode: &mode,
            axes: &axes,
        },
    )?;
    let settle_from = super::settle::read_settle_from(&mut r)?;
    if settle_max_s.is_none() {
        super::scene::note_unused(&mut r, (&["map.settle_from"], "this map does not settle"))?;
    }
    let orbits = super::orbits::read_orbits(&mut r, &metrics, &mode)?;
    let transients = super::transients::read_transients(&mut r, settle_max_s.is_some())?;
    let mut notes = scene.notes.clone();
    notes.extend(r.take_notes());
    r.finish()?;

    let spec = MapSpec {
        scene,
        base_table,
        source_table,
        axes,
        metrics,
        bifurcation,
        samples_per_period,
        strobe_phase,
        r_max_samples,
        phase_convention,
        k_n_c,
        k_seed,
        period_max,
        period_window,
        period_tol_rad,
        bifurcation_samples,
        early_stop,
        early_stop_tol,
        gpu_kernel,
        settle_max_s,
        settle_from,
        transients,
        orbits,
        lyapunov,
        accept_huge,
        mode,
        notes,
    };
    // Every axis key must be a scene key that takes this kind of value, and one the scene
    // uses: check the first point.
    let first = spec.instance_scene(0)?;
    MAP_AXES.refuse_unused(&spec.axes, &first)?;
    Ok(spec)
}

/// The map's keys of a feature that is switched off are accepted, and each one set is named in
/// a note, as the scene's are ([`super::scene::note_unused`]).
fn note_switched_off(
    r: &mut Reader,
    mode: &MapMode,
    metrics: &[Metric],
    (early_stop, bifurcation): (bool, bool),
) -> Result<(), ConfigError> {
    use super::scene::note_unused;
    if !matches!(mode, MapMode::Refined(_)) {
        note_unused(
            r,
            (
                &[
                    "map.refine_spacing",
                    "map.refine_follow",
                    "map.refine_threshold",
                    "map.refine_audit",
                    "map.refine_audit_min",
                    "map.refine_seed",
                ],
                "map.refine is not true",
            ),
        )?;
    }
    if !matches!(
        mode,
        MapMode::Attractors {
            starts: Some(_),
            ..
        }
    ) {
        note_unused(
            r,
            (
                &[
                    "map.initial_angle_min_deg",
                    "map.initial_angle_max_deg",
                    "map.initial_rate_min_deg_s",
                    "map.initial_rate_max_deg_s",
                    "map.initial_seed",
                ],
                "map.initial_states does not draw starts",
            ),
        )?;
    }
    if !metrics.contains(&Metric::Lyapunov) {
        note_unused(
            r,
            (
                &[
                    "map.lyapunov_window_s",
                    "map.lyapunov_align_periods",
                    "map.lyapunov_perturbation",
                ],
                "lambda1 is not among map.metrics",
            ),
        )?;
    }
    if !bifurcation {
        note_unused(
            r,
            (&["map.bifurcation_samples"], "map.bifurcation is not true"),
        )?;
    }
    if !early_stop {
        note_unused(r, (&["map.early_stop_tol"], "map.early_stop = false"))?;
    }
    note_metric_keys(r, mode, metrics, early_stop)
}

/// The keys of an indicator the map does not form are named as unused: K's (the regime brings
/// K in), R's, and the period test's (the regime, the early stop and the attractor modes use
/// it too).
fn note_metric_keys(
    r: &mut Reader,
    mode: &MapMode,
    metrics: &[Metric],
    early_stop: bool,
) -> Result<(), ConfigError> {
    use super::scene::note_unused;
    let has = |m: Metric| metrics.contains(&m);
    if !has(Metric::K) && !has(Metric::Regime) {
        note_unused(
            r,
            (
                &["map.k_n_c", "map.k_seed"],
                "neither K nor the regime is among map.metrics",
            ),
        )?;
    }
    if !has(Metric::R) {
        note_unused(
            r,
            (
                &["map.r_max_samples", "map.phase_convention"],
                "R is not among map.metrics",
            ),
        )?;
    }
    let period_used = has(Metric::Period)
        || has(Metric::Regime)
        || early_stop
        || !matches!(mode, MapMode::Plain | MapMode::Refined(_));
    if !period_used {
        note_unused(
            r,
            (
                &["map.period_max", "map.period_window", "map.period_tol_rad"],
                "neither the period nor the regime is among map.metrics, and map.early_stop = false",
            ),
        )?;
    }
    Ok(())
}

/// `map.refine` and its keys: refused before any work when there is nothing to follow, the
/// spacing does not divide the grid, or the audit share is outside (0, 1].
fn read_refine(
    r: &mut Reader,
    axes: &[MapAxis],
    metrics: &[Metric],
    bifurcation: bool,
) -> Result<Option<RefineSpec>, ConfigError> {
    let on = r.boolean("map.refine", false)?;
    let spacing = r.integer("map.refine_spacing", 8, 2, 1024)? as u32;
    let follow = r.choice("map.refine_follow", "regime", &REFINE_FOLLOW)?;
    let threshold = r.number("map.refine_threshold", 0.1, Range::NonNegative, "")?;
    let audit_share = r.number("map.refine_audit", 0.02, Range::OpenClosed(0.0, 1.0), "")?;
    let audit_min = r.number("map.refine_audit_min", 0.98, Range::Closed(0.0, 1.0), "")?;
    let audit_seed = r.integer("map.refine_seed", 0, 0, i64::MAX)? as u64;
    if !on {
        return Ok(None);
    }
    let refused = |key: &str, reason: String| {
        Err(ConfigError::Inconsistent {
            key: key.into(),
            reason,
        })
    };
    if bifurcation {
        return refused(
            "map.refine",
            "a bifurcation diagram needs every cell's samples: set map.refine = false".into(),
        );
    }
    let follow = match follow.as_str() {
        "regime" if !metrics.contains(&Metric::Regime) => {
            return refused(
                "map.refine_follow",
                "refinement follows the regime, which this map does not compute: add \"regime\" to map.metrics, or follow one of its metrics (map.refine_follow)".into(),
            );
        }
        "regime" => RefineFollow::Regime,
        name => {
            let metric = Metric::parse(name).expect("a listed choice");
            if !metrics.contains(&metric) {
                return refused(
                    "map.refine_follow",
                    format!("refinement follows {name}, which is not among map.metrics"),
                );
            }
            RefineFollow::Metric { metric, threshold }
        }
    };
    if !spacing.is_power_of_two() {
        return Err(ConfigError::OutOfRange {
            key: "map.refine_spacing".into(),
            value: f64::from(spacing),
            range: "powers of two from 2 to 1024".into(),
        });
    }
    for a in axes.iter().filter(|a| a.values.len() > 1) {
        let cells = a.values.len() - 1;
        if cells % spacing as usize != 0 {
            let fits: Vec<String> = (1..=10)
                .map(|k| 1usize << k)
                .filter(|s| cells % s == 0)
                .map(|s| s.to_string())
                .collect();
            return refused(
                "map.refine_spacing",
                format!(
                    "spacing {spacing} does not divide the {cells} intervals of axis {} ({} values); it accepts {}, or give the axis a count of k·{spacing} + 1 values",
                    a.key,
                    a.values.len(),
                    if fits.is_empty() {
                        "no power of two".into()
                    } else {
                        fits.join(", ")
                    }
                ),
            );
        }
    }
    Ok(Some(RefineSpec {
        spacing,
        follow,
        audit_share,
        audit_min,
        audit_seed,
    }))
}

/// What `map.refine_follow` accepts: the regime, or a metric with one value per cell.
const REFINE_FOLLOW: [&str; 10] = [
    "regime",
    "K",
    "R",
    "period",
    "hops",
    "impacts_per_s",
    "power",
    "line",
    "lyapunov",
    "alpha_range",
];

/// `map.early_stop_tol`: `"auto"` (1e-5 in f64, 1e-4 in f32) or a number in (0, 0.1).
fn read_early_stop_tol(r: &mut Reader) -> Result<Option<f64>, ConfigError> {
    let key = "map.early_stop_tol";
    match r.raw(key)? {
        Some(Value::String(s)) if s == "auto" => Ok(None),
        Some(Value::String(s)) => Err(ConfigError::BadChoice {
            key: key.into(),
            value: s.clone(),
            choices: "\"auto\" or a number in (0, 0.1)".into(),
        }),
        _ => r.number_opt(key, Range::Open(0.0, 0.1), ""),
    }
}

/// `map.r_max_samples`: the longest series R is computed from, 1024 by default; a power of
/// two, since R's series are cut to power-of-two lengths.
fn read_r_max_samples(r: &mut Reader) -> Result<u32, ConfigError> {
    let r_max_samples = r.integer("map.r_max_samples", 1024, 32, 65536)? as u32;
    if !r_max_samples.is_power_of_two() {
        return Err(ConfigError::OutOfRange {
            key: "map.r_max_samples".into(),
            value: r_max_samples as f64,
            range: "powers of two in [32, 65536]".into(),
        });
    }
    Ok(r_max_samples)
}

/// `map.lyapunov_window_s`, `map.lyapunov_align_periods`, `map.lyapunov_perturbation`.
fn read_lyapunov(r: &mut Reader) -> Result<LyapunovSettings, ConfigError> {
    let key = "map.lyapunov_window_s";
    let window_s = match r.raw(key)? {
        Some(Value::String(s)) if s == "whole" => None,
        Some(Value::String(s)) => {
            return Err(ConfigError::BadChoice {
                key: key.into(),
                value: s.clone(),
                choices: "\"whole\" (the run after the transient) or a number of seconds above 0"
                    .into(),
            });
        }
        _ => r.number_opt(key, Range::Positive, "s")?,
    };
    let align_periods = r.integer("map.lyapunov_align_periods", 8, 1, 10_000)? as u32;
    let key = "map.lyapunov_perturbation";
    let perturbation = match r.raw(key)? {
        None => Perturbation::Auto,
        Some(Value::String(s)) if s == "auto" => Perturbation::Auto,
        Some(Value::String(s)) => {
            return Err(ConfigError::BadChoice {
                key: key.into(),
                value: s.clone(),
                choices: format!("\"auto\" or a number in (0, {}]", SEPARATION_MAX),
            });
        }
        Some(_) => {
            Perturbation::Given(r.number(key, 0.0, Range::OpenClosed(0.0, SEPARATION_MAX), "")?)
        }
    };
    Ok(LyapunovSettings {
        window_s,
        align_periods,
        perturbation,
    })
}

/// `map.phase_convention`: `standard` (the default) or the paper's.
fn read_phase_convention(r: &mut Reader) -> Result<PhaseConvention, ConfigError> {
    let convention = match r
        .choice("map.phase_convention", "standard", &["standard", "paper"])?
        .as_str()
    {
        "paper" => PhaseConvention::Paper,
        _ => PhaseConvention::Standard,
    };
    Ok(convention)
}

/// The keys of a start: an axis over one of them draws a basin picture.
pub(crate) const START_KEYS: [&str; 2] = ["initial.angle_deg", "initial.rate_deg_s"];

/// The metrics an attractor's fingerprint reads (`docs/analysis.md`, "Attractors"): the
/// regime (which brings λ1, the period and K), the α range, the hops and, with the piezo on,
/// the power; added to those asked for, in output order.
fn with_attractor_metrics(mut metrics: Vec<Metric>, scene: &Scene) -> Vec<Metric> {
    let mut need = vec![Metric::Regime, Metric::AlphaRange, Metric::Hops];
    need.extend_from_slice(Metric::Regime.needs());
    if scene.piezo.enabled {
        need.push(Metric::Power);
    }
    for m in need {
        if !metrics.contains(&m) {
            metrics.push(m);
        }
    }
    metrics.sort_by_key(|m| Metric::ALL.iter().position(|a| a == m));
    metrics
}

fn read_metrics(v: Option<Value>, scene: &Scene) -> Result<Vec<Metric>, ConfigError> {
    let Some(v) = v else {
        let mut all: Vec<Metric> = Metric::ALL.to_vec();
        if !scene.piezo.enabled {
            all.retain(|m| *m != Metric::Power);
        }
        return Ok(all);
    };
    let Value::Array(items) = v else {
        return Err(ConfigError::WrongType {
            key: "map.metrics".into(),
            expected: "an array of metric names".into(),
            found: "a single value".into(),
        });
    };
    let names = Metric::ALL.map(|m| format!("\"{}\"", m.name())).join(", ");
    let mut out = Vec::new();
    for item in items {
        let Value::String(s) = &item else {
            return Err(ConfigError::WrongType {
                key: "map.metrics".into(),
                expected: format!("metric names out of {names}"),
                found: format!("{item}"),
            });
        };
        let m = Metric::parse(s).ok_or_else(|| ConfigError::BadChoice {
            key: "map.metrics".into(),
            value: s.clone(),
            choices: names.clone(),
        })?;
        if m == Metric::Power && !scene.piezo.enabled {
            return Err(ConfigError::Inconsistent {
                key: "map.metrics".into(),
                reason: "metric \"power\" needs piezo.enabled = true".into(),
            });
        }
        if !out.contains(&m) {
            out.push(m);
        }
    }
    if out.is_empty() {
        return Err(ConfigError::Inconsistent {
            key: "map.metrics".into(),
            reason: "the list is empty: name at least one metric".into(),
        });
    }
    let needed: Vec<Metric> = out.iter().flat_map(|m| m.needs().iter().copied()).collect();
    for m in needed {
        if !out.contains(&m) {
            out.push(m);
        }
    }
    out.sort();
    Ok(out)
}

/// `[[map.axes]]`: 1 to 3 swept keys and at most [`MAX_INSTANCES`] grid points in all.
const MAP_AXES: SweepList = SweepList {
    section: "map.axes",
    entry: "a map axis",
    needs: "a map needs 1 to 3 axes",
    max_entries: 3,
    max_points: MAX_INSTANCES,
    points: "instances",
    example_key: "excitation.frequency_hz",
};

/// Why `key` cannot be a map axis: every instance of a map shares the segment count and the
/// excitation's kind, and map settings are not scene keys.
fn axis_refusal(key: &str) -> Option<String> {
    if key == "beam.segments" {
        return Some("every instance of a map shares one segment count (run one map per N)".into());
    }
    if key.starts_with("map.") || key.starts_with("excitation.sweep") || key == "excitation.kind" {
        return Some("map settings and the kind of excitation are shared by every instance".into());
    }
    None
}
