//! The orbit stage's files (`docs/analysis.md`, §15): per-cell arrays of each cell's own
//! orbit, `orbits.json` (every orbit known at each cell) and `bifurcations.json` (the
//! curves), and `map.json`'s `orbits` summary.

use super::{ArrayData, MapArray, stem};
use pendulum_atlas_core::config::MapSpec;
use pendulum_atlas_core::reduce::orbits::{
    BifurcationKind, KnownOrbit, LOCATE_STEPS, OrbitMap, OrbitStatus, TOL,
};
use serde_json::{Value, json};

/// The per-cell arrays of the cells' own orbits (NaN, 0 or −1 where a cell has none).
pub(super) fn orbit_arrays(spec: &MapSpec, o: &OrbitMap) -> Vec<MapArray> {
    let grid = |name: &str, data| MapArray {
        name: name.to_string(),
        shape: spec.shape(),
        data,
    };
    let n = o.status.len();
    let own = |f: &dyn Fn(&KnownOrbit) -> f64| -> ArrayData {
        ArrayData::F64((0..n).map(|k| o.own_orbit(k).map_or(f64::NAN, f)).collect())
    };
    let count = |f: &dyn Fn(&KnownOrbit) -> bool| -> ArrayData {
        ArrayData::I32(
            o.known
                .iter()
                .map(|c| c.iter().filter(|k| f(k)).count() as i32)
                .collect(),
        )
    };
    vec![
        grid(
            stem::ORBIT_STATUS,
            ArrayData::I8(o.status.iter().map(|s| s.code()).collect()),
        ),
        grid(
            stem::ORBIT_PERIOD,
            ArrayData::I32(
                (0..n)
                    .map(|k| o.own_orbit(k).map_or(0, |x| x.orbit.period as i32))
                    .collect(),
            ),
        ),
        grid(stem::ORBIT_RESIDUAL, own(&|x| x.orbit.residual)),
        grid(stem::FLOQUET_MAX, own(&|x| x.orbit.multipliers.max_abs)),
        grid(
            stem::FLOQUET_MINUS1,
            own(&|x| x.orbit.multipliers.near_minus_one),
        ),
        grid(
            stem::FLOQUET_PLUS1,
            own(&|x| x.orbit.multipliers.near_plus_one),
        ),
        grid(stem::ORBIT_EXTENT, own(&|x| x.orbit.extent_rad)),
        grid(
            stem::ORBIT_FAMILY,
            ArrayData::I32(
                (0..n)
                    .map(|k| o.own_orbit(k).map_or(-1, |x| x.family as i32))
                    .collect(),
            ),
        ),
        grid(stem::ORBITS_KNOWN, count(&|_| true)),
        grid(stem::ORBITS_STABLE, count(&|k| k.orbit.stable())),
    ]
}

/// `orbits.json`: the orbits known at every cell that has one.
pub(super) fn orbits_json(spec: &MapSpec, o: &OrbitMap) -> Value {
    let cells: Vec<Value> = o
        .known
        .iter()
        .enumerate()
        .filter(|(_, c)| !c.is_empty())
        .map(|(k, c)| {
            json!({
                "cell": k,
                "index": spec.index_of(k),
                "values": spec.values_of(k),
                "own": o.own[k],
                "orbits": c.iter().map(|x| json!({
                    "family": x.family,
                    "period": x.orbit.period,
                    "stable": x.orbit.stable(),
                    "depth": x.depth,
                    "x_star": x.orbit.x(),
                    "residual": x.orbit.residual,
                    "multipliers": x.orbit.multipliers.values,
                    "floquet_max": x.orbit.multipliers.max_abs,
                    "extent_rad": x.orbit.extent_rad,
                    "margin_m": x.orbit.margin_m,
                })).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({
        "state": "x_star = [theta_1..theta_N (rad); their rates (rad/s); piezo voltage (V) when coupled], at forcing phase 0",
        "families": o.families,
        "cells": cells,
    })
}

/// `bifurcations.json`: the curves, in axis values.
pub fn bifurcations_json(spec: &MapSpec, o: &OrbitMap) -> Value {
    json!({
        "axes": spec.axes.iter().map(|a| a.key.as_str()).collect::<Vec<_>>(),
        "kinds": BifurcationKind::ALL.iter().map(|k| k.name()).collect::<Vec<_>>(),
        "tolerance": format!(
            "each point within `tol` (a share of the cell step along its edge; {} at best, after {LOCATE_STEPS} halvings) of the crossing",
            0.5f64.powi(LOCATE_STEPS as i32 + 1)
        ),
        "curves": o.curves,
    })
}

/// `map.json`'s `orbits`: what the stage did, and how to read its files.
pub(super) fn orbits_summary(o: &OrbitMap, wall_s: f64) -> Value {
    let status_count = |s: OrbitStatus| o.status.iter().filter(|&&x| x == s).count();
    let shot = o.status.len() - status_count(OrbitStatus::NotPeriodic);
    let known: usize = o.known.iter().map(Vec::len).sum();
    let kind_count = |k: BifurcationKind| o.curves.iter().filter(|c| c.kind == k).count();
    json!({
        "cells_shot": shot,
        "converged": status_count(OrbitStatus::Converged),
        "status_counts": OrbitStatus::ALL.iter().map(|&s| (s.name(), status_count(s))).collect::<std::collections::BTreeMap<_, _>>(),
        "status_codes": OrbitStatus::ALL.iter().map(|&s| (s.name(), s.code())).collect::<std::collections::BTreeMap<_, _>>(),
        "reach": o.reach,
        "families": o.families,
        "orbits_known": known,
        "continued_tries": o.continued_tries,
        "continued_found": o.continued_found,
        "periods_corrected": o.periods_corrected,
        "unstable_own": o.unstable_own,
        "timings_s": o.timings,
        "curves": BifurcationKind::ALL.iter().map(|&k| (k.name(), kind_count(k))).collect::<std::collections::BTreeMap<_, _>>(),
        "wall_s": wall_s,
        "method": format!(
            "Newton shooting on the stroboscopic map (RK4 at the cell's step, or RK4's stable step in an IMEX cell, contact events located; f64, CPU) from the cell's end state; converged at a scaled residual of {TOL:e} (rad, rates over 2 pi f); multipliers from the monodromy matrix by forward differences"
        ),
        "arrays": {
            "orbit_status": "what shooting from the cell's own end state gave (status_codes)",
            "orbit_period": "the converged orbit's least period (forcing periods; 0: none); where the orbit is stable, period.npy holds it too (periods_corrected: the cells where it differed from the detector's)",
            "orbit_residual": "its scaled residual",
            "floquet_max": "its largest Floquet multiplier modulus (< 1: stable)",
            "floquet_minus1": "its real multiplier nearest -1 (NaN: none real)",
            "floquet_plus1": "its real multiplier nearest +1 (NaN: none real)",
            "orbit_extent_rad": "the range of the holder angle over the orbit (rad)",
            "orbit_family": "its family label across cells (-1: none)",
            "orbits_known": "orbits known at the cell, its own and those continued into it",
            "orbits_stable": "of those, the stable ones",
        },
        "details": ["orbits.json", "bifurcations.json"],
    })
}
