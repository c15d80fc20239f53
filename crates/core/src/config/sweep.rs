//! Swept scene keys: one type for every list of them, the axes of a map (`[[map.axes]]`), the
//! design variables of the harvesting search (`[[search.variables]]`) and the unknowns of a
//! calibration (`[[calibrate.unknowns]]`), read by one reader ([`SweepList::read`]).
//!
//! Each entry names a dotted scene key and its values, either listed or as a range:
//!
//! ```toml
//! [[map.axes]]
//! key = "excitation.frequency_hz"
//! start = 4.0            # or: values = [4.0, 6.0, 8.0]
//! end = 12.0
//! count = 33
//! scale = "linear"       # or "log" (start > 0)
//! ```
//!
//! Values are finite and strictly increasing; the product of the counts (the grid's size) is
//! bounded by the list's own limit. Steps of a search are taken in the key's step space (ln for
//! log keys, [`SweptKey::to_step_space`]), clamped to its range and rounded for integer keys.

use super::error::ConfigError;
use super::reader::{Range, Reader};
use super::scene::Scene;
use crate::text::num;
use serde::Serialize;
use toml::{Table, Value};

/// Spacing of an axis's values.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum AxisScale {
    /// Evenly spaced.
    Linear,
    /// Evenly spaced in log (start and end > 0).
    Log,
}

/// One swept scene key: a map axis, a design variable, an unknown.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SweptKey {
    /// Dotted scene key, e.g. `excitation.frequency_hz`.
    pub key: String,
    /// Values of the key, strictly increasing.
    pub values: Vec<f64>,
    /// Spacing of the values, also the space in which a search's steps are taken.
    pub scale: AxisScale,
    /// The key holds an integer (a search's steps are rounded). Map axes: always false.
    #[serde(skip_serializing_if = "is_false")]
    pub integer: bool,
}

fn is_false(b: &bool) -> bool {
    !*b
}

/// A map axis: a swept key whose values are the grid's coordinates along one dimension.
pub type MapAxis = SweptKey;

impl SweptKey {
    /// A label with the unit in physical terms, for pictures.
    pub fn label(&self) -> String {
        axis_label(&self.key)
    }

    /// Smallest value: a search never goes below it.
    pub fn lo(&self) -> f64 {
        self.values[0]
    }

    /// Largest value: a search never goes above it.
    pub fn hi(&self) -> f64 {
        self.values[self.values.len() - 1]
    }

    /// A value in the space steps are taken in (ln for log keys).
    pub(crate) fn to_step_space(&self, v: f64) -> f64 {
        match self.scale {
            AxisScale::Linear => v,
            AxisScale::Log => v.ln(),
        }
    }

    /// Back from step space.
    pub(crate) fn value_from_step_space(&self, u: f64) -> f64 {
        match self.scale {
            AxisScale::Linear => u,
            AxisScale::Log => u.exp(),
        }
    }

    /// The mean spacing of the values in step space (0 for a single value: the key is fixed).
    pub(crate) fn grid_step(&self) -> f64 {
        let n = self.values.len();
        if n < 2 {
            return 0.0;
        }
        (self.to_step_space(self.hi()) - self.to_step_space(self.lo())) / (n - 1) as f64
    }

    /// Clamp to the range of the values and round integer keys.
    pub(crate) fn admissible(&self, v: f64) -> f64 {
        let v = v.clamp(self.lo(), self.hi());
        if self.integer { v.round() } else { v }
    }
}

/// The neighbours of `centre` (one value per key of `keys`): one step of the grid spacing ×
/// `shrink` along each key, both ways, in the key's step space, clamped to its range
/// (integers rounded). The compass step of the search and of calibrate.
pub fn neighbours(keys: &[SweptKey], centre: &[f64], shrink: f64) -> Vec<Vec<f64>> {
    let mut out = Vec::new();
    for (i, key) in keys.iter().enumerate() {
        let step = key.grid_step() * shrink;
        if step == 0.0 {
            continue;
        }
        for sign in [-1.0, 1.0] {
            let u = key.to_step_space(centre[i]) + sign * step;
            let mut cand = centre.to_vec();
            cand[i] = key.admissible(key.value_from_step_space(u));
            out.push(cand);
        }
    }
    out
}

/// A text identifying a point of the grid by its values (for "already evaluated" sets).
pub fn point_key(values: &[f64]) -> String {
    values
        .iter()
        .map(|v| format!("{v:.12e}"))
        .collect::<Vec<_>>()
        .join(",")
}

/// Scene keys whose values are integers whatever the base scene writes.
const INTEGER_KEYS: [&str; 1] = ["piezo.segments"];

/// What distinguishes one list of swept keys from another: its name, what an entry is called
/// in messages, how many entries and grid points it takes.
#[derive(Debug, Clone, Copy)]
pub struct SweepList {
    /// The TOML array, e.g. `map.axes`.
    pub section: &'static str,
    /// One entry in messages, with its article: "a map axis", "a design variable".
    pub entry: &'static str,
    /// The list's rule on its length, as messages say it: "a map needs 1 to 3 axes".
    pub needs: &'static str,
    /// Most entries (at least one is always needed).
    pub max_entries: usize,
    /// Most grid points in all (the product of the counts).
    pub max_points: usize,
    /// What a grid point is called: "instances", "designs", "candidates".
    pub points: &'static str,
    /// A key shown in the message for a key that is not a string.
    pub example_key: &'static str,
}

impl SweepList {
    /// The entries of the list `v`, each checked (key a string that `refusal` accepts and not
    /// swept twice, values by `read_sweep`), and at most `max_points` grid points in all.
    /// With a `base` scene table, integer keys are marked and their values must be whole.
    pub fn read(
        &self,
        v: Option<Value>,
        base: Option<&Table>,
        refusal: impl Fn(&str) -> Option<String>,
    ) -> Result<Vec<SweptKey>, ConfigError> {
        let mut keys: Vec<SweptKey> = Vec::new();
        let mut total: usize = 1;
        for (i, table) in self.tables(v)?.into_iter().enumerate() {
            let prefix = format!("{}[{}]", self.section, i + 1);
            let mut r = Reader::new(nest(&prefix, table));
            let key = self.key(&mut r, &prefix, &keys, &refusal)?;
            let (values, scale) = read_sweep(&mut r, &prefix, &key, self.max_points)?;
            r.finish()?;
            total = total
                .checked_mul(values.len())
                .filter(|&t| t <= self.max_points)
                .ok_or_else(|| ConfigError::OutOfRange {
                    key: format!("{prefix}.count"),
                    value: values.len() as f64,
                    range: format!(
                        "grids of at most {} {} in all (this one would need more)",
                        self.max_points, self.points
                    ),
                })?;
            let integer = base.is_some_and(|b| is_integer_key(b, &key));
            if integer && values.iter().any(|v| v.fract() != 0.0) {
                return Err(ConfigError::Inconsistent {
                    key: format!("{prefix}.values"),
                    reason: format!("{key}: this key takes integers: every value must be whole"),
                });
            }
            keys.push(SweptKey {
                key,
                values,
                scale,
                integer,
            });
        }
        Ok(keys)
    }

    /// Refuse an entry over a key that `scene` (a point's, its swept values set) does not
    /// use (`Scene::unused_keys`): every point would be the same.
    pub fn refuse_unused(&self, keys: &[SweptKey], scene: &Scene) -> Result<(), ConfigError> {
        let unused = scene.unused_keys();
        for (i, k) in keys.iter().enumerate() {
            if let Some((_, why)) = unused.iter().find(|(u, _)| *u == k.key) {
                return Err(ConfigError::Inconsistent {
                    key: format!("{}[{}].key", self.section, i + 1),
                    reason: format!(
                        "`{}` cannot be {}: this scene does not use it ({why}), so every one of its {} would be the same",
                        k.key, self.entry, self.points
                    ),
                });
            }
        }
        Ok(())
    }

    /// The entries of the list: an array of 1 to `max_entries` tables.
    fn tables(&self, v: Option<Value>) -> Result<Vec<Table>, ConfigError> {
        let section = self.section;
        let items = match v {
            Some(Value::Array(items)) => items,
            Some(_) => {
                return Err(ConfigError::WrongType {
                    key: section.into(),
                    expected: format!("an array of tables ([[{section}]])"),
                    found: "a single value".into(),
                });
            }
            None => {
                return Err(ConfigError::Inconsistent {
                    key: section.into(),
                    reason: format!("{} ([[{section}]] with key, start, end, count)", self.needs),
                });
            }
        };
        if items.is_empty() || items.len() > self.max_entries {
            return Err(ConfigError::Inconsistent {
                key: section.into(),
                reason: format!("{}, found {}", self.needs, items.len()),
            });
        }
        entry_tables(
            section,
            items,
            "a table with key, start, end, count (or values)",
        )
    }

    /// The scene key an entry at `prefix` sweeps: a string that `refusal` accepts, not
    /// already swept by `earlier`.
    fn key(
        &self,
        r: &mut Reader,
        prefix: &str,
        earlier: &[SweptKey],
        refusal: &impl Fn(&str) -> Option<String>,
    ) -> Result<String, ConfigError> {
        let at = format!("{prefix}.key");
        let key = match r.raw(&at)? {
            Some(Value::String(s)) => s.clone(),
            Some(other) => {
                return Err(ConfigError::WrongType {
                    key: at,
                    expected: format!("a dotted scene key such as \"{}\"", self.example_key),
                    found: format!("{other}"),
                });
            }
            None => {
                return Err(ConfigError::Inconsistent {
                    key: at,
                    reason: "missing: name the scene key it sweeps".into(),
                });
            }
        };
        let reason = refusal(&key)
            .map(|why| format!("`{key}` cannot be {}: {why}", self.entry))
            .or_else(|| {
                earlier
                    .iter()
                    .any(|k| k.key == key)
                    .then(|| format!("`{key}` is {} twice", self.entry))
            });
        match reason {
            Some(reason) => Err(ConfigError::Inconsistent { key: at, reason }),
            None => Ok(key),
        }
    }
}

/// The entries of the TOML array of tables `key` (`[[key]]`), each required to be a table
/// (`expected` says what one holds, for the message naming the entry that is not).
pub fn entry_tables(
    key: &str,
    items: Vec<Value>,
    expected: &str,
) -> Result<Vec<Table>, ConfigError> {
    items
        .into_iter()
        .enumerate()
        .map(|(i, item)| match item {
            Value::Table(t) => Ok(t),
            _ => Err(ConfigError::WrongType {
                key: format!("{key}[{}]", i + 1),
                expected: expected.into(),
                found: "a value".into(),
            }),
        })
        .collect()
}

/// Whether `key` holds an integer: a key of [`INTEGER_KEYS`], or one the base scene table
/// writes as an integer.
fn is_integer_key(base: &Table, key: &str) -> bool {
    INTEGER_KEYS.contains(&key) || lookup_key(base, key).is_some_and(Value::is_integer)
}

/// The entry table `t` at a dotted `prefix` (`map.axes[1]`), nested so that the reader's
/// messages name each key in full.
fn nest(prefix: &str, t: Table) -> Table {
    let mut out = t;
    for part in prefix.rsplit('.') {
        let mut outer = Table::new();
        outer.insert(part.to_string(), Value::Table(out));
        out = outer;
    }
    out
}

/// The value at a dotted key of a scene table, if any.
pub fn lookup_key<'a>(table: &'a Table, key: &str) -> Option<&'a Value> {
    let mut cursor = table;
    let parts: Vec<&str> = key.split('.').collect();
    for (i, p) in parts.iter().enumerate() {
        let v = cursor.get(*p)?;
        if i + 1 == parts.len() {
            return Some(v);
        }
        cursor = v.as_table()?;
    }
    None
}

/// A readable label (with unit) for a scene key; unknown keys are shown as they are.
pub fn axis_label(key: &str) -> String {
    match key {
        "excitation.frequency_hz" => "forcing frequency f (Hz)".into(),
        "excitation.amplitude_m" => "cart amplitude A (m)".into(),
        "limiter.clearance_deg" => "clearance θc (deg)".into(),
        "limiter.contact_arc_m" => "bumper arc s_b (m)".into(),
        "limiter.stiffness_n_per_m" => "contact stiffness k_c (N/m)".into(),
        "tip.mass_kg" => "tip mass M (kg)".into(),
        "piezo.load_ohm" => "load R_L (Ω)".into(),
        "beam.damping_ratio" => "damping ratio ζ1".into(),
        "initial.angle_deg" => "initial angle (deg)".into(),
        "initial.rate_deg_s" => "initial rate (deg/s)".into(),
        other => match key_unit(other) {
            Some(u) => format!("{other} ({u})"),
            None => other.to_string(),
        },
    }
}

/// Units of scene keys by the suffix of their name, longest suffixes first.
const KEY_UNITS: [(&str, &str); 16] = [
    ("_n_per_m", "N/m"),
    ("_ns_per_m", "N s/m"),
    ("_nm_per_v", "N m/V"),
    ("_deg_s", "deg/s"),
    ("_m_s2", "m/s^2"),
    ("_kgm2", "kg m^2"),
    ("_nms", "N m s/rad"),
    ("_ohm", "ohm"),
    ("_deg", "deg"),
    ("_hz", "Hz"),
    ("_kg", "kg"),
    ("_pa", "Pa"),
    ("_m", "m"),
    ("_s", "s"),
    ("_f", "F"),
    ("_v", "V"),
];

/// The unit of a scene key's value, read off its name (`excitation.frequency_hz` → `Hz`);
/// `None` for keys without one (ratios, counts, switches).
pub fn key_unit(key: &str) -> Option<&'static str> {
    KEY_UNITS
        .iter()
        .find(|(suffix, _)| key.ends_with(suffix))
        .map(|&(_, unit)| unit)
}

/// The values of a swept scene key (a map axis, a design variable) read from the table at
/// `prefix`: either `values = [...]` (finite, strictly increasing) or `start`, `end`, `count`
/// with an optional `scale = "linear" | "log"`. At most `max` values. Errors name the key.
fn read_sweep(
    r: &mut Reader,
    prefix: &str,
    key: &str,
    max: usize,
) -> Result<(Vec<f64>, AxisScale), ConfigError> {
    let scale = match r
        .choice(&format!("{prefix}.scale"), "linear", &["linear", "log"])?
        .as_str()
    {
        "log" => AxisScale::Log,
        _ => AxisScale::Linear,
    };
    let values = match r.raw(&format!("{prefix}.values"))?.cloned() {
        Some(Value::Array(vs)) => listed_values(r, prefix, key, max, vs)?,
        Some(other) => {
            return Err(ConfigError::WrongType {
                key: format!("{prefix}.values"),
                expected: "an array of numbers".into(),
                found: format!("{other}"),
            });
        }
        None => ranged_values(r, prefix, key, max, scale)?,
    };
    if scale == AxisScale::Log && values.first().is_some_and(|&v| v <= 0.0) {
        return Err(sweep_error(
            prefix,
            key,
            "scale",
            format!(
                "a log scale needs values above 0, and the first is {}: drop scale = \"log\", or list positive values",
                crate::text::num(values[0])
            ),
        ));
    }
    Ok((values, scale))
}

/// An inconsistency at `{prefix}.{what}`, its reason prefixed with the swept key.
fn sweep_error(prefix: &str, key: &str, what: &str, reason: String) -> ConfigError {
    ConfigError::Inconsistent {
        key: format!("{prefix}.{what}"),
        reason: format!("{key}: {reason}"),
    }
}

/// `values = [...]`: 1 to `max` finite numbers, strictly increasing, with no start, end or
/// count beside them.
fn listed_values(
    r: &mut Reader,
    prefix: &str,
    key: &str,
    max: usize,
    vs: Vec<Value>,
) -> Result<Vec<f64>, ConfigError> {
    let named = |what: &str, reason: String| sweep_error(prefix, key, what, reason);
    let out = vs
        .into_iter()
        .map(|v| listed_number(prefix, v))
        .collect::<Result<Vec<f64>, _>>()?;
    if out.is_empty() {
        return Err(named("values", "the range is empty (values = [])".into()));
    }
    if out.len() > max {
        return Err(named("values", format!("at most {max} values")));
    }
    if out.windows(2).any(|w| w[1] <= w[0]) {
        return Err(named("values", "values must be strictly increasing".into()));
    }
    for k in ["start", "end", "count"] {
        if r.raw(&format!("{prefix}.{k}"))?.is_some() {
            return Err(named(
                k,
                "give either `values` or start/end/count, not both".into(),
            ));
        }
    }
    Ok(out)
}

/// One entry of `values`: a finite number (an integer is taken as a float).
fn listed_number(prefix: &str, v: Value) -> Result<f64, ConfigError> {
    let x = match v {
        Value::Float(f) => f,
        Value::Integer(i) => i as f64,
        other => {
            return Err(ConfigError::WrongType {
                key: format!("{prefix}.values"),
                expected: "an array of numbers".into(),
                found: format!("{other}"),
            });
        }
    };
    if !x.is_finite() {
        return Err(ConfigError::NotFinite {
            key: format!("{prefix}.values"),
            value: x,
        });
    }
    Ok(x)
}

/// `start`, `end` and `count` (all required), checked for an empty or impossible range, then
/// spread over it linearly or logarithmically per `scale`.
fn ranged_values(
    r: &mut Reader,
    prefix: &str,
    key: &str,
    max: usize,
    scale: AxisScale,
) -> Result<Vec<f64>, ConfigError> {
    let missing = |what: &str| {
        sweep_error(
            prefix,
            key,
            what,
            "missing: give start, end and count (or values)".into(),
        )
    };
    let start = r
        .number_opt(&format!("{prefix}.start"), Range::Any, "")?
        .ok_or_else(|| missing("start"))?;
    let end = r
        .number_opt(&format!("{prefix}.end"), Range::Any, "")?
        .ok_or_else(|| missing("end"))?;
    let count = match r.raw(&format!("{prefix}.count"))? {
        None => return Err(missing("count")),
        Some(_) => r.integer(&format!("{prefix}.count"), 0, i64::MIN, i64::MAX)?,
    };
    check_range(prefix, key, max, scale, (start, end, count))?;
    Ok(spread(start, end, count as usize, scale))
}

/// Refuse a range that is empty, whose count and ends disagree, a log range reaching 0, or
/// one of more than `max` values.
fn check_range(
    prefix: &str,
    key: &str,
    max: usize,
    scale: AxisScale,
    (start, end, count): (f64, f64, i64),
) -> Result<(), ConfigError> {
    let named = |what: &str, reason: String| sweep_error(prefix, key, what, reason);
    if count < 1 {
        return Err(named(
            "count",
            format!("the range is empty (count = {count})"),
        ));
    }
    if end < start {
        return Err(named(
            "end",
            format!(
                "the range is empty: end = {} is below start = {}",
                num(end),
                num(start)
            ),
        ));
    }
    if count == 1 && start != end {
        return Err(named("count", "count = 1 needs start = end".into()));
    }
    if count > 1 && end == start {
        return Err(named(
            "end",
            format!(
                "the range is empty: start = end = {} with count = {count}",
                num(start)
            ),
        ));
    }
    if scale == AxisScale::Log && start <= 0.0 {
        return Err(named("start", "a log range needs start > 0".into()));
    }
    if count as u64 > max as u64 {
        return Err(ConfigError::OutOfRange {
            key: format!("{prefix}.count"),
            value: count as f64,
            range: format!("at most {max} values"),
        });
    }
    Ok(())
}

/// `n` values from `start` to `end`, evenly spaced on a linear or a log scale (`start` alone
/// when `n` is 1).
fn spread(start: f64, end: f64, n: usize, scale: AxisScale) -> Vec<f64> {
    (0..n)
        .map(|j| {
            let u = if n == 1 {
                0.0
            } else {
                j as f64 / (n - 1) as f64
            };
            match scale {
                AxisScale::Linear => start + (end - start) * u,
                AxisScale::Log => (start.ln() + (end.ln() - start.ln()) * u).exp(),
            }
        })
        .collect()
}
