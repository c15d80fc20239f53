//! The map's orbit stage (`map.orbits`, on by default on a plain or refined map; `docs/analysis.md`,
//! §15): after settling, every cell whose verdict is periodic is shot from its end state, the
//! orbits are continued into the neighbouring cells and the bifurcation curves located
//! ([`pendulum_atlas_core::reduce::orbits`]).
//!
//! ```text
//! seed:     a periodic cell (period p ≥ 1) whose run kept its end state at a whole
//!           forcing period (every run ends on one: the early stop closes at a period's end)
//! plans:    the map's own instances; a bisection between two cells plans its point as the
//!           map plans a cell (same options, its own step)
//! period:   a cell whose own orbit converged, is stable, and has a least period other
//!           than its verdict's takes the orbit's period: the detector saw a slowly
//!           converging orbit (a multiplier near −1) alternate within its tolerance, or the
//!           map's error-controlled steps kept it from settling (docs/bench/ORBITS.md)
//! after:    the end states are dropped; the stage's wall time is `timings_s.orbits_s`
//! ```

use super::{MapRun, confidence};
use pendulum_atlas_core::config::MapSpec;
use pendulum_atlas_core::engine::{EnsembleOptions, EnsemblePlan, InstancePlan};
use pendulum_atlas_core::reduce::Regime;
use pendulum_atlas_core::reduce::orbits::{OrbitMap, OrbitStatus, Seed, curves, orbit_map};
use std::time::Instant;

/// Find the orbits of `run`'s periodic cells when `spec` asks for them; `run.final_state` is
/// emptied.
pub fn find_orbits(spec: &MapSpec, run: &mut MapRun) {
    let states = std::mem::take(&mut run.final_state);
    let Some(os) = spec.orbits else {
        return;
    };
    let t0 = Instant::now();
    let (seeds, status) = seeds(run, &states);
    let plans = &run.plan.instances;
    let mut map = orbit_map(&spec.shape(), plans, &seeds, &status, os.reach);
    let opts = EnsembleOptions::from_spec(spec);
    let plan_at = |v: &[f64]| -> Option<InstancePlan> {
        let scene = spec.scene_at(v).ok()?;
        EnsemblePlan::from_scenes(&[scene], &opts)
            .ok()?
            .instances
            .into_iter()
            .next()
    };
    let values = |k: usize| spec.values_of(k);
    let t1 = Instant::now();
    map.curves = curves(&map, plans, &values, &plan_at);
    map.timings.curves_s = t1.elapsed().as_secs_f64();
    map.periods_corrected = confirm_periods(run, &map);
    map.unstable_own = unstable_own(run, &map);
    run.orbits = Some(map);
    confidence::fill_run(&spec.shape(), run);
    let wall = t0.elapsed().as_secs_f64();
    run.timings.orbits_s = wall;
    run.timings.total_s += wall;
}

/// Give each cell whose own orbit converged stable the orbit's least period; the cells
/// changed.
fn confirm_periods(run: &mut MapRun, map: &OrbitMap) -> usize {
    let mut changed = 0;
    for (k, r) in run.results.iter_mut().enumerate() {
        let Some(own) = map.own_orbit(k).filter(|o| o.orbit.stable()) else {
            continue;
        };
        let p = f64::from(own.orbit.period);
        if r.period != p {
            r.period = p;
            changed += 1;
        }
    }
    changed
}

/// The periodic cells whose own orbit converged unstable (`confidence` holds them below
/// firm).
fn unstable_own(run: &MapRun, map: &OrbitMap) -> usize {
    (0..run.results.len())
        .filter(|&k| confidence::own_orbit_unstable(&run.results[k], map, k))
        .count()
}

/// Each cell's seed, and the status of a cell without one.
fn seeds(run: &MapRun, states: &[Vec<f64>]) -> (Vec<Option<Seed>>, Vec<OrbitStatus>) {
    let n = run.results.len();
    let mut seeds = vec![None; n];
    let mut status = vec![OrbitStatus::NotPeriodic; n];
    for k in 0..n {
        let r = &run.results[k];
        if r.regime != Regime::Periodic || r.period.is_nan() || r.period < 1.0 {
            continue;
        }
        let spp = u64::from(run.plan.instances[k].spp);
        match states.get(k).filter(|y| !y.is_empty()) {
            Some(x) if r.steps.is_multiple_of(spp) => {
                seeds[k] = Some(Seed {
                    x: x.clone(),
                    period: r.period as u32,
                });
            }
            _ => status[k] = OrbitStatus::NoStart,
        }
    }
    (seeds, status)
}
