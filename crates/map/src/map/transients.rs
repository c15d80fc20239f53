//! The map's transient stage (`map.transient_copies`, on wherever the map settles;
//! `docs/analysis.md`, §16): each cell that settling leaves not firm runs M copies nudged from
//! its end state, as instances of the same engine, and the copies' eventual verdicts
//! ([`pendulum_atlas_core::reduce::escape`]) see through a chaotic transient and name the
//! cells where the start decides.
//!
//! ```text
//! cells:     decided or undecided, not failed, run on by settling, verdict_confidence <
//!            FIRM after settling, with an end state (a refined map's inferred cells have
//!            none); a cell run again on its own (`map::cell`) runs them where its map did
//! copy j:    the cell's end state, the first segment's rate + (j+1)·nudge, run as the
//!            cell's settling run on (the map's run of T_s continued from period P: the same
//!            steps, window and early stop) for T_s − T
//! take:      where the copies decide another verdict (a cell not periodic: every escape on
//!            one orbit; any cell: more than half of the copies on one verdict, `escape`),
//!            the cell takes the first such copy's result (indicators, λ1, period), end
//!            state and tail
//! keep:      otherwise the cell's result stays; its steps count its copies' in either case
//! per cell:  transient_s (τ, NaN without an escape; only where the cell was chaotic or
//!            undecided: copies of an orbit that return to it escape from nothing), its
//!            standard error, start_sensitivity (NaN where the cell ran no copies)
//! after:     verdict_confidence is computed again over the whole grid; a cell whose
//!            sensitivity s > 0 is held to FIRM·(1 − s), never firm (`confidence`)
//! ```

use super::{MapRun, confidence, run_engine, settle};
use pendulum_atlas_core::config::{FIRM, MapSpec, Metric, TransientSpec};
use pendulum_atlas_core::engine::{Engine, EngineError, EnsemblePlan, InstancePlan, Progress};
use pendulum_atlas_core::reduce::escape::{
    CopyOutcome, Eventual, confirm_periods, decide, lifetime,
};
use pendulum_atlas_core::reduce::{InstanceResult, ReduceOptions, Regime};
use serde::Serialize;
use std::time::Instant;

/// What the stage found, per cell and in all (`map.json`'s `transients`).
#[derive(Debug, Clone, Serialize)]
pub struct TransientMap {
    /// Copies per cell examined (M).
    pub copies: u32,
    /// The nudge step of the first segment's rate (deg/s).
    pub nudge_deg_s: f64,
    /// Cells that ran copies.
    pub cells: usize,
    /// Copies that escaped to a periodic orbit.
    pub escapes: usize,
    /// Cells with at least one escape.
    pub cells_escaping: usize,
    /// Cells whose verdict became the copies' orbit: chaos seen as a transient, or a regular
    /// cell's orbit confirmed.
    pub took_orbit: usize,
    /// Undecided cells that took the copies' decided verdict.
    pub decided: usize,
    /// Cells with a start sensitivity above 0.
    pub start_decides: usize,
    /// Instance-steps of the copies.
    pub steps: u64,
    /// Wall time of the stage (s).
    pub wall_s: f64,
    /// Per cell: the chaotic transient's mean lifetime τ (s); NaN without an escape.
    #[serde(skip)]
    pub lifetime_s: Vec<f64>,
    /// Per cell: τ's standard error (s).
    #[serde(skip)]
    pub lifetime_se_s: Vec<f64>,
    /// Per cell: the share of copies whose eventual verdict differs from the cell's; NaN
    /// where the cell ran none.
    #[serde(skip)]
    pub sensitivity: Vec<f64>,
    /// Per cell: whether its verdict is the copies' periodic orbit after a chaotic transient
    /// (it was chaotic or undecided: `transient_s` is finite there, and only there among the
    /// periodic cells).
    #[serde(skip)]
    pub after_transient: Vec<bool>,
}

impl TransientMap {
    fn empty(ts: TransientSpec, n: usize) -> TransientMap {
        TransientMap {
            copies: ts.copies,
            nudge_deg_s: ts.nudge_deg_s,
            cells: 0,
            escapes: 0,
            cells_escaping: 0,
            took_orbit: 0,
            decided: 0,
            start_decides: 0,
            steps: 0,
            wall_s: 0.0,
            lifetime_s: vec![f64::NAN; n],
            lifetime_se_s: vec![f64::NAN; n],
            sensitivity: vec![f64::NAN; n],
            after_transient: vec![false; n],
        }
    }

    /// Whether the start decides cell `k`'s verdict (its copies disagree).
    pub fn start_decides_at(&self, k: usize) -> bool {
        self.sensitivity.get(k).is_some_and(|&s| s > 0.0)
    }
}

/// Run the copies of `run`'s cells `which` (a map's: those not firm after settling; a cell
/// run again on its own whose map ran its copies: every one) when `spec` asks for them, and
/// put what they decide in place (`long`: the settling plan).
pub(crate) fn see_through(
    spec: &MapSpec,
    run: &mut MapRun,
    (long, which): (&EnsemblePlan, settle::Which),
    engine: &Engine,
    progress: Progress,
) -> Result<(), EngineError> {
    let Some(ts) = spec.transients else {
        return Ok(());
    };
    let t0 = Instant::now();
    let mut map = TransientMap::empty(ts, run.results.len());
    let cells = examined(run, long, which);
    // At most as many copies at once as the map has instances: the map's memory check
    // (`check_host_memory`) then bounds the stage's too, whatever map.transient_copies.
    let per_batch = (spec.instances() / ts.copies as usize).max(1);
    for batch in cells.chunks(per_batch) {
        run_copies(spec, run, (long, batch), (engine, progress), &mut map)?;
    }
    map.wall_s = t0.elapsed().as_secs_f64();
    run.timings.total_s += map.wall_s;
    run.transients = Some(map);
    confidence::fill_run(&spec.shape(), run);
    Ok(())
}

/// Run the copies of `cells` (planned from `long`) on `engine` and apply each cell's
/// decision; the copies' sub-steps and times join the map's (their early stops are not the
/// map's instances').
fn run_copies(
    spec: &MapSpec,
    run: &mut MapRun,
    (long, cells): (&EnsemblePlan, &[usize]),
    (engine, progress): (&Engine, Progress),
    map: &mut TransientMap,
) -> Result<(), EngineError> {
    let m = map.copies as usize;
    let ts = spec.transients.expect("see_through checked it");
    let plan = copies_plan(run, long, cells, ts);
    let tail = (!run.strobe_tail.is_empty()).then_some(spec.bifurcation_samples as usize);
    let opts = ReduceOptions::from_spec(spec);
    let (part, states) = run_engine(plan, &opts, tail, true, engine, progress)?;
    let window = long.early_stop.map_or(spec.period_window, |e| e.window);
    let confirm = |p: u32| confirm_periods(window, p, spec.wants(Metric::Lyapunov));
    for (i, &k) in cells.iter().enumerate() {
        let at = i * m..(i + 1) * m;
        let results = &part.results[at.clone()];
        let outcomes = outcomes(results, &part.plan.instances[at.clone()], &confirm);
        if let Some(j) = apply(run, k, &outcomes, results, map) {
            run.final_state[k] = states[at.start + j].clone();
            if let Some(t) = part.strobe_tail.get(at.start + j) {
                run.strobe_tail[k] = t.clone();
            }
        }
    }
    map.cells += cells.len();
    map.steps += part.results.iter().map(|r| r.steps).sum::<u64>();
    settle::absorb(run, &part);
    Ok(())
}

/// The cells that run copies: not failed, run on by settling, not firm (with
/// [`settle::Which::Unsettled`]), with an end state whose settling run continues after the
/// map's length.
fn examined(run: &MapRun, long: &EnsemblePlan, which: settle::Which) -> Vec<usize> {
    (0..run.results.len())
        .filter(|&k| {
            let r = &run.results[k];
            let firm = which == settle::Which::Unsettled && r.verdict_confidence >= FIRM;
            let kept = run.final_state.get(k).is_some_and(|y| !y.is_empty());
            let after = run.plan.instances[k].total_periods;
            let fits = long.instances[k].continued_after(after).is_some();
            // A cell run again on its own runs copies only where it ran on (`map::cell`).
            r.regime != Regime::Failed && r.ran_on && !firm && kept && fits
        })
        .collect()
}

/// The ensemble of `cells`' copies, `ts.copies` per cell in cell order.
fn copies_plan(
    run: &MapRun,
    long: &EnsemblePlan,
    cells: &[usize],
    ts: TransientSpec,
) -> EnsemblePlan {
    let m = ts.copies as usize;
    let members: Vec<usize> = cells
        .iter()
        .flat_map(|&k| std::iter::repeat_n(k, m))
        .collect();
    let mut plan = long.select(&members);
    let rate = long.segments;
    for (i, inst) in plan.instances.iter_mut().enumerate() {
        let k = members[i];
        let after = run.plan.instances[k].total_periods;
        *inst = inst.continued_after(after).expect("examined kept it");
        let mut y = run.final_state[k].clone();
        y[rate] += ts.nudge_rad_s((i % m) as u32);
        inst.y0 = y;
    }
    plan.total_steps = plan.instances.iter().map(InstancePlan::total_steps).sum();
    plan
}

/// The copies' outcomes: eventual verdict, time run and confirmation span (`confirm`: of a
/// period, in forcing periods).
fn outcomes(
    results: &[InstanceResult],
    plans: &[InstancePlan],
    confirm: &dyn Fn(u32) -> u32,
) -> Vec<CopyOutcome> {
    results
        .iter()
        .zip(plans)
        .map(|(r, p)| {
            let eventual = Eventual::of(r.regime, r.period);
            let period_s = 1.0 / p.frequency_hz;
            let ran_s = r.steps as f64 / f64::from(p.spp) * period_s;
            let confirm_s = if eventual.periodic() {
                f64::from(confirm(eventual.period)) * period_s
            } else {
                0.0
            };
            CopyOutcome {
                eventual,
                ran_s,
                confirm_s,
            }
        })
        .collect()
}

/// Put cell `k`'s decision in place: its result (the taken copy's), steps and per-cell
/// figures; the index of the copy taken.
fn apply(
    run: &mut MapRun,
    k: usize,
    outcomes: &[CopyOutcome],
    results: &[InstanceResult],
    map: &mut TransientMap,
) -> Option<usize> {
    let old = run.results[k];
    let own = Eventual::of(old.regime, old.period);
    let d = decide(own, outcomes);
    let copies_steps: u64 = results.iter().map(|r| r.steps).sum();
    let mut new = match d.take {
        Some(j) => results[j],
        None => old,
    };
    new.steps = old.steps + copies_steps;
    new.ran_on = old.ran_on || d.take.is_some();
    run.results[k] = new;
    map.sensitivity[k] = d.sensitivity;
    map.start_decides += usize::from(d.sensitivity > 0.0);
    // Copies of an orbit that return to it do not escape from chaos: a transient, and its
    // lifetime, only where the cell was chaotic or undecided.
    let chaotic = matches!(own.regime, Regime::Chaotic | Regime::Undecided);
    let orbit = d.take.is_some() && d.verdict.periodic();
    map.after_transient[k] = orbit && chaotic;
    map.took_orbit += usize::from(orbit);
    map.decided += usize::from(d.take.is_some() && !orbit);
    if chaotic {
        let escapes = outcomes.iter().filter(|o| o.escape_s().is_some()).count();
        map.escapes += escapes;
        map.cells_escaping += usize::from(escapes > 0);
        if let Some((tau, se)) = lifetime(outcomes) {
            map.lifetime_s[k] = tau;
            map.lifetime_se_s[k] = se;
        }
    }
    d.take
}
