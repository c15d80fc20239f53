//! A map from start to finish: plan the instances of a [`MapSpec`], run them on an opened
//! [`Engine`], keep what the pictures need. [`crate::output::map`] writes the files.

use crate::config::MapSpec;
use crate::engine::gpu::GpuTimings;
use crate::engine::{
    Engine, EngineError, EngineInfo, EngineKind, EnsemblePlan, Progress, Readback,
};
use crate::reduce::{InstanceResult, ReduceOptions};
use crate::shard::Shard;
use serde::Serialize;
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
    /// Everything.
    pub total_s: f64,
    /// The GPU's own stages.
    pub gpu: Option<GpuTimings>,
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
    /// Stroboscopic tail per instance for the bifurcation diagram (empty unless asked for).
    #[serde(skip)]
    pub strobe_tail: Vec<Vec<f64>>,
    /// The shards it was merged from (empty for a run in one piece).
    pub shards: Vec<ShardSummary>,
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
    /// Instance-steps per second of the integration stage (the GPU's integration dispatches
    /// alone, without its reductions, on the GPU backend).
    pub fn instance_steps_per_s(&self) -> f64 {
        let t = match &self.timings.gpu {
            Some(g) => g.integrate_s,
            None => self.timings.integrate_s,
        };
        let steps: u64 = self.results.iter().map(|r| r.steps).sum();
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

/// Plan, integrate and reduce a map on an opened engine.
pub fn run_map(spec: &MapSpec, engine: &Engine, progress: Progress) -> Result<MapRun, EngineError> {
    let t0 = Instant::now();
    let plan = EnsemblePlan::new(spec)?;
    let plan_s = t0.elapsed().as_secs_f64();
    let tail = spec
        .bifurcation
        .then_some(spec.bifurcation_samples as usize);
    let mut run = run_plan(
        plan,
        &ReduceOptions::from_spec(spec),
        tail,
        engine,
        progress,
    )?;
    run.timings.plan_s = plan_s;
    run.timings.total_s += plan_s;
    Ok(run)
}

/// Integrate and reduce an already planned ensemble (see [`EnsemblePlan::from_scenes`]) on an
/// opened engine. `strobe_tail` keeps that many trailing stroboscopic samples per instance.
pub fn run_plan(
    mut plan: EnsemblePlan,
    opts: &ReduceOptions,
    strobe_tail: Option<usize>,
    engine: &Engine,
    progress: Progress,
) -> Result<MapRun, EngineError> {
    let t_all = Instant::now();
    if engine.info().kind == EngineKind::Gpu && plan.early_stop.take().is_some() {
        plan.warnings.push(
            "map.early_stop is ignored on the GPU backend: a stopped invocation idles until its whole workgroup finishes, so the saving there is small; runs go to the end".into(),
        );
    }
    let readback = Readback {
        strobe: strobe_tail.is_some(),
        r_series: false,
    };
    let run = engine.run(&plan, opts, readback, progress)?;
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
        total_s: t_all.elapsed().as_secs_f64(),
        gpu: run.timings.gpu,
    };
    Ok(MapRun {
        results: run.results,
        plan,
        engine: engine.info().clone(),
        timings,
        dispatches: run.dispatches,
        stopped_early: run.stopped_early,
        strobe_tail,
        shards: Vec::new(),
    })
}

/// Plan the whole map (so that every instance gets the step and method of the unsharded
/// run), then integrate and reduce only `shard`'s instances; the results are in member order
/// ([`Shard::members`]).
pub fn run_map_shard(
    spec: &MapSpec,
    shard: Shard,
    engine: &Engine,
    progress: Progress,
) -> Result<MapRun, EngineError> {
    let t0 = Instant::now();
    let plan = EnsemblePlan::new(spec)?.select(&shard.members(spec.instances()));
    if plan.instances.is_empty() {
        return Err(EngineError::Empty);
    }
    let plan_s = t0.elapsed().as_secs_f64();
    let tail = spec
        .bifurcation
        .then_some(spec.bifurcation_samples as usize);
    let mut run = run_plan(
        plan,
        &ReduceOptions::from_spec(spec),
        tail,
        engine,
        progress,
    )?;
    run.timings.plan_s = plan_s;
    run.timings.total_s += plan_s;
    Ok(run)
}
