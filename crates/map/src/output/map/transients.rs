//! The transient stage's files (`docs/analysis.md`, §16): per-cell arrays of the chaotic
//! transient's lifetime and the start sensitivity, and `map.json`'s `transients` summary.

use super::{ArrayData, MapArray, stem};
use crate::map::transients::TransientMap;
use pendulum_atlas_core::config::MapSpec;
use serde_json::{Value, json};

/// `transient_s`, `transient_se_s` and `start_sensitivity` (NaN where a cell ran no copies,
/// or, for the lifetime, saw no escape).
pub(super) fn transient_arrays(spec: &MapSpec, t: &TransientMap) -> Vec<MapArray> {
    let grid = |name: &str, v: &[f64]| MapArray {
        name: name.to_string(),
        shape: spec.shape(),
        data: ArrayData::F64(v.to_vec()),
    };
    vec![
        grid(stem::TRANSIENT_S, &t.lifetime_s),
        grid(stem::TRANSIENT_SE_S, &t.lifetime_se_s),
        grid(stem::START_SENSITIVITY, &t.sensitivity),
    ]
}

/// `map.json`'s `transients`: what the stage did, and how to read its arrays.
pub(super) fn transients_summary(t: &TransientMap) -> Value {
    json!({
        "copies": t.copies,
        "nudge_deg_s": t.nudge_deg_s,
        "cells": t.cells,
        "escapes": t.escapes,
        "cells_escaping": t.cells_escaping,
        "took_orbit": t.took_orbit,
        "undecided_decided": t.decided,
        "start_decides": t.start_decides,
        "steps": t.steps,
        "wall_s": t.wall_s,
        "rule": "each cell not firm after settling runs `copies` copies from its end state, copy j with the first segment's rate raised by j times nudge_deg_s, for the settling run's length; a cell that is not periodic takes the orbit every one of its escaped copies landed on (took_orbit: a chaotic transient; the copies still chaotic have not escaped yet), and any cell a verdict more than half of its copies share (an undecided one any decided verdict: undecided_decided); the share of copies whose decided verdict differs from the cell's is its start sensitivity, and a cell with a sensitivity above 0 is never firm (verdict_confidence at most 0.9 (1 - s))",
        "marks": "regime.png and period.png hatch the cells where the start decides (start_sensitivity > 0) and dot those whose verdict follows a chaotic transient (transient_s finite, periodic)",
        "arrays": {
            "transient_s": "the chaotic transient's mean lifetime from the copies' escape times (s; exponential escapes, copies that did not escape censored; an upper bound by the early stop's confirmation); NaN where no copy escaped or none ran",
            "transient_se_s": "its standard error (s)",
            "start_sensitivity": "the share of the cell's nudged copies whose eventual verdict differs from the cell's: above 0, the start decides the end state; NaN where the cell ran none (firm after settling)",
        },
    })
}
