//! The map's settling stage (`map.settle_max_s`, on by default; `docs/analysis.md`, §10
//! "Settling"): the cells whose verdict is not firm run on, with the early stop, so that
//! transient chaos gets the time to settle.
//!
//! ```text
//! run on:    undecided, or verdict_confidence < FIRM (0.9); a failed cell is final
//! continue:  a cell that ran the map's whole length T (P forcing periods) goes on from its
//!            final state as the cell's run of T_s from period P on: the same steps, strobe
//!            instants and indicators' window W = T − T_tr as one run of T_s
//!            (`InstancePlan::continued_after`); the forcing's phase carries over; the sums'
//!            compensation and the early stop's watch start again (so a chaotic cell takes
//!            another, equally accurate trajectory, and an orbit is confirmed anew)
//! rerun:     a cell the early stop ended before T (continuing it saved no time: its watch
//!            starts again, measured on the default map), and every cell with
//!            `map.settle_from = "start"`, runs again from its start for T_s, transient
//!            T_s − W: one run of T_s, bit for bit
//! result:    the run-on's indicators replace the cell's; steps add up; verdict_confidence is
//!            computed again over the whole grid (the neighbours' new verdicts included),
//!            from the table measured on settled maps (`confidence::SETTLED`)
//! copies:    the cells still not firm then run nudged copies (`map.transient_copies`,
//!            [`super::transients`])
//! ```
//!
//! One pass: a firm cell whose neighbour changes its verdict is not run on. The stage needs
//! the whole grid: `run_map` and `--devices` run it after the map, `merge` after the shards
//! (which keep their cells' final states for it).

use super::{MapRun, confidence, run_engine};
use pendulum_atlas_core::config::{FIRM, MapSpec, SettleFrom};
use pendulum_atlas_core::engine::gpu::GpuTimings;
use pendulum_atlas_core::engine::{Engine, EngineError, EnsemblePlan, Progress, add_counts};
use pendulum_atlas_core::reduce::{InstanceResult, ReduceOptions, Regime};
use serde::Serialize;
use std::time::Instant;

/// What the settling stage did (`map.json`'s `settle`).
#[derive(Debug, Clone, Serialize)]
pub struct SettleReport {
    /// `map.settle_max_s` (s).
    pub max_s: f64,
    /// `map.settle_from`: where a cell run on starts again.
    pub from: SettleFrom,
    /// The confidence below which a cell ran on.
    pub firm: f64,
    /// Cells run on.
    pub cells: usize,
    /// Of those, cells continued from their final state.
    pub continued: usize,
    /// Of those, cells rerun from their start (stopped early before the map's length).
    pub rerun: usize,
    /// Of those, cells stopped early (their orbit confirmed before `max_s`).
    pub stopped_early: usize,
    /// Of those, cells whose verdict changed.
    pub changed: usize,
    /// Cells that were chaotic at the map's length and periodic or regular after it.
    pub chaos_settled: usize,
    /// Instance-steps of the runs on.
    pub steps: u64,
    /// Wall time of the stage (s).
    pub wall_s: f64,
}

/// Which cells the stage runs on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Which {
    /// Those whose verdict is not firm ([`unsettled`]): a map's stage.
    Unsettled,
    /// Every cell that did not fail: a map cell run again on its own, which its map ran on
    /// (`map::cell::rerun_cell`).
    Every,
}

/// The cells the stage runs on: decided but not firm, or undecided; never a failed one.
pub fn unsettled(results: &[InstanceResult]) -> Vec<usize> {
    (0..results.len())
        .filter(|&k| {
            let r = &results[k];
            let firm = r.verdict_confidence >= FIRM;
            r.regime != Regime::Failed && !firm
        })
        .collect()
}

/// Run `spec`'s unsettled cells of `run` on (when `map.settle_max_s` is set) on `engine`,
/// and put their results in place. `run.final_state` must hold every cell's final state
/// (the map keeps them when it settles); it is emptied here, unless the orbit stage follows
/// (`map.orbits`): then the cells run on hold their new end states. The cells still not
/// firm then run their nudged copies ([`super::transients`]).
pub fn settle(
    spec: &MapSpec,
    run: &mut MapRun,
    engine: &Engine,
    progress: Progress,
) -> Result<(), EngineError> {
    settle_cells(spec, run, Which::Unsettled, engine, progress)
}

/// [`settle`] on the cells `which`.
pub(crate) fn settle_cells(
    spec: &MapSpec,
    run: &mut MapRun,
    which: Which,
    engine: &Engine,
    progress: Progress,
) -> Result<(), EngineError> {
    let Some(max_s) = spec.settle_max_s else {
        return Ok(());
    };
    let t0 = Instant::now();
    let members = match which {
        Which::Unsettled => unsettled(&run.results),
        Which::Every => (0..run.results.len())
            .filter(|&k| run.results[k].regime != Regime::Failed)
            .collect(),
    };
    let long = spec.lengthened(max_s)?;
    let long_plan = EnsemblePlan::new(&long)?;
    let (continued, rerun) = match spec.settle_from {
        SettleFrom::End => split(run, &long_plan, &members),
        SettleFrom::Start => (Vec::new(), members.clone()),
    };
    let mut report = SettleReport {
        max_s,
        from: spec.settle_from,
        firm: FIRM,
        cells: members.len(),
        continued: continued.len(),
        rerun: rerun.len(),
        stopped_early: 0,
        changed: 0,
        chaos_settled: 0,
        steps: 0,
        wall_s: 0.0,
    };
    let mut shifted = long_plan.clone();
    for &k in &continued {
        let done = run.plan.instances[k].total_periods;
        let inst = &mut shifted.instances[k];
        *inst = inst.continued_after(done).expect("split kept it");
        inst.y0 = std::mem::take(&mut run.final_state[k]);
    }
    // The copies and the orbit stage start from the end states of the runs on too.
    let keep = spec.orbits.is_some() || spec.transients.is_some();
    if !keep {
        run.final_state = Vec::new();
    }
    let groups = [
        (continued.clone(), shifted.select(&continued)),
        (rerun.clone(), long_plan.select(&rerun)),
    ];
    let tail = (!run.strobe_tail.is_empty()).then_some(spec.bifurcation_samples as usize);
    // (The map's own options: they do not depend on the run's length. Settling is a stage of
    // its own, which `merge` runs on a merged map, so it reads them from the scene too.)
    let opts = ReduceOptions::from_spec(spec);
    for (cells, plan) in groups {
        if cells.is_empty() {
            continue;
        }
        let (part, states) = run_engine(plan, &opts, tail, keep, engine, progress)?;
        for (&k, y) in cells.iter().zip(states) {
            run.final_state[k] = y;
        }
        report.stopped_early += part.stopped_early;
        put_in_place(run, &cells, &part, &mut report);
        absorb(run, &part);
    }
    report.wall_s = t0.elapsed().as_secs_f64();
    run.timings.total_s += report.wall_s;
    run.settle = Some(report);
    confidence::fill_run(&spec.shape(), run);
    super::transients::see_through(spec, run, (&long_plan, which), engine, progress)?;
    if spec.orbits.is_none() {
        run.final_state = Vec::new();
    }
    Ok(())
}

/// `members` split into the cells that ran the map's whole length, kept their final state
/// and lie within the transient of their run on `long` (continued), and the rest (stopped
/// early: rerun from their start).
fn split(run: &MapRun, long: &EnsemblePlan, members: &[usize]) -> (Vec<usize>, Vec<usize>) {
    members.iter().partition(|&&k| {
        let first = &run.plan.instances[k];
        let whole = run.results[k].steps == first.total_steps();
        let kept = run.final_state.get(k).is_some_and(|y| !y.is_empty());
        let fits = long.instances[k]
            .continued_after(first.total_periods)
            .is_some();
        whole && kept && fits
    })
}

/// The runs on's results (and tails) in the cells `members` of `run`, counted in `report`.
fn put_in_place(run: &mut MapRun, members: &[usize], rerun: &MapRun, report: &mut SettleReport) {
    for (j, &k) in members.iter().enumerate() {
        let old = run.results[k];
        let mut new = rerun.results[j];
        report.steps += new.steps;
        new.steps += old.steps;
        new.ran_on = true;
        report.changed += usize::from(new.regime != old.regime);
        report.chaos_settled += usize::from(
            old.regime == Regime::Chaotic
                && matches!(new.regime, Regime::Periodic | Regime::Regular),
        );
        run.results[k] = new;
        // A cell of a refined map that ran on is computed, no longer filled from its block.
        if let Some(inferred) = run.inferred.get_mut(k).filter(|i| **i) {
            *inferred = false;
            if let Some(r) = run.refine.as_mut() {
                r.inferred -= 1;
                r.computed += 1;
            }
        }
        if let Some(t) = rerun.strobe_tail.get(j) {
            run.strobe_tail[k] = t.clone();
        }
    }
}

/// A stage's run `part` counted in the map's: its sub-steps and stage times (its early stops
/// are the stage's own, in its report).
pub(super) fn absorb(run: &mut MapRun, part: &MapRun) {
    run.sub_steps = add_counts(run.sub_steps, part.sub_steps);
    add_times(run, part);
}

/// The run on's stage times added to the map's, the GPU's own among them, so that the map's
/// throughput divides every step it counts by the time of all of them (its total is the
/// stage's own wall time).
fn add_times(run: &mut MapRun, rerun: &MapRun) {
    let (t, r) = (&mut run.timings, &rerun.timings);
    t.plan_s += r.plan_s;
    t.integrate_s += r.integrate_s;
    t.reduce_s += r.reduce_s;
    t.gpu = GpuTimings::join(t.gpu.take(), r.gpu.clone());
}
