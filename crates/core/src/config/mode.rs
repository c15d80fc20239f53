//! How a map runs its cells: one [`MapMode`] per map, chosen and checked once when the map is
//! read ([`MapMode::of`]), so that the planner, the shard check, the outputs and the explorer
//! branch on one value instead of three optional settings.
//!
//! | mode | keys | cells |
//! |---|---|---|
//! | plain | none | every cell once, from the scene's own start, all at once |
//! | attractors | `map.initial_states`, or an axis over `initial.angle_deg`/`initial.rate_deg_s` | several starts per cell, labelled by the attractor stage; a basin picture when every axis is over the start |
//! | continuation | `map.continuation` | one axis cell after cell, each from its neighbour's final state |
//! | refined | `map.refine` | a coarse lattice first, then only where neighbours disagree |
//!
//! The modes exclude one another: continuation has one start per cell (its neighbour's state)
//! and runs every cell of its path; refinement does not label attractors yet.

use super::continuation::ContinuationSpec;
use super::error::ConfigError;
use super::starts::StartSet;
use crate::schema::Metric;
use serde::Serialize;

/// How a map runs its cells.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "lowercase", tag = "kind")]
pub enum MapMode {
    /// Every cell once, from the scene's own start, all at once.
    Plain,
    /// Cells that label attractors.
    Attractors {
        /// The starts of `map.initial_states` (`None`: one start per cell, an axis over it).
        starts: Option<StartSet>,
        /// Every axis is over the start: every cell runs the same scene from another start.
        basin: bool,
    },
    /// One axis run cell after cell (`map.continuation`).
    Continuation(ContinuationSpec),
    /// Adaptive refinement (`map.refine`).
    Refined(RefineSpec),
}

/// What a map's keys ask for, before they are checked against one another.
#[derive(Debug, Clone, Default)]
pub struct ModeKeys {
    /// `map.initial_states`.
    pub starts: Option<StartSet>,
    /// Some axis is over the start.
    pub start_axis: bool,
    /// Every axis is over the start.
    pub all_start_axes: bool,
    /// `map.continuation`.
    pub continuation: Option<ContinuationSpec>,
    /// `map.refine`.
    pub refine: Option<RefineSpec>,
}

impl MapMode {
    /// The one mode the keys ask for, or the refusal of a combination the modes exclude.
    pub fn of(keys: ModeKeys) -> Result<MapMode, ConfigError> {
        let labels = keys.starts.is_some() || keys.start_axis;
        let refused = |key: &str, reason: &str| {
            Err(ConfigError::Inconsistent {
                key: key.into(),
                reason: reason.into(),
            })
        };
        match (labels, keys.continuation, keys.refine) {
            (true, _, Some(_)) => refused(
                "map.refine",
                "refinement of a map that labels attractors (map.initial_states, or an axis over initial.angle_deg or initial.rate_deg_s) is not supported yet: set map.refine = false",
            ),
            (true, Some(_), None) => refused(
                "map.continuation",
                "continuation starts each cell from its neighbour's final state, one start per cell: drop map.initial_states and the axes over initial.angle_deg and initial.rate_deg_s, or drop map.continuation",
            ),
            (false, Some(_), Some(_)) => refused(
                "map.continuation",
                "continuation runs every cell of its path: set map.refine = false",
            ),
            (true, None, None) => Ok(MapMode::Attractors {
                basin: keys.starts.is_none() && keys.all_start_axes,
                starts: keys.starts,
            }),
            (false, Some(c), None) => Ok(MapMode::Continuation(c)),
            (false, None, Some(r)) => Ok(MapMode::Refined(r)),
            (false, None, None) => Ok(MapMode::Plain),
        }
    }

    /// The mode's name in messages and manifests.
    pub fn name(&self) -> &'static str {
        match self {
            MapMode::Plain => "plain",
            MapMode::Attractors { basin: true, .. } => "basin",
            MapMode::Attractors { .. } => "attractors",
            MapMode::Continuation(_) => "continuation",
            MapMode::Refined(_) => "refined",
        }
    }

    /// Why the map's cells cannot be split across processes or devices, with the key to
    /// change; `None` when they can (plain maps).
    pub fn unshardable(&self) -> Option<(&'static str, &'static str)> {
        match self {
            MapMode::Attractors {
                starts: Some(_), ..
            } => Some((
                "map.initial_states",
                "a map that labels attractors cannot be sharded yet: run it in one piece (drop --shard and --devices)",
            )),
            MapMode::Attractors { starts: None, .. } => Some((
                "map.axes",
                "a map over the start (an axis over initial.angle_deg or initial.rate_deg_s) labels attractors, and such a map cannot be sharded yet: run it in one piece (drop --shard and --devices)",
            )),
            MapMode::Continuation(_) => Some((
                "map.continuation",
                "a map run by continuation cannot be sharded: its cells run one after another (drop --shard and --devices)",
            )),
            MapMode::Refined(_) => Some((
                "map.refine",
                "a refined map (map.refine = true) cannot be split: each refinement level chooses its cells from the results of the one before, so its shards would not be independent; run it in one process, or set map.refine = false to shard the full grid",
            )),
            MapMode::Plain => None,
        }
    }
}

/// What refinement compares between neighbouring cells.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum RefineFollow {
    /// The regime, and the period of periodic cells.
    Regime,
    /// One metric: neighbours differ when their values differ by more than `threshold` (or
    /// one is NaN and the other not).
    Metric {
        /// The metric.
        metric: Metric,
        /// Largest absolute difference read as equal (the metric's unit).
        threshold: f64,
    },
}

/// `map.refine_*`: the coarse lattice, what is followed, and the audit
/// (`docs/analysis.md`, "Adaptive refinement").
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct RefineSpec {
    /// Cells between neighbouring points of the coarse lattice (a power of two dividing every
    /// axis's count − 1).
    pub spacing: u32,
    /// What neighbouring cells are compared by.
    pub follow: RefineFollow,
    /// Share of the inferred cells computed to check them, in (0, 1].
    pub audit_share: f64,
    /// Agreement of the audit below which the blocks of its disagreeing cells are computed.
    pub audit_min: f64,
    /// Seed of the audit's draw.
    pub audit_seed: u64,
}
