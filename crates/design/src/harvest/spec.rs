//! Search scenes: a harvester scene (piezo on) plus a `[search]` section naming the design
//! variables, the frequency band, the base excitation, the initial states, the bandwidth
//! threshold and the refinement.
//!
//! ```toml
//! [[search.variables]]
//! key = "limiter.clearance_deg"      # any numeric scene key
//! start = 2.0
//! end = 20.0
//! count = 4                          # or: values = [2.0, 5.0, 10.0]; scale = "log"
//! [search.band]
//! start_hz = 4.0
//! end_hz = 30.0
//! count = 53
//! base_acceleration_m_s2 = 1.0       # or base_amplitude_m = 0.001
//! [search.threshold]
//! relative_to_baseline_peak = 0.1    # or power_w = 1e-6
//! ```
//!
//! Parsing follows the scene's two phases: the raw table (with `--set` overrides) is read
//! key by key with [`Reader`], so a typo in `[search]` is an unknown key, and every design
//! variable is checked against the scene schema before any integration starts.

use pendulum_atlas_core::config::{
    ConfigError, ExcitationKind, Range, Reader, Scene, SweepList, SweptKey, refuse_sets_on_swept,
    scene_text, set_key, split_section,
};
use serde::Serialize;
use toml::{Table, Value};

/// The embedded default search (`configs/harvest/default.toml`): what `pendulum-atlas search`
/// runs with no scene.
pub const DEFAULT_SEARCH_TOML: &str = include_str!("../../../../configs/harvest/default.toml");

/// Largest number of designs in the initial grid.
pub(crate) const MAX_GRID_DESIGNS: usize = 100_000;

/// One design variable: a numeric scene key and the values the grid takes, a [`SweptKey`]
/// like a map axis.
pub type DesignVariable = SweptKey;

/// How hard the cart shakes at each frequency of the band.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum BaseExcitation {
    /// Constant acceleration amplitude a: the cart amplitude is `a/(2πf)²` (how ambient
    /// vibration is usually specified).
    Acceleration {
        /// Acceleration amplitude (m/s²).
        acceleration_m_s2: f64,
    },
    /// Constant cart amplitude A at every frequency (the acceleration grows as f²).
    Amplitude {
        /// Cart amplitude (m).
        amplitude_m: f64,
    },
}

impl BaseExcitation {
    /// Cart amplitude at frequency `f_hz` (m).
    pub fn amplitude_m(&self, f_hz: f64) -> f64 {
        match *self {
            BaseExcitation::Acceleration { acceleration_m_s2 } => {
                acceleration_m_s2 / (std::f64::consts::TAU * f_hz).powi(2)
            }
            BaseExcitation::Amplitude { amplitude_m } => amplitude_m,
        }
    }

    /// A one-line description for reports.
    pub fn describe(&self) -> String {
        match *self {
            BaseExcitation::Acceleration { acceleration_m_s2 } => format!(
                "constant base acceleration {acceleration_m_s2} m/s² ({:.3} g)",
                acceleration_m_s2 / 9.81
            ),
            BaseExcitation::Amplitude { amplitude_m } => {
                format!("constant cart amplitude {} mm", amplitude_m * 1e3)
            }
        }
    }
}

/// The frequency band the designs are judged over.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Band {
    /// Frequencies evaluated (Hz), evenly spaced from start to end.
    pub frequencies_hz: Vec<f64>,
    /// The excitation at every frequency.
    pub excitation: BaseExcitation,
}

impl Band {
    /// Lowest frequency (Hz).
    pub fn start_hz(&self) -> f64 {
        self.frequencies_hz[0]
    }

    /// Highest frequency (Hz).
    pub fn end_hz(&self) -> f64 {
        self.frequencies_hz[self.frequencies_hz.len() - 1]
    }

    /// Spacing of the frequencies (Hz).
    pub fn step_hz(&self) -> f64 {
        (self.end_hz() - self.start_hz()) / (self.frequencies_hz.len() - 1) as f64
    }
}

/// The power a frequency must reach to count towards the bandwidth.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Threshold {
    /// A fixed power (W).
    Absolute {
        /// Threshold (W).
        power_w: f64,
    },
    /// A fraction of the linear baseline's peak power.
    RelativeToBaselinePeak {
        /// Fraction of the baseline's peak (> 0).
        fraction: f64,
    },
}

impl Threshold {
    /// The threshold in watts given the baseline's peak power.
    pub fn power_w(&self, baseline_peak_w: f64) -> f64 {
        match *self {
            Threshold::Absolute { power_w } => power_w,
            Threshold::RelativeToBaselinePeak { fraction } => fraction * baseline_peak_w,
        }
    }
}

/// Where an instance starts: a straight beam at rest in one well, or any straight state.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InitialState {
    /// Name shown in reports ("+well", "-well", ...).
    pub name: String,
    /// `Some(±1)`: initial angle = ± the design's clearance (resting on that bumper).
    pub well: Option<f64>,
    /// Initial angle of every segment (deg), when `well` is not given.
    pub angle_deg: Option<f64>,
    /// Initial rate of every segment (deg/s).
    pub rate_deg_s: f64,
    /// Initial patch voltage (V).
    pub voltage_v: f64,
}

impl InitialState {
    /// The initial angle for a design with this clearance (deg).
    pub(crate) fn angle_for(&self, clearance_deg: f64) -> f64 {
        match (self.well, self.angle_deg) {
            (Some(w), _) => w * clearance_deg,
            (None, Some(a)) => a,
            (None, None) => 0.0,
        }
    }
}

/// Local refinement around the best designs (a batched multi-start compass search).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Refinement {
    /// Rounds of refinement (0: grid only).
    pub rounds: u32,
    /// Designs refined per round (the best so far).
    pub top: usize,
    /// Step of round r = grid step × shrink^r, per variable, in its step space.
    pub shrink: f64,
}

/// How the P(f) curves of a design's starts become the one curve it is ranked by.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum Weighting {
    /// At each frequency the smallest power over the named initial states: the worst start.
    Robust,
    /// At each frequency the mean power over `starts` sampled starts (a seeded Latin hypercube
    /// over the holder angle within ± the design's clearance and the rate within ±200 deg/s):
    /// the expected power of a harvester started at random, each attractor weighed by its
    /// basin fraction.
    Expected {
        /// Sampled starts per (design, frequency).
        starts: usize,
        /// Seed of the hypercube.
        seed: u64,
    },
}

impl Weighting {
    /// "robust" or "expected".
    pub fn name(self) -> &'static str {
        match self {
            Weighting::Robust => "robust",
            Weighting::Expected { .. } => "expected",
        }
    }

    /// The curve a design is ranked by, from its P(f) per start (`[start][frequency]`).
    pub fn curve(self, per_state: &[Vec<f64>]) -> Vec<f64> {
        match self {
            Weighting::Robust => super::band::robust_curve(per_state),
            Weighting::Expected { .. } => super::band::mean_curve(per_state),
        }
    }

    /// In words, for reports: what the ranked curve is.
    pub fn describe(self, states: usize) -> String {
        match self {
            Weighting::Robust => format!("robust: the smallest power over {states} initial states"),
            Weighting::Expected { starts, .. } => format!(
                "expected: the mean power over {starts} sampled starts, each attractor weighed by its basin fraction"
            ),
        }
    }
}

/// Largest sampled starts of `search.basin_starts`.
pub(crate) const MAX_BASIN_STARTS: usize = 1024;

/// Largest |holder rate| of the sampled starts of the expected weighting (deg/s).
pub(crate) const BASIN_RATE_DEG_S: f64 = 200.0;

/// What "best" means.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Objective {
    /// Widest robust bandwidth; ties (e.g. all zero) broken by robust band-averaged power.
    Bandwidth,
    /// Largest robust band-averaged power; ties broken by robust bandwidth.
    Power,
}

/// The zoomed frequency grid of the linear baseline around its first natural frequency.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BaselineZoom {
    /// Half-width of the zoom around the clamped first natural frequency (Hz).
    pub halfwidth_hz: f64,
    /// Frequencies in the zoom (0: no zoom).
    pub count: usize,
}

/// A validated search scene.
#[derive(Debug, Clone, Serialize)]
pub struct SearchSpec {
    /// The base scene (piezo on), validated.
    pub scene: Scene,
    /// The base scene table (after overrides, without `[search]`).
    #[serde(skip)]
    pub base_table: Table,
    /// The whole search scene after overrides (`[search]` included), as `search_scene.toml`
    /// keeps it.
    #[serde(skip)]
    pub source_table: Table,
    /// The design variables; the initial grid is their Cartesian product (last fastest).
    pub variables: Vec<DesignVariable>,
    /// The band and its excitation.
    pub band: Band,
    /// The bandwidth threshold.
    pub threshold: Threshold,
    /// The initial states every (design, frequency) is integrated from.
    pub initial_states: Vec<InitialState>,
    /// Refinement settings.
    pub refine: Refinement,
    /// What the ranking maximises.
    pub objective: Objective,
    /// Which curve of a design's starts the ranking reads.
    pub weighting: Weighting,
    /// Designs listed in best.md and drawn in power_vs_frequency.png.
    pub report_top: usize,
    /// Steps per forcing period are a multiple of this (ensemble sampling).
    pub samples_per_period: u32,
    /// The baseline's zoom around its resonance.
    pub baseline_zoom: BaselineZoom,
    /// Re-simulate the best design with the single-run engine of `simulate`.
    pub verify: bool,
    /// Most instances in one ensemble: larger batches run as several chunks. By default a
    /// stage's instances go to the engine together (up to `MAX_BATCH_INSTANCES`), and the
    /// GPU engine splits them by the adapter's limits; a smaller value bounds the host memory
    /// one ensemble takes.
    pub max_batch_instances: usize,
}

/// The default and the largest `search.max_batch_instances`.
pub(crate) const MAX_BATCH_INSTANCES: usize = 4_000_000;

impl SearchSpec {
    /// Number of designs in the initial grid.
    pub fn grid_designs(&self) -> usize {
        self.variables.iter().map(|v| v.values.len()).product()
    }

    /// Design `k` of the initial grid (C order: last variable fastest).
    pub(crate) fn grid_design(&self, k: usize) -> Vec<f64> {
        let mut rem = k;
        let mut out = vec![0.0; self.variables.len()];
        for (i, v) in self.variables.iter().enumerate().rev() {
            out[i] = v.values[rem % v.values.len()];
            rem /= v.values.len();
        }
        out
    }

    /// The base table with a design's values set, and the validated design scene.
    pub fn design_table(&self, values: &[f64]) -> Result<(Table, Scene), ConfigError> {
        let mut table = self.base_table.clone();
        for (v, &x) in self.variables.iter().zip(values) {
            set_number(&mut table, &v.key, x, v.integer)?;
        }
        let scene = Scene::from_table(table.clone()).map_err(|e| ConfigError::Inconsistent {
            key: "search.variables".into(),
            reason: format!(
                "the design {} gives an invalid scene: {e}",
                describe_design(&self.variables, values)
            ),
        })?;
        Ok((table, scene))
    }

    /// The scene of one instance: a design table at frequency `f_hz` from `state`.
    pub fn instance_scene(
        &self,
        design_table: &Table,
        clearance_deg: f64,
        state: &InitialState,
        f_hz: f64,
    ) -> Result<Scene, ConfigError> {
        Scene::from_table(self.instance_table(design_table, clearance_deg, state, f_hz)?)
    }

    /// The scene table of [`SearchSpec::instance_scene`].
    pub fn instance_table(
        &self,
        design_table: &Table,
        clearance_deg: f64,
        state: &InitialState,
        f_hz: f64,
    ) -> Result<Table, ConfigError> {
        let mut t = design_table.clone();
        set_number(&mut t, "excitation.frequency_hz", f_hz, false)?;
        set_number(
            &mut t,
            "excitation.amplitude_m",
            self.band.excitation.amplitude_m(f_hz),
            false,
        )?;
        set_number(
            &mut t,
            "initial.angle_deg",
            state.angle_for(clearance_deg),
            false,
        )?;
        set_number(&mut t, "initial.rate_deg_s", state.rate_deg_s, false)?;
        set_number(&mut t, "initial.voltage_v", state.voltage_v, false)?;
        Ok(t)
    }

    /// The linear baseline's table: the base scene clamped, without bumpers, at rest.
    pub(crate) fn baseline_table(&self) -> Result<Table, ConfigError> {
        let mut t = self.base_table.clone();
        for (key, value) in [
            ("pivot.mode", Value::String("clamped".into())),
            ("limiter.enabled", Value::Boolean(false)),
            ("initial.angle_deg", Value::Float(0.0)),
            ("initial.rate_deg_s", Value::Float(0.0)),
            ("initial.voltage_v", Value::Float(0.0)),
        ] {
            set_key(&mut t, key, value)?;
        }
        Ok(t)
    }
}

/// `key = value, key = value` for reports and errors.
pub(crate) fn describe_design(vars: &[DesignVariable], values: &[f64]) -> String {
    vars.iter()
        .zip(values)
        .map(|(v, x)| format!("{} = {x}", v.key))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Set a numeric key in a scene table (integers for integer keys).
fn set_number(table: &mut Table, key: &str, v: f64, integer: bool) -> Result<(), ConfigError> {
    let value = if integer {
        if v.fract() != 0.0 {
            return Err(ConfigError::WrongType {
                key: key.into(),
                expected: "an integer (it is a design variable)".into(),
                found: format!("{v}"),
            });
        }
        Value::Integer(v as i64)
    } else {
        Value::Float(v)
    };
    set_key(table, key, value)
}

/// Read a search scene: `path` (or the embedded default when `None`) with `--set` overrides,
/// which may target scene keys or `search.` keys.
pub fn load_search(
    path: Option<&std::path::Path>,
    sets: &[String],
) -> Result<SearchSpec, ConfigError> {
    let (text, origin) = scene_text(path, DEFAULT_SEARCH_TOML, "configs/harvest/default.toml")?;
    search_from_toml(&text, &origin, sets)
}

/// Parse a search scene from TOML text.
pub fn search_from_toml(
    text: &str,
    origin: &str,
    sets: &[String],
) -> Result<SearchSpec, ConfigError> {
    let (table, search) = split_section(
        text,
        origin,
        sets,
        "search",
        "a search scene names its design variables and band (see configs/harvest/)",
    )?;
    refuse_sets_on_swept(
        sets,
        &search,
        "variables",
        "a design variable of this search",
    )?;
    let mut source_table = table.clone();
    source_table.insert("search".into(), Value::Table(search.clone()));
    let scene = Scene::from_table(table.clone())?;
    if !scene.piezo.enabled {
        return Err(ConfigError::Inconsistent {
            key: "piezo.enabled".into(),
            reason: "a harvesting search needs the piezo patch: set piezo.enabled = true".into(),
        });
    }
    if !matches!(scene.excitation.kind, ExcitationKind::Harmonic { .. }) {
        return Err(ConfigError::Inconsistent {
            key: "excitation.kind".into(),
            reason: "a search shakes the cart harmonically at each frequency of the band".into(),
        });
    }
    let mut spec = read_search(search, scene, table)?;
    spec.source_table = source_table;
    Ok(spec)
}

/// Read the `[search]` table (variables and initial states already taken out) and check
/// the design variables against the scene schema.
fn read_search(
    mut search: Table,
    scene: Scene,
    base_table: Table,
) -> Result<SearchSpec, ConfigError> {
    let vars_value = search.remove("variables");
    let initial_value = search.remove("initial");
    let mut wrapped = Table::new();
    if !search.is_empty() {
        wrapped.insert("search".into(), Value::Table(search));
    }
    let mut r = Reader::new(wrapped);
    let variables = SEARCH_VARIABLES.read(vars_value, Some(&base_table), |k| {
        reserved(k).map(String::from)
    })?;
    let band = read_band(&mut r)?;
    let threshold = read_threshold(&mut r)?;
    let weighting = read_weighting(&mut r, initial_value.is_some())?;
    let initial_states = match weighting {
        Weighting::Robust => read_initial_states(initial_value)?,
        Weighting::Expected { starts, seed } => sampled_states(starts, seed),
    };
    let refine = Refinement {
        rounds: r.integer("search.refine.rounds", 2, 0, 20)? as u32,
        top: r.integer("search.refine.top", 4, 1, 1000)? as usize,
        shrink: r.number("search.refine.shrink", 0.5, Range::Open(0.0, 1.0), "")?,
    };
    let objective = match r
        .choice("search.objective", "bandwidth", &["bandwidth", "power"])?
        .as_str()
    {
        "power" => Objective::Power,
        _ => Objective::Bandwidth,
    };
    let report_top = r.integer("search.report_top", 5, 1, 20)? as usize;
    let samples_per_period = r.integer("search.samples_per_period", 16, 4, 4096)? as u32;
    let baseline_zoom = BaselineZoom {
        halfwidth_hz: r.number(
            "search.baseline.zoom_halfwidth_hz",
            band.step_hz(),
            Range::Positive,
            "Hz",
        )?,
        count: r.integer("search.baseline.zoom_count", 41, 0, 10_000)? as usize,
    };
    let verify = r.boolean("search.verify", true)?;
    let accept_huge = r.boolean("search.accept_huge", false)?;
    let max_batch_instances = r.integer(
        "search.max_batch_instances",
        MAX_BATCH_INSTANCES as i64,
        1,
        MAX_BATCH_INSTANCES as i64,
    )? as usize;
    r.finish()?;
    let spec = SearchSpec {
        scene,
        base_table,
        source_table: Table::new(),
        variables,
        band,
        threshold,
        initial_states,
        refine,
        objective,
        weighting,
        report_top,
        samples_per_period,
        baseline_zoom,
        verify,
        max_batch_instances,
    };
    check_variables(&spec)?;
    check_size(&spec, accept_huge)?;
    let first: Vec<f64> = spec.variables.iter().map(|v| v.values[0]).collect();
    SEARCH_VARIABLES.refuse_unused(&spec.variables, &spec.design_table(&first)?.1)?;
    Ok(spec)
}

/// Refuse a search whose first round alone is above the map's guard
/// ([`pendulum_atlas_map::map::size::HUGE_WORK`] instance-steps: designs × frequencies ×
/// starts runs of the base scene's steps) unless `search.accept_huge`: refused before any
/// work, with its figures, instead of running for hours.
fn check_size(spec: &SearchSpec, accepted: bool) -> Result<(), ConfigError> {
    use pendulum_atlas_map::map::size::HUGE_WORK;
    let Ok(plan) = pendulum_atlas_core::engine::StepPlan::for_scene(&spec.scene) else {
        return Ok(()); // the run itself names what its scene lacks
    };
    let (designs, band) = (spec.grid_designs(), spec.band.frequencies_hz.len());
    let starts = spec.initial_states.len().max(1);
    let work = designs as f64 * band as f64 * starts as f64 * plan.steps as f64;
    if accepted || work <= HUGE_WORK {
        return Ok(());
    }
    Err(ConfigError::Inconsistent {
        key: "search.band.count".into(),
        reason: format!(
            "the first round alone is {designs} designs × {band} frequencies × {starts} starts of about {} steps ({work:.2e} instance-steps, above {HUGE_WORK:.0e}, hours of work): use fewer frequencies, designs (search.variables) or starts, or set search.accept_huge = true to run it",
            plan.steps
        ),
    })
}

/// `[search.band]`: the frequencies and the base excitation (acceleration or amplitude).
fn read_band(r: &mut Reader) -> Result<Band, ConfigError> {
    let start = r
        .number_opt("search.band.start_hz", Range::Positive, "Hz")?
        .ok_or_else(|| missing("search.band.start_hz", "the band's lowest frequency"))?;
    let end = r
        .number_opt("search.band.end_hz", Range::Positive, "Hz")?
        .ok_or_else(|| missing("search.band.end_hz", "the band's highest frequency"))?;
    let count = r.integer("search.band.count", 0, 0, 100_000)? as usize;
    if count < 2 {
        return Err(ConfigError::Inconsistent {
            key: "search.band.count".into(),
            reason: format!(
                "the band is empty or a single point (count = {count}): give at least 2 frequencies"
            ),
        });
    }
    if end <= start {
        return Err(ConfigError::Inconsistent {
            key: "search.band.end_hz".into(),
            reason: format!("the band is empty: end_hz = {end} must exceed start_hz = {start}"),
        });
    }
    let acc = r.number_opt(
        "search.band.base_acceleration_m_s2",
        Range::Positive,
        "m/s^2",
    )?;
    let amp = r.number_opt("search.band.base_amplitude_m", Range::Positive, "m")?;
    let excitation = match (acc, amp) {
        (Some(a), None) => BaseExcitation::Acceleration {
            acceleration_m_s2: a,
        },
        (None, Some(a)) => BaseExcitation::Amplitude { amplitude_m: a },
        (Some(_), Some(_)) => {
            return Err(ConfigError::Inconsistent {
                key: "search.band.base_amplitude_m".into(),
                reason: "give either base_acceleration_m_s2 or base_amplitude_m, not both".into(),
            });
        }
        (None, None) => {
            return Err(missing(
                "search.band.base_acceleration_m_s2",
                "the excitation: base_acceleration_m_s2 (constant acceleration) or base_amplitude_m (constant cart amplitude)",
            ));
        }
    };
    let frequencies_hz = (0..count)
        .map(|j| start + (end - start) * j as f64 / (count - 1) as f64)
        .collect();
    Ok(Band {
        frequencies_hz,
        excitation,
    })
}

/// `[search.threshold]`: absolute (`power_w`) or relative to the baseline's peak.
fn read_threshold(r: &mut Reader) -> Result<Threshold, ConfigError> {
    let rel = r.number_opt(
        "search.threshold.relative_to_baseline_peak",
        Range::Positive,
        "",
    )?;
    let abs = r.number_opt("search.threshold.power_w", Range::NonNegative, "W")?;
    match (rel, abs) {
        (Some(f), None) => Ok(Threshold::RelativeToBaselinePeak { fraction: f }),
        (None, Some(p)) => Ok(Threshold::Absolute { power_w: p }),
        (Some(_), Some(_)) => Err(ConfigError::Inconsistent {
            key: "search.threshold.power_w".into(),
            reason: "give either power_w or relative_to_baseline_peak, not both".into(),
        }),
        (None, None) => Err(missing(
            "search.threshold.relative_to_baseline_peak",
            "the bandwidth threshold: relative_to_baseline_peak (fraction of the linear baseline's peak) or power_w",
        )),
    }
}

/// A required key that is absent, with what to give.
fn missing(key: &str, what: &str) -> ConfigError {
    ConfigError::Inconsistent {
        key: key.into(),
        reason: format!("missing: give {what}"),
    }
}

/// `search.weighting` with `search.basin_starts` and `search.basin_seed`; named initial states
/// (`named`) are refused with the expected weighting, which samples its own.
fn read_weighting(r: &mut Reader, named: bool) -> Result<Weighting, ConfigError> {
    let kind = r.choice("search.weighting", "robust", &["robust", "expected"])?;
    let starts = r.integer("search.basin_starts", 16, 2, MAX_BASIN_STARTS as i64)? as usize;
    let seed = r.integer("search.basin_seed", 0, 0, i64::MAX)? as u64;
    if kind == "robust" {
        for key in ["search.basin_starts", "search.basin_seed"] {
            if r.given(key)? {
                return Err(ConfigError::Inconsistent {
                    key: key.into(),
                    reason: "is only read with search.weighting = \"expected\"".into(),
                });
            }
        }
        return Ok(Weighting::Robust);
    }
    if named {
        return Err(ConfigError::Inconsistent {
            key: "search.initial".into(),
            reason: "the expected weighting samples its own starts (search.basin_starts) so that each attractor counts by its basin; named [[search.initial]] states go with search.weighting = \"robust\"".into(),
        });
    }
    Ok(Weighting::Expected { starts, seed })
}

/// The sampled starts of the expected weighting: the angle as a share of the design's
/// clearance (a `well` in (−1, 1)), the rate within ±[`BASIN_RATE_DEG_S`].
fn sampled_states(starts: usize, seed: u64) -> Vec<InitialState> {
    let rate = (-BASIN_RATE_DEG_S, BASIN_RATE_DEG_S);
    pendulum_atlas_core::config::latin_hypercube(starts, (-1.0, 1.0), rate, seed)
        .into_iter()
        .enumerate()
        .map(|(i, s)| InitialState {
            name: format!("start {}", i + 1),
            well: Some(s.angle_deg),
            angle_deg: None,
            rate_deg_s: s.rate_deg_s,
            voltage_v: 0.0,
        })
        .collect()
}

/// `[[search.initial]]`: the initial states (both wells when absent).
fn read_initial_states(v: Option<Value>) -> Result<Vec<InitialState>, ConfigError> {
    let items = match v {
        None => {
            return Ok(vec![well_state(1.0, 0.0, 0.0), well_state(-1.0, 0.0, 0.0)]);
        }
        Some(Value::Array(items)) => items,
        Some(_) => {
            return Err(ConfigError::WrongType {
                key: "search.initial".into(),
                expected: "an array of tables ([[search.initial]])".into(),
                found: "a single value".into(),
            });
        }
    };
    if items.is_empty() {
        return Err(ConfigError::Inconsistent {
            key: "search.initial".into(),
            reason: "the list of initial states is empty".into(),
        });
    }
    items
        .into_iter()
        .enumerate()
        .map(|(i, item)| read_initial_state(&format!("search.initial[{}]", i + 1), item))
        .collect()
}

/// One `[[search.initial]]` table at `prefix`: a well or an angle, a rate, a voltage and an
/// optional name.
fn read_initial_state(prefix: &str, item: Value) -> Result<InitialState, ConfigError> {
    let Value::Table(t) = item else {
        return Err(ConfigError::WrongType {
            key: prefix.to_string(),
            expected: "a table with well or angle_deg".into(),
            found: "a value".into(),
        });
    };
    let mut r = Reader::new(wrap(prefix, t));
    let well = r.number_opt(&format!("{prefix}.well"), Range::Closed(-1.0, 1.0), "")?;
    let angle = r.number_opt(
        &format!("{prefix}.angle_deg"),
        Range::Open(-90.0, 90.0),
        "deg",
    )?;
    let rate = r.number(&format!("{prefix}.rate_deg_s"), 0.0, Range::Any, "deg/s")?;
    let volt = r.number(&format!("{prefix}.voltage_v"), 0.0, Range::Any, "V")?;
    let name = match r.raw(&format!("{prefix}.name"))? {
        Some(Value::String(s)) => Some(s.clone()),
        Some(other) => {
            return Err(ConfigError::WrongType {
                key: format!("{prefix}.name"),
                expected: "a string".into(),
                found: format!("{other}"),
            });
        }
        None => None,
    };
    r.finish()?;
    let mut s = start_state(prefix, well, angle, rate, volt)?;
    if let Some(n) = name {
        s.name = n;
    }
    Ok(s)
}

/// The state a `[[search.initial]]` entry gives: on the bumper of `well` (±1), or at `angle`
/// (deg); exactly one of them.
fn start_state(
    prefix: &str,
    well: Option<f64>,
    angle: Option<f64>,
    rate: f64,
    volt: f64,
) -> Result<InitialState, ConfigError> {
    match (well, angle) {
        (Some(w), None) if w == 1.0 || w == -1.0 => Ok(well_state(w, rate, volt)),
        (Some(w), None) => Err(ConfigError::OutOfRange {
            key: format!("{prefix}.well"),
            value: w,
            range: "1 (positive bumper) or -1 (negative bumper)".into(),
        }),
        (None, Some(a)) => Ok(InitialState {
            name: format!("{a} deg, {rate} deg/s"),
            well: None,
            angle_deg: Some(a),
            rate_deg_s: rate,
            voltage_v: volt,
        }),
        (Some(_), Some(_)) => Err(ConfigError::Inconsistent {
            key: format!("{prefix}.angle_deg"),
            reason: "give either well (±1: on a bumper) or angle_deg, not both".into(),
        }),
        (None, None) => Err(missing(
            &format!("{prefix}.well"),
            "well = 1 or -1 (straight beam on that bumper) or angle_deg",
        )),
    }
}

/// A straight beam at rest (or at `rate`) on the bumper of well `w` (±1).
fn well_state(w: f64, rate: f64, volt: f64) -> InitialState {
    let mut name = if w > 0.0 { "+well" } else { "-well" }.to_string();
    if rate != 0.0 {
        name.push_str(&format!(", {rate} deg/s"));
    }
    InitialState {
        name,
        well: Some(w),
        angle_deg: None,
        rate_deg_s: rate,
        voltage_v: volt,
    }
}

/// Nest `t` under a dotted prefix such as `search.variables[2]` so that [`Reader`] reports
/// the full key.
fn wrap(prefix: &str, t: Table) -> Table {
    let (head, tail) = prefix.split_once('.').expect("dotted prefix");
    let mut inner = Table::new();
    inner.insert(tail.to_string(), Value::Table(t));
    let mut outer = Table::new();
    outer.insert(head.to_string(), Value::Table(inner));
    outer
}

/// Keys the search itself sets, with the reason they cannot be design variables.
fn reserved(key: &str) -> Option<&'static str> {
    match key {
        "excitation.frequency_hz" | "excitation.amplitude_m" => {
            Some("the band ([search.band]) sets the frequency and the cart amplitude")
        }
        k if k.starts_with("excitation.") => Some("a search uses harmonic excitation"),
        k if k.starts_with("initial.") => {
            Some("the initial states are listed in [[search.initial]]")
        }
        "beam.segments" => {
            Some("every instance of an ensemble shares one segment count: run one search per N")
        }
        "limiter.enabled" | "piezo.enabled" => {
            Some("every instance of an ensemble shares the bumpers and the piezo")
        }
        k if k.starts_with("search.") => Some("it is a search setting, not a scene key"),
        _ => None,
    }
}

/// `[[search.variables]]`: 1 or more swept keys, at most [`MAX_GRID_DESIGNS`] grid designs.
const SEARCH_VARIABLES: SweepList = SweepList {
    section: "search.variables",
    entry: "a design variable",
    needs: "a search needs at least one design variable",
    max_entries: usize::MAX,
    max_points: MAX_GRID_DESIGNS,
    points: "designs",
    example_key: "limiter.clearance_deg",
};

/// Every variable must be a numeric scene key, and each of its values must give a valid
/// scene (the other variables at their first value): checked before any work starts.
fn check_variables(spec: &SearchSpec) -> Result<(), ConfigError> {
    let first: Vec<f64> = spec.variables.iter().map(|v| v.values[0]).collect();
    for (i, var) in spec.variables.iter().enumerate() {
        let prefix = format!("search.variables[{}]", i + 1);
        for &x in &var.values {
            let mut values = first.clone();
            values[i] = x;
            let mut table = spec.base_table.clone();
            for (v, &y) in spec.variables.iter().zip(&values) {
                set_number(&mut table, &v.key, y, v.integer)?;
            }
            if let Err(e) = Scene::from_table(table) {
                let reason = match &e {
                    ConfigError::UnknownKey { key, suggestion } if *key == var.key => format!(
                        "`{}` is not a scene key{}",
                        var.key,
                        suggestion
                            .as_ref()
                            .map(|s| format!(" (did you mean `{s}`?)"))
                            .unwrap_or_default()
                    ),
                    ConfigError::WrongType { key, .. } if *key == var.key => {
                        format!("`{}` cannot be a design variable: {e}", var.key)
                    }
                    _ => format!("{} = {x} gives an invalid scene: {e}", var.key),
                };
                return Err(ConfigError::Inconsistent {
                    key: format!("{prefix}.key"),
                    reason,
                });
            }
        }
    }
    Ok(())
}
