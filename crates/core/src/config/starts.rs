//! `map.initial_states`: several starts per cell, run in the map's one ensemble so that
//! coexisting attractors, their basins and basin fractions come out of one map
//! (`docs/analysis.md`, "Attractors").
//!
//! The starts are either `k` points of a seeded Latin hypercube over the holder angle and
//! rate (each range cut into `k` equal strata, one point drawn in each stratum of each
//! variable, the strata paired by a seeded shuffle: every angle and every rate band is hit
//! exactly once), or an explicit list. Every start is a straight beam at rest relative to the
//! holder, as `initial.angle_deg` and `initial.rate_deg_s` describe it.

use super::error::ConfigError;
use super::reader::{Range, Reader};
use super::scene::Scene;
use super::sweep::SweptKey;
use crate::text::num;
use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::Serialize;
use toml::Value;

/// Most starts per cell.
pub const MAX_STARTS: usize = 1024;

/// Largest |holder rate| of a start (deg/s): 20 turns a second.
pub const MAX_START_RATE_DEG_S: f64 = 7200.0;

/// One start: the holder's angle and rate at t = 0.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Start {
    /// `initial.angle_deg` (deg).
    pub angle_deg: f64,
    /// `initial.rate_deg_s` (deg/s).
    pub rate_deg_s: f64,
}

/// Where the starts came from.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum StartSource {
    /// A seeded Latin hypercube over the two ranges.
    Sampled {
        /// Holder angle range (deg).
        angle_deg: (f64, f64),
        /// Holder rate range (deg/s).
        rate_deg_s: (f64, f64),
        /// Seed of the ChaCha8 stream.
        seed: u64,
    },
    /// Listed one by one in `map.initial_states`.
    Listed,
}

/// The starts of every cell of a map.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StartSet {
    /// The starts, in run order (start `s` of cell `c` is instance `c·k + s`).
    pub states: Vec<Start>,
    /// How they were made.
    pub source: StartSource,
}

impl StartSet {
    /// Number of starts per cell.
    pub fn len(&self) -> usize {
        self.states.len()
    }

    /// Whether there are none (never, once read).
    pub fn is_empty(&self) -> bool {
        self.states.is_empty()
    }
}

/// `map.initial_states` and its ranges, checked against the scene (starts within the bumpers'
/// reach in every cell: the smallest clearance where an axis sweeps it), the grid (at most
/// `max_runs` runs in all, the map's instance limit) and the axes (no axis may set the start
/// itself). `None` when the key is absent: one start per cell, the scene's own.
pub(crate) fn read_starts(
    r: &mut Reader,
    value: Option<Value>,
    scene: &Scene,
    (cells, max_runs): (usize, usize),
    axes: &[SweptKey],
) -> Result<Option<StartSet>, ConfigError> {
    let axis_keys: Vec<&str> = axes.iter().map(|a| a.key.as_str()).collect();
    let swept_clearance = axes.iter().find(|a| a.key == "limiter.clearance_deg");
    let reach = match (scene.limiter.enabled, swept_clearance) {
        (false, _) => 89.0,
        (true, Some(axis)) => axis.lo(),
        (true, None) => scene.limiter.clearance_deg,
    };
    let angle_lo = r.number(
        "map.initial_angle_min_deg",
        -reach,
        Range::Closed(-reach, reach),
        "deg (within the bumpers' reach, ±limiter.clearance_deg, the smallest of the map's cells)",
    )?;
    let angle_hi = r.number(
        "map.initial_angle_max_deg",
        reach,
        Range::Closed(-reach, reach),
        "deg (within the bumpers' reach, ±limiter.clearance_deg, the smallest of the map's cells)",
    )?;
    let rate_range = Range::Closed(-MAX_START_RATE_DEG_S, MAX_START_RATE_DEG_S);
    let rate_lo = r.number("map.initial_rate_min_deg_s", -200.0, rate_range, "deg/s")?;
    let rate_hi = r.number("map.initial_rate_max_deg_s", 200.0, rate_range, "deg/s")?;
    let seed = r.integer("map.initial_seed", 0, 0, i64::MAX)? as u64;
    let Some(value) = value else {
        return Ok(None);
    };
    for key in ["initial.angle_deg", "initial.rate_deg_s"] {
        if axis_keys.contains(&key) {
            return Err(inconsistent(format!(
                "{key} is an axis of this map and map.initial_states sets it too: keep one (an axis over the start draws a basin picture)"
            )));
        }
    }
    check_order("map.initial_angle_max_deg", angle_lo, angle_hi)?;
    check_order("map.initial_rate_max_deg_s", rate_lo, rate_hi)?;
    let set = match value {
        Value::Integer(k) => {
            let k = count(k)?;
            StartSet {
                states: latin_hypercube(k, (angle_lo, angle_hi), (rate_lo, rate_hi), seed),
                source: StartSource::Sampled {
                    angle_deg: (angle_lo, angle_hi),
                    rate_deg_s: (rate_lo, rate_hi),
                    seed,
                },
            }
        }
        Value::Array(items) => StartSet {
            states: listed(&items, reach)?,
            source: StartSource::Listed,
        },
        other => {
            return Err(ConfigError::WrongType {
                key: "map.initial_states".into(),
                expected: format!(
                    "a number of starts (1 to {MAX_STARTS}) or a list of {{ angle_deg = ..., rate_deg_s = ... }}"
                ),
                found: other.type_str().into(),
            });
        }
    };
    check_instances(cells, set.len(), max_runs)?;
    Ok(Some(set))
}

fn inconsistent(reason: String) -> ConfigError {
    ConfigError::Inconsistent {
        key: "map.initial_states".into(),
        reason,
    }
}

fn check_order(key: &str, lo: f64, hi: f64) -> Result<(), ConfigError> {
    if hi < lo {
        return Err(ConfigError::Inconsistent {
            key: key.into(),
            reason: format!(
                "the range is empty: its end {} is below its start {}",
                num(hi),
                num(lo)
            ),
        });
    }
    Ok(())
}

fn count(k: i64) -> Result<usize, ConfigError> {
    if !(1..=MAX_STARTS as i64).contains(&k) {
        return Err(ConfigError::OutOfRange {
            key: "map.initial_states".into(),
            value: k as f64,
            range: format!("integers in [1, {MAX_STARTS}] (starts per cell)"),
        });
    }
    Ok(k as usize)
}

/// Every cell runs every start: refused beyond `max_runs` runs, with the most starts this
/// grid allows.
fn check_instances(cells: usize, starts: usize, max_runs: usize) -> Result<(), ConfigError> {
    if cells.saturating_mul(starts) > max_runs {
        return Err(inconsistent(format!(
            "{starts} starts in each of {cells} cells are {} runs, more than the {max_runs} a map takes: give at most {} starts, or fewer cells",
            cells.saturating_mul(starts),
            max_runs / cells.max(1)
        )));
    }
    Ok(())
}

/// `k` points of a Latin hypercube over the two ranges, from a ChaCha8 stream seeded by
/// `seed`: point `i` takes angle stratum `i` and rate stratum `π(i)` (π a seeded shuffle),
/// each at a uniform offset within its stratum.
pub fn latin_hypercube(k: usize, angle: (f64, f64), rate: (f64, f64), seed: u64) -> Vec<Start> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut pairing: Vec<usize> = (0..k).collect();
    pairing.shuffle(&mut rng);
    let at = |(lo, hi): (f64, f64), stratum: usize, u: f64| {
        lo + (hi - lo) * (stratum as f64 + u) / k as f64
    };
    (0..k)
        .map(|i| {
            let (ua, ur) = (rng.random::<f64>(), rng.random::<f64>());
            Start {
                angle_deg: at(angle, i, ua),
                rate_deg_s: at(rate, pairing[i], ur),
            }
        })
        .collect()
}

/// An explicit list of `{ angle_deg, rate_deg_s }`, each within the bumpers' reach.
fn listed(items: &[Value], reach: f64) -> Result<Vec<Start>, ConfigError> {
    if items.is_empty() || items.len() > MAX_STARTS {
        return Err(inconsistent(format!(
            "a list of starts holds 1 to {MAX_STARTS}, this one {}",
            items.len()
        )));
    }
    items
        .iter()
        .enumerate()
        .map(|(i, item)| {
            let key = format!("map.initial_states[{i}]");
            let field = |name: &str, range: (f64, f64), unit: &str| {
                let v = item.get(name).and_then(|v| match v {
                    Value::Float(f) => Some(*f),
                    Value::Integer(n) => Some(*n as f64),
                    _ => None,
                });
                match v {
                    Some(x) if x >= range.0 && x <= range.1 => Ok(x),
                    Some(x) => Err(ConfigError::OutOfRange {
                        key: format!("{key}.{name}"),
                        value: x,
                        range: format!("[{}, {}] {unit}", num(range.0), num(range.1)),
                    }),
                    None => Err(ConfigError::WrongType {
                        key: key.clone(),
                        expected: format!("a table with a number `{name}` ({unit})"),
                        found: item.type_str().into(),
                    }),
                }
            };
            if let Value::Table(t) = item
                && let Some(extra) = t
                    .keys()
                    .find(|k| !["angle_deg", "rate_deg_s"].contains(&k.as_str()))
            {
                return Err(ConfigError::UnknownKey {
                    key: format!("{key}.{extra}"),
                    suggestion: None,
                });
            }
            Ok(Start {
                angle_deg: field("angle_deg", (-reach, reach), "deg")?,
                rate_deg_s: field(
                    "rate_deg_s",
                    (-MAX_START_RATE_DEG_S, MAX_START_RATE_DEG_S),
                    "deg/s",
                )?,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_latin_hypercube_hits_every_stratum_of_each_variable_once() {
        let k = 16;
        let pts = latin_hypercube(k, (-20.0, 20.0), (-200.0, 200.0), 7);
        let mut angle_strata: Vec<usize> = pts
            .iter()
            .map(|p| ((p.angle_deg + 20.0) / 40.0 * k as f64) as usize)
            .collect();
        let mut rate_strata: Vec<usize> = pts
            .iter()
            .map(|p| ((p.rate_deg_s + 200.0) / 400.0 * k as f64) as usize)
            .collect();
        angle_strata.sort_unstable();
        rate_strata.sort_unstable();
        assert_eq!(angle_strata, (0..k).collect::<Vec<_>>());
        assert_eq!(rate_strata, (0..k).collect::<Vec<_>>());
        assert_eq!(pts, latin_hypercube(k, (-20.0, 20.0), (-200.0, 200.0), 7));
        assert_ne!(pts, latin_hypercube(k, (-20.0, 20.0), (-200.0, 200.0), 8));
    }
}
