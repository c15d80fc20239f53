//! The map's settling stage (`map.settle_max_s`; `docs/analysis.md`, §10 "Settling"): the
//! cells whose verdict is not firm run on, with the early stop, so that transient chaos gets
//! the time to settle.
//!
//! ```text
//! run on:   undecided, or verdict_confidence < FIRM (0.9); a failed cell is final
//! rerun:    from the cell's start for settle_max_s, transient settle_max_s − (T − T_tr),
//!           the early stop on: a cell stops once its orbit is confirmed and λ1 shrinks it
//! result:   the rerun's indicators replace the cell's; steps add up; verdict_confidence is
//!           computed again over the whole grid (the neighbours' new verdicts included),
//!           from the table measured on settled maps (`confidence::SETTLED`)
//! ```
//!
//! One pass: a firm cell whose neighbour changes its verdict is not rerun. The stage is the
//! map's, so it needs the whole grid (`run_map`, `--devices`), not a shard.

use super::{MapRun, confidence, run_plan};
use pendulum_atlas_core::config::{FIRM, MapSpec};
use pendulum_atlas_core::engine::{Engine, EngineError, EnsemblePlan, Progress};
use pendulum_atlas_core::reduce::{InstanceResult, ReduceOptions, Regime};
use serde::Serialize;
use std::time::Instant;

/// What the settling stage did (`map.json`'s `settle`).
#[derive(Debug, Clone, Serialize)]
pub struct SettleReport {
    /// `map.settle_max_s` (s).
    pub max_s: f64,
    /// The confidence below which a cell ran on.
    pub firm: f64,
    /// Cells run on.
    pub cells: usize,
    /// Of those, cells stopped early (their orbit confirmed before `max_s`).
    pub stopped_early: usize,
    /// Of those, cells whose verdict changed.
    pub changed: usize,
    /// Cells that were chaotic at the map's length and periodic or regular after it.
    pub chaos_settled: usize,
    /// Instance-steps of the reruns.
    pub steps: u64,
    /// Wall time of the stage (s).
    pub wall_s: f64,
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
/// and put their results in place.
pub fn settle(
    spec: &MapSpec,
    run: &mut MapRun,
    engine: &Engine,
    progress: Progress,
) -> Result<(), EngineError> {
    let Some(max_s) = spec.settle_max_s else {
        return Ok(());
    };
    let t0 = Instant::now();
    let members = unsettled(&run.results);
    let mut report = SettleReport {
        max_s,
        firm: FIRM,
        cells: members.len(),
        stopped_early: 0,
        changed: 0,
        chaos_settled: 0,
        steps: 0,
        wall_s: 0.0,
    };
    if !members.is_empty() {
        let long = spec.lengthened(max_s)?;
        let plan = EnsemblePlan::new(&long)?.select(&members);
        let tail = (!run.strobe_tail.is_empty()).then_some(spec.bifurcation_samples as usize);
        let rerun = run_plan(
            plan,
            &ReduceOptions::from_spec(&long),
            tail,
            engine,
            progress,
        )?;
        report.stopped_early = rerun.stopped_early;
        run.sub_steps = pendulum_atlas_core::engine::add_counts(run.sub_steps, rerun.sub_steps);
        put_in_place(run, &members, &rerun, &mut report);
        add_times(run, &rerun);
    }
    report.wall_s = t0.elapsed().as_secs_f64();
    run.timings.total_s += report.wall_s;
    run.settle = Some(report);
    confidence::fill_run(&spec.shape(), run);
    Ok(())
}

/// The reruns' results (and tails) in the cells `members` of `run`, counted in `report`.
fn put_in_place(run: &mut MapRun, members: &[usize], rerun: &MapRun, report: &mut SettleReport) {
    for (j, &k) in members.iter().enumerate() {
        let old = run.results[k];
        let mut new = rerun.results[j];
        report.steps += new.steps;
        new.steps += old.steps;
        report.changed += usize::from(new.regime != old.regime);
        report.chaos_settled += usize::from(
            old.regime == Regime::Chaotic
                && matches!(new.regime, Regime::Periodic | Regime::Regular),
        );
        run.results[k] = new;
        if let Some(t) = rerun.strobe_tail.get(j) {
            run.strobe_tail[k] = t.clone();
        }
    }
}

/// The rerun's stage times added to the map's (its total is the stage's own wall time).
fn add_times(run: &mut MapRun, rerun: &MapRun) {
    let (t, r) = (&mut run.timings, &rerun.timings);
    t.plan_s += r.plan_s;
    t.integrate_s += r.integrate_s;
    t.reduce_s += r.reduce_s;
}
