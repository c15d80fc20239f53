//! A map from start to finish: plan the instances of a [`MapSpec`], run them on an opened
//! [`Engine`], keep what the pictures need. [`crate::output::map`] writes the files.

pub mod cell;
pub mod confidence;
pub mod continuation;
pub mod hardware_default;
pub mod orbits;
pub mod refine;
pub mod settle;
pub mod shard;
pub mod size;
pub mod transients;

use pendulum_atlas_core::config::{MapMode, MapSpec};
use pendulum_atlas_core::engine::gpu::GpuTimings;
use pendulum_atlas_core::engine::{
    Engine, EngineError, EngineInfo, EnsemblePlan, Progress, Readback, add_counts,
};
use pendulum_atlas_core::reduce::{
    AttractorMap, AttractorRule, InstanceResult, ReduceOptions, attractor_map, basin_map,
};
use serde::Serialize;
use shard::Shard;
use std::borrow::Cow;
use std::time::Instant;

/// Wall time of each stage (s).
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct MapTimings {
    /// Validating every instance's scene and choosing its step.
    pub plan_s: f64,
    /// Opening the engine (the GPU device) before the map.
    pub device_s: f64,
    /// Integration (on the GPU backend: everything on the device, reductions included; see
    /// `gpu` for the split).
    pub integrate_s: f64,
    /// Reductions on the host (CPU runs: K, R, period with the analysis library).
    pub reduce_s: f64,
    /// The attractor stage of a map that labels attractors (fingerprints, matching, labels),
    /// after the reductions.
    #[serde(default)]
    pub attractors_s: f64,
    /// The orbit stage (shooting, continuation, bifurcation curves), after settling.
    #[serde(default)]
    pub orbits_s: f64,
    /// Everything.
    pub total_s: f64,
    /// The GPU's own stages.
    pub gpu: Option<GpuTimings>,
}

impl MapTimings {
    /// The share of the wall time (of `total_s`) each stage took: planning, opening the
    /// engine, integration and host reductions (on the GPU backend the device's reductions
    /// are inside `integrate`, see [`GpuTimings`]).
    pub fn wall_share(&self) -> WallShare {
        let of = |t: f64| t / self.total_s.max(1e-12);
        WallShare {
            plan: of(self.plan_s),
            device: of(self.device_s),
            integrate: of(self.integrate_s),
            reduce: of(self.reduce_s),
        }
    }
}

/// Fractions of a map's wall time, stage by stage (see [`MapTimings::wall_share`]).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct WallShare {
    /// Planning.
    pub plan: f64,
    /// Opening the engine.
    pub device: f64,
    /// Integration.
    pub integrate: f64,
    /// Host reductions (K, R, period, spectra of the CPU engine).
    pub reduce: f64,
}

/// A finished map.
#[derive(Debug, Clone, Serialize)]
pub struct MapRun {
    /// Per-instance results in grid order (last axis fastest).
    #[serde(skip)]
    pub results: Vec<InstanceResult>,
    /// The instances' plans.
    #[serde(skip)]
    pub plan: EnsemblePlan,
    /// The engine that ran it.
    pub engine: EngineInfo,
    /// Wall time per stage.
    pub timings: MapTimings,
    /// Integration dispatches (GPU).
    pub dispatches: u32,
    /// Instances stopped early on a confirmed periodic orbit.
    pub stopped_early: usize,
    /// Adaptive steps: the sub-steps every integration of the map tried, accepted and
    /// rejected (`None` at fixed steps).
    pub sub_steps: Option<u64>,
    /// Stroboscopic tail per instance for the bifurcation diagram (empty unless asked for).
    #[serde(skip)]
    pub strobe_tail: Vec<Vec<f64>>,
    /// The shards it was merged from (empty for a run in one piece).
    pub shards: Vec<ShardSummary>,
    /// Per grid point, whether it was filled from its block by refinement (empty without
    /// refinement).
    #[serde(skip)]
    pub inferred: Vec<bool>,
    /// What refinement did, when it ran.
    pub refine: Option<refine::RefineReport>,
    /// The attractors of a map run from several starts per cell; `results`, `plan` and
    /// `strobe_tail` then hold each cell's representative run (the first start that reached
    /// its most likely attractor), and `runs` counts every run.
    pub attractors: Option<AttractorMap>,
    /// Every run of the ensemble when it is more than one per cell.
    pub runs: Option<RunCount>,
    /// A map run by continuation: each direction's results (the first is `results`), and
    /// where up and down differ.
    pub continuation: Option<continuation::ContinuationRun>,
    /// What the settling stage did, when `map.settle_max_s` is set.
    pub settle: Option<settle::SettleReport>,
    /// Each instance's state at the end of its run, kept for the settling stage where the
    /// map settles and for the orbit stage (empty otherwise, and after those stages).
    #[serde(skip)]
    pub final_state: Vec<Vec<f64>>,
    /// What the nudged copies of the cells settling left not firm found, when
    /// `map.transient_copies` is set (`transients`).
    pub transients: Option<transients::TransientMap>,
    /// The exact periodic orbits, their multipliers and bifurcation curves, when
    /// `map.orbits` is on.
    #[serde(skip)]
    pub orbits: Option<pendulum_atlas_core::reduce::orbits::OrbitMap>,
}

/// The size of a map's ensemble when cells ran several starts: what was integrated in all.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct RunCount {
    /// Runs (cells × starts).
    pub runs: usize,
    /// Runs that ended ok.
    pub ok: usize,
    /// Instance-steps integrated, every run.
    pub steps: u64,
    /// Instance-steps planned, every run.
    pub planned_steps: u64,
}

/// One shard of a merged map, as `map.json` lists it.
#[derive(Debug, Clone, Serialize)]
pub struct ShardSummary {
    /// Which shard.
    pub shard: Shard,
    /// Its folder.
    pub dir: String,
    /// The device it ran on.
    pub device: String,
    /// Its instances.
    pub instances: usize,
    /// Its wall time (s).
    pub total_s: f64,
}

impl MapRun {
    /// A run of `plan` with its results, engine, times, `(dispatches, early stops, sub-steps)` and
    /// stroboscopic tails, and nothing of the staged maps (shards, refinement, attractors,
    /// continuation) yet.
    fn new(
        results: Vec<InstanceResult>,
        plan: EnsemblePlan,
        engine: EngineInfo,
        timings: MapTimings,
        (dispatches, stopped_early, sub_steps): Counts,
        strobe_tail: Vec<Vec<f64>>,
    ) -> MapRun {
        MapRun {
            results,
            plan,
            engine,
            timings,
            dispatches,
            stopped_early,
            sub_steps,
            strobe_tail,
            shards: Vec::new(),
            inferred: Vec::new(),
            refine: None,
            attractors: None,
            runs: None,
            continuation: None,
            settle: None,
            final_state: Vec::new(),
            transients: None,
            orbits: None,
        }
    }

    /// Instance-steps per second of the integration stage (the GPU's integration dispatches
    /// alone, without its reductions, on the GPU backend).
    pub fn instance_steps_per_s(&self) -> f64 {
        let t = match &self.timings.gpu {
            Some(g) => g.integrate_s,
            None => self.timings.integrate_s,
        };
        let steps: u64 = match &self.runs {
            Some(c) => c.steps,
            None => self.results.iter().map(|r| r.steps).sum(),
        };
        steps as f64 / t.max(1e-12)
    }

    /// Segment-steps per second (instance-steps × N).
    pub fn segment_steps_per_s(&self) -> f64 {
        self.instance_steps_per_s() * self.plan.segments as f64
    }

    /// Wall time of integration and reductions (s).
    pub fn engine_s(&self) -> f64 {
        match &self.timings.gpu {
            Some(g) => g.integrate_s + g.reduce_s,
            None => self.timings.integrate_s + self.timings.reduce_s,
        }
    }
}

/// Host memory a map takes to plan and hold its results (bytes), estimated before any work:
/// about 1 kB per instance plus 200 B per segment (its plan's coefficient vectors; measured:
/// a peak RSS of 342 404 KiB for 200 000 instances at N = 3, files included) and its
/// bifurcation tail.
pub(crate) fn host_bytes_estimate(spec: &MapSpec) -> u64 {
    let tail = if spec.bifurcation {
        8 * u64::from(spec.bifurcation_samples)
    } else {
        0
    };
    let per_instance = 1024 + 200 * spec.scene.beam.segments as u64 + tail;
    (spec.instances() * spec.starts_per_cell()) as u64 * per_instance
}

/// Refuse a map whose plan and results would not fit in half the memory available now (every
/// shard plans the whole map, so sharding does not shrink it).
pub fn check_host_memory(spec: &MapSpec) -> Result<(), EngineError> {
    use crate::machine::memory_available;
    use pendulum_atlas_core::text::bytes;
    let need = host_bytes_estimate(spec);
    match memory_available() {
        Some(available) if need > available / 2 => Err(EngineError::HostMemory {
            instances: spec.instances(),
            segments: spec.scene.beam.segments,
            need: bytes(need),
            available: bytes(available),
        }),
        _ => Ok(()),
    }
}

/// Plan, integrate and reduce a map on an opened engine.
pub fn run_map(spec: &MapSpec, engine: &Engine, progress: Progress) -> Result<MapRun, EngineError> {
    run_map_settling(spec, settle::Which::Unsettled, engine, progress)
}

/// [`run_map`], its settling stage on the cells `which`.
fn run_map_settling(
    spec: &MapSpec,
    which: settle::Which,
    engine: &Engine,
    progress: Progress,
) -> Result<MapRun, EngineError> {
    let t0 = Instant::now();
    let plan = EnsemblePlan::new_with(spec, progress)?;
    let mut run = run_map_part(spec, Cow::Owned(plan), None, engine, progress, t0)?;
    confidence::fill_run(&spec.shape(), &mut run);
    settle::settle_cells(spec, &mut run, which, engine, progress)?;
    orbits::find_orbits(spec, &mut run);
    Ok(run)
}

/// Refuse to split a map whose cells cannot run apart ([`MapMode::unshardable`]), before any
/// planning: a map that labels attractors, a continuation, a refined map.
pub fn check_shardable(spec: &MapSpec) -> Result<(), EngineError> {
    match spec.mode.unshardable() {
        Some((key, reason)) => Err(pendulum_atlas_core::config::ConfigError::Inconsistent {
            key: key.into(),
            reason: reason.into(),
        }
        .into()),
        None => Ok(()),
    }
}

/// Keep `shard`'s instances of the whole map's `plan` (all without one), integrate and reduce
/// them; planning time (since `t0`) counts in the run's timings.
fn run_map_part(
    spec: &MapSpec,
    plan: Cow<'_, EnsemblePlan>,
    shard: Option<Shard>,
    engine: &Engine,
    progress: Progress,
    t0: Instant,
) -> Result<MapRun, EngineError> {
    if shard.is_some() {
        check_shardable(spec)?;
    }
    // The reductions' options, the same for every mode and every ensemble of the map.
    let opts = ReduceOptions::from_spec(spec);
    match &spec.mode {
        MapMode::Attractors { .. } => {
            return run_starts(plan.into_owned(), (spec, &opts), engine, progress, t0);
        }
        MapMode::Continuation(cs) => {
            let plan = plan.into_owned();
            return run_continued(plan, (spec, &opts), cs, engine, progress, t0);
        }
        MapMode::Refined(rs) => {
            let plan_s = t0.elapsed().as_secs_f64();
            let mut run = run_refined(plan.into_owned(), rs, (spec, &opts), engine, progress)?;
            run.timings.plan_s = plan_s;
            run.timings.total_s += plan_s;
            return Ok(run);
        }
        MapMode::Plain => {}
    }
    let plan = match shard {
        Some(s) => {
            let part = plan.select(&s.members(spec.instances()));
            if part.instances.is_empty() {
                return Err(EngineError::Empty);
            }
            part
        }
        None => plan.into_owned(),
    };
    let plan_s = t0.elapsed().as_secs_f64();
    let tail = spec
        .bifurcation
        .then_some(spec.bifurcation_samples as usize);
    let keep = spec.keeps_final_state();
    let (mut run, final_state) = run_engine(plan, &opts, tail, keep, engine, progress)?;
    run.final_state = final_state;
    run.timings.plan_s = plan_s;
    run.timings.total_s += plan_s;
    Ok(run)
}

/// A map that labels attractors (several starts per cell, or a basin picture with one): every
/// (cell, start) run in the one ensemble with the stroboscopic tail its fingerprint needs,
/// then the attractor stage ([`pendulum_atlas_core::reduce::attractors`]) groups and labels the runs and
/// picks each cell's representative.
fn run_starts(
    plan: EnsemblePlan,
    (spec, opts): (&MapSpec, &ReduceOptions),
    engine: &Engine,
    progress: Progress,
    t0: Instant,
) -> Result<MapRun, EngineError> {
    let plan_s = t0.elapsed().as_secs_f64();
    let bifurcation = spec
        .bifurcation
        .then_some(spec.bifurcation_samples as usize);
    let tail = bifurcation.unwrap_or(0).max(spec.period_max as usize);
    let mut run = run_plan(plan, opts, Some(tail), engine, progress)?;
    let t_stage = Instant::now();
    let k = spec.starts_per_cell();
    let rule = AttractorRule::for_period_tol(spec.period_tol_rad);
    let map = if spec.is_basin_picture() {
        basin_map(&run.results, &run.strobe_tail, rule)
    } else {
        attractor_map(&spec.shape(), k, &run.results, &run.strobe_tail, rule)
    };
    let pick = |c: usize| c * k + map.representative[c];
    run.runs = Some(RunCount {
        runs: run.results.len(),
        ok: run.results.iter().filter(|r| r.status.is_ok()).count(),
        steps: run.results.iter().map(|r| r.steps).sum(),
        planned_steps: run.plan.total_steps,
    });
    let picks: Vec<usize> = (0..spec.instances()).map(pick).collect();
    run.results = picks.iter().map(|&i| run.results[i]).collect();
    run.plan = run.plan.select(&picks);
    run.strobe_tail = match bifurcation {
        Some(n) => picks
            .iter()
            .map(|&i| {
                let t = &run.strobe_tail[i];
                t[t.len().saturating_sub(n)..].to_vec()
            })
            .collect(),
        None => Vec::new(),
    };
    run.attractors = Some(map);
    run.timings.attractors_s = t_stage.elapsed().as_secs_f64();
    run.timings.plan_s = plan_s;
    run.timings.total_s += plan_s + run.timings.attractors_s;
    Ok(run)
}

/// A map's dispatches, instances stopped early and sub-steps tried (adaptive steps).
type Counts = (u32, usize, Option<u64>);

/// Times, dispatches, early stops, sub-steps and warnings added up over the ensembles of a
/// staged map (refinement's levels, continuation's steps).
#[derive(Default)]
struct StageTotals {
    timings: MapTimings,
    dispatches: u32,
    stopped_early: usize,
    sub_steps: Option<u64>,
    warnings: Vec<String>,
}

impl StageTotals {
    fn add(&mut self, run: &MapRun) {
        let t = &mut self.timings;
        t.integrate_s += run.timings.integrate_s;
        t.reduce_s += run.timings.reduce_s;
        t.gpu = GpuTimings::join(t.gpu.take(), run.timings.gpu.clone());
        self.dispatches += run.dispatches;
        self.stopped_early += run.stopped_early;
        self.sub_steps = add_counts(self.sub_steps, run.sub_steps);
        for w in &run.plan.warnings {
            if !self.warnings.contains(w) {
                self.warnings.push(w.clone());
            }
        }
    }

    /// The timings (with the engine's opening and the wall time since `t_all`), and the
    /// dispatches, early stops and sub-steps.
    fn finish(&mut self, engine: &Engine, t_all: &Instant) -> (MapTimings, Counts) {
        let mut timings = std::mem::take(&mut self.timings);
        timings.device_s = engine.info().open_s;
        timings.total_s = t_all.elapsed().as_secs_f64();
        (
            timings,
            (self.dispatches, self.stopped_early, self.sub_steps),
        )
    }
}

/// A map by continuation ([`continuation`]): each step of each direction is one ensemble
/// whose cells start from their predecessors' final states; the map's arrays hold the first
/// direction, and `continuation` every direction and their hysteresis.
fn run_continued(
    plan: EnsemblePlan,
    (spec, opts): (&MapSpec, &ReduceOptions),
    cs: &pendulum_atlas_core::config::ContinuationSpec,
    engine: &Engine,
    progress: Progress,
    t0: Instant,
) -> Result<MapRun, EngineError> {
    let plan_s = t0.elapsed().as_secs_f64();
    let t_all = Instant::now();
    let tail = (spec.period_max as usize).max(spec.bifurcation_samples as usize);
    let steps = (spec.axes[cs.axis].values.len() * cs.sweep.directions().len()) as u64;
    let mut step = 0u64;
    let mut totals = StageTotals::default();
    let fits = |k: usize, p: usize, y: &[f64]| {
        continuation::carried_state_fits(&plan.instances[p].params, &plan.instances[k].params, y)
    };
    let mut cont = continuation::continue_map(spec, cs, fits, |cells, starts| {
        let mut part = plan.select(cells);
        for (inst, start) in part.instances.iter_mut().zip(starts) {
            if let Some(y) = start {
                inst.y0 = y;
            }
        }
        let j = step;
        let step_progress =
            |done: u64, total: u64, unit| progress(j * total + done, steps * total, unit);
        let (run, final_state) = run_engine(part, opts, Some(tail), true, engine, &step_progress)?;
        step += 1;
        totals.add(&run);
        Ok(continuation::StepRun {
            results: run.results,
            strobe_tail: run.strobe_tail,
            final_state,
        })
    })?;
    let (mut timings, counts) = totals.finish(engine, &t_all);
    timings.plan_s = plan_s;
    timings.total_s += plan_s;
    let beyond: Vec<String> = cont.legs.iter().filter(|l| l.beyond_bumpers > 0).map(|l| {
        format!(
            "continuation {}: {} cell(s) started from the scene's state, because the state their neighbour ended in lay beyond their bumpers (a smaller limiter.clearance_deg)",
            l.direction.name(),
            l.beyond_bumpers
        )
    }).collect();
    let first = &mut cont.legs[0];
    let strobe_tail = if spec.bifurcation {
        let n = spec.bifurcation_samples as usize;
        first
            .strobe_tail
            .iter()
            .map(|t| t[t.len().saturating_sub(n)..].to_vec())
            .collect()
    } else {
        Vec::new()
    };
    let mut plan = plan;
    plan.warnings = std::mem::take(&mut totals.warnings);
    plan.warnings.extend(beyond);
    let results = first.results.clone();
    let mut run = MapRun::new(
        results,
        plan,
        engine.info().clone(),
        timings,
        counts,
        strobe_tail,
    );
    run.continuation = Some(cont);
    Ok(run)
}

/// A map by adaptive refinement ([`refine`]): each stage integrates and reduces its cells on
/// `engine`; times, dispatches and early stops add up over the stages.
fn run_refined(
    plan: EnsemblePlan,
    rs: &pendulum_atlas_core::config::RefineSpec,
    (spec, opts): (&MapSpec, &ReduceOptions),
    engine: &Engine,
    progress: Progress,
) -> Result<MapRun, EngineError> {
    let t_all = Instant::now();
    let mut totals = StageTotals::default();
    // A settling map keeps each computed cell's final state, for its run on, and so does a
    // map that finds its orbits.
    let keep = spec.keeps_final_state();
    let mut final_state = vec![Vec::new(); if keep { plan.instances.len() } else { 0 }];
    let refined = refine::refine(spec, rs, |members| {
        let (run, states) = run_engine(plan.select(members), opts, None, keep, engine, progress)?;
        totals.add(&run);
        for (&k, y) in members.iter().zip(states) {
            final_state[k] = y;
        }
        Ok(run.results)
    })?;
    let (timings, counts) = totals.finish(engine, &t_all);
    let mut plan = plan;
    plan.warnings = totals.warnings;
    let info = engine.info().clone();
    let mut run = MapRun::new(refined.results, plan, info, timings, counts, Vec::new());
    run.inferred = refined.inferred;
    run.refine = Some(refined.report);
    run.final_state = final_state;
    Ok(run)
}

/// Integrate and reduce an already planned ensemble (see [`EnsemblePlan::from_scenes`]) on an
/// opened engine. `strobe_tail` keeps that many trailing stroboscopic samples per instance.
pub fn run_plan(
    plan: EnsemblePlan,
    opts: &ReduceOptions,
    strobe_tail: Option<usize>,
    engine: &Engine,
    progress: Progress,
) -> Result<MapRun, EngineError> {
    Ok(run_engine(plan, opts, strobe_tail, false, engine, progress)?.0)
}

/// [`run_plan`], with every instance's final state when `final_state` (else an empty list).
fn run_engine(
    plan: EnsemblePlan,
    opts: &ReduceOptions,
    strobe_tail: Option<usize>,
    final_state: bool,
    engine: &Engine,
    progress: Progress,
) -> Result<(MapRun, Vec<Vec<f64>>), EngineError> {
    let t_all = Instant::now();
    let readback = Readback {
        strobe: strobe_tail.is_some(),
        strobe_last: strobe_tail.map(|k| k as u32),
        r_series: false,
        final_state,
    };
    let mut run = engine.run(&plan, opts, readback, progress)?;
    let states = std::mem::take(&mut run.final_state);
    let keep = strobe_tail.unwrap_or(0);
    let strobe_tail = run
        .strobe
        .iter()
        .map(|s| s[s.len().saturating_sub(keep)..].to_vec())
        .collect();
    let timings = MapTimings {
        plan_s: 0.0,
        device_s: engine.info().open_s,
        integrate_s: run.timings.integrate_s,
        reduce_s: run.timings.reduce_s,
        attractors_s: 0.0,
        orbits_s: 0.0,
        total_s: t_all.elapsed().as_secs_f64(),
        gpu: run.timings.gpu,
    };
    let counts = (run.dispatches, run.stopped_early, run.sub_steps);
    let info = engine.info().clone();
    let map_run = MapRun::new(run.results, plan, info, timings, counts, strobe_tail);
    Ok((map_run, states))
}

/// One separately run part of a map (a shard, or one device's share): its instances' results.
#[derive(Debug, Clone)]
pub struct MapPart {
    /// Which part.
    pub shard: Shard,
    /// Where it ran or lies (a shard folder, a device).
    pub label: String,
    /// Grid index of each result.
    pub members: Vec<usize>,
    /// Results in member order.
    pub results: Vec<InstanceResult>,
    /// Stroboscopic tails in member order (empty without a bifurcation diagram).
    pub strobe_tail: Vec<Vec<f64>>,
    /// The engine that ran it.
    pub engine: EngineInfo,
    /// Its wall times.
    pub timings: MapTimings,
    /// Its dispatches.
    pub dispatches: u32,
    /// Its instances stopped early.
    pub stopped_early: usize,
    /// Its sub-steps tried (adaptive steps).
    pub sub_steps: Option<u64>,
    /// Final states in member order, for the settling stage (empty where the map does not
    /// settle).
    pub final_state: Vec<Vec<f64>>,
}

/// The parts' results in grid order, their times summed, as one run of `plan` (the whole map).
/// The parts must cover the grid exactly once (the callers check it).
pub fn assemble(plan: EnsemblePlan, parts: Vec<MapPart>) -> MapRun {
    let n = plan.instances.len();
    let mut results = vec![None; n];
    let with_tail = parts.iter().any(|p| !p.strobe_tail.is_empty());
    let mut strobe_tail = vec![Vec::new(); if with_tail { n } else { 0 }];
    let with_state = parts.iter().all(|p| p.final_state.len() == p.members.len());
    let mut final_state = vec![Vec::new(); if with_state { n } else { 0 }];
    let mut timings = MapTimings::default();
    let mut shards = Vec::new();
    let mut devices: Vec<String> = Vec::new();
    for p in &parts {
        for (j, &k) in p.members.iter().enumerate() {
            results[k] = Some(p.results[j]);
            if with_tail {
                strobe_tail[k] = p.strobe_tail[j].clone();
            }
            if with_state {
                final_state[k] = p.final_state[j].clone();
            }
        }
        let t = &p.timings;
        timings.plan_s += t.plan_s;
        timings.device_s += t.device_s;
        timings.integrate_s += t.integrate_s;
        timings.reduce_s += t.reduce_s;
        timings.total_s += t.total_s;
        if !devices.contains(&p.engine.device) {
            devices.push(p.engine.device.clone());
        }
        shards.push(ShardSummary {
            shard: p.shard,
            dir: p.label.clone(),
            device: p.engine.device.clone(),
            instances: p.members.len(),
            total_s: t.total_s,
        });
    }
    shards.sort_by_key(|s| s.shard.index);
    let mut engine = parts[0].engine.clone();
    engine.device = devices.join(" + ");
    let results = results
        .into_iter()
        .map(|r| r.expect("the parts cover the grid"))
        .collect();
    let counts = (
        parts.iter().map(|p| p.dispatches).sum(),
        parts.iter().map(|p| p.stopped_early).sum(),
        parts.iter().map(|p| p.sub_steps).fold(None, add_counts),
    );
    let mut run = MapRun::new(results, plan, engine, timings, counts, strobe_tail);
    run.shards = shards;
    run.final_state = final_state;
    run
}

/// One map split over several opened engines (every GPU of a node), each integrating the
/// shard `d` of `engines.len()` in its own thread, assembled in grid order. Each device's
/// share is what `map --shard d/n` would integrate.
pub fn run_map_on_devices(
    spec: &MapSpec,
    engines: &[Engine],
    progress: Progress,
) -> Result<MapRun, EngineError> {
    let n = engines.len() as u32;
    let t0 = Instant::now();
    check_shardable(spec)?;
    let plan = EnsemblePlan::new_with(spec, progress)?;
    let plan_s = t0.elapsed().as_secs_f64();
    let runs: Vec<Result<MapPart, EngineError>> = std::thread::scope(|s| {
        let handles: Vec<_> = engines
            .iter()
            .enumerate()
            .map(|(d, engine)| {
                let plan = &plan;
                s.spawn(move || {
                    let shard = Shard {
                        index: d as u32,
                        count: n,
                    };
                    let started = Instant::now();
                    let run = run_map_part(
                        spec,
                        Cow::Borrowed(plan),
                        Some(shard),
                        engine,
                        progress,
                        started,
                    )?;
                    Ok(MapPart {
                        shard,
                        label: format!("device {d}"),
                        members: shard.members(spec.instances()),
                        results: run.results,
                        strobe_tail: run.strobe_tail,
                        engine: run.engine,
                        timings: run.timings,
                        dispatches: run.dispatches,
                        stopped_early: run.stopped_early,
                        sub_steps: run.sub_steps,
                        final_state: run.final_state,
                    })
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("a device thread panicked"))
            .collect()
    });
    let parts: Vec<MapPart> = runs.into_iter().collect::<Result<_, _>>()?;
    let mut run = assemble(plan, parts);
    confidence::fill_run(&spec.shape(), &mut run);
    settle::settle(spec, &mut run, &engines[0], progress)?;
    orbits::find_orbits(spec, &mut run);
    run.timings.plan_s += plan_s;
    run.timings.total_s = t0.elapsed().as_secs_f64();
    Ok(run)
}

/// Plan the whole map (so that every instance gets the step and method of the unsharded
/// run), then integrate and reduce only `shard`'s instances; the results are in member order
/// ([`Shard::members`]). A map that settles keeps its final states: `merge` settles the
/// whole grid ([`settle::settle`]).
pub fn run_map_shard(
    spec: &MapSpec,
    shard: Shard,
    engine: &Engine,
    progress: Progress,
) -> Result<MapRun, EngineError> {
    check_shardable(spec)?;
    let t0 = Instant::now();
    let plan = EnsemblePlan::new_with(spec, progress)?;
    run_map_part(spec, Cow::Owned(plan), Some(shard), engine, progress, t0)
}
