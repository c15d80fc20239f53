//! `map.continuation`: the cells of one axis run one after another, each from the state its
//! neighbour ended in, as an experiment sweeps its frequency up or down and the harvester
//! stays on the attractor it is on until that attractor ends (hysteresis; `docs/analysis.md`,
//! "Continuation and hysteresis").
//!
//! Keys: `map.continuation = "up" | "down" | "both"` (absent: every cell starts from the
//! scene's state) and `map.continuation_axis` (a key of `[[map.axes]]`; the first axis when
//! omitted). Refused before any work: an axis that is not one of the map's, an axis over the
//! start itself (`initial.*`, which continuation overwrites), an axis of one value, and
//! continuation together with several starts per cell or refinement.

use super::error::ConfigError;
use super::reader::Reader;
use super::sweep::MapAxis;
use crate::text::num;
use serde::{Deserialize, Serialize};
use toml::Value;

/// Which way along the axis the cells run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Direction {
    /// From the smallest value of the axis to the largest.
    Up,
    /// From the largest value to the smallest.
    Down,
}

impl Direction {
    /// "up" or "down".
    pub fn name(self) -> &'static str {
        match self {
            Direction::Up => "up",
            Direction::Down => "down",
        }
    }
}

/// `map.continuation`: one direction, or both one after the other.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Sweep {
    /// Up only.
    Up,
    /// Down only.
    Down,
    /// Up, then down, each from the scene's state at its first cell.
    Both,
}

impl Sweep {
    /// The directions run, in order; the first one's results are the map's arrays.
    pub fn directions(self) -> &'static [Direction] {
        match self {
            Sweep::Up => &[Direction::Up],
            Sweep::Down => &[Direction::Down],
            Sweep::Both => &[Direction::Up, Direction::Down],
        }
    }
}

/// A map run by continuation along one of its axes.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ContinuationSpec {
    /// Up, down or both.
    pub sweep: Sweep,
    /// Index of the axis in `map.axes`.
    pub axis: usize,
    /// The axis's scene key.
    pub key: String,
}

impl ContinuationSpec {
    /// The axis's indices in the order `direction` visits them (by value, not by listing).
    pub fn order(&self, axes: &[MapAxis], direction: Direction) -> Vec<usize> {
        let values = &axes[self.axis].values;
        let mut order: Vec<usize> = (0..values.len()).collect();
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        if direction == Direction::Down {
            order.reverse();
        }
        order
    }
}

const SWEEPS: [&str; 3] = ["up", "down", "both"];

/// Read `map.continuation` and `map.continuation_axis` against the map's axes.
pub(crate) fn read_continuation(
    r: &mut Reader,
    axes: &[MapAxis],
) -> Result<Option<ContinuationSpec>, ConfigError> {
    let axis_key = match r.raw("map.continuation_axis")? {
        None => None,
        Some(Value::String(s)) => Some(s.clone()),
        Some(_) => {
            return Err(refused(
                "map.continuation_axis",
                "must be a key of [[map.axes]], as a string, e.g. \"excitation.frequency_hz\""
                    .into(),
            ));
        }
    };
    if !r.given("map.continuation")? {
        if axis_key.is_some() {
            return Err(refused(
                "map.continuation_axis",
                "is only read with map.continuation = \"up\", \"down\" or \"both\"".into(),
            ));
        }
        return Ok(None);
    }
    let sweep = match r.choice("map.continuation", "up", &SWEEPS)?.as_str() {
        "up" => Sweep::Up,
        "down" => Sweep::Down,
        _ => Sweep::Both,
    };
    let keys: Vec<&str> = axes.iter().map(|a| a.key.as_str()).collect();
    let key = axis_key.unwrap_or_else(|| keys[0].to_string());
    let Some(axis) = keys.iter().position(|k| *k == key) else {
        return Err(refused(
            "map.continuation_axis",
            format!(
                "\"{key}\" is not an axis of this map; continuation runs along one of its axes: {}",
                keys.join(", ")
            ),
        ));
    };
    if key.starts_with("initial.") {
        return Err(refused(
            "map.continuation_axis",
            format!(
                "continuation starts each cell from its neighbour's final state, which replaces {key}: continue along a scene parameter instead"
            ),
        ));
    }
    let n = axes[axis].values.len();
    if n < 2 {
        return Err(refused(
            "map.continuation_axis",
            format!(
                "{key} has {} value ({}): continuation needs at least 2",
                n,
                num(axes[axis].values[0])
            ),
        ));
    }
    Ok(Some(ContinuationSpec { sweep, axis, key }))
}

fn refused(key: &str, reason: String) -> ConfigError {
    ConfigError::Inconsistent {
        key: key.into(),
        reason,
    }
}
