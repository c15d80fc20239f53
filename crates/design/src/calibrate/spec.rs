//! A calibration scene: a scene plus a `[calibrate]` section, validated into a
//! [`CalibrationSpec`] before any work.
//!
//! ```toml
//! [calibrate]
//! initial_states = 3          # runs per case, initial.angle_deg spread over ± initial_spread_deg
//! initial_spread_deg = 1.0
//! agreement = 0.67            # share of a case's ok runs that must match an observation
//! phase_convention = "paper"  # R's convention ("standard" or "paper")
//! samples_per_period = 16
//! refine = { rounds = 1, top = 3, shrink = 0.5 }
//!
//! [[calibrate.unknowns]]      # like a map axis: key, start, end, count (or values), scale
//! key = "limiter.contact_arc_m"
//! start = 0.1
//! end = 0.35
//! count = 4
//!
//! [[calibrate.cases]]
//! name = "10 Hz, 12 mm"
//! set = { "excitation.frequency_hz" = 10.0, "excitation.amplitude_m" = 0.012 }
//! k_class = "regular"         # or "chaotic"
//! k = { value = 0.0, tol = 0.2 }
//! r = { value = 0.88, tol = 0.1 }
//! period = 3                  # 0: not periodic (no period up to 8)
//! line = "1/3"                # dominant line of α at f/3, within 5 % (or { fraction = "1/3", tol = 0.05 })
//! hops = false
//! alpha_range_rad = [0.1, 0.3]
//! ```

use super::observe::Observation;
use pendulum_atlas_core::analysis::PhaseConvention;
use pendulum_atlas_core::config::{
    ConfigError, MAX_INSTANCES, Range, Reader, Scene, SweepList, SweptKey, entry_tables, set_key,
    split_section,
};
use pendulum_atlas_core::reduce::ReduceOptions;
use serde::Serialize;
use toml::{Table, Value};

/// Largest number of grid candidates.
pub(crate) const MAX_CANDIDATES: usize = 10_000;

/// One unknown parameter: a scene key and the values the coarse grid takes, a [`SweptKey`]
/// like a design variable of the harvesting search (the same step space and refinement).
pub type Unknown = SweptKey;

/// One observed setting and what was observed there.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Case {
    /// Name for tables.
    pub name: String,
    /// Scene overrides of this case (key, value).
    pub set: Vec<(String, Value)>,
    /// The observations.
    pub observations: Vec<Observation>,
}

/// Refinement around the best candidates.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Refine {
    /// Rounds after the grid.
    pub rounds: u32,
    /// Candidates refined around per round.
    pub top: usize,
    /// Step factor per round.
    pub shrink: f64,
}

/// A validated calibration.
#[derive(Debug, Clone)]
pub struct CalibrationSpec {
    /// The scene with the `[calibrate]` section removed.
    pub base_table: Table,
    /// The whole calibration scene after overrides (`[calibrate]` included), as
    /// `calibrate_scene.toml` keeps it.
    pub source_table: Table,
    /// The unknowns.
    pub unknowns: Vec<Unknown>,
    /// The cases.
    pub cases: Vec<Case>,
    /// Runs per case.
    pub initial_states: u32,
    /// Spread of the initial angles (deg).
    pub initial_spread_deg: f64,
    /// Share of ok runs that must match.
    pub agreement: f64,
    /// R's convention.
    pub convention: PhaseConvention,
    /// Integration steps per forcing period (as a map's).
    pub samples_per_period: u32,
    /// Refinement.
    pub refine: Refine,
}

impl CalibrationSpec {
    /// The initial-angle offsets of a case's runs (deg): evenly over ± the spread, 0 for one.
    pub fn angle_offsets_deg(&self) -> Vec<f64> {
        let n = self.initial_states as usize;
        if n == 1 {
            return vec![0.0];
        }
        let s = self.initial_spread_deg;
        (0..n)
            .map(|i| -s + 2.0 * s * i as f64 / (n - 1) as f64)
            .collect()
    }

    /// The scene of `case` for a candidate's unknowns from initial-angle offset `offset_deg`.
    pub fn scene(
        &self,
        case: &Case,
        values: &[f64],
        offset_deg: f64,
    ) -> Result<Scene, ConfigError> {
        Scene::from_table(self.scene_table(case, values, offset_deg)?)
    }

    /// The scene table of [`CalibrationSpec::scene`].
    pub fn scene_table(
        &self,
        case: &Case,
        values: &[f64],
        offset_deg: f64,
    ) -> Result<Table, ConfigError> {
        let mut table = self.base_table.clone();
        for (k, v) in &case.set {
            set_key(&mut table, k, v.clone())?;
        }
        for (u, &x) in self.unknowns.iter().zip(values) {
            set_key(&mut table, &u.key, Value::Float(x))?;
        }
        let angle = Scene::from_table(table.clone())?.initial.angle_deg + offset_deg;
        set_key(&mut table, "initial.angle_deg", Value::Float(angle))?;
        Ok(table)
    }
}

/// Read a calibration scene file with `--set` overrides (scene or `calibrate.` keys).
pub fn load_calibration(
    path: &std::path::Path,
    sets: &[String],
) -> Result<CalibrationSpec, ConfigError> {
    let text = pendulum_atlas_core::config::read_scene_file(path)?;
    calibration_from_toml(&text, &path.display().to_string(), sets)
}

/// Parse a calibration scene from TOML text with `--set` overrides.
pub fn calibration_from_toml(
    text: &str,
    origin: &str,
    sets: &[String],
) -> Result<CalibrationSpec, ConfigError> {
    let (base_table, mut section) = split_section(
        text,
        origin,
        sets,
        "calibrate",
        "a calibration lists its [[calibrate.cases]] and [[calibrate.unknowns]]",
    )?;
    Scene::from_table(base_table.clone())?;
    let mut source_table = base_table.clone();
    source_table.insert("calibrate".into(), Value::Table(section.clone()));
    let unknowns = UNKNOWNS.read(section.remove("unknowns"), None, |k| {
        reserved(k).map(String::from)
    })?;
    let cases = read_cases(section.remove("cases"), &unknowns)?;
    let mut r = Reader::new(wrap("calibrate", section));
    let spec = CalibrationSpec {
        base_table,
        source_table,
        unknowns,
        cases,
        initial_states: r.integer("calibrate.initial_states", 3, 1, 64)? as u32,
        initial_spread_deg: r.number(
            "calibrate.initial_spread_deg",
            1.0,
            Range::NonNegative,
            "deg",
        )?,
        agreement: r.number(
            "calibrate.agreement",
            2.0 / 3.0,
            Range::OpenClosed(0.0, 1.0),
            "",
        )?,
        convention: match r
            .choice(
                "calibrate.phase_convention",
                "paper",
                &["standard", "paper"],
            )?
            .as_str()
        {
            "standard" => PhaseConvention::Standard,
            _ => PhaseConvention::Paper,
        },
        samples_per_period: r.integer("calibrate.samples_per_period", 16, 4, 4096)? as u32,
        refine: Refine {
            rounds: r.integer("calibrate.refine.rounds", 1, 0, 10)? as u32,
            top: r.integer("calibrate.refine.top", 3, 1, 100)? as usize,
            shrink: r.number("calibrate.refine.shrink", 0.5, Range::Open(0.0, 1.0), "")?,
        },
    };
    r.finish()?;
    check_size(&spec)?;
    check_scenes(&spec)?;
    Ok(spec)
}

/// `{prefix}` as nested tables around `t` (`a.b` → `{a = {b = t}}`); nothing for an empty `t`,
/// which would otherwise be a key nobody reads.
fn wrap(prefix: &str, t: Table) -> Table {
    if t.is_empty() {
        return t;
    }
    let mut out = t;
    for part in prefix.rsplit('.') {
        let mut outer = Table::new();
        outer.insert(part.to_string(), Value::Table(out));
        out = outer;
    }
    out
}

/// The non-empty array of tables at `key`.
fn tables(v: Option<Value>, key: &str, what: &str) -> Result<Vec<Table>, ConfigError> {
    let items = match v {
        Some(Value::Array(items)) if !items.is_empty() => items,
        Some(Value::Array(_)) | None => {
            return Err(ConfigError::Inconsistent {
                key: key.into(),
                reason: format!("a calibration needs at least one: {what}"),
            });
        }
        Some(_) => {
            return Err(ConfigError::WrongType {
                key: key.into(),
                expected: format!("an array of tables ([[{key}]])"),
                found: "a single value".into(),
            });
        }
    };
    entry_tables(key, items, "a table")
}

/// Keys a calibration sets itself.
fn reserved(key: &str) -> Option<&'static str> {
    match key {
        k if k.starts_with("excitation.") => Some("the cases set the excitation"),
        k if k.starts_with("initial.") => Some("the initial states are calibrate.initial_*"),
        "beam.segments" | "limiter.enabled" | "piezo.enabled" => {
            Some("every instance of an ensemble shares N, the bumpers and the piezo")
        }
        _ => None,
    }
}

/// `[[calibrate.unknowns]]`: 1 or more swept keys, at most [`MAX_CANDIDATES`] grid points.
const UNKNOWNS: SweepList = SweepList {
    section: "calibrate.unknowns",
    entry: "an unknown",
    needs: "a calibration needs at least one unknown",
    max_entries: usize::MAX,
    max_points: MAX_CANDIDATES,
    points: "candidates",
    example_key: "limiter.contact_arc_m",
};

/// `[[calibrate.cases]]`: a name, overrides and at least one observation each.
fn read_cases(v: Option<Value>, unknowns: &[Unknown]) -> Result<Vec<Case>, ConfigError> {
    let items = tables(
        v,
        "calibrate.cases",
        "a name, its `set` and its observations",
    )?;
    items
        .into_iter()
        .enumerate()
        .map(|(i, t)| read_case(&format!("calibrate.cases[{}]", i + 1), t, unknowns))
        .collect()
}

fn read_case(prefix: &str, mut t: Table, unknowns: &[Unknown]) -> Result<Case, ConfigError> {
    let name = match t.remove("name") {
        Some(Value::String(s)) => s,
        None => prefix.to_string(),
        Some(other) => {
            return Err(ConfigError::WrongType {
                key: format!("{prefix}.name"),
                expected: "a string".into(),
                found: format!("{other}"),
            });
        }
    };
    let set = match t.remove("set") {
        Some(Value::Table(s)) => s.into_iter().collect::<Vec<_>>(),
        None => Vec::new(),
        Some(_) => {
            return Err(ConfigError::WrongType {
                key: format!("{prefix}.set"),
                expected: "a table of scene keys, e.g. { \"excitation.frequency_hz\" = 8.0 }"
                    .into(),
                found: "a value".into(),
            });
        }
    };
    if let Some((k, _)) = set
        .iter()
        .find(|(k, _)| unknowns.iter().any(|u| &u.key == k))
    {
        return Err(ConfigError::Inconsistent {
            key: format!("{prefix}.set"),
            reason: format!("`{k}` is an unknown of this calibration: a case cannot fix it"),
        });
    }
    let observations = read_observations(prefix, t)?;
    Ok(Case {
        name,
        set,
        observations,
    })
}

/// The observations of one case, in a fixed order.
fn read_observations(prefix: &str, t: Table) -> Result<Vec<Observation>, ConfigError> {
    let mut r = Reader::new(wrap(prefix, t));
    let key = |k: &str| format!("{prefix}.{k}");
    let mut out = Vec::new();
    if r.raw(&key("k_class"))?.is_some() {
        let c = r.choice(&key("k_class"), "chaotic", &["chaotic", "regular"])?;
        out.push(Observation::KClass {
            chaotic: c == "chaotic",
        });
    }
    if let Some((value, tol)) = value_tol(&mut r, &key("k"), Range::Closed(-0.5, 1.5))? {
        out.push(Observation::K { value, tol });
    }
    if let Some((value, tol)) = value_tol(&mut r, &key("r"), Range::Closed(0.0, 1.0))? {
        out.push(Observation::R { value, tol });
    }
    if r.raw(&key("period"))?.is_some() {
        let max = i64::from(ReduceOptions::default().period_max);
        let period = r.integer(&key("period"), 1, 0, max)? as u32;
        out.push(Observation::Period { period });
    }
    if let Some(line) = line(&mut r, &key("line"))? {
        out.push(line);
    }
    if r.raw(&key("hops"))?.is_some() {
        out.push(Observation::Hops {
            hops: r.boolean(&key("hops"), false)?,
        });
    }
    if let Some(range) = alpha_range(&mut r, &key("alpha_range_rad"))? {
        out.push(range);
    }
    r.finish()?;
    if out.is_empty() {
        return Err(ConfigError::Inconsistent {
            key: prefix.into(),
            reason: "a case needs at least one observation: k_class, k, r, period, line, hops or alpha_range_rad".into(),
        });
    }
    Ok(out)
}

/// `{ value = v, tol = t }` with `v` in `range` and `t > 0`.
fn value_tol(r: &mut Reader, key: &str, range: Range) -> Result<Option<(f64, f64)>, ConfigError> {
    if r.raw(key)?.is_none() {
        return Ok(None);
    }
    let value = r.number_opt(&format!("{key}.value"), range, "")?;
    let tol = r.number_opt(&format!("{key}.tol"), Range::Positive, "")?;
    match (value, tol) {
        (Some(v), Some(t)) => Ok(Some((v, t))),
        _ => Err(ConfigError::Inconsistent {
            key: key.into(),
            reason: "give both the observed value and its tolerance: { value = 0.9, tol = 0.1 }"
                .into(),
        }),
    }
}

/// Default relative tolerance of a line observation.
pub(crate) const LINE_REL_TOL: f64 = 0.05;

/// `"p/q"` or `{ fraction = "p/q", tol = t }`: the dominant line at `p/q` of the forcing
/// frequency within the relative tolerance `t` (default [`LINE_REL_TOL`]).
fn line(r: &mut Reader, key: &str) -> Result<Option<Observation>, ConfigError> {
    let Some(v) = r.raw(key)?.cloned() else {
        return Ok(None);
    };
    let (text, rel_tol) = match &v {
        Value::String(s) => (s.clone(), LINE_REL_TOL),
        Value::Table(_) => {
            let f = r
                .raw(&format!("{key}.fraction"))?
                .and_then(|f| f.as_str().map(str::to_string));
            let tol = r.number_opt(&format!("{key}.tol"), Range::Open(0.0, 1.0), "")?;
            (f.unwrap_or_default(), tol.unwrap_or(LINE_REL_TOL))
        }
        _ => (String::new(), LINE_REL_TOL),
    };
    let fraction = text.split_once('/').and_then(|(p, q)| {
        let (p, q) = (p.trim().parse::<u32>().ok()?, q.trim().parse::<u32>().ok()?);
        (p >= 1 && (1..=64).contains(&q) && p <= 64 * q).then_some((p, q))
    });
    match fraction {
        Some((p, q)) => Ok(Some(Observation::Line { p, q, rel_tol })),
        None => Err(ConfigError::WrongType {
            key: key.into(),
            expected: "a fraction of the forcing frequency \"p/q\" (1 <= q <= 64, e.g. \"1/3\"), or { fraction = \"1/3\", tol = 0.05 }".into(),
            found: format!("{v}"),
        }),
    }
}

/// `[lo, hi]` in radians, 0 ≤ lo < hi.
fn alpha_range(r: &mut Reader, key: &str) -> Result<Option<Observation>, ConfigError> {
    let Some(v) = r.raw(key)? else {
        return Ok(None);
    };
    let pair = v.as_array().and_then(|a| match a.as_slice() {
        [lo, hi] => Some((as_f64(lo)?, as_f64(hi)?)),
        _ => None,
    });
    match pair {
        Some((lo, hi)) if lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo < hi => {
            Ok(Some(Observation::AlphaRange {
                lo_rad: lo,
                hi_rad: hi,
            }))
        }
        _ => Err(ConfigError::WrongType {
            key: key.into(),
            expected: "[lo, hi] in radians with 0 <= lo < hi".into(),
            found: format!("{v}"),
        }),
    }
}

fn as_f64(v: &Value) -> Option<f64> {
    v.as_float().or_else(|| v.as_integer().map(|i| i as f64))
}

/// The grid's instances (candidates × cases × initial states) within a map's limit.
fn check_size(spec: &CalibrationSpec) -> Result<(), ConfigError> {
    let candidates: usize = spec.unknowns.iter().map(|u| u.values.len()).product();
    let instances = candidates * spec.cases.len() * spec.initial_states as usize;
    if instances > MAX_INSTANCES {
        return Err(ConfigError::Inconsistent {
            key: "calibrate".into(),
            reason: format!(
                "the grid needs {instances} instances ({candidates} candidates × {} cases × {} initial states); at most {MAX_INSTANCES}: use fewer grid values or initial states",
                spec.cases.len(),
                spec.initial_states
            ),
        });
    }
    Ok(())
}

/// Every case at every unknown's first and last value gives a valid scene.
fn check_scenes(spec: &CalibrationSpec) -> Result<(), ConfigError> {
    let ends = |last: bool| -> Vec<f64> {
        spec.unknowns
            .iter()
            .map(|u| {
                if last {
                    u.values[u.values.len() - 1]
                } else {
                    u.values[0]
                }
            })
            .collect()
    };
    // The case and angle whose starts come closest to ±90 deg bind the spread.
    let mut widest: Option<(&Case, f64)> = None;
    for case in &spec.cases {
        for values in [ends(false), ends(true)] {
            let scene = spec
                .scene(case, &values, 0.0)
                .map_err(|e| ConfigError::Inconsistent {
                    key: "calibrate.cases".into(),
                    reason: format!("case `{}` gives an invalid scene: {e}", case.name),
                })?;
            UNKNOWNS.refuse_unused(&spec.unknowns, &scene)?;
            let angle = scene.initial.angle_deg;
            if widest.is_none_or(|(_, a)| angle.abs() > a.abs()) {
                widest = Some((case, angle));
            }
        }
    }
    match widest {
        Some((case, angle)) => check_spread(spec, case, angle),
        None => Ok(()),
    }
}

/// The starts of a case, its initial angle ± the spread, must stay inside (−90, 90) deg: a
/// spread that leaves it is the spread's fault, and named so, with the bound of the case whose
/// angle is widest (the binding one, so that one refusal gives the range that holds).
fn check_spread(spec: &CalibrationSpec, case: &Case, angle_deg: f64) -> Result<(), ConfigError> {
    let spread = spec.initial_spread_deg;
    if spec.initial_states > 1 && angle_deg.abs() + spread >= 90.0 {
        return Err(ConfigError::OutOfRange {
            key: "calibrate.initial_spread_deg".into(),
            value: spread,
            range: format!(
                "[0, {}) deg: case `{}` starts at {angle_deg} deg (the widest start of the cases over the unknowns' ranges), and its starts must stay within ±90 deg",
                90.0 - angle_deg.abs(),
                case.name
            ),
        });
    }
    Ok(())
}
