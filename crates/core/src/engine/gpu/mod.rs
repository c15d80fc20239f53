//! The GPU ensemble engine: the WGSL kernels of `shaders/` on wgpu.
//!
//! One invocation integrates one instance in `f32`. Integration is split into bounded
//! dispatches (state stays in buffers between them) so that no submission holds the GPU for
//! long and a progress bar can move; then the reductions run on the GPU, and only the
//! per-instance results (plus, when asked, the recorded series) come back.
//!
//! Stages of `GpuEngine::run`: the kernels of the plan's [`KernelKey`] (compiled once per
//! [`GpuContext`]), buffers sized against the adapter and
//! allocated in error scopes (`buffers`), integration dispatches sized by wall time, the R
//! and K reductions (one submission each), the read-back through one kept buffer.
//!
//! Every wait is bounded and checks the device's health: a lost device, an allocation that
//! fails or work the device refuses ends the run with [`EngineError::GpuFault`], never a panic
//! or a hang ([`fault`] injects both for the tests).

mod buffers;
mod clock;
pub mod codegen;
mod context;
pub mod fault;
pub mod gpu_struct;
pub mod kernels;
pub mod layout;
mod loop_count;
#[cfg(test)]
mod rules_check;
pub mod slices;

pub use context::{AdapterChoice, AdapterListing, DeviceCounts, GpuContext, list_adapters};

use crate::analysis::PhaseConvention;
use crate::config::Metric;
use crate::engine::error::{EngineError, GpuFaultKind};
use crate::engine::plan::EnsemblePlan;
use crate::engine::{EngineRun, EngineTimings, EnsembleEngine, Progress, ProgressUnit, Readback};
use crate::model::{ChainShape, Status};
use crate::reduce::regime::confidence;
use crate::reduce::{InstanceResult, ReduceOptions, Span, Tally};
use crate::schema::{Source, field, gpu_fields};
use buffers::{Buffers, Sizes, batch_capacity, software_step_budget};
use bytemuck::Zeroable;
use clock::KernelClock;
use kernels::{GpuKernel, KernelKey, Kernels, WG};
use layout::{GPU_MAX_SEGMENTS, GpuAccum, GpuControl, SCHED_LIVE};
use serde::Serialize;
use slices::{Pass, Slicing, run_passes};
use std::time::{Duration, Instant};

/// Environment variable that turns "no GPU adapter" from a skip into a test failure.
pub const REQUIRE_GPU_ENV: &str = "PENDULUM_ATLAS_REQUIRE_GPU";

/// Target wall time of one dispatch: the integration's, and each slice of a reduction's.
const DISPATCH_TARGET: Duration = Duration::from_millis(100);

/// How long one poll of the device blocks before the device's health is checked again.
const POLL_SLICE: Duration = Duration::from_millis(250);

/// The longest one submission may run before the device is declared unresponsive: far above
/// any dispatch the engine sizes (integration and reduction slices aim at [`DISPATCH_TARGET`];
/// one submission holds at most a stage's passes).
const WAIT_LIMIT: Duration = Duration::from_secs(600);

/// Wall time of each stage of a GPU run (s).
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct GpuTimings {
    /// Looking up (and, the first time, compiling) the kernels.
    pub pipelines_s: f64,
    /// Buffer creation and upload.
    pub upload_s: f64,
    /// Integration dispatches.
    pub integrate_s: f64,
    /// Reduction kernels (R, K, period).
    pub reduce_s: f64,
    /// Copy back to the host.
    pub readback_s: f64,
    /// The integration kernels' own time by the device's clock, summed over the dispatches
    /// (`None` where the adapter has no timestamps): `integrate_s` less the host's share.
    #[serde(default)]
    pub integrate_kernel_s: Option<f64>,
    /// Device memory of the run's per-instance buffers (parameters, state, accumulators,
    /// series, work space, K_c values; bytes).
    pub device_bytes: u64,
    /// Queue submissions of the run (every batch's together).
    #[serde(default)]
    pub submissions: u64,
    /// Bytes the run copied back to the host (results, the live count per dispatch, kept series).
    #[serde(default)]
    pub read_back_bytes: u64,
}

impl GpuTimings {
    /// Two runs' GPU times added, either of which may have none (a CPU run).
    pub fn join(a: Option<GpuTimings>, b: Option<GpuTimings>) -> Option<GpuTimings> {
        match (a, b) {
            (Some(a), Some(b)) => Some(a.joined(&b)),
            (a, b) => a.or(b),
        }
    }

    /// The stages of two consecutive batches: times added, the larger device memory.
    pub fn joined(&self, next: &GpuTimings) -> GpuTimings {
        GpuTimings {
            pipelines_s: self.pipelines_s + next.pipelines_s,
            upload_s: self.upload_s + next.upload_s,
            integrate_s: self.integrate_s + next.integrate_s,
            reduce_s: self.reduce_s + next.reduce_s,
            readback_s: self.readback_s + next.readback_s,
            integrate_kernel_s: match (self.integrate_kernel_s, next.integrate_kernel_s) {
                (Some(a), Some(b)) => Some(a + b),
                _ => None,
            },
            device_bytes: self.device_bytes.max(next.device_bytes),
            submissions: self.submissions + next.submissions,
            read_back_bytes: self.read_back_bytes + next.read_back_bytes,
        }
    }
}

/// The reduction settings in the form the kernels take.
#[derive(Debug, Clone)]
pub(crate) struct ReduceSettings {
    /// c values of the 0–1 test (rad).
    pub c_values: Vec<f64>,
    /// R in the paper's convention.
    pub paper_convention: bool,
    /// Longest period searched.
    pub period_max: u32,
    /// Trailing samples that must repeat.
    pub period_window: u32,
    /// Tolerance (rad).
    pub period_tol_rad: f64,
}

impl ReduceSettings {
    /// From the map's reduction options (the same seeded c values as the CPU engine).
    pub(crate) fn from_options(o: &ReduceOptions) -> ReduceSettings {
        ReduceSettings {
            c_values: crate::analysis::draw_c_values(o.zero_one.n_c, o.zero_one.seed),
            paper_convention: o.convention == PhaseConvention::Paper,
            period_max: o.period_max,
            period_window: o.period_window,
            period_tol_rad: o.period_tol_rad,
        }
    }
}

/// The GPU engine on an opened device.
pub struct GpuEngine {
    ctx: GpuContext,
    limits: GpuLimits,
}

/// How the engine splits its work, where a caller sets it (tests and benches).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct GpuLimits {
    /// At most this many instances at a time (`None`: as many as the adapter's limits allow).
    pub max_batch: Option<usize>,
    /// How the reductions are sliced (`None`: above a size, by a timed probe to
    /// `DISPATCH_TARGET`, `slices.rs`).
    pub reduce_slice: Option<Slicing>,
    /// At most this many steps (adaptive: passes) per integration dispatch (`None`: sized by
    /// wall time, and on a software adapter by its loop budget).
    pub dispatch_steps: Option<u64>,
}

impl GpuEngine {
    /// The engine of an opened device.
    pub fn new(ctx: GpuContext) -> GpuEngine {
        GpuEngine {
            ctx,
            limits: GpuLimits::default(),
        }
    }

    /// Build the kernels with wgpu's runtime checks, or without ([`GpuContext::set_runtime_checks`]).
    pub(crate) fn set_runtime_checks(&mut self, on: bool) {
        self.ctx.set_runtime_checks(on);
    }

    /// Run at most `max` instances at a time (`None`: as many as the adapter's limits allow),
    /// to bound the device memory a run takes.
    pub(crate) fn set_max_batch(&mut self, max: Option<usize>) {
        self.limits.max_batch = max.map(|m| m.max(1));
    }

    /// Slice each reduction pass as `slicing` says (`None`: the default). For tests: the
    /// results do not depend on it.
    pub(crate) fn set_reduce_slice(&mut self, slicing: Option<Slicing>) {
        self.limits.reduce_slice = slicing;
    }

    /// At most `steps` steps per integration dispatch (`None`: the default). For tests: the
    /// results do not depend on it.
    pub(crate) fn set_dispatch_steps(&mut self, steps: Option<u64>) {
        self.limits.dispatch_steps = steps.map(|s| s.max(1));
    }

    /// The device and its compiled kernels.
    pub fn context(&self) -> &GpuContext {
        &self.ctx
    }
}

impl EnsembleEngine for GpuEngine {
    fn run(
        &self,
        plan: &EnsemblePlan,
        reduce: &ReduceOptions,
        readback: Readback,
        progress: Progress,
    ) -> Result<EngineRun, EngineError> {
        run_gpu(&self.ctx, plan, reduce, readback, self.limits, progress)
    }
}

/// The specialisation a plan needs.
fn kernel_key(
    plan: &EnsemblePlan,
    chain: ChainShape,
    reduce: &ReduceSettings,
    kernel: GpuKernel,
) -> KernelKey {
    let want = |m: Metric| plan.metrics.contains(&m);
    KernelKey {
        chain,
        want_strobe: plan.want_strobe,
        want_rseries: plan.want_rseries,
        want_r: want(Metric::R),
        want_line: want(Metric::Line),
        want_k: want(Metric::K),
        run_k_final: Metric::any_from(&plan.metrics, Source::Strobe),
        paper_convention: reduce.paper_convention,
        n_c: reduce.c_values.len().max(1),
        method: plan.method,
        want_twin: Metric::any_from(&plan.metrics, Source::Twin),
        want_early: plan.early_stop.is_some(),
        adaptive: plan.is_adaptive(),
        kernel,
        runtime_checks: false,
    }
}

/// Integrate and reduce every instance of `plan` on the GPU of `ctx`: in one run when the
/// plan fits the adapter's limits (and `limits.max_batch`), else in consecutive batches of the
/// most instances that fit (`buffers::batch_capacity`), their results joined in plan order.
pub(crate) fn run_gpu(
    ctx: &GpuContext,
    plan: &EnsemblePlan,
    opts: &ReduceOptions,
    readback: Readback,
    limits: GpuLimits,
    progress: Progress,
) -> Result<EngineRun, EngineError> {
    if plan.segments > GPU_MAX_SEGMENTS {
        return Err(EngineError::TooManySegments {
            segments: plan.segments,
            max: GPU_MAX_SEGMENTS,
        });
    }
    if plan.instances.is_empty() {
        return Err(EngineError::Empty);
    }
    let chain = plan.kernel_shape()?;
    let twin_d0 = plan.twin_separation(crate::engine::Precision::F32)?;
    let reduce = ReduceSettings::from_options(opts);
    let kernel = GpuKernel::resolve(plan.gpu_kernel);
    let key = KernelKey {
        runtime_checks: ctx.runtime_checks(),
        ..kernel_key(plan, chain, &reduce, kernel)
    };
    let n = plan.instances.len();
    let cap = batch_capacity(ctx, plan, &key)?.min(limits.max_batch.unwrap_or(usize::MAX));
    let batch = Batch {
        reduce: &reduce,
        key: &key,
        twin_d0: twin_d0.unwrap_or(0.0),
        readback,
        reduce_slice: limits.reduce_slice,
        dispatch_steps: limits.dispatch_steps,
    };
    if n <= cap {
        return run_batch(ctx, plan, &batch, progress);
    }
    let members: Vec<usize> = (0..n).collect();
    let batches = n.div_ceil(cap) as u64;
    let mut joined: Option<EngineRun> = None;
    for (b, chunk) in members.chunks(cap).enumerate() {
        let part = plan.select(chunk);
        let b = b as u64;
        let batch_progress =
            |done: u64, total: u64, unit| progress(b * total + done, batches * total, unit);
        let run = run_batch(ctx, &part, &batch, &batch_progress)?;
        joined = Some(match joined {
            None => run,
            Some(all) => all.joined(run),
        });
    }
    Ok(joined.expect("a non-empty plan has a batch"))
}

/// What every batch of a run shares.
struct Batch<'a> {
    reduce: &'a ReduceSettings,
    key: &'a KernelKey,
    /// λ1's twin separation (0 without λ1).
    twin_d0: f64,
    readback: Readback,
    /// How the reductions are sliced ([`GpuLimits::reduce_slice`]).
    reduce_slice: Option<Slicing>,
    /// The most steps a dispatch takes where a test sets it ([`GpuLimits::dispatch_steps`]).
    dispatch_steps: Option<u64>,
}

/// One run of `plan`, which fits the adapter.
fn run_batch(
    ctx: &GpuContext,
    plan: &EnsemblePlan,
    batch: &Batch,
    progress: Progress,
) -> Result<EngineRun, EngineError> {
    let sizes = Sizes::new(ctx, plan, batch.key)?;
    run_sized(ctx, plan, batch, &sizes, progress).map_err(|e| sized(e, plan, &sizes))
}

/// A GPU fault with the size of the batch that was running.
fn sized(e: EngineError, plan: &EnsemblePlan, sizes: &Sizes) -> EngineError {
    match e {
        EngineError::GpuFault {
            adapter,
            kind,
            message,
            ..
        } => EngineError::GpuFault {
            adapter,
            kind,
            message,
            instances: sizes.n_inst,
            segments: plan.segments,
            mib: sizes.device_bytes() as f64 / f64::from(1 << 20),
        },
        other => other,
    }
}

/// [`run_batch`] once its buffer sizes are known.
fn run_sized(
    ctx: &GpuContext,
    plan: &EnsemblePlan,
    batch: &Batch,
    sizes: &Sizes,
    progress: Progress,
) -> Result<EngineRun, EngineError> {
    let (reduce, key, readback) = (batch.reduce, batch.key, batch.readback);
    let sizes = *sizes;
    let t_all = Instant::now();
    let counts_before = ctx.counts();
    let budget = match (
        software_step_budget(ctx, plan, key, reduce)?,
        batch.dispatch_steps,
    ) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    };
    let mut timings = GpuTimings {
        device_bytes: sizes.device_bytes(),
        ..GpuTimings::default()
    };
    let t0 = Instant::now();
    let kernels = ctx.kernels(key);
    timings.pipelines_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let (mut control, _) = GpuControl {
        n_inst: sizes.n_inst as u32,
        steps_per_dispatch: 64,
        strobe_stride: sizes.strobe_stride,
        rwork_stride: sizes.rwork_stride,
        period_max: reduce.period_max,
        period_window: reduce.period_window,
        period_tol: reduce.period_tol_rad as f32,
        c_index: 0,
        slice_first: 0,
        slice_end: sizes.n_inst as u32,
        n_active: sizes.n_inst as u32,
        one: 1.0,
        ..GpuControl::zeroed()
    }
    .with_early(plan);
    let bufs = Buffers::upload(ctx, plan, reduce, &sizes, &control, batch.twin_d0)?;
    timings.upload_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let mut clock = KernelClock::new(ctx);
    let dispatches = integrate(
        ctx,
        &kernels,
        &bufs,
        (plan, &mut control),
        (budget, clock.as_mut()),
        progress,
    )?;
    timings.integrate_kernel_s = clock.map(|c| c.finish(ctx)).transpose()?;
    if let Some(finish) = &kernels.early_finish {
        let done = submit(ctx, finish, &bufs.bind, (sizes.n_inst as u32).div_ceil(WG));
        wait(ctx, done)?;
    }
    timings.integrate_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let (strobe, r_series) = read_series(ctx, &bufs, plan, &sizes, readback)?;
    let final_state = if readback.final_state {
        read_final_state(ctx, &bufs, plan, &sizes)?
    } else {
        Vec::new()
    };
    timings.readback_s += t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    run_reductions(ctx, &kernels, &bufs, key, &control, batch.reduce_slice)?;
    timings.reduce_s = t0.elapsed().as_secs_f64();
    let t0 = Instant::now();
    let accum: Vec<GpuAccum> = read_buffer(ctx, &bufs.accum, sizes.accum_bytes)?;
    timings.readback_s += t0.elapsed().as_secs_f64();
    let accum = &accum[..sizes.n_inst];
    let counts = ctx.counts().since(counts_before);
    timings.submissions = counts.submissions;
    timings.read_back_bytes = counts.read_back_bytes;
    Ok(EngineRun {
        results: results(plan, accum)?,
        strobe,
        r_series,
        final_state,
        timings: EngineTimings {
            integrate_s: t_all.elapsed().as_secs_f64(),
            reduce_s: 0.0,
            gpu: Some(timings),
        },
        dispatches,
        stopped_early: accum.iter().filter(|a| a.stopped != 0).count(),
        sub_steps: plan
            .is_adaptive()
            .then(|| accum.iter().map(|a| u64::from(a.sub_steps)).sum()),
    })
}

/// Integration in bounded dispatches, each aimed at [`DISPATCH_TARGET`] of wall time. After
/// each, the instances that finished (failed, stopped early, or ran all their steps) leave the
/// work on the device (`shaders/schedule.wgsl`): a compaction keeps the others in the live
/// list's other half and sizes the next dispatch, which is indirect, so no workgroup waits on
/// finished invocations. The host reads back one word per dispatch, the count still
/// integrating, to know when all have finished and to report progress.
fn integrate(
    ctx: &GpuContext,
    kernels: &Kernels,
    bufs: &Buffers,
    (plan, control): (&EnsemblePlan, &mut GpuControl),
    (budget, mut clock): (Option<u64>, Option<&mut KernelClock>),
    progress: Progress,
) -> Result<u32, EngineError> {
    let n = plan.instances.len();
    let max_steps = plan
        .instances
        .iter()
        .map(|p| p.total_steps())
        .max()
        .unwrap_or(0);
    let mut live = n as u32;
    let (mut done, mut chunk, mut dispatches) = (0u64, 64u64, 0u32);
    let lose = fault::failpoint()? == Some(fault::Failpoint::LoseDevice);
    // Adaptive steps: a dispatch is sized in passes (one sub-step tried each), not in base
    // steps, so every invocation of a warp tries as many sub-steps as the others: one in free
    // flight covers more base steps than one in contact, instead of waiting for it. A dispatch
    // may so end within a base step, and the run goes on until every instance has finished.
    let adaptive = plan.is_adaptive();
    while live > 0 && (adaptive || done < max_steps) {
        // (Adaptive: not cut to the steps left, since an instance may lag behind `done`.)
        let left = if adaptive { u64::MAX } else { max_steps - done };
        let this = chunk.min(left).min(budget.unwrap_or(u64::MAX));
        if adaptive {
            (control.pass_budget, control.steps_per_dispatch) = (this as u32, u32::MAX);
        } else {
            control.steps_per_dispatch = this as u32;
        }
        // (n_active is the device's count, copied in by the dispatch's first command.)
        control.live_from = (dispatches % 2) * n as u32;
        ctx.queue
            .write_buffer(&bufs.control, 0, bytemuck::bytes_of(control));
        let started = Instant::now();
        let submitted = submit_chunk(ctx, kernels, bufs, clock.as_deref());
        if lose {
            ctx.lose();
        }
        wait(ctx, submitted)?;
        let took = started.elapsed();
        if let Some(c) = clock.as_deref_mut() {
            c.add(ctx)?;
        }
        dispatches += 1;
        done = (done + this).min(max_steps);
        if !adaptive && progress(done, max_steps, ProgressUnit::Steps).is_break() {
            return Err(EngineError::Cancelled);
        }
        live = read_range::<u32>(ctx, &bufs.sched, 4 * u64::from(SCHED_LIVE), 4)?[0];
        // (Adaptive: a dispatch's passes say little of the base steps covered, so progress
        // counts the instances finished, as the CPU engine's does.)
        let finished_n = (n - live as usize) as u64;
        if adaptive && progress(finished_n, n as u64, ProgressUnit::Instances).is_break() {
            return Err(EngineError::Cancelled);
        }
        // Aim each dispatch at DISPATCH_TARGET, growing at most 4× at a time.
        let scale = DISPATCH_TARGET.as_secs_f64() / took.as_secs_f64().max(1e-6);
        chunk = ((this as f64 * scale.clamp(0.25, 4.0)) as u64).clamp(16, 1 << 22);
    }
    let (all, unit) = match adaptive {
        true => (n as u64, ProgressUnit::Instances),
        false => (max_steps, ProgressUnit::Steps),
    };
    if progress(all, all, unit).is_break() {
        return Err(EngineError::Cancelled);
    }
    Ok(dispatches)
}

/// Index of sample `j` of instance `i` in the series buffers (strobe, rwork, kc), which are
/// sample-major like the state (the shaders' `at`): neighbouring invocations touch neighbouring
/// words.
fn sample_major(sizes: &Sizes, i: usize, j: usize) -> usize {
    j * sizes.n_inst + i
}

/// Per-instance series read back from the GPU: (stroboscopic α, R series).
type SeriesReadback = (Vec<Vec<f64>>, Vec<Vec<f64>>);

/// The stroboscopic and R series, read back before the reductions overwrite the work space.
fn read_series(
    ctx: &GpuContext,
    bufs: &Buffers,
    plan: &EnsemblePlan,
    sizes: &Sizes,
    readback: Readback,
) -> Result<SeriesReadback, EngineError> {
    let mut r_series = Vec::new();
    if readback.r_series && plan.want_rseries {
        let raw: Vec<[f32; 2]> = read_buffer(ctx, &bufs.rwork, sizes.rwork_bytes)?;
        r_series = plan
            .instances
            .iter()
            .enumerate()
            .map(|(i, p)| {
                (0..p.r_count as usize)
                    .map(|j| f64::from(raw[sample_major(sizes, i, j)][0]))
                    .collect()
            })
            .collect();
    }
    let mut strobe = Vec::new();
    if readback.strobe && plan.want_strobe {
        strobe = read_strobe(ctx, bufs, plan, sizes, readback.strobe_last)?;
    }
    Ok((strobe, r_series))
}

/// The stroboscopic α of every instance, or only its last `last` samples: the buffer is
/// sample-major (row j holds sample j of every instance), so only the rows from the earliest
/// kept sample to the longest series are copied back.
fn read_strobe(
    ctx: &GpuContext,
    bufs: &Buffers,
    plan: &EnsemblePlan,
    sizes: &Sizes,
    last: Option<u32>,
) -> Result<Vec<Vec<f64>>, EngineError> {
    let keep = |count: u32| last.map_or(0, |k| count.saturating_sub(k))..count;
    let counts = plan.instances.iter().map(|p| p.strobe_count);
    let lo = counts.clone().map(|c| keep(c).start).min().unwrap_or(0) as usize;
    let hi = counts.max().unwrap_or(0) as usize;
    let row = 4 * sizes.n_inst as u64;
    let raw: Vec<f32> = read_range(ctx, &bufs.strobe, lo as u64 * row, (hi - lo) as u64 * row)?;
    Ok(plan
        .instances
        .iter()
        .enumerate()
        .map(|(i, p)| {
            keep(p.strobe_count)
                .map(|j| f64::from(raw[sample_major(sizes, i, j as usize - lo)]))
                .collect()
        })
        .collect())
}

/// Every instance's main state `[θ; θ̇; v]` where it ended (the state buffer is
/// component-major: component j of instance i at `j·n_inst + i`).
fn read_final_state(
    ctx: &GpuContext,
    bufs: &Buffers,
    plan: &EnsemblePlan,
    sizes: &Sizes,
) -> Result<Vec<Vec<f64>>, EngineError> {
    let n = sizes.n_inst;
    let dim = 2 * plan.segments + 1;
    let raw: Vec<f32> = read_buffer(ctx, &bufs.state, 4 * (dim * n) as u64)?;
    Ok((0..n)
        .map(|i| (0..dim).map(|j| f64::from(raw[j * n + i])).collect())
        .collect())
}

/// One pass of `pipeline` (workgroups of `wg`) with `c_index` 0.
fn one(pipeline: &wgpu::ComputePipeline, wg: u32) -> Pass<'_> {
    Pass {
        pipeline,
        wg,
        c_index: 0,
    }
}

/// The dominant line, R (three kernels), then the 0–1 test (one pass per c value), the
/// median and period, then λ1 and the regime: each stage's passes sliced over the instances
/// and submitted together ([`slices::run_passes`]).
fn run_reductions(
    ctx: &GpuContext,
    kernels: &Kernels,
    bufs: &Buffers,
    key: &KernelKey,
    control: &GpuControl,
    slicing: Option<Slicing>,
) -> Result<(), EngineError> {
    let run = |passes: &[Pass<'_>]| run_passes(ctx, bufs, control, passes, slicing);
    if let Some(p) = &kernels.line {
        run(&[one(p, WG)])?;
    }
    if let Some(r) = &kernels.r {
        run(&r.iter().map(|p| one(p, WG)).collect::<Vec<_>>())?;
    }
    if let Some(p) = &kernels.k_pass {
        let passes: Vec<Pass<'_>> = (0..key.n_c as u32)
            .map(|c| Pass {
                pipeline: p,
                wg: WG,
                c_index: c,
            })
            .collect();
        run(&passes)?;
    }
    if let Some(p) = &kernels.k_final {
        run(&[one(p, key.wg_k())])?;
    }
    if let Some(p) = &kernels.verdict {
        run(&[one(p, WG)])?;
    }
    Ok(())
}

/// The status of instance `index` as the GPU left it, checked: a defined code, and an `ok`
/// instance only after its last step (or stopped early before it).
fn checked_status(index: usize, a: &GpuAccum, total_steps: u64) -> Result<Status, EngineError> {
    let inconsistent = |what: String| EngineError::GpuInconsistent { index, what };
    let code = a.word("status");
    let status = Status::from_code(code)
        .ok_or_else(|| inconsistent(format!("unknown status code {code}")))?;
    let step = u64::from(a.word("steps"));
    let stopped = a.stopped != 0 && step < total_steps;
    if status == Status::Ok && step != total_steps && !stopped {
        return Err(inconsistent(format!(
            "status ok at step {step} of {total_steps}"
        )));
    }
    Ok(status)
}

/// The GPU's accumulators and reductions as instance results: the tally's words through
/// [`Tally::result`], the words the kernels leave final ([`crate::schema::Stage::gpu_final`]) as they are,
/// the regime's code checked, and its confidence formed on the host.
fn results(plan: &EnsemblePlan, accum: &[GpuAccum]) -> Result<Vec<InstanceResult>, EngineError> {
    plan.instances
        .iter()
        .zip(accum)
        .enumerate()
        .map(|(index, (p, a))| {
            let status = checked_status(index, a, p.total_steps())?;
            let tally = Tally {
                status,
                steps: u64::from(a.word("steps")),
                alpha_range_rad: (a.read("alpha_min_rad"), a.read("alpha_max_rad")),
                hops: a.word("hops"),
                impacts: a.word("impacts_per_s"),
                power_sum_w: a.read("power_w"),
            };
            let span = Span {
                seconds: p.post_transient_s(),
                steps: p.total_steps() - p.transient_steps(),
            };
            let mut out = tally.result(span, &plan.metrics);
            let inconsistent = |what: String| EngineError::GpuInconsistent { index, what };
            for (i, (f, g)) in gpu_fields().enumerate() {
                let formed = f.formed_for(&plan.metrics);
                if formed && f.stage.gpu_final() && status == Status::Ok {
                    (f.set)(&mut out, g.ty.read(a.slots[i]))
                        .map_err(|e| inconsistent(format!("{} {e}", f.name)))?;
                }
            }
            if plan.metrics.contains(&Metric::Regime) {
                let regime = field("regime").expect("the schema's regime");
                (regime.set)(&mut out, a.read("regime"))
                    .map_err(|e| inconsistent(format!("regime {e}")))?;
                out.regime_confidence = confidence(
                    out.regime,
                    &out.evidence(1.0 / p.frequency_hz, p.strobe_count),
                );
            }
            Ok(out)
        })
        .collect()
}

fn submit(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    bind: &wgpu::BindGroup,
    groups: u32,
) -> wgpu::SubmissionIndex {
    submit_timed(ctx, pipeline, bind, groups, None)
}

/// Byte offset of `n_active` in the control block.
const N_ACTIVE_OFFSET: u64 = std::mem::offset_of!(GpuControl, n_active) as u64;

/// One dispatch of the integration and its schedule, in one submission: the device's count of
/// the instances still integrating becomes `n_active` and the dispatch's size (indirect), the
/// integration runs (timed by `clock` where there is one), then the compaction and the next
/// size (`shaders/schedule.wgsl`). The compaction takes the integration's workgroup count.
fn submit_chunk(
    ctx: &GpuContext,
    kernels: &Kernels,
    bufs: &Buffers,
    clock: Option<&KernelClock>,
) -> wgpu::SubmissionIndex {
    let live_word = 4 * u64::from(SCHED_LIVE);
    let mut enc = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    enc.copy_buffer_to_buffer(&bufs.sched, live_word, &bufs.control, N_ACTIVE_OFFSET, 4);
    enc.copy_buffer_to_buffer(&bufs.sched, 0, &bufs.args, 0, 12);
    let indirect = |enc: &mut wgpu::CommandEncoder, pipeline, timed: Option<&KernelClock>| {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: None,
            timestamp_writes: timed.map(KernelClock::writes),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &bufs.bind, &[]);
        pass.dispatch_workgroups_indirect(&bufs.args, 0);
    };
    indirect(&mut enc, &kernels.integrate, clock);
    enc.clear_buffer(&bufs.sched, live_word, Some(4));
    indirect(&mut enc, &kernels.compact, None);
    record_pass(&mut enc, &kernels.schedule, &bufs.bind, 1);
    ctx.submit(enc.finish())
}

/// [`submit`], the pass timed by `clock` where there is one.
fn submit_timed(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    bind: &wgpu::BindGroup,
    groups: u32,
    clock: Option<&KernelClock>,
) -> wgpu::SubmissionIndex {
    let mut enc = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    {
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: None,
            timestamp_writes: clock.map(KernelClock::writes),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, bind, &[]);
        pass.dispatch_workgroups(groups, 1, 1);
    }
    ctx.submit(enc.finish())
}

/// One compute pass of `pipeline` over `groups` workgroups, recorded into `enc`.
fn record_pass(
    enc: &mut wgpu::CommandEncoder,
    pipeline: &wgpu::ComputePipeline,
    bind: &wgpu::BindGroup,
    groups: u32,
) {
    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
        label: None,
        timestamp_writes: None,
    });
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, bind, &[]);
    pass.dispatch_workgroups(groups, 1, 1);
}

/// Wait for submission `index` (this thread's own: other threads may submit to the same
/// device meanwhile), in polls of [`POLL_SLICE`] with the device's health checked between
/// them: a lost device or an uncaptured error ends the wait at once, and a submission still
/// running after [`WAIT_LIMIT`] ends it as unresponsive. Never blocks without bound.
fn wait(ctx: &GpuContext, index: wgpu::SubmissionIndex) -> Result<(), EngineError> {
    let started = Instant::now();
    loop {
        ctx.health()?;
        let poll = ctx.poll(wgpu::PollType::Wait {
            submission_index: Some(index.clone()),
            timeout: Some(POLL_SLICE),
        });
        match poll {
            Ok(_) => return ctx.health(),
            Err(wgpu::PollError::Timeout) if started.elapsed() < WAIT_LIMIT => {}
            Err(wgpu::PollError::Timeout) => {
                return Err(ctx.fault(
                    GpuFaultKind::Timeout,
                    format!(
                        "a submission was still running after {} s",
                        WAIT_LIMIT.as_secs()
                    ),
                ));
            }
            Err(e) => {
                ctx.health()?;
                return Err(EngineError::Gpu {
                    stage: "wait",
                    message: e.to_string(),
                });
            }
        }
    }
}

/// Copy the first `size` bytes of a storage buffer to the host.
fn read_buffer<T: bytemuck::Pod>(
    ctx: &GpuContext,
    src: &wgpu::Buffer,
    size: u64,
) -> Result<Vec<T>, EngineError> {
    read_range(ctx, src, 0, size)
}

/// Copy `size` bytes of a storage buffer from `offset` to the host, through the device's
/// read-back buffer (kept across calls, grown when too small).
fn read_range<T: bytemuck::Pod>(
    ctx: &GpuContext,
    src: &wgpu::Buffer,
    offset: u64,
    size: u64,
) -> Result<Vec<T>, EngineError> {
    if size == 0 {
        return Ok(Vec::new());
    }
    let failed = |message: String| EngineError::Gpu {
        stage: "readback",
        message,
    };
    let mut slot = ctx.staging.lock().unwrap_or_else(|e| e.into_inner());
    if slot.as_ref().is_none_or(|b| b.size() < size) {
        *slot = Some(ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size: size.next_power_of_two().max(size),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        }));
    }
    let staging = slot.as_ref().expect("a read-back buffer was just made");
    let mut enc = ctx
        .device
        .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
    enc.copy_buffer_to_buffer(src, offset, staging, 0, size);
    let copied = ctx.submit(enc.finish());
    let (tx, rx) = std::sync::mpsc::channel();
    staging.map_async(wgpu::MapMode::Read, ..size, move |r| {
        let _ = tx.send(r);
    });
    wait(ctx, copied)?;
    rx.recv()
        .map_err(|_| failed("the read-back was dropped".into()))?
        .map_err(|e| failed(e.to_string()))?;
    let view = staging
        .get_mapped_range(..size)
        .map_err(|e| failed(format!("the read-back buffer cannot be mapped: {e}")))?;
    let out = bytemuck::cast_slice::<u8, T>(&view).to_vec();
    drop(view);
    staging.unmap();
    ctx.count_read_back(size);
    Ok(out)
}
