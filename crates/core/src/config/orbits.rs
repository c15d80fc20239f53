//! `map.orbits` and `map.orbits_reach`: whether a map finds the exact periodic orbits of its
//! periodic cells, and how far it continues them (`docs/analysis.md`, §15).
//!
//! ```text
//! default:   on for a plain or refined map with the verdict ("regime" among the metrics), off
//!            otherwise (a refined map's inferred cells kept no end state: `no_start`)
//! asked:     map.orbits = true on a map that cannot serve it is refused with the reason
//! reach:     map.orbits_reach = 1 cell beyond the cells that found an orbit, 0..=64
//! ```

use super::error::ConfigError;
use super::mode::MapMode;
use super::reader::Reader;
use crate::schema::Metric;
use serde::Serialize;

/// The longest continuation accepted (cells).
pub const REACH_MAX: u32 = 64;

/// The orbit stage of a map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct OrbitSpec {
    /// Cells an orbit is continued beyond the cells that found it from their end state.
    pub reach: u32,
}

/// `map.orbits` as the map runs it: `None` where it finds no orbits.
pub(super) fn read_orbits(
    r: &mut Reader,
    metrics: &[Metric],
    mode: &MapMode,
) -> Result<Option<OrbitSpec>, ConfigError> {
    let asked = r.given("map.orbits")?;
    let on = r.boolean("map.orbits", true)?;
    let reach = r.integer("map.orbits_reach", 1, 0, i64::from(REACH_MAX))? as u32;
    if !on {
        super::scene::note_unused(r, (&["map.orbits_reach"], "map.orbits = false"))?;
        return Ok(None);
    }
    match why_not(metrics, mode) {
        None => Ok(Some(OrbitSpec { reach })),
        Some(reason) if asked => Err(ConfigError::Inconsistent {
            key: "map.orbits".into(),
            reason,
        }),
        Some(reason) => {
            if r.given("map.orbits_reach")? {
                r.note(format!("map.orbits_reach is set but not used: {reason}"));
            }
            Ok(None)
        }
    }
}

/// Why a map cannot find its orbits (`None`: it can).
fn why_not(metrics: &[Metric], mode: &MapMode) -> Option<String> {
    if !metrics.contains(&Metric::Regime) {
        return Some(
            "the orbit stage shoots from the cells whose verdict is periodic, and the verdict needs \"regime\" in map.metrics (or map.orbits = false)".into(),
        );
    }
    let name = match mode {
        MapMode::Plain | MapMode::Refined(_) => return None,
        MapMode::Attractors { .. } => "a map of several starts per cell or a basin picture",
        MapMode::Continuation(_) => "a continuation map",
    };
    Some(format!(
        "the orbit stage cannot serve {name} yet: it shoots from one end state per cell of a plain or refined map (set map.orbits = false)"
    ))
}
