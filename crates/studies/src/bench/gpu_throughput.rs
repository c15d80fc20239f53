//! `bench --throughput`: the ensemble engine on a GPU adapter (and the CPU engine beside it)
//! against the device's FP32 peak.
//!
//! Stages of [`run_throughput`]:
//! 1. workloads ([`workload`]): the default map's plane near its top frequency (11–12 Hz) and
//!    the paper's scene on a band around its 8 Hz, 9 mm, at N = 3, 9, 17, with RK4 (on the
//!    earlier reading of the damping, ζ1 = 0.0035, where RK4's step is the chain's and not the
//!    joint dampers') and the IMEX method (on the library reading); one forcing period per
//!    instance from rest in the well, α range only: the integration kernel is what is timed;
//! 2. the instance ladder 10³ … 10⁶ (`LADDER`) per workload and engine, after an untimed
//!    pilot of `PILOT` instances that compiles the kernels: each rung runs until it ends or
//!    its wall time passes the row budget; a rung stopped there gives the rate of the steps it
//!    took, and the larger rungs are listed as skipped. (No rung is skipped on an estimate:
//!    a GPU's rate grows with the instance count until the device is full, so a small run's
//!    rate says little about a large one's. On an H200 a pilot's rate scaled up would have
//!    skipped rungs that take seconds.);
//! 3. flop per step from [`super::cost`]'s table (counted by the lab on the engine's own RK4
//!    and IMEX steps), FLOP/s against the adapter's FP32 peak ([`peak_flop_per_s`]);
//! 4. K only against all metrics (`metric_rows`): a slice of the default map at its real
//!    horizon per N, with the integration and the reductions timed apart;
//! 5. the peers' results (`benches/peers/`, JSON) from `--peers`.

use super::cost::{FlopCount, step_flops};
use super::workload::WorkloadError;
use pendulum_atlas_core::config::{DEFAULT_MAP_TOML, Metric, map_from_toml};
use pendulum_atlas_core::engine::gpu::kernels::GpuKernel;
use pendulum_atlas_core::engine::method::Method;
use pendulum_atlas_core::engine::{
    CpuLoop, Engine, EngineError, EngineKind, EnsemblePlan, Precision, Readback, no_progress,
};
use pendulum_atlas_core::reduce::ReduceOptions;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Instance counts of the ladder.
pub(crate) const LADDER: [usize; 4] = [1_000, 10_000, 100_000, 1_000_000];

/// Instances of the pilot run that gives each workload's first rate (not reported).
pub(crate) const PILOT: usize = 64;

/// Segment counts of the study.
pub const SEGMENTS: [usize; 3] = [3, 9, 17];

/// Settings of the study.
pub struct ThroughputOptions<'a> {
    /// The GPU engine (lavapipe or a hardware adapter), if any.
    pub gpu: Option<&'a Engine>,
    /// Also measure the CPU engine (SIMD loop, f32) on the same workloads.
    pub cpu: bool,
    /// Largest rung of the ladder.
    pub max_instances: usize,
    /// Longest wall time of one row (s): a rung that passes it is stopped there, and the
    /// larger rungs of its ladder are skipped.
    pub row_budget_s: f64,
    /// The FP32 peak of the GPU adapter (flop/s), where the built-in table does not know it.
    pub peak_flop_per_s: Option<f64>,
    /// A folder of peer results (`jax_gpu_*.json`, `cuda_*.json`, see benches/peers/).
    pub peers: Option<PathBuf>,
    /// Segment counts, scenes and methods to measure (the whole grid by default).
    pub segments: Vec<usize>,
    /// The GPU's integration kernels to measure (each gets its ladders).
    pub kernels: Vec<GpuKernel>,
}

/// The scenes of the study.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ThroughputScene {
    /// The embedded default map (configs/maps/default.toml) near its top frequency.
    Default,
    /// The paper's scene (configs/paper.toml) on a band around its 8 Hz, 9 mm.
    Paper,
}

impl ThroughputScene {
    /// Both scenes.
    pub const ALL: [ThroughputScene; 2] = [ThroughputScene::Default, ThroughputScene::Paper];

    /// The scene's name.
    pub fn name(self) -> &'static str {
        match self {
            ThroughputScene::Default => "default",
            ThroughputScene::Paper => "paper",
        }
    }

    /// The map TOML and its origin: the default map, or the paper's scene (every key from
    /// configs/paper.toml) with a map over (f, A).
    fn toml(self) -> (String, &'static str) {
        match self {
            ThroughputScene::Default => (DEFAULT_MAP_TOML.to_string(), "configs/maps/default.toml"),
            ThroughputScene::Paper => (
                "[map]\nmetrics = [\"alpha_range\"]\n".to_string(),
                "configs/paper.toml",
            ),
        }
    }

    /// The (f, A) band its instances are spread over (Hz, m).
    fn band(self) -> [(f64, f64); 2] {
        match self {
            ThroughputScene::Default => [(11.0, 12.0), (0.004, 0.025)],
            ThroughputScene::Paper => [(7.5, 8.5), (0.008, 0.010)],
        }
    }
}

/// One measured (or skipped) row of the ladder.
#[derive(Debug, Clone, Serialize)]
pub struct LadderRow {
    /// The engine, in words.
    pub engine: String,
    /// GPU or CPU.
    pub kind: EngineKind,
    /// The GPU's integration kernel (`None` on the CPU engine).
    #[serde(default)]
    pub kernel: Option<GpuKernel>,
    /// The scene.
    pub scene: ThroughputScene,
    /// Segments N.
    pub segments: usize,
    /// Integration method.
    pub method: Method,
    /// Instances.
    pub instances: usize,
    /// Steps per instance (mean).
    pub steps_per_instance: f64,
    /// Instance-steps of the run.
    pub instance_steps: u64,
    /// Integration time (s; on the GPU the integration dispatches), `None` when skipped.
    pub integrate_s: Option<f64>,
    /// Instance-steps per second.
    pub instance_steps_per_s: Option<f64>,
    /// The integration kernels' own time by the device's clock (s; GPU rows where the adapter
    /// has timestamps), measured as a peer's CUDA events measure its kernel.
    #[serde(default)]
    pub kernel_s: Option<f64>,
    /// Instance-steps per second of kernel time.
    #[serde(default)]
    pub kernel_instance_steps_per_s: Option<f64>,
    /// Segment-steps per second.
    pub segment_steps_per_s: Option<f64>,
    /// Counted flop per step of this method at N.
    pub flop_per_step: u64,
    /// Achieved flop/s (counted flop × instance-steps / time).
    pub flop_per_s: Option<f64>,
    /// Its share of the device's FP32 peak, where the peak is known.
    pub share_of_peak: Option<f64>,
    /// Device memory of the run's per-instance buffers (GPU; bytes).
    pub device_bytes: Option<u64>,
    /// Why the row was not run (the rung before it reached the row budget).
    pub skipped: Option<String>,
    /// The share of the run's steps taken when the row budget stopped it (`None`: it ran
    /// to the end); the rate is that of the steps taken.
    #[serde(default)]
    pub stopped_at: Option<f64>,
}

/// K only against all metrics on one engine at one N.
#[derive(Debug, Clone, Serialize)]
pub struct MetricRow {
    /// The engine, in words.
    pub engine: String,
    /// Segments N.
    pub segments: usize,
    /// Integration method.
    pub method: Method,
    /// Instances.
    pub instances: usize,
    /// Instance-steps of the run.
    pub instance_steps: u64,
    /// All metrics: integration and reductions (s), warm, median of 3.
    pub all: Option<Split>,
    /// K only (s).
    pub k_only: Option<Split>,
    /// Why the row was not run.
    pub skipped: Option<String>,
}

/// Integration and reductions of one run (s).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Split {
    /// Integration (GPU dispatches or the CPU loop).
    pub integrate_s: f64,
    /// Reductions (R, K, period; on the GPU the device's kernels).
    pub reduce_s: f64,
}

impl Split {
    /// Both.
    pub fn total_s(&self) -> f64 {
        self.integrate_s + self.reduce_s
    }
}

/// A peer's result, as its JSON reports it (`benches/peers/jax_gpu.py`, `cuda/`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct GpuPeerRow {
    /// The peer's name (`jax`, `cuda`).
    pub peer: String,
    /// Its variant.
    pub variant: String,
    /// The device it ran on, in words.
    pub device: String,
    /// Segments N.
    pub segments: usize,
    /// Instances.
    pub instances: usize,
    /// Steps per instance.
    pub steps: u64,
    /// Median time (s).
    pub median_s: f64,
    /// Instance-steps per second.
    pub instance_steps_per_s: f64,
    /// Largest |Δy| against our f64 engine after the case's check steps (f32 run).
    pub check_max_abs_err: f64,
}

/// Everything the study measured.
#[derive(Debug, Clone, Serialize)]
pub struct ThroughputReport {
    /// The machine, in words.
    pub machine: String,
    /// The GPU adapter, in words, if one was measured.
    pub adapter: Option<String>,
    /// Its FP32 peak (flop/s) and where the figure comes from.
    pub peak: Option<(f64, String)>,
    /// Flop per step by method and N.
    pub flops: Vec<(Method, FlopCount)>,
    /// The ladder.
    pub rows: Vec<LadderRow>,
    /// K only against all metrics.
    pub metrics: Vec<MetricRow>,
    /// Peers' results.
    pub peers: Vec<GpuPeerRow>,
    /// The row budget (s).
    pub row_budget_s: f64,
    /// Wall time of the study (s).
    pub total_s: f64,
}

/// What can stop the study.
#[derive(Debug, thiserror::Error)]
pub enum ThroughputError {
    /// A plan or a run failed.
    #[error(transparent)]
    Engine(#[from] EngineError),
    /// A workload could not be made.
    #[error(transparent)]
    Case(#[from] WorkloadError),
    /// A peer result could not be read.
    #[error("peer result {path}: {reason}")]
    Peer {
        /// The file.
        path: PathBuf,
        /// Why.
        reason: String,
    },
}

/// Run the study.
pub fn run_throughput(
    opts: &ThroughputOptions,
    progress: &dyn Fn(&str),
) -> Result<ThroughputReport, ThroughputError> {
    // The peers' results are read first: a bad --peers costs nothing.
    let peers = match &opts.peers {
        Some(dir) => read_peers(dir)?,
        None => Vec::new(),
    };
    let t0 = Instant::now();
    let cpu = Engine::cpu_with(Precision::F32, CpuLoop::Simd);
    let engines: Vec<&Engine> = opts
        .gpu
        .into_iter()
        .chain(opts.cpu.then_some(&cpu))
        .collect();
    let peak = opts
        .gpu
        .and_then(|g| peak_flop_per_s(g, opts.peak_flop_per_s));
    let mut flops = Vec::new();
    let mut rows = Vec::new();
    for &n in &opts.segments {
        for method in [Method::Rk4, Method::Imex] {
            let probe = workload(ThroughputScene::Default, n, method, 1)?;
            let count = step_flops(method, &probe.instances[0].params);
            for scene in ThroughputScene::ALL {
                for engine in &engines {
                    for kernel in kernels_of(engine, opts) {
                        let ctx = LadderCtx {
                            engine,
                            kernel,
                            scene,
                            n,
                            method,
                            count: &count,
                            peak: peak.as_ref().map(|p| p.0),
                        };
                        rows.extend(ladder(&ctx, opts, progress)?);
                    }
                }
            }
            flops.push((method, count));
        }
    }
    let mut metrics = Vec::new();
    for engine in &engines {
        metrics.extend(metric_rows(engine, opts, &rows, progress)?);
    }
    Ok(ThroughputReport {
        machine: super::machine(opts.gpu),
        adapter: opts.gpu.map(|g| g.info().device.clone()),
        peak,
        flops,
        rows,
        metrics,
        peers,
        row_budget_s: opts.row_budget_s,
        total_s: t0.elapsed().as_secs_f64(),
    })
}

/// The kernels `engine` is measured with: each asked for on the GPU, none on the CPU.
fn kernels_of(engine: &Engine, opts: &ThroughputOptions) -> Vec<Option<GpuKernel>> {
    match engine.info().kind {
        EngineKind::Gpu => opts.kernels.iter().copied().map(Some).collect(),
        EngineKind::Cpu => vec![None],
    }
}

/// The workload of `scene` at N with `method`: `count` instances spread over the scene's band,
/// one forcing period each from rest, α range only (see the module's stage 1).
pub fn workload(
    scene: ThroughputScene,
    n: usize,
    method: Method,
    count: usize,
) -> Result<EnsemblePlan, WorkloadError> {
    let [(f0, f1), (a0, a1)] = scene.band();
    let nf = count.clamp(2, 64);
    let na = count.div_ceil(nf).max(2);
    let mut sets = vec![
        format!("beam.segments={n}"),
        format!("integration.method=\"{}\"", method.name()),
        // A study of fixed steps: instance-steps per second at the automatic step.
        "integration.step=\"fixed\"".to_string(),
        "integration.transient_s=0.0".to_string(),
        // (Nothing could stop early within the run: the early stop's bookkeeping is left out.)
        "map.early_stop=false".to_string(),
        format!("integration.duration_s={}", 1.5 / f0),
        "map.metrics=[\"alpha_range\"]".to_string(),
        format!(
            "map.axes=[{{key=\"excitation.frequency_hz\",start={f0},end={f1},count={nf}}},\
{{key=\"excitation.amplitude_m\",start={a0},end={a1},count={na}}}]"
        ),
    ];
    if method == Method::Rk4 {
        sets.push("beam.damping_ratio=0.0035".to_string());
    }
    let (text, origin) = scene.toml();
    let spec = map_from_toml(&text, origin, &sets)?;
    let plan = EnsemblePlan::new(&spec)?;
    let members: Vec<usize> = (0..count).collect();
    Ok(plan.select(&members))
}

/// One workload on one engine.
struct LadderCtx<'a> {
    engine: &'a Engine,
    kernel: Option<GpuKernel>,
    scene: ThroughputScene,
    n: usize,
    method: Method,
    count: &'a FlopCount,
    peak: Option<f64>,
}

/// The ladder of one workload on one engine: the pilot, then each rung until one reaches the
/// row budget.
fn ladder(
    c: &LadderCtx,
    opts: &ThroughputOptions,
    progress: &dyn Fn(&str),
) -> Result<Vec<LadderRow>, ThroughputError> {
    let on_kernel = |mut plan: EnsemblePlan| {
        if let Some(k) = c.kernel {
            plan.gpu_kernel = k.into();
        }
        plan
    };
    let pilot = on_kernel(workload(c.scene, c.n, c.method, PILOT)?);
    run_integration(c.engine, &pilot)?; // compiles the kernels' specialisation
    let steps_per_instance = pilot.total_steps as f64 / PILOT as f64;
    let mut rows = Vec::new();
    let mut reached: Option<usize> = None;
    for &count in LADDER.iter().filter(|&&k| k <= opts.max_instances) {
        let mut row = LadderRow {
            engine: c.engine.info().device.clone(),
            kind: c.engine.info().kind,
            kernel: c.kernel,
            scene: c.scene,
            segments: c.n,
            method: c.method,
            instances: count,
            steps_per_instance,
            instance_steps: (steps_per_instance * count as f64) as u64,
            integrate_s: None,
            instance_steps_per_s: None,
            kernel_s: None,
            kernel_instance_steps_per_s: None,
            segment_steps_per_s: None,
            flop_per_step: c.count.flop_per_step,
            flop_per_s: None,
            share_of_peak: None,
            device_bytes: None,
            skipped: None,
            stopped_at: None,
        };
        if let Some(prev) = reached {
            row.skipped = Some(format!(
                "the rung of {prev} instances reached the {} s row budget",
                opts.row_budget_s
            ));
            rows.push(row);
            continue;
        }
        let plan = on_kernel(workload(c.scene, c.n, c.method, count)?);
        let capped = run_capped(c.engine, &plan, opts.row_budget_s)?;
        fill(&mut row, &plan, &capped, c.peak);
        if capped.stopped_at.is_some() {
            reached = Some(count);
        }
        progress(&format!(
            "throughput: {}{} {} N = {} {} {count} instances: {:.3e} instance-steps/s{}",
            row.engine,
            c.kernel
                .map_or(String::new(), |k| format!(" ({} kernel)", k.name())),
            c.scene.name(),
            c.n,
            c.method.name(),
            capped.steps as f64 / capped.seconds,
            capped.stopped_at.map_or(String::new(), |f| format!(
                " (stopped at the row budget, {:.0} % of the steps)",
                100.0 * f
            ))
        ));
        rows.push(row);
    }
    Ok(rows)
}

/// A run of a rung, whole or stopped at the row budget.
struct Capped {
    /// Integration time (s): the GPU's dispatches, or the wall time until the stop.
    seconds: f64,
    /// Instance-steps taken.
    steps: u64,
    /// Device memory (GPU).
    device_bytes: Option<u64>,
    /// The integration kernels' time by the device's clock (GPU, where it has timestamps).
    kernel_s: Option<f64>,
    /// The share of the steps taken when the budget stopped it.
    stopped_at: Option<f64>,
}

/// Run `plan`, stopping once its wall time passes `budget_s`: the engine's progress (steps of
/// the GPU's dispatches, or the CPU's finished instances) says how much was done by then.
fn run_capped(engine: &Engine, plan: &EnsemblePlan, budget_s: f64) -> Result<Capped, EngineError> {
    let start = Instant::now();
    let last = std::sync::Mutex::new((0.0_f64, 0.0_f64));
    let watch = |done: u64, total: u64, _| {
        let elapsed = start.elapsed().as_secs_f64();
        if let Ok(mut l) = last.lock() {
            *l = (done as f64 / total.max(1) as f64, elapsed);
        }
        if elapsed > budget_s {
            std::ops::ControlFlow::Break(())
        } else {
            std::ops::ControlFlow::Continue(())
        }
    };
    match engine.run(plan, &ReduceOptions::default(), Readback::default(), &watch) {
        Ok(run) => Ok(Capped {
            seconds: run.integration_s().max(1e-9),
            steps: plan.total_steps,
            device_bytes: run.timings.gpu.as_ref().map(|g| g.device_bytes),
            kernel_s: run.timings.gpu.as_ref().and_then(|g| g.integrate_kernel_s),
            stopped_at: None,
        }),
        Err(EngineError::Cancelled) => {
            let (share, seconds) = *last.lock().unwrap_or_else(|e| e.into_inner());
            Ok(Capped {
                seconds: seconds.max(1e-9),
                steps: (share * plan.total_steps as f64) as u64,
                device_bytes: None,
                kernel_s: None,
                stopped_at: Some(share),
            })
        }
        Err(e) => Err(e),
    }
}

/// The measured figures of a row.
fn fill(row: &mut LadderRow, plan: &EnsemblePlan, run: &Capped, peak: Option<f64>) {
    let rate = run.steps as f64 / run.seconds;
    let flop_per_s = rate * row.flop_per_step as f64;
    row.instance_steps = run.steps;
    row.steps_per_instance = plan.total_steps as f64 / plan.instances.len() as f64;
    row.integrate_s = Some(run.seconds);
    row.instance_steps_per_s = Some(rate);
    row.kernel_s = run.kernel_s;
    row.kernel_instance_steps_per_s = run.kernel_s.map(|k| run.steps as f64 / k.max(1e-9));
    row.segment_steps_per_s = Some(rate * row.segments as f64);
    row.flop_per_s = Some(flop_per_s);
    row.share_of_peak = match row.kind {
        EngineKind::Gpu => peak.map(|p| flop_per_s / p),
        EngineKind::Cpu => None,
    };
    row.device_bytes = run.device_bytes;
    row.stopped_at = run.stopped_at;
}

/// Integration time of one run of `plan` (s) and the device memory it used.
fn run_integration(
    engine: &Engine,
    plan: &EnsemblePlan,
) -> Result<(f64, Option<u64>), EngineError> {
    let run = engine.run(
        plan,
        &ReduceOptions::default(),
        Readback::default(),
        &no_progress,
    )?;
    let bytes = run.timings.gpu.as_ref().map(|g| g.device_bytes);
    Ok((run.integration_s().max(1e-9), bytes))
}

/// Instances of the K-only comparison.
const METRIC_INSTANCES: usize = 256;

/// K only against all metrics on a slice of the default map (its real horizon: 34 s, 10 s of
/// transient) at each N with the method auto picks, warm, median of 3; skipped where the
/// ladder's rate says it would overrun the budget.
fn metric_rows(
    engine: &Engine,
    opts: &ThroughputOptions,
    ladder: &[LadderRow],
    progress: &dyn Fn(&str),
) -> Result<Vec<MetricRow>, ThroughputError> {
    let mut rows = Vec::new();
    for &n in &opts.segments {
        let plan = metric_plan(n, &[])?;
        let method = plan.method;
        let mut row = MetricRow {
            engine: engine.info().device.clone(),
            segments: n,
            method,
            instances: plan.instances.len(),
            instance_steps: plan.total_steps,
            all: None,
            k_only: None,
            skipped: None,
        };
        let skip = match smallest_rung(ladder, &row.engine, n, method) {
            None => Some(format!(
                "no measured rate at N = {n} with {} (every rung of its ladder was over the \
row budget)",
                method.name()
            )),
            Some((rung, rate)) => {
                let scale = (rung as f64 / plan.instances.len() as f64).max(1.0);
                let estimate = 8.0 * plan.total_steps as f64 * scale / rate;
                (estimate > opts.row_budget_s).then(|| {
                    format!(
                        "estimated {estimate:.0} s for 8 runs, over the {} s row budget",
                        opts.row_budget_s
                    )
                })
            }
        };
        if skip.is_some() {
            row.skipped = skip;
            rows.push(row);
            continue;
        }
        row.all = Some(warm_split(engine, n, &Metric::ALL[..6])?);
        row.k_only = Some(warm_split(engine, n, &[Metric::K])?);
        progress(&format!(
            "throughput: {} N = {n}: K only {:.2} s, all metrics {:.2} s",
            row.engine,
            row.k_only.map_or(f64::NAN, |s| s.total_s()),
            row.all.map_or(f64::NAN, |s| s.total_s())
        ));
        rows.push(row);
    }
    Ok(rows)
}

/// [`METRIC_INSTANCES`] instances spread evenly over the default map at N, with the method
/// auto picks and the overrides `extra`.
fn metric_plan(n: usize, extra: &[&str]) -> Result<EnsemblePlan, WorkloadError> {
    let mut sets = vec![
        format!("beam.segments={n}"),
        "integration.step=\"fixed\"".to_string(),
    ];
    sets.extend(extra.iter().map(|s| s.to_string()));
    let spec = map_from_toml(DEFAULT_MAP_TOML, "configs/maps/default.toml", &sets)?;
    let plan = EnsemblePlan::new(&spec)?;
    let total = plan.instances.len();
    let members: Vec<usize> = (0..METRIC_INSTANCES)
        .map(|i| i * total / METRIC_INSTANCES)
        .collect();
    Ok(plan.select(&members))
}

/// The smallest measured rung of the default scene's ladder at N with `method` on `engine`:
/// (instances, rate). A GPU runs fewer instances at no higher rate per instance, so
/// `instance_steps × max(1, rung / instances) / rate` bounds the time of a smaller run from
/// above, where the best rung's rate would bound it from below.
fn smallest_rung(
    ladder: &[LadderRow],
    engine: &str,
    n: usize,
    method: Method,
) -> Option<(usize, f64)> {
    ladder
        .iter()
        .filter(|r| {
            r.engine == engine
                && r.segments == n
                && r.method == method
                && r.scene == ThroughputScene::Default
        })
        .find_map(|r| r.instance_steps_per_s.map(|rate| (r.instances, rate)))
}

/// Integration and reductions of the metric slice with `metrics`: one untimed run (no first
/// use of a kernel specialisation is timed), then the median of 3 by total.
fn warm_split(engine: &Engine, n: usize, metrics: &[Metric]) -> Result<Split, ThroughputError> {
    let names: Vec<String> = metrics
        .iter()
        .map(|m| format!("\"{}\"", m.name()))
        .collect();
    let set = format!("map.metrics=[{}]", names.join(","));
    let plan = metric_plan(n, &[set.as_str()])?;
    let reduce = ReduceOptions::default();
    let once = || -> Result<Split, EngineError> {
        let run = engine.run(&plan, &reduce, Readback::default(), &no_progress)?;
        let (integrate_s, reduce_s) = match &run.timings.gpu {
            Some(g) => (g.integrate_s, g.reduce_s),
            None => (run.timings.integrate_s, run.timings.reduce_s),
        };
        Ok(Split {
            integrate_s,
            reduce_s,
        })
    };
    once()?;
    let mut runs = (0..3).map(|_| once()).collect::<Result<Vec<_>, _>>()?;
    runs.sort_by(|a, b| a.total_s().total_cmp(&b.total_s()));
    Ok(runs[1])
}

/// The FP32 peak of the GPU adapter (flop/s) and its source: `given` when set, else the
/// built-in table of data-sheet figures (non-tensor FP32, boost clock), else for the software
/// adapter the CPU's AVX2 FMA ceiling (cores × clock × 32 flop per cycle).
pub fn peak_flop_per_s(gpu: &Engine, given: Option<f64>) -> Option<(f64, String)> {
    if let Some(p) = given {
        return Some((p, "given with --peak-tflops".into()));
    }
    let name = gpu.info().device.to_lowercase();
    let sheet = [
        ("h100 pcie", 51.2e12),
        ("h100", 66.9e12),
        ("h200", 66.9e12),
        ("a100", 19.5e12),
        ("l40s", 91.6e12),
        ("l4", 30.3e12),
        ("rtx 4090", 82.6e12),
    ];
    if let Some((key, p)) = sheet.iter().find(|(k, _)| name.contains(k)) {
        return Some((
            *p,
            format!("data sheet ({key}: non-tensor FP32 at boost clock)"),
        ));
    }
    let software = gpu.gpu_context().is_some_and(|c| c.is_software);
    let ghz = super::cpu_throughput::cpu_ghz()?;
    software.then(|| {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        (
            ghz * 1e9 * 32.0 * cores as f64,
            format!("the CPU lavapipe runs on: {cores} cores × {ghz:.2} GHz × 32 flop/cycle (AVX2 FMA, f32)"),
        )
    })
}

/// Every `jax_gpu_*.json` and `cuda_*.json` in `dir`.
fn read_peers(dir: &Path) -> Result<Vec<GpuPeerRow>, ThroughputError> {
    super::cpu_throughput::read_peer_files(dir, |n| {
        n.starts_with("jax_gpu_") || n.starts_with("cuda_")
    })
    .map_err(|(path, reason)| ThroughputError::Peer { path, reason })
}
